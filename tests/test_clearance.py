"""Cables clear of the arm (issue 11): segment geometry, the paper's state 3,
and the flag in JSON/HDF5 outputs."""
from __future__ import annotations

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest

from elastica_petsc.core.clearance import cable_clear, crossing_elements, segment_hits
from elastica_petsc.core.model import load_config
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.loading import Loading
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.reach import replay


def test_segment_hits_cross_touch_and_miss():
    a = np.array([[0.0, 0.0], [0.0, 1.0], [2.0, 0.0]])
    b = np.array([[1.0, 1.0], [1.0, 2.0], [3.0, 0.0]])
    c0, c1 = np.array([0.0, 1.0]), np.array([1.0, 0.0])          # crosses the first only
    np.testing.assert_array_equal(segment_hits(c0, c1, a, b), [True, False, False])
    # an end point on the other segment is not a proper crossing, but is within tol
    touch0, touch1 = np.array([0.5, 0.5]), np.array([0.5, -1.0])
    assert not segment_hits(touch0, touch1, a[:1], b[:1])[0]
    assert segment_hits(touch0, touch1, a[:1], b[:1], tol=1e-9)[0]


def test_cable_clear_on_a_hooked_polyline():
    """A U-shaped arm: a cable from the tip to a point beyond the first leg
    crosses it; one routed away from the arm does not; the element at the
    attachment itself is never counted."""
    nodes = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [1, 1], [0.5, 1]], float)
    tip = len(nodes) - 1
    routes = np.array([[0.5, -1.0], [0.5, 2.0]])
    np.testing.assert_array_equal(cable_clear(nodes, [tip, tip], routes), [False, True])
    np.testing.assert_array_equal(crossing_elements(nodes, tip, routes[0]), [0])
    # inside the U: clear; through the bottom leg: not
    assert cable_clear(nodes, [tip], np.array([[1.5, 0.5]]))[0]
    assert not cable_clear(nodes, [tip], np.array([[1.5, -0.5]]))[0]
    # an attachment mid-arm: its own two elements are not tested
    assert cable_clear(nodes, [2], np.array([[2.5, -1.0]]))[0]


def test_paper_state_3_cable_2_crosses_the_arm():
    """Fig. 8, p = (25.2, 10.8): state 3 (order 1,2) has tendon 2's cable from the
    tip at (-94.4, -387.0) mm to r_2 = (26.1, 51.1) mm pass through the arm about
    12 mm from the clamp (the line crosses y = 0 at x = 12.0 mm); state 1 (order 2,1)
    has both cables clear."""
    arm = load_config()
    disc = Discretisation.from_arm(arm, 180)
    with EquilibriumSolver(disc) as solver:
        s3 = replay(solver, Loading.ordered([25.2, 10.8], (1, 2)))
        s1 = replay(solver, Loading.ordered([25.2, 10.8], (2, 1)))
    np.testing.assert_allclose(s3.cable_lengths * 600.0, [96.2, 454.3], atol=0.2)
    np.testing.assert_array_equal(cable_clear(s3.x, disc.attach_nodes, disc.routes),
                                  [True, False])
    np.testing.assert_array_equal(cable_clear(s1.x, disc.attach_nodes, disc.routes),
                                  [True, True])
    crossed = crossing_elements(s3.x, disc.attach_nodes[1], disc.routes[1])
    s_mm = (crossed + 0.5) * 600.0 / 180
    assert len(crossed) == 1 and 5.0 < s_mm[0] < 20.0
    # independent check: where the cable's line meets y = 0, against the arm there
    tip, r2 = s3.tip * 600.0, np.array([26.1, 51.1])
    t = -tip[1] / (r2[1] - tip[1])
    x_cross = tip[0] + t * (r2[0] - tip[0])
    assert 10.0 < x_cross < 14.0 and abs(s3.x[crossed[0], 1] * 600.0) < 1.0


@pytest.mark.slow
def test_solve_reports_cable_clear_in_json_text_and_hdf5(tmp_path):
    out = tmp_path / "s3.h5"
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "solve", "--tensions",
                          "25.2", "10.8", "--order", "1,2", "--json", "--out", str(out)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["cable_clear"] == [True, False]
    with h5py.File(out, "r") as fh:
        flag = fh["tendons/cable_clear"]
        assert flag.dtype == np.bool_ and list(flag[()]) == [True, False]
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "solve", "--from",
                          str(out)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and "tendon 2's cable crosses the arm" in run.stdout


@pytest.mark.slow
def test_tip_control_cable_policies():
    """The tip of state 3 (tendon 2 through the arm): 'prefer' keeps the reached
    state (flagged) when no clear one is found, 'require' reports it as not
    reached with its own reason."""
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.solvers.reach import CABLE_CROSSES_ARM, Reacher

    arm = load_config()
    with TipController(arm, n_elements=90) as ctl:
        s3 = replay(ctl.solver, Loading.ordered([25.2, 10.8], (1, 2)))
        reacher = Reacher(ctl)
        prefer = reacher.reach(s3.tip, p0=[25.0, 10.0], cables="prefer")
        require = reacher.reach(s3.tip, p0=[25.0, 10.0], cables="require")
    assert prefer.converged and not np.all(cable_clear(
        prefer.equilibrium.x, prefer.equilibrium.disc.attach_nodes,
        prefer.equilibrium.disc.routes))
    assert not require.converged and require.reason == CABLE_CROSSES_ARM
    assert require.reachable is None and require.tip_error_mm < 1e-5


def test_path_clear_tests_every_segment_of_a_guided_cable():
    """A cable through guides (docs/model.md §11): each of its segments is tested;
    a point on the centreline skips its own two elements, an offset point none."""
    from elastica_petsc.core.clearance import path_clear
    nodes = np.array([[0, 0], [1, 0], [2, 0], [3, 0]], float)
    above = (np.array([[0, 0.2], [1, 0.2], [3, 0.2]]), [-1, 1, 3], [1.0, 0.2, 0.2])
    dips = (np.array([[0, 0.2], [1.5, -0.2], [3, 0.2]]), [-1, 1, 3], [1.0, 0.2, 0.2])
    on_line = (np.array([[0, 0.2], [2, 0.0]]), [-1, 2], [1.0, 0.0])
    np.testing.assert_array_equal(path_clear(nodes, [above, dips, on_line]), [True, False, True])


def test_guided_robot_cables_clear_the_arm():
    from elastica_petsc.core.clearance import state_cable_clear
    from conftest import REPO
    disc = Discretisation.from_arm(load_config(REPO / "configs" / "guided3.toml"))
    with EquilibriumSolver(disc) as solver:
        eq = solver.solve([3.0, 1.0])
    assert eq.converged and np.all(state_cable_clear(eq))
    assert len(eq.cable_points[0]) == 5                     # route, 3 guides, end
