"""What ``design`` tells a user when the design cannot be improved (issue 26):
an infeasible start says what fails and what to change, a TAO stop after 0
iterations is not reported as a result, and --out is written only for an
improved design."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

# an asymmetric user arm whose tendon 1, routed along the arm at (300, 15) mm,
# crosses the arm on the edge of the 10 N tension box
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


def design(tmp_path, *extra):
    (tmp_path / "arm.toml").write_text(CROSSING_ARM)
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "design", "--config",
                           "arm.toml", "--vary", "tendon1.route", "tendon2.route", "--objective",
                           "area", "--resample-cells", "2", "--iterations", "2", "--quiet",
                           "--out", "designed.toml", *extra],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_infeasible_start_says_what_fails_and_writes_nothing(tmp_path):
    run = design(tmp_path)
    assert run.returncode == 1, run.stderr
    text = run.stdout
    assert "the starting design is infeasible" in text
    # which cable, at which tensions, and what to change
    assert "tendon 1's cable crosses the arm at 1 of the 96 nodes, P = (10, 0.833) N" in text
    assert "move r_1 farther from the arm" in text and "lower --tension-max-N below 10 N" in text
    assert "TAO:" not in text and "%" not in text       # no optimiser "result" of 0 iterations
    assert "designed.toml not written" in text
    assert not (tmp_path / "designed.toml").exists()
    run = design(tmp_path, "--json")
    data = json.loads(run.stdout)
    assert data["outcome"] == "INFEASIBLE_START" and data["file"] is None
    assert data["start"]["cables_clear"] is False and data["iterations"] == 0
    crossing, = data["start"]["crossings"]
    assert crossing["tendon"] == 1 and crossing["first_tensions_N"] == [10.0, 0.8333]
    assert data["resampled_before"] is None          # no re-sampling of an infeasible start


def test_fold_note_is_a_whole_sentence():
    from elastica_petsc.cli.design import area_lines

    sampled = {"area_mm2": 1.0, "error_mm2": 0.1, "samples": 4, "reached": 4, "stable": 4,
               "cables_clear": 4}
    summary = {"outcome": "NOT_CONFIRMED", "tension_max_N": 10.0, "tension_max": 18.0,
               "elements": 30, "area_before_mm2": 1.0, "area_after_mm2": 1.1,
               "resampled_before": sampled, "resampled_after": sampled, "confirmed": False,
               "iterations": 2, "evaluations": 3, "seconds": 1.0, "tao_reason": "DIVERGED_MAXITS",
               "routes_before_mm": [[1, 2]], "routes_after_mm": [[1, 2]],
               "attach_before_mm": [1.0], "attach_after_mm": [1.0],
               "fold_sign_changes_before": 2, "fold_sign_changes_after": 2}
    note = [line for line in area_lines(summary) if "note:" in line][0]
    assert note.endswith("is the one to trust")
