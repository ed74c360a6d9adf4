"""Progress (core/progress.py): a live bar on a terminal (also under mpiexec, where
only rank 0's stdout may be one), sparse log lines otherwise, nothing with --quiet."""
from __future__ import annotations

import io
import os
import re
import select
import shutil
import subprocess
import sys
import time

import pytest

from elastica_petsc.core import progress
from elastica_petsc.core.progress import Progress


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_bar_is_redrawn_while_the_caller_is_busy():
    """One update, then a long chunk of work: the elapsed time keeps moving."""
    out = FakeTerminal()
    with Progress(10, "job", stream=out, interval=0.1) as bar:
        bar.update(1)
        time.sleep(0.65)
    draws = out.getvalue().split("\r")[1:]
    assert len(draws) >= 5
    assert all("job [" in d for d in draws) and draws[-1].endswith("\n")


def test_log_lines_every_few_percent_when_not_a_terminal():
    out = io.StringIO()
    bar = Progress(200, "job", stream=out, log_percent=5.0, log_seconds=0.0)
    for k in range(1, 201):
        bar.update(k)
    bar.close(200)
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue()
    percents = [int(re.search(r"\((\d+) %\)", line).group(1)) for line in lines]
    assert percents == list(range(5, 101, 5))          # one line per 5 %, the last at 100 %
    assert lines[0].startswith("job: 10/200 (5 %)") and "s left" in lines[0]


def test_short_runs_and_quiet_print_nothing():
    out = io.StringIO()
    bar = Progress(10, "job", stream=out)              # log_seconds 2: a quick run is silent
    for k in range(1, 11):
        bar.update(k)
    bar.close(10)
    assert out.getvalue() == ""
    progress.configure(quiet=True)
    try:
        tty = FakeTerminal()
        with Progress(10, "job", stream=tty, interval=0.05) as bar:
            bar.update(5)
            time.sleep(0.2)
        assert tty.getvalue() == "" and bar.mode == "off"
    finally:
        progress.configure(quiet=False)


def test_under_mpi_a_rank_terminal_is_not_enough(monkeypatch):
    """OpenMPI gives each rank's stdout a pseudo-terminal even when mpiexec's
    output goes to a file: the bar is drawn only if mpiexec's own is a terminal."""
    monkeypatch.setattr(sys, "stdout", FakeTerminal())
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    monkeypatch.setenv("OMPI_COMM_WORLD_RANK", "0")
    monkeypatch.setattr(progress, "_launcher_on_terminal", lambda: False)
    assert progress._terminal() is None
    monkeypatch.setattr(progress, "_launcher_on_terminal", lambda: True)
    assert progress._terminal() is sys.stdout
    monkeypatch.delenv("OMPI_COMM_WORLD_RANK")
    monkeypatch.setattr(progress, "_launcher_on_terminal", lambda: False)
    assert progress._terminal() is sys.stdout              # no launcher: the stream decides


@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="needs mpiexec")
def test_mpi_workspace_shows_progress_in_a_terminal(tmp_path):
    """`mpiexec -n 2 ... workspace` on a pseudo-terminal: the bar appears within
    5 s of the start and is redrawn at least every 5 s until the end."""
    import pty

    master, slave = pty.openpty()
    cmd = ["mpiexec", "-n", "2", sys.executable, "-m", "elastica_petsc.cli", "workspace",
           "--spacing", "20", "--box", "250", "550", "50", "300", "--elements", "60",
           "--out", str(tmp_path / "ws.h5")]
    t0 = time.monotonic()
    # env given explicitly: os.environ, not the C environment of this process, into which
    # Open MPI's singleton initialisation (any test that imported mpi4py) has written
    # variables that make a child mpiexec exit 1 without a word
    proc = subprocess.Popen(cmd, stdin=slave, stdout=slave, stderr=slave, close_fds=True,
                            env=dict(os.environ))
    os.close(slave)
    events = []
    try:
        while True:
            ready, _, _ = select.select([master], [], [], 0.2)
            if ready:
                try:
                    data = os.read(master, 4096)
                except OSError:                            # the terminal closed
                    break
                if not data:
                    break
                events.append((time.monotonic() - t0, data.decode(errors="replace")))
            elif proc.poll() is not None:
                break
            assert time.monotonic() - t0 < 240, "workspace run did not end"
    finally:
        proc.wait(timeout=60)
        os.close(master)
    assert proc.returncode == 0, "".join(d for _, d in events)
    draws = [(t, m.group(1), m.group(2)) for t, d in events
             for m in re.finditer(r"workspace \(targets, 2 rank\(s\)\) \[[#.]+\] (\d+)/(\d+)", d)]
    assert draws, "".join(d for _, d in events)
    times = [t for t, _, _ in draws]
    assert times[0] <= 5.0
    assert max(b - a for a, b in zip(times, times[1:])) <= 5.0
    done = [int(d) for _, d, _ in draws]
    assert done == sorted(done) and done[-1] == int(draws[-1][2]) == 208
    assert "workspace samples: 208/208 done" in "".join(d for _, d in events)
