"""The README's tour is executable documentation: every ``$ command`` in it runs,
in order, in an empty folder, with the exit status the README shows (0 unless
an ``(exit status N)`` line follows)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow          # left out by scripts/test.sh --fast

ROOT = Path(__file__).resolve().parents[1]


def tour_commands() -> list[tuple[str, int]]:
    text = (ROOT / "README.md").read_text()
    tour = text.split("## A tour", 1)[1].split("## Exit status", 1)[0]
    commands, lines = [], tour.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("    $ "):
            status = 0
            for follow in lines[i + 1:]:
                if not follow.startswith("    ") or follow.startswith("    $ "):
                    break
                match = re.fullmatch(r"    \(exit status (\d+)\)", follow)
                if match:
                    status = int(match.group(1))
            commands.append((line[6:], status))
    return commands


def test_readme_has_a_tour_of_every_command():
    names = {cmd.split("elastica-petsc ", 1)[1].split()[0] for cmd, _ in tour_commands()}
    assert names >= {"solve", "control", "trace", "stability", "equilibria", "lengths",
                     "replay", "workspace"}


def test_readme_tour_commands_run_as_documented(tmp_path):
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    for command, status in tour_commands():
        run = subprocess.run(["bash", "-c", command], cwd=tmp_path, env=env, capture_output=True,
                             text=True, timeout=300)
        assert run.returncode == status, f"{command}\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}"
        assert "Traceback" not in run.stderr, command


def test_readme_setup_commands_exist():
    text = (ROOT / "README.md").read_text()
    quick = text.split("## Quick start", 1)[1].split("## A tour", 1)[0]
    commands = [line.strip() for line in quick.splitlines() if line.startswith("    ")]
    assert commands == ["bash scripts/run.sh", "bash scripts/test.sh"]
    assert "bash scripts/test.sh" in (ROOT / ".ci" / "run").read_text()
