"""Replaying a traced path under length control: the cable-length schedule of
tip control (Sec. 4.5 (v)) applied to the length-controlled arm (Sec. 4.6),
with every snap, buckling and loss of stability on the way reported.
Lengths in mm where named ``*_mm``, else in units of l."""
from __future__ import annotations

from dataclasses import dataclass
import itertools
import math

import numpy as np

from ..core.errors import InputError
from ..solvers.equilibrium import EquilibriumSolver
from ..solvers.lengths import LengthEquilibrium, LengthSolver, check_lengths


@dataclass(frozen=True)
class ReplayPoint:
    """One point of a replayed schedule (mm where named so, else units of l)."""

    index: int
    lengths_mm: np.ndarray        # prescribed cable lengths
    planned_tip_mm: np.ndarray
    state: LengthEquilibrium      # the replayed equilibrium (converged or not)
    tip_error_mm: float           # |replayed tip - planned tip|
    shape_error: float | None     # max |theta - planned theta| [rad], if planned shapes given
    on_branch: bool               # shape (or tip) within tolerance of the plan
    jumped: bool                  # a snap/buckling happened on the way to this point

    @property
    def tip_mm(self) -> np.ndarray:
        return self.state.tip_mm

    @property
    def stable(self) -> bool:
        """Stable under length control."""
        return self.state.length_unstable_modes == 0


@dataclass(frozen=True)
class Replay:
    """The length-controlled model stepped through a planned schedule."""

    points: tuple                 # ReplayPoint per reached point
    n_planned: int
    start_method: str             # how the first point was reached

    @property
    def completed(self) -> bool:
        return len(self.points) == self.n_planned and all(q.state.converged for q in self.points)

    @property
    def max_tip_error_mm(self) -> float:
        return max((q.tip_error_mm for q in self.points), default=math.nan)

    @property
    def all_on_branch(self) -> bool:
        return self.completed and all(q.on_branch for q in self.points)

    @property
    def first_departure(self) -> int | None:
        """Index of the first point off the planned branch (or not reached)."""
        for q in self.points:
            if not (q.state.converged and q.on_branch):
                return q.index
        return None if self.completed else len(self.points)

    @property
    def jumps(self) -> list[tuple[int, np.ndarray]]:
        """(point index, cable lengths in mm) of every snap/buckling on the way."""
        return [(q.index, np.asarray(L) * q.state.length_mm)
                for q in self.points for L in q.state.jumps]

    @property
    def instabilities(self) -> list[tuple[int, np.ndarray, str]]:
        """(point index, cable lengths in mm, kind) of every loss of stability on
        the way: kind "bifurcation" (buckling: the path switched to a stable
        branch beside it) or "limit point" (a fold: the arm snapped),
        :func:`~elastica_petsc.solvers.lengths.instability_kind`."""
        return [(q.index, np.asarray(L) * q.state.length_mm, kind)
                for q in self.points
                for L, kind in zip(q.state.instabilities, q.state.instability_kinds)]

    def summary(self) -> str:
        lines = [f"replayed {len(self.points)} of {self.n_planned} points under length control "
                 f"(first point by {self.start_method}); max tip error "
                 f"{self.max_tip_error_mm:.3g} mm; "
                 + ("stayed on the planned branch" if self.all_on_branch else
                    f"left the planned branch at point {self.first_departure}")]
        for k, L, kind in self.instabilities:
            what = ("a bifurcation (buckling; switched to a stable branch beside it)"
                    if kind == "bifurcation" else "a limit point (the arm snaps)")
            lines.append(f"  stability lost before point {k} at L = ("
                         + ", ".join(f"{v:.3f}" for v in L) + f") mm: {what}")
        for k, L in self.jumps:
            lines.append(f"  jump (snap/buckling) before point {k} at L = ("
                         + ", ".join(f"{v:.3f}" for v in L) + ") mm")
        unstable = [q.index for q in self.points if q.state.converged and not q.stable]
        if unstable:
            lines.append(f"  unstable under length control at points {unstable}")
        return "\n".join(lines)


def replay(solver: LengthSolver, lengths_mm, planned_tips_mm, planned_tensions=None,
           planned_thetas=None, *, eq_solver: EquilibriumSolver | None = None,
           tip_tol_mm: float = 1e-3, shape_tol: float = 1e-3, on_point=None) -> Replay:
    """Step the length-controlled arm through a schedule of cable lengths.

    ``lengths_mm`` (K, n) and ``planned_tips_mm`` (K, 2) come from a traced
    path (tip control at each point, Sec. 4.5 (v)); ``planned_tensions``
    (K, n, non-dimensional p) and ``planned_thetas`` (K, N+1 nodal angles)
    are optional.  The first point is reached from the straight arm: with
    planned tensions, by the load-controlled state at the first planned
    tensions (loading orders tried: proportional, then each permutation;
    the one whose tip is nearest the plan is used) and a length-controlled
    solve from it; without, by length continuation from the straight arm.
    Every further point is reached by :meth:`LengthSolver.follow` from the
    previous one (warm start, stability kept, snaps and buckling recorded).
    A point is on the planned branch if its shape is within ``shape_tol``
    rad of the planned shape (when given) or else its tip within
    ``tip_tol_mm`` of the planned tip.  Stops after a point that cannot be
    reached.  ``on_point(done)`` is called after each point (progress).
    """
    if solver.length_mm is None:
        raise InputError("replay needs the arm length: build the solver with "
                         "LengthSolver.from_arm()")
    disc, l_mm = solver.disc, solver.length_mm
    Ls = np.atleast_2d(np.asarray(lengths_mm, float))
    tips = np.atleast_2d(np.asarray(planned_tips_mm, float))
    K = Ls.shape[0]
    if Ls.shape != (K, disc.n_tendons) or tips.shape != (K, 2):
        raise InputError(f"replay needs lengths_mm of shape (K, {disc.n_tendons}) and "
                         f"planned_tips_mm of shape (K, 2); got {Ls.shape} and {tips.shape}")
    if planned_thetas is not None:
        planned_thetas = np.atleast_2d(np.asarray(planned_thetas, float))
        if planned_thetas.shape != (K, disc.n_elements + 1):
            raise InputError(f"planned_thetas must have shape ({K}, {disc.n_elements + 1})")
    for L in Ls:
        check_lengths(L, disc.n_tendons)

    start, method = None, "length continuation from the straight arm"
    if planned_tensions is not None:
        P = np.atleast_2d(np.asarray(planned_tensions, float))
        if P.shape != (K, disc.n_tendons):
            raise InputError(f"planned_tensions must have shape ({K}, {disc.n_tendons})")
        own = eq_solver is None
        eqs = EquilibriumSolver(disc) if own else eq_solver
        try:
            best = None
            for order in [None] + list(itertools.permutations(range(1, disc.n_tendons + 1))):
                eq = eqs.solve(P[0], order=order)
                if eq.converged:
                    err = np.linalg.norm(eq.tip * l_mm - tips[0])
                    if best is None or err < best[0]:
                        best = (err, eq, order)
        finally:
            if own:
                eqs.destroy()
        if best is not None:
            start = best[1]
            how = "proportional" if best[2] is None else "order " + ",".join(map(str, best[2]))
            method = f"load-controlled state at the planned tensions ({how}), then length control"

    points = []
    state = start
    for k in range(K):
        state = solver.follow(Ls[k] / l_mm, state, keep_stable=True, label=f"point {k}")
        tip_err = float(np.linalg.norm(state.tip * l_mm - tips[k]))
        shape_err = None
        if planned_thetas is not None:
            shape_err = float(np.max(np.abs(state.theta - planned_thetas[k])))
            on = shape_err <= shape_tol
        else:
            on = tip_err <= tip_tol_mm
        points.append(ReplayPoint(k, Ls[k].copy(), tips[k].copy(), state, tip_err, shape_err,
                                  bool(on and state.converged),
                                  bool(state.jumps or state.instabilities)))
        if on_point is not None:
            on_point(k + 1)
        if not state.converged:
            break
    return Replay(tuple(points), K, method)


def replay_trace(trace: dict, *, first_by_lengths: bool = False, tip_tol_mm: float = 1e-3,
                 shape_tol: float = 1e-3, on_point=None) -> Replay:
    """:func:`replay` of a traced path as read by
    :func:`elastica_petsc.io.replay.read_trace` (its arm, mesh, cable lengths
    and tips in mm, planned tensions and shapes), with a solver made for it;
    ``first_by_lengths``: reach the first point by length continuation instead
    of the load-controlled state at the planned tensions; ``on_point(done)``:
    progress, as for :func:`replay`."""
    from ..core.fem import Discretisation

    arm = trace["arm"]
    disc = Discretisation.from_arm(arm, trace["elements"])
    with LengthSolver(disc, length_mm=arm.length_mm) as solver:
        return replay(solver, trace["cable_lengths"], trace["tip"],
                      None if first_by_lengths else trace["tensions"], trace["theta"],
                      tip_tol_mm=tip_tol_mm, shape_tol=shape_tol, on_point=on_point)
