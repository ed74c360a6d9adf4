"""The timed motor schedule (core/schedule.py, studies/schedule.py): an approach
from the straight arm, a time column, reached flags, documented step signs.

The CSV is checked by a reader written from the documented columns alone
(core/schedule.py docstring), and the schedule is driven through the
length-controlled model (Sec. 4.6) in the order of its time column: it must
reproduce the planned tips.
"""
from __future__ import annotations

import csv
import math
import os
import stat

import h5py
import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.schedule import motor_schedule
from elastica_petsc.solvers.control import TipController
from elastica_petsc.solvers.lengths import LengthSolver
from elastica_petsc.studies.replay import replay
from elastica_petsc.studies.schedule import approach_targets, trace_schedule
from elastica_petsc.studies.trace import densify, line

ELEMENTS = 60
SPEED = 5.0          # mm/s


@pytest.fixture(scope="module")
def planned():
    arm = load_config()
    path = densify(line((420.0, 200.0), (470.0, 240.0)), 10.0)
    with TipController(arm, n_elements=ELEMENTS) as controller:
        return arm, trace_schedule(controller, path, step_mm=10.0, speed_mm_s=SPEED)


def read_documented_csv(path):
    """A reader that knows only the columns documented in core/schedule.py."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    n = sum(1 for c in rows[0] if c.startswith("length_") and c.endswith("_mm"))
    expected = ["row", "phase", "point", "time_s", "duration_s", "limited_by", "reached",
                "target_x_mm", "target_y_mm",
                "tip_x_mm", "tip_y_mm"]
    for i in range(1, n + 1):
        expected += [f"tension_{i}_N", f"tension_{i}_p", f"length_{i}_mm", f"revolutions_{i}",
                     f"steps_{i}", f"step_increment_{i}", f"rounding_error_{i}_mm"]
    assert list(rows[0]) == expected
    col = {c: np.array([float(r[c]) for r in rows]) for c in expected
           if c not in ("phase", "reached", "limited_by")}
    col["phase"] = [r["phase"] for r in rows]
    assert {r["reached"] for r in rows} <= {"true", "false"}
    col["reached"] = np.array([r["reached"] == "true" for r in rows])
    return n, col


def test_csv_passes_a_checker_of_its_documented_columns(planned, tmp_path):
    arm, plan = planned
    out = tmp_path / "schedule.csv"
    plan.schedule.write_csv(out)
    # the mode of any new file (0666 less the umask), not mkstemp's 0600
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(os.stat(out).st_mode) == 0o666 & ~mask
    n, col = read_documented_csv(out)
    R = len(col["row"])
    np.testing.assert_array_equal(col["row"], np.arange(R))
    # approach rows first (from the straight arm at row 0), then the path
    phases = col["phase"]
    k = phases.index("path")
    assert k > 0 and set(phases[:k]) == {"approach"} and set(phases[k:]) == {"path"}
    np.testing.assert_array_equal(col["point"][:k], np.arange(k))
    np.testing.assert_array_equal(col["point"][k:], np.arange(R - k))
    np.testing.assert_allclose([col["tip_x_mm"][0], col["tip_y_mm"][0]], [600.0, 0.0], atol=1e-9)
    for i in range(1, n + 1):
        assert col[f"tension_{i}_N"][0] == 0.0 and col[f"steps_{i}"][0] == 0
    # time: 0 at row 0, the tip moves between rows at the given speed
    tips = np.column_stack((col["tip_x_mm"], col["tip_y_mm"]))
    assert col["time_s"][0] == 0.0
    np.testing.assert_allclose(np.diff(col["time_s"]),
                               np.linalg.norm(np.diff(tips, axis=0), axis=1) / SPEED,
                               rtol=1e-6, atol=1e-9)     # 12 significant digits in the CSV
    # reached: the tip is within the tolerance (1e-5 mm) of the target, and only then
    targets = np.column_stack((col["target_x_mm"], col["target_y_mm"]))
    np.testing.assert_array_equal(col["reached"],
                                  np.linalg.norm(tips - targets, axis=1) <= 1e-5 * (1 + 1e-6))
    # steps from row 0 on a 31 mm spool at 200 x 16 microsteps; > 0 pays cable out
    mm_per_step = 2 * math.pi * 31.0 / 3200
    for i in range(1, n + 1):
        L, steps = col[f"length_{i}_mm"], col[f"steps_{i}"]
        dL = L - L[0]
        np.testing.assert_array_equal(steps, np.rint(dL / mm_per_step))
        assert np.all(np.sign(steps[np.abs(dL) > mm_per_step]) ==
                      np.sign(dL[np.abs(dL) > mm_per_step]))
        np.testing.assert_array_equal(col[f"step_increment_{i}"], np.diff(steps, prepend=0))
        np.testing.assert_allclose(col[f"rounding_error_{i}_mm"], steps * mm_per_step - dL,
                                   atol=1e-7)
        assert np.abs(col[f"rounding_error_{i}_mm"]).max() <= mm_per_step / 2 + 1e-7
        np.testing.assert_allclose(col[f"revolutions_{i}"], dL / (2 * math.pi * 31.0),
                                   rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(col[f"tension_{i}_N"],
                                   col[f"tension_{i}_p"] * arm.force_scale_N, rtol=1e-8)
    # pulling the tip up and back from the straight arm reels cable 2 (at the tip) in
    assert col["steps_2"][-1] < 0 and col["tension_2_N"][-1] > 0


def test_replay_of_the_timed_schedule_reproduces_the_plan(planned):
    """Sec. 4.6: the motors impose cable lengths.  Started at the straight
    arm and stepped through the rows in the order of the time column (length
    continuation, no tensions given), the length-controlled model stays on
    the planned branch at every row; between rows (lengths interpolated in
    time, as motors at constant speed do) the tip stays near the plan."""
    arm, plan = planned
    sched = plan.schedule
    assert sched.reached.all()
    order = np.argsort(sched.time_s, kind="stable")
    np.testing.assert_array_equal(order, np.arange(sched.n_rows))
    disc = Discretisation.from_arm(arm, ELEMENTS)
    with LengthSolver(disc, length_mm=arm.length_mm) as solver:
        result = replay(solver, sched.lengths_at(sched.time_s[order]), sched.tips_mm[order])
        assert result.completed and result.all_on_branch, result.summary()
        assert result.max_tip_error_mm < 1e-3
        # halfway between rows in time the tip stays within 0.15 mm of the
        # midpoint of the planned tips (measured 0.12 mm; with uniform 10 mm
        # approach steps from the straight arm it strayed 11 mm)
        mid = 0.5 * (sched.time_s[:-1] + sched.time_s[1:])
        tips_mid = 0.5 * (sched.tips_mm[:-1] + sched.tips_mm[1:])
        between = replay(solver, sched.lengths_at(mid), tips_mid, tip_tol_mm=0.15)
        assert between.completed and between.all_on_branch, between.summary()


def test_hdf5_schedule_group_matches_the_csv(planned, tmp_path):
    from elastica_petsc.io.hdf5 import write_schedule

    _, plan = planned
    sched = plan.schedule
    with h5py.File(tmp_path / "s.h5", "w") as fh:
        write_schedule(fh.create_group("schedule"), sched)
    with h5py.File(tmp_path / "s.h5", "r") as fh:
        g = fh["schedule"]
        assert g["reached"].dtype == np.bool_
        assert [p.decode() for p in g["phase"][()]] == list(sched.phase)
        np.testing.assert_array_equal(g["steps"][()], sched.steps)
        np.testing.assert_array_equal(g["time"][()], sched.time_s)
        assert g.attrs["speed_mm_s"] == SPEED and g["time"].attrs["units"] == "s"


def test_approach_targets_and_untimed_schedule():
    pts = approach_targets((600.0, 0.0), (500.0, 100.0), 10.0)
    np.testing.assert_allclose(pts[0], (600.0, 0.0))
    h = np.linalg.norm(np.diff(np.vstack((pts, (500.0, 100.0))), axis=0), axis=1)
    d = np.linalg.norm(pts - (600.0, 0.0), axis=1)
    assert h[0] == pytest.approx(0.05) and h.max() <= 10.0 + 1e-9
    np.testing.assert_allclose(h[:-1], np.minimum(10.0, np.maximum(0.05, np.sqrt(0.5 * d[:-1]))))
    arm = load_config()
    sched = motor_schedule([[100.0], [110.0]], arm.motor)
    assert np.isnan(sched.time_s).all() and math.isnan(sched.speed_mm_s)
    with pytest.raises(Exception, match="no time column"):
        sched.lengths_at(0.0)


@pytest.mark.slow
def test_trace_command_per_point_json_schedule_and_speed(tmp_path):
    """`trace --json --per-point --schedule --speed-mm-s`: the JSON points, the
    CSV's path rows and the HDF5 schedule agree; a line leaving the workspace
    has its unreached points flagged (exit status 1)."""
    import json
    import subprocess
    import sys

    csv_path, h5 = tmp_path / "s.csv", tmp_path / "t.h5"
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "trace", "--shape", "line",
                          "--center", "560", "150", "--end", "640", "150", "--step", "20",
                          "--elements", str(ELEMENTS), "--speed-mm-s", "4", "--json",
                          "--per-point", "--schedule", str(csv_path), "--out", str(h5),
                          "--quiet"], capture_output=True, text=True, timeout=300)
    assert run.returncode == 1, run.stderr
    assert "--per-point" in run.stderr and "Traceback" not in run.stderr
    data = json.loads(run.stdout)
    points = data["per_point"]
    assert len(points) == data["points"] == 5
    assert [p["point"] for p in points] == list(range(5))
    assert data["speed_mm_s"] == 4.0 and data["speed_source"] == "given"
    n, col = read_documented_csv(csv_path)
    path = [k for k, ph in enumerate(col["phase"]) if ph == "path"]
    assert [p["reached"] for p in points] == list(col["reached"][path])
    assert 0 < sum(p["reached"] for p in points) < len(points)    # (640, 150) is beyond reach
    np.testing.assert_allclose([p["time_s"] for p in points], col["time_s"][path], atol=1e-3)
    np.testing.assert_allclose([p["tensions_N"] for p in points],
                               np.column_stack([col[f"tension_{i}_N"][path] for i in (1, 2)]),
                               rtol=1e-5, atol=1e-6)
    with h5py.File(h5, "r") as fh:
        np.testing.assert_array_equal(fh["schedule/reached"][()], col["reached"])
        np.testing.assert_array_equal(fh["path/converged"][()], [p["reached"] for p in points])
