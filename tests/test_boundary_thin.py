"""A thin workspace (configs/aluminium.toml: W_0 a crescent 2-3 mm wide along
the circle of reach): the default trace's area against an independent sampled
map (forward solves on a tension lattice, the union of the cells' images,
``resampled_area``) within the map's error bar, and against a trace with every
step limit divided by 4.  Before the corners carried their curve's tangent
(``Walker._corner_tangent``, docs/model.md §26) the last piece of every curve was a
straight chord and the default trace gave 1,050.7 mm^2 against 783.3 +- 13.8
sampled (34 % too large)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from elastica_petsc.core.model import load_config
from elastica_petsc.studies.boundary import compare_traces, trace_boundary
from elastica_petsc.studies.design_area import resampled_area

ALUMINIUM = Path(__file__).resolve().parents[1] / "configs" / "aluminium.toml"
AREA_TOL = 2e-3          # relative, against the 4x finer trace (tests/test_design_speed.py)


def test_thin_workspace_area_agrees_with_a_sampled_map_and_a_finer_trace():
    arm = load_config(ALUMINIUM)
    default, fine = trace_boundary(arm), trace_boundary(arm, refine=4)
    report = compare_traces(default, fine)
    for name in ("W0", "restricted"):
        assert report[name]["relative_area_difference"] < AREA_TOL, report
    sampled = resampled_area(arm, arm.max_tension, cells=32, lattice_mm=0.02)
    assert sampled.stable == sampled.samples          # D is the whole tension box
    assert abs(default.areas_mm2["W0"] - sampled.area_mm2) <= sampled.error_mm2, (
        default.areas_mm2["W0"], sampled)
    assert sampled.error_mm2 < 0.02 * sampled.area_mm2


def test_corner_nodes_carry_their_curves_tangent():
    """The corner ending each curve of the W_0 loop moves along that curve (its
    tip velocity now shapes the last Hermite piece): within 0.3 degrees of the
    direction of the last step (0.4-3 mm of tip) of the trace with every step
    limit divided by 16.  Measured: 0.02-0.18 degrees; with the tangent of the
    node before (what corners carried) 0.15-0.61, and that node's own tip
    velocity 5-13 degrees off."""
    arm = load_config(ALUMINIUM)
    coarse, fine = (trace_boundary(arm, restricted=False, tip_folds=False, refine=r)
                    .regions["W0"] for r in (1, 16))
    assert [c.constraint for c in coarse.curves] == [c.constraint for c in fine.curves]
    for c, f in zip(coarse.curves, fine.curves):
        corner = c.points[-1]
        secant = f.points[-1].tip - f.points[-2].tip
        cos = secant @ corner.tip_velocity / (np.linalg.norm(secant)
                                              * np.linalg.norm(corner.tip_velocity))
        assert cos > np.cos(np.radians(0.3)), c.constraint
        assert np.isnan(corner.tip_det)             # corners carry no tip-map test
