"""Issue 25, design at speed: the boundary's walker against a finer trace of
itself (area and curves within the walker's tolerance), the restricted walk
taking over W_0's nodes, and the area objective's warm starts, its early
rejection and its re-sampling by one loading path, each against the plain
computation."""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.geometry import union_area
from elastica_petsc.core.model import load_config
from elastica_petsc.studies.boundary import compare_traces, trace_boundary
from elastica_petsc.studies.boundary.faces import loop_polygon
from elastica_petsc.studies.boundary.walker import Walker, constraints_for
from elastica_petsc.studies.design import with_routes
from elastica_petsc.studies.design_area import resampled_area
from elastica_petsc.solvers.continuation import CurveTracer
from elastica_petsc.studies.traced_area import WarmStart, traced_area

ELEMENTS = 30
P_MAX = 18.0                                  # 10 N on the paper's arm
Q0 = np.array([46.3, -97.1, 26.1, 51.1])      # both routing points, mm
AREA_TOL = 2e-3          # relative: the default trace against one with 4x finer steps
CELLS_TOL = 3            # curves within 3 cells (l/500) of the finer trace: the margin
#                          OUTSIDE_BOUNDARY keeps from every traced curve (docs/model.md §9.1)


def test_default_trace_agrees_with_a_finer_trace():
    """The paper's arm at 180 elements (what `boundary` traces by default): W_0,
    the restricted workspace and the tip-map fold curves against the trace with
    every step limit divided by 4."""
    arm = load_config()
    coarse, fine = trace_boundary(arm), trace_boundary(arm, refine=4)
    report = compare_traces(coarse, fine)
    cell_mm = arm.length_mm / 500
    for name in ("W0", "restricted"):
        assert report[name]["relative_area_difference"] < AREA_TOL, report
        assert report[name]["hausdorff_mm"] < CELLS_TOL * cell_mm, report
    assert report["fold_curves"]["count"] == (3, 3)
    assert report["fold_curves"]["hausdorff_mm"] < CELLS_TOL * cell_mm, report
    assert not coarse.untraced_folds and coarse.area_bounds_mm2[0] == coarse.area_bounds_mm2[1]
    assert coarse.solves < fine.solves / 2


def test_restricted_walk_takes_over_w0_nodes():
    """The restricted walk with W_0's curves known: nodes taken over (the same
    objects), fewer solves, and the same loop as the walk by steps alone
    within the walker's tolerance."""
    arm = load_config()
    disc = Discretisation.from_arm(arm, 60)
    with CurveTracer(disc) as tracer:
        w0 = np.concatenate((disc.straight(), np.zeros(2)))
        regions, solves = {}, {}
        for name, restricted, known in (("W0", False, ()), ("steps", True, ()),
                                        ("replay", True, "W0")):
            cons = constraints_for(tracer, arm, restricted)
            walker = Walker(tracer, cons, known=regions[known].curves if known else ())
            regions[name] = walker.walk(name, w0, first=cons[1], previous=cons[0])
            solves[name] = walker.counts.solves
            walker.destroy()
    assert all(r.closed for r in regions.values())
    shared = {id(pt) for c in regions["W0"].curves for pt in c.points}
    taken = sum(id(pt) in shared for c in regions["replay"].curves for pt in c.points)
    assert taken >= 10 and solves["replay"] < solves["steps"] - 10, (taken, solves)
    assert [c.constraint for c in regions["replay"].curves] == \
        [c.constraint for c in regions["steps"].curves]
    areas = [union_area(loop_polygon(regions[k], arm.length_mm)) for k in ("steps", "replay")]
    assert areas[1] == pytest.approx(areas[0], rel=AREA_TOL)


def test_area_objective_equals_the_boundary_area_warm_or_cold():
    """The design objective of the paper's arm is `boundary`'s W_0 area of the
    arm with the motor limit; a design evaluated after another (its check
    warm-started from that design's states) gives the same check and area as
    evaluated alone."""
    arm = load_config()
    from elastica_petsc.studies.traced_area import limited

    limited_arm = limited(arm, P_MAX)
    boundary = trace_boundary(limited_arm, Discretisation.from_arm(limited_arm, ELEMENTS))
    a = traced_area(arm, [0, 1], P_MAX, elements=ELEMENTS)
    assert a.area_mm2 == pytest.approx(boundary.areas_mm2["W0"], rel=1e-12)
    warm = WarmStart()
    traced_area(arm, [0, 1], P_MAX, elements=ELEMENTS, warm=warm)
    moved = with_routes(arm, [0, 1], Q0 + [2.0, -3.0, -1.0, -2.0])
    cold = traced_area(moved, [0, 1], P_MAX, elements=ELEMENTS)
    hot = traced_area(moved, [0, 1], P_MAX, elements=ELEMENTS, warm=warm, skip_infeasible=True)
    assert hot.traced and hot.feasible == cold.feasible
    assert np.array_equal(hot.node_converged, cold.node_converged)
    assert np.array_equal(hot.node_clear, cold.node_clear)
    assert hot.area_mm2 == cold.area_mm2 and np.array_equal(hot.gradient, cold.gradient)


def test_rejected_design_is_not_traced():
    """A design whose cable crosses the arm (routing point 2 at 3 mm from the arm's
    line, far beyond the start): the check stops at its first failure and the
    boundary is not traced; evaluated in full it is infeasible too."""
    arm = with_routes(load_config(), [1], [26.1, 3.0])
    full = traced_area(arm, [0, 1], P_MAX, elements=ELEMENTS)
    warm = WarmStart()
    quick = traced_area(arm, [0, 1], P_MAX, elements=ELEMENTS, warm=warm, skip_infeasible=True)
    assert not full.feasible and not quick.feasible and not quick.traced
    assert np.isnan(quick.area_mm2)
    stop = int(np.argmin(quick.node_converged & quick.node_clear.all(axis=1)))
    assert not (full.node_converged[stop] and full.node_clear[stop].all())
    assert quick.node_converged[:stop].all() and not quick.node_converged[stop + 1:].any()
    assert np.array_equal(np.flatnonzero(quick.node_checked), np.arange(stop + 1))
    seen = quick.node_checked
    assert np.array_equal(quick.node_converged[seen], full.node_converged[seen])
    assert np.array_equal(quick.node_clear[seen], full.node_clear[seen])
    # the next design checks the node that stopped this one first, and stops there
    again = traced_area(with_routes(arm, [1], [26.1, 2.5]), [0, 1], P_MAX, elements=ELEMENTS,
                        warm=warm, skip_infeasible=True)
    assert np.flatnonzero(again.node_checked).tolist() == [stop] and not again.feasible


def test_resampling_by_one_loading_path_equals_the_map():
    """The re-sampling's serpentine loading path with inertia counts against
    ``workspace --mode tensions`` (chunks from the straight arm, SLEPc's
    lambda_min): the same stable lattice and area."""
    from elastica_petsc.studies.workspace import Status, run_map

    arm = load_config()
    cells = 8
    ours = resampled_area(arm, P_MAX, elements=ELEMENTS, cells=cells, lattice_mm=0.5)
    disc = Discretisation.from_arm(arm, ELEMENTS)
    ws = run_map(arm, disc, mode="tensions", tension_spacing=P_MAX / cells, tension_max=P_MAX,
                 comm=MPI.COMM_SELF, progress=False)
    s = ws.samples
    stable = (s["status"] == Status.REACHED) & (s["lambda_min"] > 0)
    assert ours.stable == int(stable.sum()) == (cells + 1) ** 2
    tips = np.sort(np.round(np.asarray(s["tip"])[stable], 6), axis=0)
    assert np.allclose(np.sort(ours.tips_mm, axis=0), tips, atol=1e-6)
