"""The public Python API: one call per study, in millimetres and newtons.

Every function takes an :class:`~elastica_petsc.core.model.Arm` (``Arm.paper()``
or ``Arm.from_toml(path)``) and returns a frozen result whose fields carry
their unit in their name (``tip_mm``, ``tensions_N``); the non-dimensional
values of the solvers (lengths / l, p = P l^2 / B, docs/model.md §3) sit
beside them (``tensions``, ``equilibrium``).  Solver objects stay available
for loops (``with TipController(arm) as c: c.solve_mm(...)``).

Every study takes ``petsc_options=`` (a mapping such as
``{"snes_rtol": 1e-10}`` or ``{"eq_snes_monitor": None}``, names with or
without their leading dash): they are put in PETSc's options database for
that call only, so they apply to the solvers it creates whether or not an
earlier call has solved; names that no solver of the call read raise
:class:`~elastica_petsc.core.errors.InputError` (a misspelt or misplaced
option never passes silently).  PETSc itself is initialised on first use
(``petsc4py.init(sys.argv)`` before the first call also works, as the
command line does).

The library prints nothing unless asked: the long studies take
``progress=`` (False by default; True draws the command line's bar on
stderr, a callable is called as ``progress(done, note)``).  Single-arm
studies run on ``PETSc.COMM_SELF``; the sampled studies (:func:`workspace`,
:func:`design_sweep`) take ``comm=`` and run on this process alone unless a
communicator is given (``comm=MPI.COMM_WORLD``: collective over its ranks).
"""
from __future__ import annotations

import functools
import inspect
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from .core import inputs
from .core.results import Result
from .core.errors import InputError
from .core.fem import Discretisation
from .core.model import Arm
from .solvers.equilibrium import Equilibrium, EquilibriumSolver, check_order


@dataclass(frozen=True, repr=False)
class State(Result):
    """A load-controlled equilibrium (Eq. (9)) of ``arm`` in user units.

    ``equilibrium`` is the solver's non-dimensional state; ``loading`` says how
    it was reached from the straight arm (``"proportional"`` or ``"order 2,1"``),
    since several stable states can share the same tensions (Fig. 8).
    """

    arm: Arm
    equilibrium: Equilibrium
    loading: str = "proportional"

    @property
    def converged(self) -> bool:
        return bool(self.equilibrium.converged)

    @property
    def reason(self) -> str:
        return self.equilibrium.reason

    @property
    def message(self) -> str:
        return self.equilibrium.message

    @property
    def stable(self) -> bool:
        """Stable under load control: K positive definite (docs/model.md §2)."""
        return bool(self.equilibrium.stable)

    @property
    def tensions(self) -> np.ndarray:
        """Non-dimensional tensions p_i = P_i l^2 / B."""
        return np.asarray(self.equilibrium.p, dtype=float)

    @property
    def tensions_N(self) -> np.ndarray:
        return self.arm.tensions_to_N(self.equilibrium.p)

    @cached_property
    def x_mm(self) -> np.ndarray:
        """Centreline at the nodes, shape (N+1, 2), mm (Eq. (2))."""
        return self.arm.to_mm(self.equilibrium.x)

    @property
    def tip_mm(self) -> np.ndarray:
        return self.x_mm[-1]

    @property
    def attachments_mm(self) -> np.ndarray:
        return self.arm.to_mm(self.equilibrium.attachments)

    @property
    def cable_lengths_mm(self) -> np.ndarray:
        """L_i = |r_i - x_i| in mm (Eq. (3))."""
        return self.arm.to_mm(self.equilibrium.cable_lengths)

    @property
    def strain_energy_J(self) -> float:
        """Strain energy (Eq. (21)) in joules."""
        return float(self.equilibrium.strain_energy * self.arm.energy_scale_J)

    @property
    def kappa_max(self) -> float:
        """max_s l |theta'| (Fig. 5a), non-dimensional."""
        return float(self.equilibrium.kappa_max)

    def to_vtk(self, directory) -> list[Path]:
        """The state as ParaView files in ``directory`` (created if missing), as
        ``solve --vtk`` writes them (``solve.vtu``: arm and cables, mm, N)."""
        from .io.vtk import write_states

        return write_states(directory, self.arm, [self.equilibrium], name="solve")

    def summary(self) -> dict:
        """The JSON object that ``elastica-petsc solve --json`` prints."""
        from .io.summary import equilibrium_summary

        return equilibrium_summary(self.arm, self.equilibrium)


def _arm(arm) -> Arm:
    if not isinstance(arm, Arm):
        raise InputError(f"arm must be an ep.Arm (Arm.paper() or Arm.from_toml(path)), got "
                         f"{type(arm).__name__}")
    return arm


@contextmanager
def _petsc_options_in_force(petsc_options):
    """``petsc_options`` ({name: value}; None values for flags) in PETSc's
    options database for the ``with`` block only (earlier values restored);
    InputError for names nothing read during the block."""
    if not petsc_options:
        yield
        return
    if not hasattr(petsc_options, "items"):
        raise InputError("petsc_options must be a mapping {name: value}, "
                         "e.g. {'eq_snes_rtol': 1e-10}")
    from petsc4py import PETSc

    from .solvers.options import unused_options

    opts = PETSc.Options()
    names = [str(name).lstrip("-") for name in petsc_options]
    before = {name: opts.getString(name) for name in names if opts.hasName(name)}
    for name, value in zip(names, petsc_options.values()):
        opts.setValue(name, "" if value is None else
                      str(value).lower() if isinstance(value, bool) else str(value))
    try:
        yield
        unused = unused_options(names)
    finally:
        for name in names:
            opts.delValue(name)
            if name in before:
                opts.setValue(name, before[name])
    if unused:
        raise InputError(f"PETSc options not used by any solver of this call: "
                         f"{' '.join(unused)} (check the name and its prefix)")


def _takes_petsc_options(study):
    """Give ``study`` the keyword ``petsc_options=`` (see the module docstring)."""
    @functools.wraps(study)
    def with_options(*args, petsc_options=None, **kwargs):
        with _petsc_options_in_force(petsc_options):
            return study(*args, **kwargs)

    signature = inspect.signature(study)
    option = inspect.Parameter("petsc_options", inspect.Parameter.KEYWORD_ONLY, default=None)
    with_options.__signature__ = signature.replace(
        parameters=[*signature.parameters.values(), option])
    return with_options


def _mesh(arm: Arm, elements: int | None) -> Discretisation:
    return Discretisation.from_arm(_arm(arm), inputs.elements(elements, "elements"))


def _tensions(arm: Arm, tensions_N, tensions, names=("tensions_N", "tensions")) -> np.ndarray:
    """Non-dimensional tensions from exactly one of newtons or p, checked in the
    unit given (``names``: the arguments, newtons first)."""
    if (tensions_N is None) == (tensions is None):
        raise InputError(f"give exactly one of {names[0]}= (newtons) or {names[1]}= "
                         "(p = P l^2/B)")
    if tensions is None:
        return arm.tensions_from_N(inputs.tensions(tensions_N, arm.n_tendons, names[0], "N",
                                                   arm.force_scale_N))
    return inputs.tensions(tensions, arm.n_tendons, names[1], "P l^2/B")


def _guess(arm: Arm, guess_N, guess) -> np.ndarray | None:
    """Initial tensions from ``guess_N`` (N) or ``guess`` (p), or None."""
    if guess_N is None and guess is None:
        return None
    return _tensions(arm, guess_N, guess, ("guess_N", "guess"))


def _floor_N(min_tension_N) -> float:
    """The pretension floor P_min (N) of tension sharing: a number >= 0."""
    value = inputs.number(min_tension_N, "min_tension_N", "N")
    if value < 0:
        raise InputError(f"min_tension_N (the minimum tension of every cable) must be >= 0 N, "
                         f"got {value:g}")
    return value


def _progress(progress, label: str, unit: str, delay: float = 0.0):
    """``progress=`` of the long studies as a context: True draws the command
    line's bar (lines in logs; ui/progress.py; on a terminal only after
    ``delay`` seconds), a callable is called as ``progress(done, note)``,
    None/False report nothing."""
    from contextlib import nullcontext

    from .ui.progress import Progress

    if progress is True:
        return Progress(None, label, unit=unit, delay=delay)
    return nullcontext(progress or None)


def _loading(order) -> str:
    return "proportional" if order is None else "order " + ",".join(map(str, order))


@_takes_petsc_options
def solve(arm: Arm, tensions_N=None, *, tensions=None, order=None, side: str | None = None,
          elements: int | None = None) -> State:
    """The equilibrium reached by loading the straight arm to the given tensions
    (Eq. (9), PETSc SNES with load stepping).

    ``order=(2, 1)`` tensions tendon 2 fully before tendon 1; ``None`` loads all
    tendons proportionally (the order selects the state, Fig. 8).  At a
    symmetric bifurcation crossed on the way, ``side="left"``/``"right"``
    picks the buckled branch on which the tip moves counter-clockwise /
    clockwise of its tangent; by default the branch of lower potential energy
    (equal energies: left).  ``State.equilibrium.bifurcations`` lists them.
    """
    from .solvers.equilibrium import solve_equilibrium

    disc = _mesh(arm, elements)
    p = _tensions(arm, tensions_N, tensions)
    order = check_order(order, arm.n_tendons)
    if side not in (None, "left", "right"):
        raise InputError(f"side must be 'left' or 'right', got {side!r}")
    eq = solve_equilibrium(disc, p, order=order, side=side)
    return State(arm, eq, _loading(order))


@_takes_petsc_options
def control(arm: Arm, target_mm, *, guess_N=None, guess=None, method: str = "blmvm",
            tol_mm: float = 1e-5, global_search: bool = True, cables: str = "prefer",
            share: str | None = None, min_tension_N: float = 0.0, animate=None,
            elements: int | None = None, progress=None, max_seconds: float | None = None):
    """Non-negative tensions that put the tip on ``target_mm`` (Eqs. (10)-(12)):
    TAO BLMVM (``method="blmvm"``) or the paper's gradient descent (``"gd"``,
    Algorithm 1), from ``guess_N`` (or ``guess`` in p = P l^2/B; default 0).

    When the local solve stalls, a global search follows (other loading
    orders, a homotopy in target space) unless ``global_search=False``;
    ``reachable`` is True, False only with evidence about the whole
    (``evidence``: ``BEYOND_REACH``, |x_d| > l; ``OUTSIDE_BOUNDARY``, outside
    the traced boundary of W_0 or in a hole of it, docs/model.md §9, traced
    once per arm in the process when the local solve first fails), or None
    when the strategies are exhausted without proof.
    ``cables``: ``"prefer"``/``"require"``/``"ignore"`` states whose cables
    cross the arm.  With n >= 3 tendons, ``share="min-norm"``/``"min-energy"``
    and ``min_tension_N`` choose among the tension sets that reach the target.
    ``animate``: a .gif/.mp4 path for the arm through the iterations.
    ``progress`` (True: a bar after 1 s, or a callable ``progress(steps, note)``)
    reports the search steps (local solves, homotopy sub-targets, the seed
    library, the boundary proof) with the stage.  With two tendons a target
    the traced boundary proves outside W_0 (or in a hole of it) is answered
    by that proof as soon as the local solve fails, without the global
    search (``strategy`` "boundary proof").  ``max_seconds``: a time budget;
    once spent the search stops at its next step and returns the closest tip
    so far with ``reason`` ``"TIME_LIMIT"`` and ``reachable`` None (the first
    local solve always returns a state; sharing, if asked, still runs).
    Returns a ``ControlResult`` (``tensions_N``, ``cable_lengths_mm``,
    ``tip_mm``, ``converged``, ``reachable``, ``loading``)."""
    import dataclasses

    from .core.budget import TimeBudget, check_max_seconds
    from .solvers.control import TipController
    from .solvers.reach import Reacher, simplest_loading
    from .solvers.share import share_rule
    from .studies.boundary import boundary_proof

    elements = _mesh(arm, elements).n_elements
    target = inputs.target_mm(arm, target_mm, "target_mm")
    p0 = _guess(arm, guess_N, guess)
    inputs.tip_tolerance_mm(arm, tol_mm, "tol_mm")
    inputs.choice(cables, "cables", ("prefer", "require", "ignore"))
    inputs.choice(method, "method", ("blmvm", "gd"))
    sharer_asked = share_rule(share, _floor_N(min_tension_N))   # bad input before any solve
    max_seconds = check_max_seconds(max_seconds)
    if animate:
        from .plots.animate import check_animation_path
        check_animation_path(animate, True, "animate")
    budget = TimeBudget(max_seconds)
    with (_progress(progress, "control", "search steps", delay=1.0) as bar,
          TipController(arm, n_elements=elements, method=method, tip_tol_mm=tol_mm) as ctl):
        reacher = Reacher(ctl, boundary=boundary_proof(arm, ctl.disc), progress=bar,
                          budget=budget)
        result = reacher.reach(arm.from_mm(target), p0=p0, global_search=global_search,
                               cables=cables)
        sharer = _sharer(arm, ctl, sharer_asked, min_tension_N)
        if sharer is not None and result.converged:
            reacher.step(f"tension sharing ({sharer.share})")
            result = sharer.solve(result)
        if not budget.expired():
            reacher.step("the simplest loading path that reaches the state", check=False)
            result = dataclasses.replace(result, loading=simplest_loading(
                ctl.solver, result.equilibrium, result.loading))
        if animate:
            from .plots.animate import animate_control
            animate_control(ctl, result, animate)
    return result


def _sharer(arm: Arm, controller, share: str | None, min_tension_N: float):
    """The TensionSharer asked for (n >= 3 tendons), or None."""
    from .solvers.share import TensionSharer, share_rule

    share = share_rule(share, min_tension_N)
    if share == "none":
        return None
    return TensionSharer(controller, share, float(arm.tensions_from_N(min_tension_N)))


def _points(points_mm, arm: Arm | None = None, name: str = "points_mm") -> np.ndarray:
    return inputs.points_mm(points_mm, name, arm)


@_takes_petsc_options
def trace(arm: Arm, points_mm, *, step_mm: float | None = None, share: str | None = None,
          min_tension_N: float = 0.0, elements: int | None = None):
    """Tip control along a path, each target warm-started from the previous
    solution (Sec. 4.5, Fig. 3).  ``step_mm`` inserts points so that no two
    consecutive targets are further apart.  With n >= 3 tendons,
    ``share="min-norm"``/``"min-energy"`` (minimum |P| or strain energy,
    Eq. (21)) and ``min_tension_N`` (every P_i >= it, N) pick one tension set
    per point among those that reach it (SQP on the KKT system, followed from
    point to point), so a closed path closes in cable space.  Returns a
    ``TraceResult`` (``tips_mm``, ``tensions_N``, ``cable_lengths_mm`` per
    point); for a timed motor schedule with an approach move see :func:`schedule`."""
    from .solvers.control import TipController
    from .studies import trace as paths

    elements = _mesh(arm, elements).n_elements
    points = _points(points_mm, arm)
    if step_mm is not None:
        points = paths.densify(points, inputs.path_step_mm(points, step_mm, "path", "step_mm"))
    with TipController(arm, n_elements=elements) as ctl:
        sharer = _sharer(arm, ctl, share, _floor_N(min_tension_N))
        return paths.trace(ctl, points, sharer=sharer)


@_takes_petsc_options
def schedule(arm: Arm, points_mm, *, step_mm: float = 1.0, speed_mm_s: float | None = None,
             amplitude_mm: float = 1.0, approach: bool = True, guess_N=None, guess=None,
             on_point=None, share: str | None = None, min_tension_N: float = 0.0,
             elements: int | None = None):
    """A timed motor schedule for a path (Sec. 4.5): an approach move from the
    straight arm (or the state at ``guess_N``, or ``guess`` in p) to the
    first point, then the path traced at ``step_mm`` spacing, cable lengths
    turned into spool revolutions and microsteps, timed at ``speed_mm_s``
    (default: the safe speed 2 pi f_1 * ``amplitude_mm`` from the lowest
    natural frequency, Sec. 4.5 (vi)).  ``on_point(done, total)`` reports
    progress.  ``share``/``min_tension_N``: tension sharing with n >= 3 tendons,
    as in :func:`trace` (along the approach the floor grows from 0 N at the
    straight arm to ``min_tension_N`` at the first point).
    Returns a ``TracedSchedule``: ``.schedule`` (``write_csv(path)``,
    ``lengths_at(t)``), ``.path`` and ``.approach`` (``TraceResult``), ``.speed``."""
    from .solvers.control import TipController
    from .studies import trace as paths
    from .studies.schedule import trace_schedule

    elements = _mesh(arm, elements).n_elements
    p0 = _guess(arm, guess_N, guess)
    points = _points(points_mm, arm)
    points = paths.densify(points, inputs.path_step_mm(points, step_mm, "path", "step_mm"))
    if speed_mm_s is not None:
        inputs.positive(speed_mm_s, "speed_mm_s", "mm/s", at_least=1e-6)
    inputs.positive(amplitude_mm, "amplitude_mm", "mm", at_least=1e-6)
    with TipController(arm, n_elements=elements) as ctl:
        return trace_schedule(ctl, points, step_mm=step_mm, speed_mm_s=speed_mm_s,
                              amplitude_mm=amplitude_mm, approach=approach, p0=p0,
                              on_point=on_point,
                              sharer=_sharer(arm, ctl, share, _floor_N(min_tension_N)))


@_takes_petsc_options
def stability(state: State, *, modes: int = 4):
    """The smallest eigenvalues of K v = lambda M v at ``state`` (SLEPc,
    Sec. 4.3 (ii)); ``lambda l^2/B`` is pi^2/4 for the unloaded arm.  Returns a
    ``Stability`` (``eigenvalues``, ``lambda_min``, ``stable``, ``negative``)."""
    from .solvers.stability import StabilitySolver

    eq = _state(state).equilibrium
    inputs.modes(modes, eq.disc.n_elements, "modes")
    with StabilitySolver(eq.disc, nev=modes) as solver:
        return solver.solve(eq.u, eq.p)


def _state(state) -> State:
    if not isinstance(state, State):
        raise InputError(f"state must be an ep.State (from ep.solve), got "
                         f"{type(state).__name__}")
    return state


@_takes_petsc_options
def frequencies(state: State, *, control: str = "load", modes: int = 3):
    """The lowest natural frequencies about ``state`` (small vibrations,
    K v = Omega M v with the arm's mass per length), with tensions held
    (``control="load"``) or cable lengths held (``"length"``).  Returns a
    ``Frequencies`` (``hz``, ``f1_hz``); needs ``mass_per_length_kg_m`` in the
    arm's configuration."""
    from .solvers.stability import StabilitySolver

    _state(state)
    if control not in ("load", "length"):
        raise InputError(f"control must be 'load' or 'length', got {control!r}")
    if state.arm.mass_per_length_kg_m is None:
        raise InputError("natural frequencies need [arm] mass_per_length_kg_m in the config")
    eq = state.equilibrium
    inputs.modes(modes, eq.disc.n_elements, "modes")
    with StabilitySolver(eq.disc) as solver:
        return solver.frequencies(eq.u, eq.p, state.arm, nev=modes, control=control)


@_takes_petsc_options
def lengths(arm: Arm, lengths_mm, *, elements: int | None = None,
            max_seconds: float | None = None):
    """Length control (Sec. 4.6, Eq. (23)): the equilibrium, with its tensions,
    that prescribed cable lengths (mm) impose (slack cables carry no tension),
    reached from the straight arm by length continuation; a
    ``LengthEquilibrium``.  Every equilibrium at these lengths:
    :func:`length_equilibria`.  ``max_seconds``: a time budget; once spent the
    continuation stops at its next step (``converged`` False, ``reason``
    ``"TIME_LIMIT"``, the state it had reached)."""
    from .core.budget import check_max_seconds
    from .studies.search import follow_lengths

    disc = _mesh(arm, elements)
    lengths_mm = inputs.cable_lengths_mm(arm, lengths_mm, "lengths_mm")
    return follow_lengths(arm, lengths_mm, elements=disc.n_elements,
                          max_seconds=check_max_seconds(max_seconds))


@_takes_petsc_options
def length_equilibria(arm: Arm, lengths_mm, *, elements: int | None = None, progress=None,
                      max_seconds: float | None = None):
    """Equilibria with 0 <= P_i <= P_crit (Eq. (22)) that prescribed cable
    lengths (mm) admit, by the search of
    :func:`~elastica_petsc.studies.search.search_lengths` (curve search and
    multi-start; a ``SearchResult``: the list found, not a proof that there
    are no more); ``progress`` (True: a bar, or a callable
    ``progress(steps, note)``) reports its search steps (curves, continuation
    points and attempts from starts).  ``max_seconds``: a time budget; once
    spent the search returns the states found so far with ``outcome``
    ``"TIME_LIMIT"`` (``stopped`` says where; the list may be incomplete)."""
    from .core.budget import check_max_seconds
    from .studies.search import search_lengths

    lengths_mm = inputs.cable_lengths_mm(arm, lengths_mm, "lengths_mm")
    max_seconds = check_max_seconds(max_seconds)
    with _progress(progress, "lengths search", "search steps") as bar:
        return search_lengths(arm, lengths_mm, elements=_mesh(arm, elements).n_elements,
                              progress=bar, max_seconds=max_seconds)


@_takes_petsc_options
def equilibria(arm: Arm, tensions_N=None, *, tensions=None, elements: int | None = None,
               progress=None, max_seconds: float | None = None):
    """Equilibria that share the given tensions (N, or non-dimensional
    ``tensions`` p = P l^2/B; load control, Eq. (9), Fig. 8), by the search of
    :func:`~elastica_petsc.studies.search.search_tensions` (loading paths,
    curve search, multi-start); a ``SearchResult``: a list, not a proof that
    there are no more.  ``progress``, ``max_seconds``: as for
    :func:`length_equilibria`."""
    from .core.budget import check_max_seconds
    from .studies.search import search_tensions

    p = _tensions(arm, tensions_N, tensions)
    max_seconds = check_max_seconds(max_seconds)
    with _progress(progress, "equilibria", "search steps") as bar:
        return search_tensions(arm, p, elements=_mesh(arm, elements).n_elements,
                               progress=bar, max_seconds=max_seconds)


MIN_SPACING_MM = 1e-100        # finer: the grid count overflows before its limit is checked


@_takes_petsc_options
def workspace(arm: Arm, *, spacing_mm: float = 20.0, box_mm=None, mode: str = "targets",
              out: str | Path | None = None, overwrite: bool = False, comm=None,
              elements: int | None = None, global_search: bool = True,
              share: str | None = None, min_tension_N: float = 0.0, progress: bool = False):
    """Sample the workspace W_0 and its restrictions (Eqs. (18)-(22), Figs. 4-5)
    on a grid of targets (``mode="targets"``: tip control to each) or of
    tensions (``"tensions"``).  Runs in this process alone (``comm`` None:
    ``MPI.COMM_SELF``, also on one rank of ``mpiexec``), or collectively on
    every rank of ``comm`` (e.g. ``MPI.COMM_WORLD``); writes HDF5 only when
    ``out`` is given.  ``progress=True``: a bar (rank 0; default none).  Returns a ``WorkspaceMap`` of per-sample
    arrays (``status``, masks ``W0``... , ``tip_mm``, ``tensions_N``).
    Targets (mm) that local tip control does not reach go through the global
    search (seeds over every loading order, reached neighbours) and are
    classed REACHED, UNDECIDED (no proof either way) or BEYOND_REACH
    (|x| > l, proven); ``global_search=False`` keeps the local verdicts.
    ``share="min-norm"``/``"min-energy"`` and ``min_tension_N`` (the floor
    P_min, N; mode targets): the tensions stored per reached target are the
    sharing rule's (n >= 3 tendons; minimum |P| or strain energy, Eq. (21));
    with a floor the map samples W_0(P_min) (reached with every P_i >= P_min;
    BELOW_FLOOR: reached with P >= 0 but no tensions >= P_min found, not a
    proof; UNIQUE_BELOW_FLOOR: two tendons, the target's only tensions are
    below P_min, proven; docs/model.md §9.3)."""
    from .io.hdf5 import H5_SUFFIXES, check_output_path
    from .studies.workspace import run_map

    disc = _mesh(arm, elements)
    inputs.positive(spacing_mm, "spacing_mm", "mm", at_least=MIN_SPACING_MM)
    if box_mm is not None:
        box_mm = tuple(inputs.box_mm(box_mm, "box_mm"))
    if out is not None:
        check_output_path(out, overwrite, H5_SUFFIXES, "out")
    return run_map(arm, disc, mode=mode, spacing_mm=spacing_mm, box_mm=box_mm,
                   comm=comm, out=out, overwrite=overwrite, global_search=global_search,
                   share=share, min_tension_N=_floor_N(min_tension_N), progress=progress)


@_takes_petsc_options
def boundary(arm: Arm, *, restricted: bool = True, elements: int | None = None,
             progress=None):
    """The boundary of the workspace W_0 of a two-tendon arm (and of the
    restricted workspace, Eqs. (18)-(22)) traced by pseudo-arclength
    continuation in tension space instead of sampling.  Returns a
    ``BoundaryResult``: ``polygons_mm`` and ``areas_mm2`` per set
    (``"W0"``, ``"restricted"``; mm, mm^2), ``solves``, ``messages`` (where
    the method stops); for W_0 also the fold curves of the tip map
    (det d x_t/dp = 0, Eq. (13): ``fold_polylines_mm``), the faces they and
    the loop cut the plane into (``faces``: winding number, preimage count),
    ``area_bounds_mm2``, ``contains(points_mm)`` and ``outside(target_mm)``
    (the OUTSIDE_BOUNDARY evidence of tip control; docs/model.md §9.1).
    ``progress`` (True: a bar, or a callable ``progress(solves, note)``)
    reports the continuation solves."""
    from .studies.boundary import trace_boundary

    with _progress(progress, "boundary", "continuation solves") as bar:
        return trace_boundary(arm, _mesh(arm, elements), restricted=restricted, progress=bar)


@_takes_petsc_options
def design(arm: Arm, points_mm, *, vary=("tendon1.route", "tendon2.route"),
           reach_mm: float = 100.0, margin: float = 1.1, elements: int | None = None,
           progress=None, max_seconds: float | None = None):
    """Routing points that make every point of a path reachable with P >= 0
    (TAO BLMVM on the exact gradient; ``vary``: ``"tendonK.route"`` names).
    Returns a ``DesignResult``: ``arm_after`` is the designed arm,
    ``misfit_before``/``misfit_after`` the path's reachability, ``history``.
    ``progress`` (True: a bar, or a callable ``progress(traces, note)``)
    reports each path trace (one per objective evaluation).  ``max_seconds``:
    a time budget; once spent the optimiser stops at its next iteration and
    the result (the best design so far, both paths traced) has ``reason``
    ``"TIME_LIMIT"``."""
    import dataclasses

    from .core.budget import TIME_LIMIT, TimeBudget, check_max_seconds
    from .studies.design import design_for_path, parse_vary

    elements = _mesh(arm, elements).n_elements
    tendons = parse_vary(list(vary), arm.n_tendons)
    points = _points(points_mm, arm)
    inputs.design_points(points, "points_mm")
    inputs.design_options(DESIGN_NAMES, reach_mm=reach_mm, margin=margin)
    budget = TimeBudget(check_max_seconds(max_seconds))
    with _progress(progress, "design", "path traces") as bar:
        result = design_for_path(arm, tendons, points, elements=elements, reach_mm=reach_mm,
                                 margin=margin, progress=bar, stop=budget.expired)
    return dataclasses.replace(result, reason=TIME_LIMIT) if budget.reached else result


DESIGN_NAMES = {k: k for k in ("iterations", "reach_mm", "clearance_mm", "margin",
                                "resample_cells")}


def _tension_max(arm: Arm, tension_max_N) -> float:
    """The motor limit of an area design, N -> p (a box of tensions with an area)."""
    value = inputs.tensions([inputs.number(tension_max_N, "tension_max_N", "N")], 1,
                            "tension_max_N", "N", arm.force_scale_N)[0]
    return float(arm.tensions_from_N([inputs.positive(value, "tension_max_N", "N",
                                                      at_least=1e-3)])[0])


@_takes_petsc_options
def design_area(arm: Arm, *, vary=("tendon1.route", "tendon2.route"),
                tension_max_N: float = 10.0, reach_mm: float = 100.0,
                iterations: int = 15, resample_cells: int | None = 32,
                elements: int | None = None, max_seconds: float | None = None):
    """Routing points (mm; ``vary`` may add ``"tendonK.attach"``: attachment
    arc lengths on mesh nodes, by a pattern search) maximising the area A
    [mm^2] of the workspace W_0 within 0 <= P_i <= ``tension_max_N`` (tips of stable equilibria connected
    to the straight arm by quasi-static loading; the motor limit of Eq. (22)):
    A is the area of its traced boundary (as :func:`boundary` measures it for
    the arm with that motor limit), dA/dq the boundary integral of the normal
    component of the tip derivative (TAO BLMVM).  Both arms are then re-sampled on a tension grid; the gain
    is ``confirmed`` only if the re-sampled areas differ by more than their
    errors.  Returns an ``AreaDesign`` (``arm_after``, ``before``/``after``,
    ``resampled_before``/``resampled_after``, ``confirmed``, ``history``).
    ``max_seconds``: a time budget; once spent the optimiser stops at its next
    iteration, the re-sampling is skipped (nothing confirmed) and ``reason``
    is ``"TIME_LIMIT"``."""
    import dataclasses

    from .core.budget import TIME_LIMIT, TimeBudget, check_max_seconds
    from .studies.design import parse_design_variables
    from .studies.design_area import design_for_area

    elements = _mesh(arm, elements).n_elements
    tendons, attaches = parse_design_variables(list(vary), arm.n_tendons)
    p_max = _tension_max(arm, tension_max_N)
    inputs.design_options(DESIGN_NAMES, reach_mm=reach_mm, iterations=iterations,
                          resample_cells=resample_cells)
    budget = TimeBudget(check_max_seconds(max_seconds))
    result = design_for_area(arm, tendons, p_max, elements=elements, attaches=attaches,
                             reach_mm=reach_mm, max_iterations=iterations,
                             resample_cells=resample_cells, stop=budget.expired)
    return dataclasses.replace(result, reason=TIME_LIMIT) if budget.reached else result


@_takes_petsc_options
def design_sweep(arm: Arm, axes, *, tension_max_N: float = 10.0, path_mm=None,
                 out: str | Path | None = None, overwrite: bool = False, resume: bool = False,
                 comm=None, elements: int | None = None, progress: bool = False):
    """Evaluate a grid of designs: ``axes`` are strings
    ``"tendonK.route.x|route.y|attach|offset=START:STOP:STEP"`` (mm; attachments on
    mesh nodes).  Per design: the area [mm^2] of W_0 within 0 <= P_i <=
    ``tension_max_N`` (as :func:`design_area`) and, with ``path_mm``, the
    path's misfit [mm^2] and targets reached.  In this process alone (``comm``
    None), or collectively on every rank of ``comm``; ``progress=True``: a
    bar (default none); checkpointed to ``out`` (.h5) and
    resumable.  Returns a ``Sweep`` (``designs``, ``values``, ``best()``)."""
    from .studies.design_sweep import parse_axis, run_sweep

    disc = _mesh(arm, elements)
    parsed = [parse_axis(text, disc.n_tendons) for text in axes]
    p_max = _tension_max(arm, tension_max_N)
    if path_mm is not None:
        inputs.design_points(_points(path_mm, arm, "path_mm"), "path_mm")
    return run_sweep(arm, disc.n_elements, parsed, p_max,
                     targets_mm=None if path_mm is None else _points(path_mm), comm=comm,
                     out=out, resume=resume, overwrite=overwrite, progress=progress)


def save(result, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write any result of this package to ``path`` (.h5, also ``result.save(path)``):
    the command line's layout where it has one, with units and provenance, and
    the whole result, so that :func:`read` returns an equal one."""
    from .io.save import save_result

    return save_result(path, result, overwrite=overwrite)


@_takes_petsc_options
def calibrate(arm: Arm, data, vary, *, bounds=None, input: str | None = None,
              huber_mm: float | None = None, folds: int = 5, candidates=None,
              method: str = "brgn", elements: int | None = None):
    """Fit the parameters named in ``vary`` (``bending_stiffness``,
    ``tendonK.route``, ``motorK.offset``, ``motor.spool_radius``, ``clamp.angle``,
    ``clamp.position``, ``frame.rotation``, ``frame.offset``) to measured states
    ``data`` (a CSV path or a :class:`CalibrationData`); ``bounds``:
    {scalar name: (lo, hi)}; ``method``: "brgn" (exact Jacobian) or "pounders"
    (derivative-free check).  Returns a CalibrationResult: ``.arm`` the fitted
    arm, ``.parameters()`` values with standard deviations, ``.summary()``
    (docs/model.md §14)."""
    from .core.calibration_data import CalibrationData, read_calibration_csv
    from .core.calibration_params import ParameterModel
    from .studies.calibrate_report import calibrate as run_calibration

    if not isinstance(data, CalibrationData):
        data = read_calibration_csv(data, arm.n_tendons, input, arm.length_mm)
    if candidates is not None and not isinstance(candidates, CalibrationData):
        candidates = read_calibration_csv(candidates, arm.n_tendons, input, arm.length_mm,
                                          measured=False)
    model = ParameterModel(arm, vary, bounds)
    return run_calibration(model, data, elements=_mesh(arm, elements).n_elements,
                           huber_mm=huber_mm, folds=folds, candidates=candidates,
                           method=method)


def read(path: str | Path):
    """Load a file written by the tool back into its result: the saved type
    itself for files written by :func:`save` (``result.save(path)``) and by
    ``control --out`` (a ``ControlResult``), ``trace --out`` (a
    ``TracedSchedule``) and ``boundary --out`` (a ``BoundaryResult``); a :class:`State` for ``solve``/``stability`` files
    (the final state), a ``WorkspaceMap`` for workspace maps, otherwise a
    dict of its datasets."""
    from .io.reader import file_kind, open_h5, read_file
    from .io.records import has_result, read_result

    with open_h5(path) as fh:
        if has_result(fh):
            return read_result(fh)
    if file_kind(path) == "workspace":
        from .studies.workspace import read_map
        return read_map(path)
    return read_file(path, State)


@_takes_petsc_options
def simulate(arm: Arm, *, tensions_N=None, history_csv=None, schedule_csv=None,
             initial_tensions_N=None, order=None, from_file=None, duration_s=None,
             settle_s: float = 0.0, dt_s: float | None = None, adaptive: bool = False,
             rtol: float = 1e-6, atol: float = 1e-8, radius: float = 1.0,
             elements: int | None = None):
    """The arm in motion (PETSc TS, docs/model.md §16) from rest: the straight arm, the
    equilibrium at ``initial_tensions_N`` (loaded in ``order``) or the last shape in
    ``from_file``; driven by constant ``tensions_N``, a tension history CSV or a motor
    schedule CSV (cable lengths, slack cables as events).  Returns a
    ``SimulationResult`` (``time_s``, ``tip_mm``, ``x_mm``, ``tensions_N``,
    ``cable_lengths_mm``, ``energy_J``, ``summary()``); needs the arm's mass per length."""
    from .io.simulation import read_theta
    from .studies.simulate import simulate as run

    return run(arm, elements=elements, initial_tensions_N=initial_tensions_N,
               order=order, from_theta=None if from_file is None else read_theta(from_file),
               tensions_N=tensions_N, history_csv=history_csv, schedule_csv=schedule_csv,
               settle_s=settle_s, duration_s=duration_s, rtol=rtol, atol=atol, radius=radius,
               dt_s=dt_s, adaptive=adaptive)
