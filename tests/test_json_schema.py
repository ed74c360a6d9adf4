"""Every command's ``--json`` output, and the error object of exit status 2,
validated against the documented schema (elastica_petsc/schema/output.schema.json,
docs/json.md) by tests/schema_check.py."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from importlib import resources
from pathlib import Path

import pytest

from schema_check import errors

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads((resources.files("elastica_petsc") / "schema" / "output.schema.json")
                    .read_text())
CROSSING_ARM = """
[arm]
length_mm = 450.0
bending_stiffness_Nm2 = 0.15
elements = 30
[[tendon]]
attach_mm = 150.0
route_mm = [300.0, 15.0]
[[tendon]]
attach_mm = 450.0
route_mm = [-20.0, 60.0]
"""
# (name, arguments, exit statuses accepted): small meshes, a few samples each; run in order
# (replay and schedule read what trace wrote)
E, Q = ["--elements", "30"], ["--quiet"]
RUNS = [
    ("solve", ["solve", "--tensions", "1", "1", *E], {0}),
    ("control", ["control", "--target", "500", "200", *E], {0}),
    ("trace", ["trace", "--shape", "line", "--center", "420", "200", "--end", "440", "220",
               "--step", "10", "--schedule", "t.csv", "--out", "t.h5", "--per-point", *E, *Q],
     {0}),
    ("stability", ["stability", "--tensions", "1", "1", *E], {0}),
    ("workspace", ["workspace", "--spacing", "100", "--box", "300", "500", "100", "300",
                   "--out", "w.h5", *E, *Q], {0}),
    ("workspace-tensions", ["workspace", "--mode", "tensions", "--tension-spacing", "10",
                            "--tension-max", "10", "--out", "wt.h5", *E, *Q], {0}),
    ("boundary", ["boundary", *E, *Q], {0}),
    ("lengths", ["lengths", "--lengths", "180", "560", *E, *Q], {0}),
    ("equilibria", ["equilibria", "--tensions", "1", "1", "--effort", "1", *E, *Q], {0}),
    ("replay", ["replay", "t.h5", *Q], {0, 1}),
    ("schedule", ["schedule", "t.csv", "--max-speed-steps-s", "1000"], {0, 1}),
    ("trace-short", ["trace", "--shape", "line", "--center", "599.5", "8", "--end", "599", "11",
                     "--schedule", "short.csv", *E, *Q], {0}),
    ("schedule-speed", ["schedule", "short.csv", "--max-deviation-mm", "1.3", "--rel-tol", "0.5",
                        *E], {0, 1}),
    ("design-path", ["design", "--vary", "tendon2.route", "--objective", "path:path.csv",
                     "--iterations", "1", *E, *Q], {0, 1}),
    ("design-area-infeasible", ["design", "--config", "cross.toml", "--vary", "tendon1.route",
                                "--objective", "area", "--resample-cells", "2", *Q], {1}),
    ("design-sweep", ["design", "--sweep", "tendon2.route.y=50:60:10", *E, *Q], {0}),
    ("design-area-guide", ["design", "--config", str(ROOT / "configs" / "guided.toml"),
                           "--elements", "12", "--vary", "tendon1.guide1.s", "--objective",
                           "area", "--tension-max-N", "27.8", "--resample-cells", "2", *Q],
     {0, 1}),
    ("calibrate", ["calibrate", "--data", "cal.csv", "--vary", "tendon1.route", "--folds", "0",
                   *E, *Q], {0, 1}),
    ("simulate", ["simulate", "--initial-tensions-N", "0", "0.05", "--tensions-N", "0", "0",
                  "--duration", "0.2", *E, *Q], {0}),
    ("friction", ["friction", "--config", str(ROOT / "configs" / "guided3.toml"), "--mu", "0.3",
                  "--peak-N", "10", "--steps", "3", "--elements", "24"], {0}),
    # exit status 5: stopped by --max-seconds (TIME_LIMIT), a budget spent at the first question
    ("control-time-limit", ["control", "--target", "380", "-100", "--max-seconds", "1e-9", *E],
     {5}),
    ("lengths-time-limit", ["lengths", "--lengths", "147.1", "472.5", "--all", "--max-seconds",
                            "1e-9", *E, *Q], {5}),
    ("design-area-time-limit", ["design", "--vary", "tendon2.route", "--objective", "area",
                                "--resample-cells", "2", "--max-seconds", "1e-9", *E, *Q], {5}),
    # exit status 2: a usage error, bad input, an output that cannot be written
    ("usage-error", ["solve", "--tensions", "x"], {2}),
    ("input-error", ["solve", "--tensions", "1"], {2}),
    ("output-error", ["solve", "--tensions", "1", "1", "--out", "no/such/dir/x.h5"], {2}),
]


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("json")
    (cwd / "path.csv").write_text("420,200\n440,220\n")
    (cwd / "cross.toml").write_text(CROSSING_ARM)
    # the first 3 rows of the shipped (synthetic) calibration data
    lines = (ROOT / "examples" / "calibration_data.csv").read_text().splitlines()
    (cwd / "cal.csv").write_text("\n".join(lines[:7]) + "\n")
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    out = {}
    for name, args, statuses in RUNS:
        run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *args, "--json"],
                             cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
        assert run.returncode in statuses, (name, run.returncode, run.stderr)
        out[name] = json.loads(run.stdout)
    return out


@pytest.mark.parametrize("name", [name for name, _, _ in RUNS])
@pytest.mark.slow
def test_json_output_matches_the_schema(outputs, name):
    data = outputs[name]
    assert data["schema_version"] == 1
    assert errors(data, SCHEMA, SCHEMA) == []


@pytest.mark.slow
def test_every_command_with_json_is_covered(outputs):
    from elastica_petsc.cli import COMMANDS

    with_json = {c for c in COMMANDS if c != "reproduce"}
    assert {d["kind"] for d in outputs.values()} == with_json | {"error"}
    assert set(SCHEMA["$defs"]) == with_json | {"error"}


@pytest.mark.slow
def test_the_checker_rejects_what_the_schema_forbids(outputs):
    """The validation can fail: a missing field, a wrong type, a status in words."""
    solve = dict(outputs["solve"])
    del solve["tip_mm"]
    assert errors(solve, SCHEMA, SCHEMA)
    assert errors(dict(outputs["control"], converged="yes"), SCHEMA, SCHEMA)
    ws = dict(outputs["workspace"], status_counts={"reached with P >= 0": 3})
    assert errors(ws, SCHEMA, SCHEMA)
    assert errors(dict(outputs["usage-error"], error="oops"), SCHEMA, SCHEMA)


@pytest.mark.slow
def test_speed_study_is_checked_as_such(outputs):
    """schedule --max-deviation-mm: the study's fields, not the motor check's, are required."""
    speed = outputs["schedule-speed"]
    assert speed["elements"] == 30 and speed["trials"]
    assert errors(dict(speed, trials=[{"speed_mm_s": 1.0}]), SCHEMA, SCHEMA)
    assert errors({k: v for k, v in speed.items() if k != "fastest_mm_s"}, SCHEMA, SCHEMA)
    assert errors({k: v for k, v in outputs["schedule"].items() if k != "playable"},
                  SCHEMA, SCHEMA)


@pytest.mark.slow
def test_time_limit_outcomes(outputs):
    """--max-seconds: the verdict TIME_LIMIT in each command's own field."""
    assert outputs["control-time-limit"]["reason"] == "TIME_LIMIT"
    assert outputs["control-time-limit"]["reachable"] is None
    assert outputs["lengths-time-limit"]["search"]["outcome"] == "TIME_LIMIT"
    assert outputs["lengths"]["search"].get("outcome") is None      # without --all: one path
    assert outputs["design-area-time-limit"]["outcome"] == "TIME_LIMIT"
    assert errors(dict(outputs["design-area-time-limit"], outcome="TIMEOUT"), SCHEMA, SCHEMA)


@pytest.mark.slow
def test_error_objects_and_workspace_fields(outputs):
    assert outputs["usage-error"]["error"] == "USAGE_ERROR"
    assert outputs["input-error"]["error"] == "INPUT_ERROR"
    assert outputs["output-error"]["message"]
    ws = outputs["workspace"]
    assert ws["spacing_mm"] == 100.0 and ws["box_mm"] == [300.0, 500.0, 100.0, 300.0]
    # the 3 x 3 box lattice: area = reached samples x spacing^2, with an error bar
    assert ws["area_mm2"] == pytest.approx(ws["masks"]["W0"] * 100.0 ** 2)
    assert ws["area_error_mm2"] >= 0
    assert outputs["workspace-tensions"]["area_mm2"] is None


def test_lattice_area_of_a_disc_is_within_its_error_bar():
    """A disc of radius R sampled on lattices of spacing h: the estimate is
    within its error bar of pi R^2, the bar is about half a spacing times the
    circumference, and the estimate converges."""
    import numpy as np

    from elastica_petsc.studies.map_area import lattice_area

    R, misses = 100.0, []
    for h in (20.0, 10.0, 5.0, 2.5):
        axis = np.arange(-R - 2 * h, R + 2 * h + h / 2, h) + 0.37 * h      # off-centre lattice
        pts = np.stack(np.meshgrid(axis, axis), -1).reshape(-1, 2)
        area, error = lattice_area(pts, np.hypot(*pts.T) <= R, h, half_plane=False)
        assert abs(area - np.pi * R * R) <= error
        assert error == pytest.approx(0.5 * h * 2 * np.pi * R, rel=0.15)
        misses.append(abs(area - np.pi * R * R))
    assert misses[-1] < 0.01 * np.pi * R * R
