"""Equilibria of one arm in user units: the :class:`State` result, the
load-controlled solve (Eq. (9)), its stability and natural frequencies,
length control (Eq. (23)) and the searches for every equilibrium at given
lengths or tensions."""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from ..core import inputs
from ..core.results import Result
from ..core.errors import InputError
from ..core.model import Arm
from ..solvers.equilibrium import Equilibrium, check_order
from .arguments import (
    takes_petsc_options as _takes_petsc_options, mesh as _mesh, tensions_p as _tensions,
    progress_bar as _progress, loading_label as _loading)


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

    def to_vtk(self, directory, *, name: str = "solve") -> list[Path]:
        """The state as ParaView files in ``directory`` (created if missing), as
        ``solve --vtk`` writes them (``<name>.vtu``: arm and cables, mm, N)."""
        from ..io.vtk import write_states

        return write_states(directory, self.arm, [self.equilibrium], name=name)

    def summary(self) -> dict:
        """The JSON object that ``elastica-petsc solve --json`` prints."""
        from ..io.summary import equilibrium_summary

        return equilibrium_summary(self.arm, self.equilibrium)


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
    from ..solvers.equilibrium import solve_equilibrium

    disc = _mesh(arm, elements)
    p = _tensions(arm, tensions_N, tensions)
    order = check_order(order, arm.n_tendons)
    if side not in (None, "left", "right"):
        raise InputError(f"side must be 'left' or 'right', got {side!r}")
    eq = solve_equilibrium(disc, p, order=order, side=side)
    return State(arm, eq, _loading(order))


@_takes_petsc_options
def stability(state: State, *, modes: int = 4):
    """The smallest eigenvalues of K v = lambda M v at ``state`` (SLEPc,
    Sec. 4.3 (ii)); ``lambda l^2/B`` is pi^2/4 for the unloaded arm.  Returns a
    ``Stability`` (``eigenvalues``, ``lambda_min``, ``stable``, ``negative``)."""
    from ..solvers.stability import StabilitySolver

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
    from ..solvers.stability import StabilitySolver

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
    from ..core.budget import check_max_seconds
    from ..studies.search import follow_lengths

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
    from ..core.budget import check_max_seconds
    from ..studies.search import search_lengths

    lengths_mm = inputs.cable_lengths_mm(arm, lengths_mm, "lengths_mm")
    max_seconds = check_max_seconds(max_seconds)
    with _progress(progress, "lengths search", "search steps") as bar:
        result = search_lengths(arm, lengths_mm, elements=_mesh(arm, elements).n_elements,
                                progress=bar, max_seconds=max_seconds)
    return replace(result, arm=arm)          # the arm, saved as provenance (config_json)


@_takes_petsc_options
def equilibria(arm: Arm, tensions_N=None, *, tensions=None, elements: int | None = None,
               progress=None, max_seconds: float | None = None):
    """Equilibria that share the given tensions (N, or non-dimensional
    ``tensions`` p = P l^2/B; load control, Eq. (9), Fig. 8), by the search of
    :func:`~elastica_petsc.studies.search.search_tensions` (loading paths,
    curve search, multi-start); a ``SearchResult``: a list, not a proof that
    there are no more.  ``progress``, ``max_seconds``: as for
    :func:`length_equilibria`."""
    from ..core.budget import check_max_seconds
    from ..studies.search import search_tensions

    p = _tensions(arm, tensions_N, tensions)
    max_seconds = check_max_seconds(max_seconds)
    with _progress(progress, "equilibria", "search steps") as bar:
        result = search_tensions(arm, p, elements=_mesh(arm, elements).n_elements,
                                 progress=bar, max_seconds=max_seconds)
    return replace(result, arm=arm)          # the arm, saved as provenance (config_json)
