"""Guide offsets as design variables of the path objective (issue 24;
studies/design_offsets.py): Danskin's gradient with the offset terms passes a
Taylor test, the optimiser moves a guide, bad names are one-line input errors."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from elastica_petsc.core.errors import InputError
from elastica_petsc.core.model import load_config
from elastica_petsc.studies.design import design_for_path, path_misfit, with_routes
from elastica_petsc.studies.design_offsets import (offset_bounds, split_offset_names,
                                                   with_offsets)

ROOT = Path(__file__).resolve().parents[1]
TARGETS = [[200.0, 150.0], [100.0, 100.0]]     # reached; out of reach (both cables taut)


@pytest.fixture(scope="module")
def arm():
    return load_config(ROOT / "configs" / "guided3.toml")


def test_path_misfit_gradient_in_offsets_and_routes_taylor(arm):
    """f(q + eps v) - f(q) - eps g.v = O(eps^2) for a routing point, a common offset
    and one guide's offset together (the targets' minimisers held by Danskin)."""
    names, offsets = split_offset_names(["tendon2.route", "tendon2.offset",
                                         "tendon1.guide2.offset"], arm)
    assert names == ["tendon2.route"]
    base = path_misfit(arm, [1], TARGETS, 24, offsets)
    assert base.f > 1.0 and base.reached.tolist() == [True, False]
    assert np.all(np.abs(base.gradient) > 1e-3)           # every variable moves the tip
    q0 = np.array([*arm.tendons[1].route_mm, -8.0, 8.0])
    v = np.array([0.4, -0.3, 1.0, -0.8])
    rem = []
    for eps in (0.2, 0.1, 0.05):
        q = q0 + eps * v
        moved = with_offsets(with_routes(arm, [1], q[:2]), offsets, q[2:])
        rem.append(abs(path_misfit(moved, [1], TARGETS, 24).f - base.f
                       - eps * base.gradient @ v))
    orders = np.log2(np.array(rem[:-1]) / rem[1:])
    assert np.all(orders > 1.8), (orders, rem)


def test_design_moves_a_guide_within_the_guide_radius(arm):
    _, offsets = split_offset_names(["tendon1.guide2.offset"], arm)
    lo, hi = offset_bounds(arm, offsets, reach_mm=100.0)
    assert lo.tolist() == [-10.0] and hi.tolist() == [10.0]      # arm.guide_radius_mm
    result = design_for_path(arm, [], [TARGETS[1]], elements=24, margin=1.0,
                             max_iterations=4, offsets=offsets)
    after = result.arm_after.tendons[0].guides[1].offset_mm
    assert after != 8.0 and -10.0 <= after <= 10.0
    assert result.misfit_after.f < result.misfit_before.f
    assert result.summary()["offset_variables"] == ["tendon1.guide2.offset"]


@pytest.mark.parametrize("names, message", [
    (["tendon3.offset"], "the arm has tendons 1..2"),
    (["tendon1.guide4.offset"], "tendon 1 has guides 1..3"),
    (["tendon1.offset", "tendon1.guide1.offset"], "overlaps another offset variable"),
])
def test_bad_offset_variables(arm, names, message):
    with pytest.raises(InputError, match=message):
        split_offset_names(names, arm)


def test_offset_variables_need_one_common_offset_and_a_guided_arm(arm):
    import dataclasses
    uneven = with_offsets(arm, split_offset_names(["tendon1.guide1.offset"], arm)[1], [5.0])
    with pytest.raises(InputError, match="at different offsets .*tendon1.guideJ.offset"):
        split_offset_names(["tendon1.offset"], uneven)
    with pytest.raises(InputError, match="no cable through guides") as err:
        split_offset_names(["tendon1.offset"], load_config(None))
    assert "--" not in str(err.value)                  # the library names no CLI flag
    assert dataclasses.replace(arm) == arm


def test_design_command_varies_an_offset(tmp_path):
    csv = tmp_path / "path.csv"
    csv.write_text("x_mm,y_mm\n100,100\n")
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "design", "--config",
                          str(ROOT / "configs" / "guided3.toml"), "--elements", "24",
                          "--objective", f"path:{csv}", "--vary", "tendon1.guide2.offset",
                          "--margin", "1", "--iterations", "2", "--json", "--quiet"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode in (0, 1), run.stderr
    out = json.loads(run.stdout)
    from importlib import resources
    from schema_check import errors
    schema = json.loads((resources.files("elastica_petsc") / "schema" / "output.schema.json")
                        .read_text())
    assert errors(out, schema, schema) == []
    assert out["offset_variables"] == ["tendon1.guide2.offset"]
    assert out["offsets_before_mm"] == [8.0] and out["offsets_after_mm"][0] != 8.0
