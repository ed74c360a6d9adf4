"""Paths (Fig. 3a), warm-started tracing (Sec. 4.5 (v)) and the motor schedule."""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from elastica_petsc.studies import trace as paths
from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.control import TipController
from elastica_petsc.core.errors import InputError
from elastica_petsc.core.schedule import motor_schedule, schedule_from_trace, write_schedule_csv

CENTER = (400.0, 200.0)   # mm; the whole drawing lies in the workspace (see the trace test)


def distance_to_segment(p, a, b) -> float:
    t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


# --- shapes ----------------------------------------------------------------------------
def test_paper_triangle_geometry():
    """Fig. 3a: side 80 sqrt(3) mm, incircle radius 40 mm tangent to the edges,
    circumcircle radius 80 mm through the vertices, all concentric."""
    c = np.array(CENTER)
    v = paths.triangle_vertices(c, 80.0)
    sides = np.linalg.norm(v - np.roll(v, -1, axis=0), axis=1)
    np.testing.assert_allclose(sides, 80.0 * math.sqrt(3.0), rtol=1e-12)
    for k in range(3):                      # incircle tangent to every edge
        a, b = v[k], v[(k + 1) % 3]
        n = np.array([b[1] - a[1], a[0] - b[0]]) / np.linalg.norm(b - a)
        assert abs(np.dot(c - a, n)) == pytest.approx(40.0, rel=1e-12)

    pts = paths.paper_triangle(c, points_per_circle=37)
    r = np.linalg.norm(pts - c, axis=1)
    on_triangle = np.array([min(distance_to_segment(p, v[k], v[(k + 1) % 3]) for k in range(3))
                            for p in pts]) < 1e-9
    on_in, on_circ = np.isclose(r, 40.0), np.isclose(r, 80.0)
    # order: the three edges from the top vertex, then the incircle, then the circumcircle
    np.testing.assert_allclose(pts[0], v[0])
    first_in = int(np.argmax(on_in & ~on_triangle))
    first_circ_only = int(np.argmax(on_circ & ~on_triangle))
    assert 0 < first_in < first_circ_only
    assert np.all(on_triangle[:first_in - 1])
    assert on_in[first_in:first_in + 36].all()                  # the incircle, closed
    assert on_circ[-37:].all()                                  # then the circumcircle
    np.testing.assert_allclose(pts[-1], v[0])                   # closed where it started
    # every point is on one of the three shapes (the moves between them run along edge 1)
    assert np.all(on_triangle | on_in | on_circ)
    assert np.all(np.linalg.norm(np.diff(pts, axis=0), axis=1) > 0)   # no duplicates


def test_circle_line_densify():
    circ = paths.circle((0.0, 0.0), 10.0, n=9)
    np.testing.assert_allclose(np.linalg.norm(circ, axis=1), 10.0)
    np.testing.assert_array_equal(circ[0], circ[-1])
    seg = paths.line((0.0, 0.0), (3.0, 4.0), n=6)
    np.testing.assert_allclose(np.diff(seg, axis=0), [[0.6, 0.8]] * 5)

    pts = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 2.5], [10.0, 2.5]])
    dense = paths.densify(pts, 3.0)
    steps = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    assert steps.max() <= 3.0 + 1e-12
    for p in pts:                                   # the original points are kept
        assert np.min(np.linalg.norm(dense - p, axis=1)) == 0.0
    np.testing.assert_array_equal(dense[0], pts[0])
    np.testing.assert_array_equal(dense[-1], pts[-1])
    assert len(paths.densify(pts, 100.0)) == len(pts)
    with pytest.raises(InputError, match="step"):
        paths.densify(pts, 0.0)
    with pytest.raises(InputError, match="radius"):
        paths.circle((0, 0), -1.0)


def test_read_csv(tmp_path):
    good = tmp_path / "path.csv"
    good.write_text("x_mm,y_mm\n# comment\n400, 200\n\n401.5,199\n")
    np.testing.assert_array_equal(paths.read_csv(good), [[400.0, 200.0], [401.5, 199.0]])
    bare = tmp_path / "bare.csv"
    bare.write_text("1,2\n3,4\n")
    np.testing.assert_array_equal(paths.read_csv(bare), [[1, 2], [3, 4]])
    swapped = tmp_path / "swapped.csv"                 # read by name, not by position
    swapped.write_text("y_mm,x_mm\n200,400\n199,401.5\n")
    np.testing.assert_array_equal(paths.read_csv(swapped), [[400.0, 200.0], [401.5, 199.0]])

    cases = {
        "cols.csv": ("x_mm,y_mm\n1,2,3\n", r"cols\.csv:2: expected 2 columns"),
        "nan.csv": ("x_mm,y_mm\n1,2\n3,abc\n", r"nan\.csv:3: not a number"),
        "xy.csv": ("x,y\n1,2\n", r"xy\.csv:1: header 'x,y'.*unknown: x, y"),
        "onecol.csv": ("x_mm\n1\n", r"onecol\.csv:1: header 'x_mm': expected"),
        "extra.csv": ("x_mm,y_mm,z_mm\n1,2,3\n", r"unknown: z_mm"),
        "inf.csv": ("1,inf\n", r"inf\.csv:1: non-finite"),
        "empty.csv": ("x_mm,y_mm\n", r"empty\.csv: no points"),
    }
    for name, (text, message) in cases.items():
        f = tmp_path / name
        f.write_text(text)
        with pytest.raises(InputError, match=message):
            paths.read_csv(f)
    with pytest.raises(InputError, match="no such path file"):
        paths.read_csv(tmp_path / "missing.csv")


# --- tracing ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def traced():
    """Fig. 3a about (400, 200) mm, densified at 10 mm (201 points), 90 elements."""
    arm = load_config()
    targets = paths.densify(paths.paper_triangle(CENTER), 10.0)
    with TipController(arm, n_elements=90) as ctl:
        trace = paths.trace(ctl, targets, keep_results=True)
    return arm, targets, trace


def test_trace_reaches_every_point(traced):
    _, targets, tr = traced
    assert tr.n_points == len(targets) == 201
    assert tr.all_converged
    assert tr.tip_errors_mm.max() < 1e-5
    np.testing.assert_allclose(tr.tips_mm, targets, atol=1e-5)
    assert np.all(tr.E < tr.results[0].eps)
    assert np.all(tr.p > 0)


def test_warm_started_points_need_few_iterations(traced):
    """Sec. 4.5 (v): < 5 iterations per warm-started point.  Measured: 2 or 3."""
    _, _, tr = traced
    warm = tr.iterations[1:]
    assert warm.max() <= 3
    assert np.median(warm) <= 3
    assert tr.iterations[0] > warm.max()            # the cold first point is the hard one
    # the warm start really is the previous point: its tensions are the initial guess
    for prev, res in zip(tr.results[:-1], tr.results[1:]):
        np.testing.assert_array_equal(res.history_p[0], prev.p)


def test_lengths_and_tensions_vary_together(traced):
    """Sec. 4.1: cable lengths and tensions change with opposite signs.  The
    sum over tendons always does (dL/dp is symmetric negative definite at a
    stable state); per tendon it holds on most steps (measured: 98 % and 86 %)."""
    _, _, tr = traced
    assert tr.work_fraction() == 1.0
    frac = tr.monotonic_fraction()
    assert frac.shape == (2,)
    assert frac[0] > 0.95 and frac[1] > 0.8
    assert all(r.equilibrium.stable for r in tr.results)


def test_schedule_csv(traced, tmp_path):
    arm, targets, tr = traced
    out = tmp_path / "schedule.csv"
    sched = write_schedule_csv(out, tr, arm)
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    expected = ["row", "phase", "point", "time_s", "duration_s", "limited_by", "reached",
                "target_x_mm", "target_y_mm",
                "tip_x_mm", "tip_y_mm"]
    for i in (1, 2):
        expected += [f"tension_{i}_N", f"tension_{i}_p", f"length_{i}_mm", f"revolutions_{i}",
                     f"steps_{i}", f"step_increment_{i}", f"rounding_error_{i}_mm"]
    assert list(rows[0].keys()) == expected
    assert len(rows) == tr.n_points
    assert [int(r["point"]) for r in rows] == list(range(tr.n_points))
    assert {r["phase"] for r in rows} == {"path"}       # no approach traced here
    for i in (1, 2):
        assert float(rows[0][f"revolutions_{i}"]) == 0.0 and int(rows[0][f"steps_{i}"]) == 0
    # spool arithmetic: 31 mm spool, 200 x 16 microsteps per revolution
    circumference = 2 * math.pi * 31.0
    dL = tr.cable_lengths_mm - tr.cable_lengths_mm[0]
    np.testing.assert_allclose(sched.revolutions, dL / circumference)
    np.testing.assert_array_equal(sched.steps, np.rint(dL / circumference * 3200).astype(int))
    np.testing.assert_allclose(sched.rounding_error_mm,
                               sched.steps * circumference / 3200 - dL, atol=1e-12)
    assert np.abs(sched.rounding_error_mm).max() <= 0.5 * circumference / 3200 + 1e-12
    last = rows[-1]
    assert float(last["length_2_mm"]) == pytest.approx(tr.cable_lengths_mm[-1, 1], rel=1e-9)
    assert float(last["tension_1_N"]) == pytest.approx(tr.tensions_N[-1, 0], rel=1e-9)
    assert int(last["steps_1"]) == sched.steps[-1, 0]
    np.testing.assert_allclose(schedule_from_trace(tr, arm).steps, sched.steps)


def test_schedule_without_trace():
    arm = load_config()
    sched = motor_schedule([[100.0], [100.0 + 2 * math.pi * 31.0]], arm.motor)
    assert sched.revolutions[1, 0] == pytest.approx(1.0)
    assert sched.steps[1, 0] == 3200
    with pytest.raises(InputError, match="shape"):
        motor_schedule([1.0, 2.0], arm.motor)
