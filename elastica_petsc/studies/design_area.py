"""The area objective of ``design`` (issue 13): the workspace of a motor with a
force limit, its exact design gradient, and its check by re-sampling.

**Which area.**  The unrestricted W_0 of the paper's arm (tips of stable
equilibria connected to the straight arm by quasi-static loading with all
P_i >= 0) is ill-posed as an objective: as P grows a cable collapses onto its
routing point, the tip map x_t(p) folds inside the tension region (det(d x_t/d
p) changes sign; on the paper's arm at 60 elements already inside the box
0 <= p_i <= 40) and several equilibria share one P, so the area of a traced
loop is not the area of W_0 and is not smooth in the design.  The last
session's optimiser of that area raised the traced area from 478e3 to 802e3
mm^2 while the independent Fig. 4 map of the optimised arm reached fewer
targets (1029 against 1401): the gain was an artefact of folds.

We therefore optimise the **restricted** workspace W_0 ∩ W_P of a motor limit
P_max (Eq. (22) with P_crit = P_max, default 10 N): the tips of the equilibria
reached by quasi-static loading from the straight arm with 0 <= P_i <= P_max.
Its area A(q) [mm^2] and dA/dq are those of its traced boundary
(studies/traced_area.py: the set and area that ``boundary`` reports for the
arm with that motor limit, the gradient from the normal velocity of the
traced loop's nodes; TAO BLMVM).  Until issue 21 the objective was the
shoelace area of the image of the tension box's boundary at 24 nodes per
edge, whose straight chords cut the curved inner edge (1.9 % too large on
the paper's arm, the gradient 15 % off).

**Its validity is checked, not assumed.**  Along the loop the intrinsic
tip-map test (det(d x_t/d p)) must keep one sign (``det_sign_changes``
reports a fold reaching the boundary); interior folds, unstable states and
states off the quasi-static branch are what the independent re-sampling
(:func:`resampled_area`) catches: forward solves on a tension lattice over
B (:func:`tension_sweep`, the states ``workspace --mode tensions`` finds),
its cells' images as triangles, and the area of their union counted on a
fine lattice.  Where the map folds, the union is
smaller than A; so the optimiser's gain is claimed only if the re-sampled
areas before and after differ by more than their errors.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.results import Result
from ..core.clearance import state_cable_clear
from ..core.fem import Discretisation
from ..core.geometry import triangles_union_area
from ..core.model import Arm
from .traced_area import TracedArea, WarmStart, traced_area


def infeasibility(area: TracedArea, force_scale_N: float) -> dict:
    """Which constraint a design's loop violates, in N: the tensions of the nodes
    whose equilibrium was not solved, and per crossing tendon (numbered from 1)
    how many nodes, the first and last along the loop, and the smallest
    max(P_1, P_2) among them (a tension box below it avoids those nodes)."""
    P = area.tensions * force_scale_N
    crossings = []
    for i in range(area.node_clear.shape[1]):
        at = np.flatnonzero(~area.node_clear[:, i])
        if len(at):
            crossings.append({"tendon": i + 1, "nodes": int(len(at)), "of": int(len(P)),
                              "first_tensions_N": P[at[0]].round(4).tolist(),
                              "last_tensions_N": P[at[-1]].round(4).tolist(),
                              "lowest_max_tension_N": float(P[at].max(axis=1).min().round(4))})
    return {"unsolved_tensions_N": P[~area.node_converged].round(4).tolist(),
            "crossings": crossings}


# --- independent re-sampling -------------------------------------------------------------------
@dataclass
class Resampled:
    """Area of the image of the tension box from a forward tension-grid map (mm^2)."""

    area_mm2: float
    error_mm2: float            # |A(s) - A(2s)| + lattice term (see resampled_area)
    samples: int
    reached: int                # converged forward solves
    stable: int                 # of them with lambda_min > 0 (Eq. (20))
    cables_clear: int           # of them with every cable clear of the arm
    seconds: float
    tips_mm: np.ndarray = None  # tips of the stable samples (k, 2), for plots


def _triangles(tips: np.ndarray, good: np.ndarray) -> np.ndarray:
    """The images (T, 3, 2) of the two triangles of each grid cell whose three
    corners are good; ``tips`` and ``good`` are (n, n[, 2]) on the tension lattice."""
    a, b = tips[:-1, :-1], tips[1:, :-1]
    c, d = tips[1:, 1:], tips[:-1, 1:]
    ga, gb, gc, gd = good[:-1, :-1], good[1:, :-1], good[1:, 1:], good[:-1, 1:]
    t1 = np.stack((a, b, c), axis=2)[ga & gb & gc]
    t2 = np.stack((a, c, d), axis=2)[ga & gc & gd]
    return np.concatenate((t1, t2))


def resampled_area(arm: Arm, p_max: float, *, elements: int | None = None, cells: int = 20,
                   lattice_mm: float = 0.25) -> Resampled:
    """Re-sample the workspace of ``arm`` within 0 <= p_i <= ``p_max``: forward
    solves on a (cells + 1)^2 tension lattice (:func:`tension_sweep`:
    quasi-static loading from the straight arm, continued along the rows),
    the union of the images of the cells whose corners are stable
    (no negative eigenvalue of K, Eq. (20)) equilibria, its area counted on
    a lattice of ``lattice_mm``.  The error is |A(s) - A(2s)| (the same map
    on every other lattice line; it bounds the chords' error whenever
    halving s at least halves it, and Richardson's s^2 estimate, a third of
    it, was too small on coarse grids) plus perimeter x lattice spacing (a
    bound on the counting's).  Measured on the paper's arm (60 elements,
    P_max = 10 N): A = 60917, 58914 mm^2 at 16, 32 cells against 58472 mm^2
    for the box loop's shoelace at 48 nodes per edge (the objective before
    issue 21)."""
    import time

    t0 = time.perf_counter()
    disc = Discretisation.from_arm(arm, elements)
    tips, reached, stable, clear = tension_sweep(disc, p_max, cells)
    tips = tips * arm.length_mm
    fine = triangles_union_area(_triangles(tips, stable), lattice_mm)
    coarse = triangles_union_area(_triangles(tips[::2, ::2], stable[::2, ::2]), lattice_mm)
    edge = np.concatenate([tips[:, 0], tips[-1, 1:], tips[-2::-1, -1], tips[0, -2:0:-1]])
    perimeter = float(np.nansum(np.linalg.norm(np.diff(edge, axis=0), axis=1)))
    return Resampled(fine, abs(fine - coarse) + perimeter * lattice_mm, reached.size,
                     int(reached.sum()), int(stable.sum()), int((clear & reached).sum()),
                     time.perf_counter() - t0, tips[stable])


def tension_sweep(disc: Discretisation, p_max: float, cells: int):
    """Forward solves on the lattice p = (i, j) p_max/cells, i, j = 0..cells:
    one quasi-static loading path from the straight arm through every node,
    serpentine along the rows (each node from the last one reached; ``workspace
    --mode tensions`` restarts from the straight arm every 24 samples and
    computes lambda_min with SLEPc: the same areas on the paper's arm and
    its optimum, at a third of the cost), stability from the path's inertia
    counts (Sylvester, Eq. (20)).  Returns tips (units of l),
    reached, stable and cables-clear masks, each on the (cells + 1)^2 lattice."""
    from ..solvers.equilibrium import EquilibriumSolver

    n, spacing = cells + 1, p_max / cells
    tips = np.full((n, n, 2), np.nan)
    reached, stable, clear = (np.zeros((n, n), bool) for _ in range(3))
    previous = None
    with EquilibriumSolver(disc) as solver:
        for i in range(n):
            for j in (range(n) if i % 2 == 0 else range(n - 1, -1, -1)):
                eq = solver.solve(np.array([i * spacing, j * spacing]), start=previous)
                if not eq.converged:
                    continue
                previous = eq
                tips[i, j], reached[i, j] = eq.tip, True
                stable[i, j] = eq.unstable_modes == 0
                clear[i, j] = bool(np.all(state_cable_clear(eq)))
    return tips, reached, stable, clear


# --- the optimiser -----------------------------------------------------------------------------
INFEASIBLE_START = "INFEASIBLE_START"   # AreaDesign.reason: the start violates a constraint
STALL_GAIN = 1e-3        # relative area gain over 3 iterations below which TAO is stopped
@dataclass(frozen=True, repr=False)
class AreaDesign(Result):
    """Outcome of ``design --objective area`` (mm, mm^2, N)."""

    arm_before: Arm
    arm_after: Arm
    tendons: list
    p_max: float                    # the box's bound, non-dimensional
    before: TracedArea
    after: TracedArea
    resampled_before: Resampled | None
    resampled_after: Resampled | None
    history: list
    reason: str
    iterations: int
    seconds: float
    offsets: tuple = ()             # OffsetVariable (design_offsets.py), after the routes

    @property
    def confirmed(self) -> bool | None:
        """The gain holds in the re-sampling: the intervals A +- error of the
        re-sampled areas before and after do not overlap (None: not re-sampled)."""
        a, b = self.resampled_before, self.resampled_after
        if a is None or b is None:
            return None
        return b.area_mm2 - b.error_mm2 > a.area_mm2 + a.error_mm2

    def summary(self) -> dict:
        """What ``design --objective area --json`` prints (areas before/after, routes)."""
        from ..io.summaries import area_summary

        return area_summary(self)


def search_attachments(arm: Arm, attaches, evaluate, *, elements: int, reach_mm: float):
    """Attachment arc lengths on mesh nodes: a pattern search (move one
    attachment by one node, keep the move if the design is feasible and the
    area grows, until no move helps), within +- ``reach_mm`` of the start and
    on (0, l].  ``evaluate(arm) -> TracedArea``.  Returns (arm, its TracedArea)."""
    from .design import with_attachment

    h = arm.length_mm / elements
    start = {i: arm.tendons[i].attach_mm for i in attaches}
    best = evaluate(arm)
    moved = True
    while moved:
        moved = False
        for i, step in ((i, step) for i in attaches for step in (h, -h)):
            s = arm.tendons[i].attach_mm + step
            if not (h - 1e-9 <= s <= arm.length_mm + 1e-9 and abs(s - start[i]) <= reach_mm):
                continue
            candidate = with_attachment(arm, i, s)
            a = evaluate(candidate)
            if a.feasible and a.area_mm2 > best.area_mm2:
                arm, best, moved = candidate, a, True
                break
    return arm, best


def design_for_area(arm: Arm, tendons, p_max: float, *, elements: int | None = None,
                    attaches=(), reach_mm: float = 100.0, clearance_mm: float = 10.0,
                    max_iterations: int = 15, scale_mm: float = 10.0,
                    resample_cells: int | None = 32, options_prefix: str = "design_",
                    progress=None, stop=None, offsets=()) -> AreaDesign:
    """Routing points (mm) of ``tendons`` (0-based) maximising the area A of the
    workspace within 0 <= p_i <= ``p_max`` (= P_max l^2/B; module docstring),
    by TAO BLMVM with the exact gradient dA/dq, within the bounds of
    :func:`~elastica_petsc.studies.design.route_bounds`; before that, the
    attachment arc lengths of ``attaches`` on mesh nodes
    (:func:`search_attachments`).  ``offsets``: guide offsets
    (:class:`~.design_offsets.OffsetVariable`, mm, within
    :func:`~.design_offsets.offset_bounds`) varied with the routing points,
    their gradient from the same loop (docs/model.md §26).  Then both arms are re-sampled
    independently (:func:`resampled_area`, ``resample_cells`` cells per
    tension axis; None skips it) and the gain is ``confirmed`` only if the
    re-sampled areas differ by more than their errors.  ``progress(evaluations,
    note)``, if given, is called after every evaluation and before the
    re-sampling.  ``stop()``, if given, is asked at every iteration: True ends
    the optimisation there and skips the re-sampling (a time budget)."""
    import time

    from .design import DesignError

    if not (np.isfinite(p_max) and p_max > 0):
        raise DesignError(f"--tension-max must be a positive force, got p = {p_max}")
    t0 = time.perf_counter()
    elements = Discretisation.from_arm(arm, elements).n_elements
    history, best, first, seen = [], {}, [], {}
    warm = WarmStart()                  # each design starts from the last one's states

    def evaluate(candidate):
        key = candidate.tendons                  # attachments, routes, guides and offsets
        if key in seen:                          # TAO's first call is the start, evaluated
            return seen[key]
        # the start in full (its report); later designs stop at a failed check
        a = seen[key] = traced_area(candidate, tendons, p_max, elements=elements, warm=warm,
                                    skip_infeasible=bool(first), offsets=offsets)
        if not first:
            first.append(a)
        history.append({"attach_mm": [t.attach_mm for t in candidate.tendons],
                        "routes_mm": [list(t.route_mm) for t in candidate.tendons],
                        **({"offsets_mm": [v.value_mm(candidate) for v in offsets]}
                           if offsets else {}),
                        "area_mm2": a.area_mm2 if a.traced else None,
                        "gradient": a.gradient.tolist() if a.traced else None,
                        "feasible": a.feasible, "converged": a.converged,
                        "cables_clear": a.cables_clear, "det_sign_changes": a.det_sign_changes})
        if a.feasible and (not best or a.area_mm2 > best["area"].area_mm2):
            best.update(area=a, arm=candidate)
        if progress is not None:
            progress(len(history), f"area {a.area_mm2:.0f} mm^2"
                     + ("" if a.feasible else " (rejected: infeasible)") if a.traced else
                     "rejected: a cable crosses the arm or a node is not solved")
        return a

    designed, reason, iterations = arm, "", 0
    if not evaluate(arm).feasible:               # nothing to start from: no optimiser, no checks
        return AreaDesign(arm, arm, list(tendons), p_max, first[0], first[0], None, None,
                          history, INFEASIBLE_START, 0, time.perf_counter() - t0, tuple(offsets))
    if attaches:
        designed, _ = search_attachments(arm, attaches, evaluate, elements=elements,
                                         reach_mm=reach_mm)
    if tendons or offsets:
        reason, iterations = _optimise_routes(designed, tendons, evaluate, history,
                                              reach_mm=reach_mm, clearance_mm=clearance_mm,
                                              scale_mm=scale_mm, max_iterations=max_iterations,
                                              options_prefix=options_prefix, stop=stop,
                                              offsets=offsets)
    after_arm = best.get("arm", arm)
    checks = [None, None]
    if resample_cells and not (stop is not None and stop()):
        if progress is not None:
            progress(len(history), "re-sampling both arms on a tension grid")
        checks = [resampled_area(a, p_max, elements=elements, cells=resample_cells)
                  for a in (arm, after_arm)]
    return AreaDesign(arm, after_arm, list(tendons), p_max, first[0], best.get("area", first[0]),
                      *checks, history, reason, iterations, time.perf_counter() - t0,
                      tuple(offsets))


def _optimise_routes(arm, tendons, evaluate, history, *, reach_mm, clearance_mm, scale_mm,
                     max_iterations, options_prefix, stop=None, offsets=()):
    """TAO BLMVM on the routing points of ``tendons`` and the guide offsets
    ``offsets`` (f = -A/A_0); an infeasible design (a node unreachable, or a
    cable across the arm) returns f = 1, so that the (Armijo) line search
    backs off."""
    from ..solvers.minimise import minimise_bounded
    from .design import design_vector

    q0, lo, hi, designed = design_vector(arm, tendons, offsets, reach_mm, clearance_mm)

    def objective(q):
        a = evaluate(designed(q))
        scale = history[0]["area_mm2"]                     # f = -A/A_0, O(1)
        if not a.feasible:
            return 1.0, np.zeros_like(a.gradient)
        return -a.area_mm2 / scale, -a.gradient / scale

    best_by_iteration = []

    def stalled() -> bool:
        """Stop when the best feasible area grew by less than 0.1 % over the last
        3 iterations (the optimum lies on the feasibility edge, where the line
        search keeps being rejected)."""
        best_by_iteration.append(max((h["area_mm2"] for h in history if h["feasible"]),
                                     default=0.0))
        b = best_by_iteration
        return len(b) > 3 and b[-1] - b[-4] < STALL_GAIN * b[-1]

    return minimise_bounded(objective, q0, lo, hi, scale_mm=scale_mm,
                            max_iterations=max_iterations, options_prefix=options_prefix,
                            line_search="armijo",
                            done=lambda: stalled() or (stop is not None and stop()))
