"""Where reproduce places the paper's experiments on a user arm (studies/placement.py)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from elastica_petsc.core.model import Arm, load_config
from elastica_petsc.studies.placement import Placement, interior_target, placement

ROOT = Path(__file__).resolve().parents[1]
PAPER = Placement(np.array([535.8, 222.6]), (400.0, 200.0), (420.0, 190.0), 1.0,
                  np.array([147.1, 472.5]))


def test_interior_target_is_the_reached_sample_farthest_from_the_rest():
    x, y = np.meshgrid(np.arange(0.0, 60.0, 10.0), np.arange(0.0, 60.0, 10.0))
    targets = np.column_stack((x.ravel(), y.ravel()))
    reached = np.max(np.abs(targets - 25.0), axis=1) < 20.0          # a 4 x 4 block
    centre, clearance = interior_target(targets, reached)
    assert reached[np.flatnonzero((targets == centre).all(axis=1))[0]]
    assert clearance == 15.0 and np.all(np.abs(centre - 25.0) <= 5.0)    # 20 less h/2
    # the edge of the sampled region counts as outside: a block against the reach circle
    x, y = np.meshgrid(np.arange(0.0, 110.0, 10.0), np.arange(0.0, 110.0, 10.0))
    targets = np.column_stack((x.ravel(), y.ravel()))
    centre, clearance = interior_target(targets, np.hypot(x, y).ravel() <= 100.0,
                                        reach_mm=100.0)
    assert clearance > 0 and np.linalg.norm(centre) + clearance + 5.0 <= 100.0 + 1e-9
    assert centre[1] >= clearance + 5.0                        # and from the line y = 0
    assert interior_target(targets, np.zeros(len(targets), bool)) is None


def test_the_paper_arm_keeps_the_papers_numbers():
    arm = dataclasses.replace(Arm.paper(), elements=60)
    assert placement(arm, PAPER, [25.2, 10.8]) is PAPER


def test_a_user_arm_gets_reachable_targets():
    """The Fig. 2 target is the tip of the arm's own state 1, reached by loading."""
    from elastica_petsc.solvers.control import TipController
    arm = dataclasses.replace(load_config(ROOT / "configs" / "guided3.toml"), elements=24)
    place = placement(arm, PAPER, [25.2, 10.8])
    assert place.note.startswith("a user arm") and place.size == 0.5
    assert np.linalg.norm(place.fig2_target_mm) < arm.length_mm
    with TipController(arm) as ctl:
        res = ctl.solve_mm(place.fig2_target_mm, p0=np.zeros(2))
    assert res.converged and res.tip_error_mm < 1e-3
