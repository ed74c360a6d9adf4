"""A --speed-mm-s the motors cannot follow is flagged (issue 26, motor-aware
schedules): ``trace`` re-times the rows where a motor limit binds, says how many
on stderr, and names the limiting motor per row in the schedule; at a speed the
motors follow, nothing is said and no row is slowed by a motor."""
from __future__ import annotations

import csv
import json
import subprocess
import sys

USER_TOML = """
[arm]
length_mm = 450.0
bending_stiffness_Nm2 = 0.15
elements = 30
[[tendon]]
attach_mm = 150.0
route_mm = [40.0, -70.0]
[[tendon]]
attach_mm = 450.0
route_mm = [-20.0, 60.0]
[motor]
spool_radius_mm = 20.0
microsteps = 8
max_speed_steps_s = [2500.0, 1200.0]
max_accel_steps_s2 = [8000.0, 3000.0]
"""


def trace(tmp_path, speed):
    (tmp_path / "user.toml").write_text(USER_TOML)
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "trace", "--config",
                          "user.toml", "--shape", "line", "--center", "300", "150", "--end",
                          "320", "180", "--step", "4", "--no-approach", "--speed-mm-s",
                          str(speed), "--schedule", f"s{speed}.csv", "--json", "--quiet"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    with open(tmp_path / f"s{speed}.csv", newline="") as fh:
        limited = [row["limited_by"] for row in csv.DictReader(fh)]
    return json.loads(run.stdout), run.stderr, limited


def test_a_speed_the_motors_cannot_follow_is_flagged(tmp_path):
    summary, stderr, limited = trace(tmp_path, 2000)
    slowed = [x for x in limited if x.startswith(("speed_", "accel_"))]
    assert summary["rows_slowed_by_motor"] == len(slowed) > 0
    assert (f"warning: the motors cannot follow --speed-mm-s 2000 on {len(slowed)} rows"
            in stderr)
    summary, stderr, limited = trace(tmp_path, 1)
    assert summary["rows_slowed_by_motor"] == 0 and "cannot follow" not in stderr
    assert not any(x.startswith(("speed_", "accel_")) for x in limited)
