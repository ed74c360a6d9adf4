"""Designing the arm for a task (issue 13): the gradient of the path misfit,
the task example, and one-line errors for bad requests."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.studies.design import (DesignError, parse_vary, path_misfit, route_bounds,
                                           with_routes)

ROOT = Path(__file__).resolve().parents[1]
ELEMENTS = 60


def test_misfit_gradient_against_central_differences():
    """f = sum of E_k over targets outside W_0; its gradient (Danskin: the tip
    derivative at the closest tensions, fixed) against central differences of
    f re-traced with moved routing points (tip control converges to
    1e-7 relative stationarity, so 1 % agreement is the check)."""
    arm = load_config()
    targets = np.array([[470.0, 320.0], [490.0, 300.0]])      # above the P_1 = 0 edge
    q0 = np.array([46.3, -97.1, 26.1, 51.1])
    m0 = path_misfit(arm, [0, 1], targets, ELEMENTS)
    assert not m0.reached.any() and m0.f > 1.0
    assert np.all(m0.gradient[:2] == 0.0)          # tendon 1 slack (P_1 = 0): r_1 has no say
    for k in (2, 3):
        h = 0.5
        fs = []
        for sign in (1.0, -1.0):
            q = q0.copy()
            q[k] += sign * h
            fs.append(path_misfit(with_routes(arm, [0, 1], q), [0, 1], targets, ELEMENTS).f)
        fd = (fs[0] - fs[1]) / (2 * h)
        assert fd == pytest.approx(m0.gradient[k], rel=1e-2), (k, fd, m0.gradient)


def test_parse_vary_and_bounds():
    assert parse_vary(["tendon2.route", "tendon1.route"], 2) == [1, 0]
    for bad, message in ((["tendon3.route"], "tendons 1..2"), (["tendon1.attach"], "attachment"),
                         (["arm.length"], "tendonK.route"), (["tendon1.route"] * 2, "twice"),
                         (["tendon1.route.x"], "tendonK.route, tendonK.attach or tendonK.guideJ.s")):
        with pytest.raises(DesignError, match=message):
            parse_vary(bad, 2)
    lo, hi = route_bounds(load_config(), [0, 1], 100.0, 10.0)
    assert np.allclose(lo, [-53.7, -197.1, -73.9, 10.0])
    assert np.allclose(hi, [146.3, -10.0, 126.1, 151.1])


@pytest.mark.slow
def test_design_task_example(tmp_path):
    """The circle of radius 80 mm about (420, 260) mm: 30 of 37 targets on the
    paper's arm, all of them (traced again, 10 mm steps) after the design."""
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "design_task.py"), "d.toml"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "paper's arm: 30 of 37 targets reached" in run.stdout
    assert "all reached: True" in run.stdout
    designed = load_config(tmp_path / "d.toml")
    assert designed.tendons[0].route_mm == (46.3, -97.1)
    assert designed.tendons[1].route_mm != (26.1, 51.1)


@pytest.mark.parametrize("args, message", [
    (["--vary", "tendon1.attach", "--objective", "path:x.csv"], "attachment points"),
    (["--vary", "tendon1.route", "--objective", "path"], "expected area or path:FILE.csv"),
    (["--vary", "tendon1.route", "--objective", "path:missing.csv"], "no such path file"),
])
def test_cli_errors_one_line(tmp_path, args, message):
    (tmp_path / "x.csv").write_text("400,200\n")
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "design", *args],
                         cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert run.returncode == 2, run.stderr
    assert message in run.stderr and run.stderr.count("\n") == 1, run.stderr
