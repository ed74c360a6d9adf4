"""Progress during ``control``'s global search (issue 11): on a terminal a bar
with the search steps, the elapsed time and the stage appears once the run has
lasted 1 s, is redrawn at least every 5 s and ends on 'done'; a fast control
draws nothing (checked on the bar itself: a command's run time depends on the
machine's load, so the terminal test sets the delay to 0 and does not depend on
how fast the machine finds the target); ``--quiet`` silences it; not a terminal: at most a line every
10 s (ui/progress.py), none for a run shorter than that."""
from __future__ import annotations

import io
import re
import subprocess
import sys
import time

import pytest
from test_progress import assert_timely, run_in_pty

from elastica_petsc.ui.progress import Progress

# timing is part of what these tests check: scripts/test.sh runs them alone
pytestmark = [pytest.mark.serial, pytest.mark.slow]

# at 30 elements the local solve stalls at (500, 0) mm (on the x axis: every target there
# is stationary from the straight arm's sensitivities) and the global search reaches it from
# a seed of the library: a few seconds
SLOW = [sys.executable, "-m", "elastica_petsc.cli", "control", "--target", "500", "0",
        "--elements", "30"]
BAR = re.compile(r"control: (\d+) search steps  (\d+) s  ([^\r\n]*)")


def test_global_search_shows_its_stage_in_a_terminal():
    # no delay: the bar is drawn from the start and each new stage at once, however fast the
    # machine (a 1 s delay outlasted the whole search on fast idle machines)
    status, events = run_in_pty(SLOW, env={"ELASTICA_PETSC_PROGRESS_DELAY_S": "0"})
    text = "".join(d for _, d in events)
    assert status == 0 and "target reached" in text, text
    draws = [(t, int(m.group(1)), m.group(3).strip()) for t, d in events
             for m in BAR.finditer(d)]
    assert_timely([t for t, _, _ in draws])
    counts = [n for _, n, _ in draws]
    assert counts == sorted(counts) and draws[-1][2] == "done", text
    notes = " | ".join(note for _, _, note in draws)
    assert "global search: seed library" in notes, notes       # the stage, not only a count
    assert text.index("done") < text.index("target reached")          # the bar ends first


def test_quiet_draws_nothing():
    status, events = run_in_pty(SLOW + ["--quiet"])
    text = "".join(d for _, d in events)
    assert status == 0 and "target reached" in text and "search steps" not in text, text


def test_not_a_terminal_writes_no_line_for_a_short_search():
    run = subprocess.run(SLOW, capture_output=True, text=True, timeout=240)
    assert run.returncode == 0 and "target reached" in run.stdout
    assert "search steps" not in run.stderr and "\r" not in run.stderr, run.stderr


def test_delayed_bar_draws_only_after_its_delay():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    quick = Tty()
    with Progress(None, "control", stream=quick, unit="search steps", delay=1.0) as bar:
        bar(1, "local tip control")
        bar(2, "global search: seed library")              # a new stage, but not yet due
    assert quick.getvalue() == ""
    slow = Tty()
    with Progress(None, "control", stream=slow, unit="search steps", delay=0.3,
                  interval=0.1) as bar:
        bar(1, "global search")
        time.sleep(0.6)
    lines = slow.getvalue()
    assert "control: 1 search steps  0 s  global search" in lines, repr(lines)
    assert lines.rstrip().endswith("done") and lines.endswith("\n"), repr(lines)


def test_a_new_stage_is_drawn_at_once():
    """Once due, a stage (a note's text before its first comma) is drawn when it starts,
    not at the next tick; counts within a stage wait for the tick."""
    class Tty(io.StringIO):
        def isatty(self):
            return True

    out = Tty()
    with Progress(None, "control", stream=out, unit="search steps", delay=0.0,
                  interval=60.0) as bar:
        bar(1, "local tip control")
        bar(2, "global search: seed library, 1 equilibria")
        bar(2, "global search: seed library, 2 equilibria")
        text = out.getvalue()
    assert "local tip control" in text and "seed library, 1 equilibria" in text, repr(text)
    assert "2 equilibria" not in text, repr(text)
