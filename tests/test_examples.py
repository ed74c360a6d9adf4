"""Every script in examples/ runs as a user would run it, and prints the pinned numbers."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from mpi_env import mpi_env

pytestmark = pytest.mark.slow          # left out by scripts/test.sh --fast

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"




def run(*cmd: str, cwd: Path) -> str:
    done = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=300,
                          env=mpi_env())
    assert done.returncode == 0, done.stderr
    return done.stdout


def numbers(line: str) -> list[float]:
    return [float(v) for v in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", line)]


def test_every_example_is_tested():
    tested = {"equilibrium_stability.py", "trace_schedule.py", "workspace_mpi.py",
              "design_task.py", "calibrate_arm.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} <= tested


def test_equilibrium_stability(tmp_path):
    out = run(sys.executable, str(EXAMPLES / "equilibrium_stability.py"), cwd=tmp_path)
    lengths = numbers(next(l for l in out.splitlines() if l.startswith("cable lengths")))
    assert lengths[:2] == pytest.approx([147.21, 472.48], abs=0.01)    # paper: (147.1, 472.5)
    assert "stable under load control: True" in out


def test_trace_schedule(tmp_path):
    out = run(sys.executable, str(EXAMPLES / "trace_schedule.py"), "s.csv", cwd=tmp_path)
    assert "all reached: True" in out
    rows = (tmp_path / "s.csv").read_text().splitlines()
    line = next(l for l in out.splitlines() if l.startswith("schedule:"))
    assert len(rows) == 1 + int(line.split()[1])            # header + one row per target
    assert int(line.split()[1]) > int(out.split()[0])         # the approach comes first


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="needs mpiexec")
def test_workspace_mpi(tmp_path):
    out = run("mpiexec", "-n", "2", sys.executable, str(EXAMPLES / "workspace_mpi.py"),
              cwd=tmp_path)
    assert out.startswith("2 rank(s):")
    assert list(tmp_path.iterdir()) == []                    # no file written


def test_calibrate_arm(tmp_path):
    out = run(sys.executable, str(EXAMPLES / "calibrate_arm.py"), cwd=tmp_path)
    assert "SYNTHETIC" in (tmp_path / "calibration_data.csv").read_text()
    rows = [numbers(l) for l in out.splitlines() if l.startswith(("bending", "tendon", "motor"))]
    assert len(rows) == 7 and all(r[-1] < 3.0 for r in rows)     # |error| / sigma
    assert "undetermined: none" in out
