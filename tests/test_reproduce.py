"""Issue 6: the reproduction pipeline, the Dockerfile and the README's commands."""
from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow          # left out by scripts/test.sh --fast

ROOT = Path(__file__).resolve().parents[1]
SPEC_ITEMS = [  # docs/model.md §6: every reference number appears in REPORT.md
    "(147.1, 472.5)", "(96.2, 454.3)", "(25.2, 10.8)", "(9.7, 12.6)", "over a dozen",
    "< 5", "< 1 s", "4201", "<= 6.5", "<= 18", "<= 40", "~1.8e-3", "138.56 / 40 / 80",
    "a few mm", "would yield and exceed the motor load"]


def test_reproduce_quick_writes_every_promised_file(tmp_path):
    out = tmp_path / "results"
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "reproduce", "--quick",
                          "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    report = (out / "REPORT.md").read_text()
    promised = re.findall(r"`([^`]+\.(?:h5|png|csv))`", report.split("## Files")[1])
    for name in ("fig2_gd.png", "fig3a.png", "fig3b.png", "fig4.png", "fig4_restrictions.png",
                 "fig6a.png", "fig6b.png", "fig6c.png", "fig7.png", "fig8.png"):
        assert name in promised
    for name in promised:
        assert (out / name).stat().st_size > 1000, name
    table = [line for line in report.splitlines() if line.startswith("| ") and "---" not in line]
    assert all(line.count("|") >= 7 for line in table)
    for item in SPEC_ITEMS:
        assert item in report, item
    rows = json.loads((out / "report.json").read_text())
    assert len(rows) == len(table) - 1                         # header row
    again = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "reproduce", "--quick",
                            "--out", str(out)], capture_output=True, text=True, timeout=60)
    assert again.returncode == 2 and "--overwrite" in again.stderr


def test_dockerfile_runs_the_setup_script_and_nothing_else():
    """No Docker engine here: CI runs the very script the Dockerfile runs
    (scripts/setup.sh via .ci/run -> scripts/test.sh), and this test pins the
    Dockerfile to it so the two cannot drift."""
    text = (ROOT / "Dockerfile").read_text()
    instructions = [line.split(None, 1) for line in text.splitlines()
                    if line.strip() and not line.lstrip().startswith("#")]
    runs = [rest for word, rest in instructions if word == "RUN"]
    assert runs == ["bash scripts/setup.sh"]
    assert instructions[0] == ["FROM", "debian:12"]
    for forbidden in ("apt-get", "pip ", "apt "):
        assert forbidden not in text, forbidden
    assert "bash scripts/setup.sh" in (ROOT / "scripts" / "test.sh").read_text().replace(
        '"$here/scripts/setup.sh"', "scripts/setup.sh")
    assert "scripts/test.sh" in (ROOT / ".ci" / "run").read_text()
    assert '"reproduce"' in text


@pytest.mark.skipif(shutil.which("hadolint") is None and not (
    Path(sys.executable).parent / "hadolint").exists(), reason="hadolint not installed")
def test_dockerfile_passes_hadolint():
    exe = shutil.which("hadolint") or str(Path(sys.executable).parent / "hadolint")
    run = subprocess.run([exe, str(ROOT / "Dockerfile")], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
