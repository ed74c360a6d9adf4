"""The public Python API: one call per study, in millimetres and newtons.

Every function takes an :class:`~elastica_petsc.core.model.Arm` (``Arm.paper()``
or ``Arm.from_toml(path)``) and returns a frozen result whose fields carry
their unit in their name (``tip_mm``, ``tensions_N``); the non-dimensional
values of the solvers (lengths / l, p = P l^2 / B, docs/model.md §3) sit
beside them (``tensions``, ``equilibrium``).  Solver objects stay available
for loops (``with TipController(arm) as c: c.solve_mm(...)``).

PETSc is initialised on first use with no options; to pass PETSc options
from a script call ``petsc4py.init(sys.argv)`` before importing this package
(the command line does exactly that).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from .core.errors import InputError
from .core.fem import Discretisation
from .core.model import Arm
from .solvers.equilibrium import Equilibrium, EquilibriumSolver, check_order, check_tensions


@dataclass(frozen=True)
class State:
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

    def summary(self) -> dict:
        """The JSON object that ``elastica-petsc solve --json`` prints."""
        from .io.summary import equilibrium_summary

        return equilibrium_summary(self.arm, self.equilibrium)


def _mesh(arm: Arm, elements: int | None) -> Discretisation:
    if elements is not None and elements < 2:
        raise InputError(f"elements must be at least 2, got {elements}")
    return Discretisation.from_arm(arm, elements)


def _tensions(arm: Arm, tensions_N, tensions) -> np.ndarray:
    """Non-dimensional tensions from exactly one of newtons or p."""
    if (tensions_N is None) == (tensions is None):
        raise InputError("give exactly one of tensions_N= (newtons) or tensions= (p = P l^2/B)")
    p = arm.tensions_from_N(tensions_N) if tensions is None else tensions
    return check_tensions(p, arm.n_tendons)


def _progress(progress, label: str, unit: str, delay: float = 0.0):
    """``progress=`` of the long studies as a context: True draws the command
    line's bar (lines in logs; core/progress.py; on a terminal only after
    ``delay`` seconds), a callable is called as ``progress(done, note)``,
    None/False report nothing."""
    from contextlib import nullcontext

    from .core.progress import Progress

    if progress is True:
        return Progress(None, label, unit=unit, delay=delay)
    return nullcontext(progress or None)


def _loading(order) -> str:
    return "proportional" if order is None else "order " + ",".join(map(str, order))


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

    p = _tensions(arm, tensions_N, tensions)
    order = check_order(order, arm.n_tendons)
    if side not in (None, "left", "right"):
        raise InputError(f"side must be 'left' or 'right', got {side!r}")
    eq = solve_equilibrium(_mesh(arm, elements), p, order=order, side=side)
    return State(arm, eq, _loading(order))


def control(arm: Arm, target_mm, *, guess_N=None, guess=None, method: str = "blmvm",
            tol_mm: float = 1e-5, global_search: bool = True, cables: str = "prefer",
            share: str | None = None, min_tension_N: float = 0.0, animate=None,
            elements: int | None = None, progress=None):
    """Non-negative tensions that put the tip on ``target_mm`` (Eqs. (10)-(12)):
    TAO BLMVM (``method="blmvm"``) or the paper's gradient descent (``"gd"``,
    Algorithm 1), from ``guess_N`` (or ``guess`` in p = P l^2/B; default 0).

    When the local solve stalls, a global search follows (other loading
    orders, a homotopy in target space) unless ``global_search=False``;
    ``reachable`` is True, False only with evidence about the whole
    (``evidence``: ``BEYOND_REACH``, |x_d| > l; ``OUTSIDE_BOUNDARY``, outside
    the traced boundary of W_0, docs/model.md §9, traced once per arm in the
    process when the search is exhausted), or None when the strategies are
    exhausted without proof.
    ``cables``: ``"prefer"``/``"require"``/``"ignore"`` states whose cables
    cross the arm.  With n >= 3 tendons, ``share="min-norm"``/``"min-energy"``
    and ``min_tension_N`` choose among the tension sets that reach the target.
    ``animate``: a .gif/.mp4 path for the arm through the iterations.
    ``progress`` (True: a bar after 1 s, or a callable ``progress(steps, note)``)
    reports the search steps (local solves, homotopy sub-targets, the seed
    library, the boundary proof) with the stage.
    Returns a ``ControlResult`` (``tensions_N``, ``cable_lengths_mm``,
    ``tip_mm``, ``converged``, ``reachable``, ``loading``)."""
    import dataclasses

    from .solvers.control import TipController
    from .solvers.reach import Reacher, simplest_loading
    from .solvers.share import share_rule
    from .studies.boundary import boundary_proof

    target = np.asarray(target_mm, dtype=float).ravel()
    if target.size != 2 or not np.all(np.isfinite(target)):
        raise InputError("target_mm must be two finite numbers [x, y] in mm")
    if guess_N is not None:
        guess = arm.tensions_from_N(guess_N)
    p0 = None if guess is None else check_tensions(guess, arm.n_tendons)
    sharer_asked = share_rule(share, min_tension_N)          # bad input before any solve
    with (_progress(progress, "control", "search steps", delay=1.0) as bar,
          TipController(arm, n_elements=elements, method=method, tip_tol_mm=tol_mm) as ctl):
        reacher = Reacher(ctl, boundary=boundary_proof(arm, ctl.disc), progress=bar)
        result = reacher.reach(arm.from_mm(target), p0=p0, global_search=global_search,
                               cables=cables)
        sharer = _sharer(arm, ctl, sharer_asked, min_tension_N)
        if sharer is not None and result.converged:
            reacher.step(f"tension sharing ({sharer.share})")
            result = sharer.solve(result)
        reacher.step("the simplest loading path that reaches the state")
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


def _points(points_mm) -> np.ndarray:
    points = np.asarray(points_mm, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 1:
        raise InputError("points_mm must be an array of shape (K, 2) in mm")
    return points


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

    points = _points(points_mm)
    if step_mm is not None:
        points = paths.densify(points, step_mm)
    with TipController(arm, n_elements=elements) as ctl:
        sharer = _sharer(arm, ctl, share, min_tension_N)
        return paths.trace(ctl, points, sharer=sharer)


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

    if guess_N is not None:
        guess = arm.tensions_from_N(guess_N)
    p0 = None if guess is None else check_tensions(guess, arm.n_tendons)
    points = paths.densify(_points(points_mm), step_mm)
    with TipController(arm, n_elements=elements) as ctl:
        return trace_schedule(ctl, points, step_mm=step_mm, speed_mm_s=speed_mm_s,
                              amplitude_mm=amplitude_mm, approach=approach, p0=p0,
                              on_point=on_point,
                              sharer=_sharer(arm, ctl, share, min_tension_N))


def stability(state: State, *, modes: int = 4):
    """The smallest eigenvalues of K v = lambda M v at ``state`` (SLEPc,
    Sec. 4.3 (ii)); ``lambda l^2/B`` is pi^2/4 for the unloaded arm.  Returns a
    ``Stability`` (``eigenvalues``, ``lambda_min``, ``stable``, ``negative``)."""
    from .solvers.stability import StabilitySolver

    eq = state.equilibrium
    with StabilitySolver(eq.disc, nev=modes) as solver:
        return solver.solve(eq.u, eq.p)


def frequencies(state: State, *, control: str = "load", modes: int = 3):
    """The lowest natural frequencies about ``state`` (small vibrations,
    K v = Omega M v with the arm's mass per length), with tensions held
    (``control="load"``) or cable lengths held (``"length"``).  Returns a
    ``Frequencies`` (``hz``, ``f1_hz``); needs ``mass_per_length_kg_m`` in the
    arm's configuration."""
    from .solvers.stability import StabilitySolver

    if state.arm.mass_per_length_kg_m is None:
        raise InputError("natural frequencies need [arm] mass_per_length_kg_m in the config")
    eq = state.equilibrium
    with StabilitySolver(eq.disc) as solver:
        return solver.frequencies(eq.u, eq.p, state.arm, nev=modes, control=control)


def lengths(arm: Arm, lengths_mm, *, all: bool = False, elements: int | None = None,
            progress=None):
    """Length control (Sec. 4.6, Eq. (23)): the equilibrium, with its tensions,
    that prescribed cable lengths (mm) impose (slack cables carry no tension).
    With ``all=True``, the search for every equilibrium with 0 <= P_i <= P_crit
    (Eq. (22)) of :func:`~elastica_petsc.studies.search.search_lengths` (curve
    search and multi-start; a ``SearchResult``: the list found, not a proof
    that there are no more); ``progress`` (True: a bar, or a callable
    ``progress(steps, note)``) reports its search steps (curves, continuation
    points and attempts from starts)."""
    from .studies.search import follow_lengths, search_lengths

    disc = _mesh(arm, elements)
    if not all:
        return follow_lengths(arm, lengths_mm, elements=disc.n_elements)
    with _progress(progress, "lengths search", "search steps") as bar:
        return search_lengths(arm, lengths_mm, elements=disc.n_elements, progress=bar)


def equilibria(arm: Arm, tensions_N=None, *, tensions=None, elements: int | None = None,
               progress=None):
    """Equilibria that share the given tensions (N, or non-dimensional
    ``tensions`` p = P l^2/B; load control, Eq. (9), Fig. 8), by the search of
    :func:`~elastica_petsc.studies.search.search_tensions` (loading paths,
    curve search, multi-start); a ``SearchResult``: a list, not a proof that
    there are no more.  ``progress``: as for :func:`lengths`."""
    from .studies.search import search_tensions

    p = _tensions(arm, tensions_N, tensions)
    with _progress(progress, "equilibria", "search steps") as bar:
        return search_tensions(arm, p, elements=_mesh(arm, elements).n_elements,
                               progress=bar)


def workspace(arm: Arm, *, spacing_mm: float = 20.0, box_mm=None, mode: str = "targets",
              out: str | Path | None = None, overwrite: bool = False, comm=None,
              elements: int | None = None, global_search: bool = True,
              share: str | None = None, min_tension_N: float = 0.0):
    """Sample the workspace W_0 and its restrictions (Eqs. (18)-(22), Figs. 4-5)
    on a grid of targets (``mode="targets"``: tip control to each) or of
    tensions (``"tensions"``).  Runs serially, or on every rank of ``comm``
    (default ``MPI.COMM_WORLD``) when launched with ``mpiexec``; writes HDF5
    only when ``out`` is given.  Returns a ``WorkspaceMap`` of per-sample
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
    from .studies.workspace import run_map

    return run_map(arm, _mesh(arm, elements), mode=mode, spacing_mm=spacing_mm, box_mm=box_mm,
                   comm=comm, out=out, overwrite=overwrite, global_search=global_search,
                   share=share, min_tension_N=min_tension_N)


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


def design(arm: Arm, points_mm, *, vary=("tendon1.route", "tendon2.route"),
           reach_mm: float = 100.0, margin: float = 1.1, elements: int | None = None,
           progress=None):
    """Routing points that make every point of a path reachable with P >= 0
    (TAO BLMVM on the exact gradient; ``vary``: ``"tendonK.route"`` names).
    Returns a ``DesignResult``: ``arm_after`` is the designed arm,
    ``misfit_before``/``misfit_after`` the path's reachability, ``history``.
    ``progress`` (True: a bar, or a callable ``progress(traces, note)``)
    reports each path trace (one per objective evaluation)."""
    from .studies.design import design_for_path, parse_vary

    tendons = parse_vary(list(vary), arm.n_tendons)
    with _progress(progress, "design", "path traces") as bar:
        return design_for_path(arm, tendons, _points(points_mm), elements=elements,
                               reach_mm=reach_mm, margin=margin, progress=bar)


def design_area(arm: Arm, *, vary=("tendon1.route", "tendon2.route"),
                tension_max_N: float = 10.0, reach_mm: float = 100.0,
                iterations: int = 15, resample_cells: int | None = 32,
                elements: int | None = None):
    """Routing points (mm; ``vary`` may add ``"tendonK.attach"``: attachment
    arc lengths on mesh nodes, by a pattern search) maximising the area A
    [mm^2] of the workspace W_0 within 0 <= P_i <= ``tension_max_N`` (tips of stable equilibria connected
    to the straight arm by quasi-static loading; the motor limit of Eq. (22)):
    A is the shoelace area of the image of the tension box's boundary, dA/dq
    the boundary integral of the normal component of the tip derivative
    (TAO BLMVM).  Both arms are then re-sampled on a tension grid; the gain
    is ``confirmed`` only if the re-sampled areas differ by more than their
    errors.  Returns an ``AreaDesign`` (``arm_after``, ``before``/``after``,
    ``resampled_before``/``resampled_after``, ``confirmed``, ``history``)."""
    from .studies.design import parse_design_variables
    from .studies.design_area import design_for_area

    tendons, attaches = parse_design_variables(list(vary), arm.n_tendons)
    p_max = float(arm.tensions_from_N([tension_max_N])[0])
    return design_for_area(arm, tendons, p_max, elements=elements, attaches=attaches,
                           reach_mm=reach_mm, max_iterations=iterations,
                           resample_cells=resample_cells)


def design_sweep(arm: Arm, axes, *, tension_max_N: float = 10.0, path_mm=None,
                 out: str | Path | None = None, overwrite: bool = False, resume: bool = False,
                 comm=None, elements: int | None = None):
    """Evaluate a grid of designs: ``axes`` are strings
    ``"tendonK.route.x|route.y|attach|offset=START:STOP:STEP"`` (mm; attachments on
    mesh nodes).  Per design: the area [mm^2] of W_0 within 0 <= P_i <=
    ``tension_max_N`` (as :func:`design_area`) and, with ``path_mm``, the
    path's misfit [mm^2] and targets reached.  On every rank of ``comm``
    (default ``MPI.COMM_WORLD``), checkpointed to ``out`` (.h5) and
    resumable.  Returns a ``Sweep`` (``designs``, ``values``, ``best()``)."""
    from .studies.design_sweep import parse_axis, run_sweep

    disc = _mesh(arm, elements)
    parsed = [parse_axis(text, disc.n_tendons) for text in axes]
    p_max = float(arm.tensions_from_N([tension_max_N])[0])
    return run_sweep(arm, disc.n_elements, parsed, p_max,
                     targets_mm=None if path_mm is None else _points(path_mm), comm=comm,
                     out=out, resume=resume, overwrite=overwrite, progress=False)


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
    """Load a file written by the tool back into its result: a :class:`State`
    for ``solve``/``control``/``stability`` files (the final state), a
    ``WorkspaceMap`` for workspace maps, otherwise a dict of its datasets."""
    from .io.reader import file_kind, read_file

    if file_kind(path) == "workspace":
        from .studies.workspace import read_map
        return read_map(path)
    return read_file(path, State)


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
