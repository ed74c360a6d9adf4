"""``control`` and ``trace`` as a user runs them (issue 3)."""
from __future__ import annotations

import csv
import json
import subprocess
import sys

import h5py
import numpy as np
import pytest


def cli(*args):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def test_control_fig2_target_json_and_hdf5(tmp_path):
    """Fig. 2 target from P = 0: tip within 1e-5 mm, history saved for the figure."""
    out, png = tmp_path / "fig2.h5", tmp_path / "fig2.png"
    run = cli("control", "--target", 535.8, 222.6, "--json", "--out", out, "--plot", png)
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    for key in ("converged", "reachable", "reason", "iterations", "tensions", "tensions_N",
                "cable_lengths_mm", "tip_mm", "tip_error_mm", "tip_sensitivity"):
        assert key in data
    assert data["converged"] and data["tip_error_mm"] < 1e-5
    assert min(data["tensions"]) >= 0
    np.testing.assert_allclose(data["tip_mm"], [535.8, 222.6], atol=1e-5)
    with h5py.File(out, "r") as fh:
        E = fh["control/history_E"][()]
        assert fh["control/history_E"].attrs["units"] == "mm^2"
        assert E[-1] < 1e-10 and np.all(np.diff(E) < 0)          # monotonic decrease (Fig. 2c)
        np.testing.assert_allclose(fh["tendons/cable_lengths"][()], data["cable_lengths_mm"],
                                   atol=1e-5)
    assert png.stat().st_size > 10_000


def test_control_unreachable_exit_3_with_message():
    """(0, 700) mm: |x_d| > l, proven unreachable (the inextensible arm's reach)."""
    run = cli("control", "--target", 0, 700, "--json")
    assert run.returncode == 3
    data = json.loads(run.stdout)                               # JSON still printed
    assert data["converged"] is False and data["reachable"] is False
    assert data["reason"] == "BEYOND_REACH" and "|x_d|" in data["evidence"]
    assert "not reachable" in run.stderr and "BEYOND_REACH" in run.stderr
    assert "Traceback" not in run.stderr


@pytest.mark.slow
def test_control_then_solve_from_file_lands_on_the_target(tmp_path):
    """The branch travels with the result: control --out, then solve --from the file
    replays the recorded loading (order 2,1 here, not proportional loading)."""
    out = tmp_path / "c.h5"
    run = cli("control", "--target", 450, 50, "--out", out, "--json")
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert data["loading"]["kind"] in ("order", "proportional", "path")
    run = cli("solve", "--from", out, "--json")
    assert run.returncode == 0, run.stderr
    again = json.loads(run.stdout)
    assert np.linalg.norm(np.subtract(again["tip_mm"], [450.0, 50.0])) < 1e-3
    assert again["tip_difference_mm"] < 1e-3
    np.testing.assert_allclose(again["tensions"], data["tensions"], atol=1e-9)
    with h5py.File(out, "r") as fh:
        assert fh["loading/vertices"].attrs["units"] == "1"              # CF: p = P l^2/B
        assert "P l^2/B" in fh["loading/vertices"].attrs["long_name"]
        assert fh["control"].attrs["strategy"]
    # user mistakes: one line, exit 2
    for args, message in (([], "--from"), (["--from", tmp_path / "none.h5"], "no such file"),
                          (["--from", out, "--point", 3], "--point"),
                          (["--from", out, "--tensions", 1, 2], "drop --tensions")):
        run = cli("solve", *args)
        assert run.returncode == 2 and message in run.stderr and "Traceback" not in run.stderr


def test_control_bad_input():
    for args, message in ((["--target", 1], "--target"),
                          (["--target", 500, 100, "--guess", -1, 2], "negative"),
                          (["--target", 500, 100, "--guess", 1], "expected 2 tensions")):
        run = cli("control", *args)
        assert run.returncode == 2 and message in run.stderr and "Traceback" not in run.stderr


@pytest.mark.slow
def test_trace_paper_triangle_schedule_and_hdf5(tmp_path):
    """Fig. 3a on a coarse step: every point reached, warm-started points need < 5
    iterations (Sec. 4.5 (v)), the schedule CSV has the documented columns."""
    out, sched = tmp_path / "trace.h5", tmp_path / "trace.csv"
    run = cli("trace", "--shape", "paper-triangle", "--center", 400, 200, "--step", 10,
              "--out", out, "--schedule", sched, "--json")
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert data["all_reached"] and data["max_tip_error_mm"] < 1e-5
    assert data["iterations_max_warm"] < 5
    # Sec. 4.5 (vi): a tracing speed from the lowest natural frequency (paper arm has a mass)
    assert 0.5 < data["f1_min_hz"] < 5 and data["max_tracing_speed_mm_s"] > 0
    with open(sched, newline="") as fh:
        rows = list(csv.DictReader(fh))
    # an approach from the straight arm, then the path, timed at the suggested speed
    assert len(rows) == data["schedule_rows"] == data["approach_points"] + data["points"]
    assert [r["phase"] for r in rows].count("path") == data["points"]
    assert data["speed_mm_s"] == data["max_tracing_speed_mm_s"]
    assert float(rows[-1]["time_s"]) == pytest.approx(data["duration_s"], abs=1e-3)
    expected = ["row", "phase", "point", "time_s", "duration_s", "limited_by", "reached",
                "target_x_mm", "target_y_mm",
                "tip_x_mm", "tip_y_mm"]
    for i in (1, 2):
        expected += [f"tension_{i}_N", f"tension_{i}_p", f"length_{i}_mm", f"revolutions_{i}",
                     f"steps_{i}", f"step_increment_{i}", f"rounding_error_{i}_mm"]
    assert list(rows[0]) == expected
    # one microstep moves 2 pi r / (200 * 16) = 0.0609 mm of cable: rounding <= half of it
    errors = [abs(float(r[f"rounding_error_{i}_mm"])) for r in rows for i in (1, 2)]
    assert max(errors) <= 0.5 * 2 * np.pi * 31.0 / 3200 + 1e-12
    with h5py.File(out, "r") as fh:
        assert fh.attrs["kind"] == "trace"
        K = data["points"]
        assert fh["path/theta"].shape == (K, 181)
        assert fh["path/tip_sensitivity"].shape == (K, 2, 2)
        np.testing.assert_allclose(fh["path/tip"][()], fh["path/target"][()], atol=1e-5)
        K = len(fh["path/tip"]) - 1
        tip_K = fh["path/tip"][K]
    # the last point's loading path (the whole trace) replays to the same state
    run = cli("solve", "--from", out, "--point", K, "--json")
    assert run.returncode == 0, run.stderr
    assert np.linalg.norm(np.subtract(json.loads(run.stdout)["tip_mm"], tip_K)) < 1e-3
    run = cli("solve", "--from", out)
    assert run.returncode == 2 and "--point" in run.stderr


@pytest.mark.slow
def test_trace_csv_path_and_errors(tmp_path):
    points = tmp_path / "points.csv"
    points.write_text("x_mm,y_mm\n450,150\n460,160\n")
    run = cli("trace", "--path", points, "--step", 5, "--json")
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["points"] == 4
    bad = tmp_path / "bad.csv"
    bad.write_text("x_mm,y_mm\n450,abc\n")
    run = cli("trace", "--path", bad)
    assert run.returncode == 2 and "bad.csv" in run.stderr and "Traceback" not in run.stderr
    run = cli("trace", "--shape", "line", "--center", 400, 200)
    assert run.returncode == 2 and "--end" in run.stderr
    run = cli("trace", "--shape", "circle", "--step", 0)
    assert run.returncode == 2 and "--step" in run.stderr
