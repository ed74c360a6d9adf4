"""The area objective of the designs (``design --objective area``, ``design
--sweep``) on the traced boundary of the workspace (issue 21).

The set is W_0 ∩ W_P of a motor limit P_max (Eq. (22)): the tips of the
stable equilibria reached by quasi-static loading from the straight arm with
0 <= P_i <= P_max.  Its boundary is traced by pseudo-arclength continuation
(studies/boundary, docs/model.md §9) on the arm with the motor limit P_max,
so the area A(q) [mm^2] is the one that ``boundary`` reports for that arm
(the winding area of the Hermite-densified loop; the loop's nodes are
adaptive, so the cables' clearance is checked on fixed nodes of the tension
box's boundary, 24 per edge, solved in turn), and

    dA/dq = sum_k  n_k . d x_k/d q     (at fixed tensions p_k)

the boundary integral of the normal velocity of the loop's nodes
(``route_gradients`` of :func:`trace_boundary`, in mm^2 per mm of the routing
points).  The node polygon of a fixed loop in tension space (the previous
objective: the image of the box's boundary at 24 nodes per edge) cut the
curved inner edge with straight chords: on the paper's arm at 10 N it gave
59,436 mm^2 against 58,330 mm^2 from ``boundary`` (58,250 since the corners'
tangents, docs/model.md §26; 58,254 converged) and a gradient 15 % off
finite differences of ``boundary``; the traced loop agrees with ``boundary``
by construction and its gradient with finite differences of ``boundary``
to 2 % (within 1.3 % on the paper's arm; tests/test_traced_area.py, docs/model.md §17.3).

For an optimiser (issue 25, docs/model.md §24) the
clearance check runs first, each node warm-started from the previous design's
state there (:class:`WarmStart`), and a design that fails it is not traced.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..core.clearance import state_cable_clear
from ..core.fem import Discretisation
from ..core.model import Arm

CHECK_NODES_PER_EDGE = 24    # the clearance check's tension nodes per edge of the box


@dataclass
class TracedArea:
    """The area objective of one design (module doc), mm and mm^2."""

    area_mm2: float
    gradient: np.ndarray        # dA/dq [mm^2/mm], 2 per varied tendon, then 1 per offset
    loop_mm: np.ndarray         # tips at the traced loop's nodes (M, 2)
    det_sign_changes: int       # sign changes of det(d x_t/d p) along the traced loop
    closed: bool                # the walk around the region closed
    tensions: np.ndarray        # the check's nodes on the box's boundary (K, 2), p = P l^2/B
    node_converged: np.ndarray  # (K,) the node's equilibrium solved
    node_clear: np.ndarray      # (K, n) cable i clear of the arm at the node (core/clearance.py)
    traced: bool = True         # False: the check failed first, the boundary was not traced
    #                             (area and gradient NaN, ``skip_infeasible``)
    node_checked: np.ndarray | None = None   # (K,) nodes the check reached (None: all)

    @property
    def _checked(self) -> np.ndarray:
        return (np.ones(len(self.node_converged), bool) if self.node_checked is None
                else self.node_checked)

    @property
    def converged(self) -> bool:
        """The walk closed (or was not needed) and every node checked was solved."""
        return ((self.closed or not self.traced)
                and bool(self.node_converged[self._checked].all()))

    @property
    def cables_clear(self) -> bool:
        """No cable crosses the arm at any node checked."""
        return bool(self.node_clear[self._checked].all())

    @property
    def feasible(self) -> bool:
        return self.traced and self.converged and self.cables_clear


@dataclass
class WarmStart:
    """What the evaluated designs leave to the next one (an optimiser's
    designs follow each other closely): the check's states at the box's
    nodes, (K, size), each from the last design that solved the node (NaN
    rows: none did), the Newton guess of the same node for the next design
    (:func:`_clearance`)."""

    check: np.ndarray | None = None
    failed: int | None = None     # the node at which the last check that stopped did


def limited(arm: Arm, p_max: float) -> Arm:
    """``arm`` with the motor limit P_max = p_max B/l^2 (Eq. (22))."""
    return dataclasses.replace(arm, motor=dataclasses.replace(
        arm.motor, max_tension_N=float(p_max * arm.force_scale_N)))


def traced_area(arm: Arm, tendons, p_max: float, *, elements: int | None = None,
                warm: WarmStart | None = None, skip_infeasible: bool = False,
                offsets=()) -> TracedArea:
    """A(q) and dA/dq (module doc) for the routing points of ``tendons``
    (0-based) of a two-tendon ``arm`` within 0 <= p_i <= ``p_max``, then for
    the guide offsets ``offsets`` (:class:`~.design_offsets.OffsetVariable`,
    mm^2 per mm; docs/model.md §26).

    ``warm``: the states of the previous design (updated with this one's),
    the Newton guesses of the clearance check.  ``skip_infeasible``: the
    check runs first and stops at its first unsolved node or crossing cable;
    the boundary is then not traced (``traced`` False, area NaN): what an
    optimiser needs of a design it rejects anyway."""
    from .boundary import trace_boundary

    arm = limited(arm, p_max)
    disc = Discretisation.from_arm(arm, elements)
    n_q = 2 * len(tendons) + len(offsets)          # the gradient's length
    tensions = box_loop(p_max, CHECK_NODES_PER_EDGE)
    solved, clear, checked = _clearance(disc, tensions, warm, stop_at_failure=skip_infeasible)
    if skip_infeasible and not (solved.all() and clear.all()):
        return TracedArea(np.nan, np.full(n_q, np.nan), np.zeros((0, 2)), 0, False,
                          tensions, solved, clear, traced=False, node_checked=checked)
    traced = trace_boundary(arm, disc, restricted=False, tip_folds=False,
                            route_gradients=tuple(tendons),
                            offset_gradients=[v.points(arm) for v in offsets])
    region = traced.regions["W0"]
    points = [pt for curve in region.curves for pt in curve.points]
    tests = np.array([pt.tip_det for pt in points])
    signs = np.sign(tests[np.isfinite(tests) & (tests != 0.0)])
    changes = int(np.sum(signs != np.roll(signs, 1))) if len(signs) > 1 else 0
    gradient = traced.area_gradients.get("W0", np.full(n_q, np.nan))
    return TracedArea(float(traced.areas_mm2["W0"]), np.asarray(gradient, float),
                      np.array([pt.tip for pt in points]) * arm.length_mm, changes,
                      bool(region.closed), tensions, solved, clear)


def box_loop(p_max: float, nodes_per_edge: int) -> np.ndarray:
    """Tensions (K, 2) around the box [0, p_max]^2, counter-clockwise in p from
    the origin: P_2 = 0, P_1 = p_max, P_2 = p_max, P_1 = 0 (``nodes_per_edge``
    nodes per edge, the corners once)."""
    t = np.arange(nodes_per_edge) / nodes_per_edge * p_max
    zero, top = np.zeros_like(t), np.full_like(t, p_max)
    return np.concatenate([np.column_stack((t, zero)), np.column_stack((top, t)),
                           np.column_stack((p_max - t, top)), np.column_stack((zero, p_max - t))])


def _clearance(disc: Discretisation, tensions: np.ndarray, warm: WarmStart | None = None, *,
               stop_at_failure: bool = False):
    """(solved (K,), clear (K, n), checked (K,)): the states along the loop of
    tension nodes, each solved from the previous one (a quasi-static loading
    path), and whether every cable clears the arm there (core/clearance.py).
    The traced loop's nodes are adaptive and may step over a short crossing;
    these fixed nodes are the feasibility check of the designs (issue 26's
    messages).

    With ``warm`` states of earlier designs, a node is first solved by Newton
    at its tensions from the last state found there (:func:`_warm_state`);
    only if that fails is it reached along the loading path.
    ``stop_at_failure``: the check stops at the first unsolved node or
    crossing cable (later nodes unchecked, False), and the node where the
    last design's check stopped is tried first, from its warm state alone
    (the same result it gets in turn)."""
    from ..solvers.equilibrium import EquilibriumSolver

    K = len(tensions)
    solved, clear = np.zeros(K, bool), np.zeros((K, disc.n_tendons), bool)
    checked = np.zeros(K, bool)
    guesses = warm.check if warm is not None and warm.check is not None else None
    if guesses is not None and guesses.shape != (K, disc.size):
        guesses = None
    states = np.full((K, disc.size), np.nan)
    found = {}

    def record(k, eq) -> bool:
        found[k], checked[k] = eq, True
        solved[k], clear[k] = bool(eq.converged), state_cable_clear(eq)
        if eq.converged:
            states[k] = eq.u
        return bool(solved[k] and clear[k].all())

    with EquilibriumSolver(disc) as solver:
        first = warm.failed if stop_at_failure and warm is not None else None
        if first is not None and guesses is not None and np.isfinite(guesses[first, 0]):
            eq = _warm_state(solver, guesses[first], tensions[first])
            if eq is not None and not record(first, eq):
                return _keep(warm, guesses, states, solved, clear, checked, first)
        for k, p in enumerate(tensions):
            eq = found.get(k)
            if eq is None and guesses is not None and np.isfinite(guesses[k, 0]):
                eq = _warm_state(solver, guesses[k], p)
            if eq is None:
                eq = solver.solve(p, start=found.get(k - 1))
            if not record(k, eq) and stop_at_failure:
                return _keep(warm, guesses, states, solved, clear, checked, k)
    return _keep(warm, guesses, states, solved, clear, checked, None)


def _keep(warm, guesses, states, solved, clear, checked, failed):
    """Leave this design's states (a node not solved keeps its older one) and
    the node where its check stopped (else the last one that stopped a check)
    in ``warm``; (solved, clear, checked)."""
    if warm is not None:
        keep = np.isnan(states[:, 0])
        if guesses is not None and keep.any():
            states = np.where(keep[:, None], guesses, states)
        warm.check = states
        warm.failed = warm.failed if failed is None else failed
    return solved, clear, checked


def _warm_state(solver, guess: np.ndarray, p: np.ndarray):
    """The equilibrium at tensions ``p`` by one Newton solve from ``guess`` (the
    same node's state of a nearby design), if it converged to a stable state
    within the solver's jump tolerance of the guess (no nodal angle moved by
    more than ``jump_tol``) with no cable collapsed; else None."""
    from ..solvers.equilibrium import COLLAPSE_LENGTH, Equilibrium, newton_converged

    disc = solver.disc
    u, its, reason = solver.newton(guess, p)
    n = disc.n_elements
    if (not newton_converged(reason) or np.max(np.abs(u[:n] - guess[:n])) > solver.jump_tol
            or np.min(disc.shortest_segments(disc.split(u)[1])) < COLLAPSE_LENGTH):
        return None
    modes = solver.inertia.negative_eigenvalues(u, p)
    if modes:
        return None
    return Equilibrium(disc, np.asarray(p, float), u, True, reason, its, 1, unstable_modes=0,
                       p_requested=np.asarray(p, float))
