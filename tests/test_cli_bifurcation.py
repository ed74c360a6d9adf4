"""The issue's must-show on the command line: a cable routed through (0.5 l, 0)
(l = 1000 mm, B = 1 N m^2, one cable at the tip, 400 elements) buckles the
straight arm at p_cr = 18.2738 (tan(k l) = k (l - c)); at p = 18.6 `solve`
converges to a stable buckled state with tip (0.9674 l, +-0.0689 l), says which
branch and why, and `equilibria` lists the straight arm and both buckled states.
The tip reference is the shooting solution of tests/test_bifurcation.py
(0.967441, +-0.068895) l; the 400-element tips differ from it by 4e-5 l."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

CONFIG = """\
[arm]
length_mm = 1000.0
bending_stiffness_Nm2 = 1.0
elements = 400

[[tendon]]
attach_mm = 1000.0
route_mm = [500.0, 0.0]
"""
TIP_MM = np.array([967.441, 68.895])          # shooting, tests/test_bifurcation.py


def cli(*args):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    path = tmp_path_factory.mktemp("bifurcation") / "middle.toml"
    path.write_text(CONFIG)
    return path


@pytest.mark.parametrize("side, sign", [(None, 1.0), ("left", 1.0), ("right", -1.0)])
def test_solve_switches_onto_a_stable_buckled_branch(config, side, sign):
    run = cli("solve", "--config", config, "--tensions", 18.6, "--json",
              *(["--side", side] if side else []))
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""                                  # no warnings
    data = json.loads(run.stdout)
    assert data["converged"] and data["stable"]
    np.testing.assert_allclose(data["tip_mm"], TIP_MM * [1.0, sign], atol=0.1)   # 1e-4 l
    (b,) = data["bifurcations"]
    assert b["side"] == (side or "left")
    assert abs(b["critical_tensions"][0] - 18.2738) < 2e-3  # O(h^2) at 400 elements
    assert b["rule"] == ("requested" if side else
                         "both sides have the same energy: the left one by convention")
    if side is None:
        text = cli("solve", "--config", config, "--tensions", 18.6).stdout
        assert "symmetric bifurcation (not a limit point)" in text
        assert "took the left branch" in text


@pytest.mark.slow
def test_equilibria_lists_the_straight_arm_and_both_buckled_states(config):
    run = cli("equilibria", "--config", config, "--tensions", 18.6, "--json", "--quiet")
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""                                  # no overflow warnings
    states = json.loads(run.stdout)["equilibria"]
    assert len(states) == 3
    stable = [s for s in states if s["stable"]]
    unstable = [s for s in states if not s["stable"]]
    assert len(stable) == 2 and len(unstable) == 1
    tips = sorted((s["tip_mm"] for s in stable), key=lambda t: t[1])
    np.testing.assert_allclose(tips, [TIP_MM * [1.0, -1.0], TIP_MM], atol=0.1)
    np.testing.assert_allclose(unstable[0]["tip_mm"], [1000.0, 0.0], atol=1e-9)
    assert unstable[0]["unstable_modes"] == 1


def test_stability_reports_the_critical_load_crossed(config):
    run = cli("stability", "--config", config, "--tensions", 18.6, "--json", "--modes", 2)
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert data["stable"] and data["lambda_min"] > 0
    (b,) = data["critical_loads_crossed"]
    assert abs(b["critical_tensions"][0] - 18.2738) < 2e-3


def test_bad_side_is_a_usage_error(config):
    run = cli("solve", "--config", config, "--tensions", 18.6, "--side", "up")
    assert run.returncode == 2 and "Traceback" not in run.stderr
