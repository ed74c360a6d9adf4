"""Progress of long runs: a live bar with time left on a terminal, sparse log lines otherwise.

* If stderr or stdout is a terminal (under ``mpiexec``: if mpiexec's own
  output is, see :func:`_launcher_on_terminal`), a one-line bar ``label [#####.....] done/total  elapsed  ~left``
  is drawn there and redrawn by a background thread every ``interval``
  seconds (default 1 s), so the elapsed time and the estimate keep moving
  even while the caller is inside a long chunk of work.
* Otherwise (logs, pipes, batch jobs) one line
  ``label: done/total (25 %), 12 s elapsed, ~36 s left`` is written to
  stderr each time another ``log_percent`` (default 5 %) of the work is
  done, at most one every ``log_seconds`` (default 2 s); runs shorter than
  that print nothing.
* Work whose total is not known in advance (``total=None``: the steps of a
  search, continuation steps, optimiser evaluations) shows the work done,
  in its ``unit``, and the elapsed time, never a percentage or a time left:
  ``label: 37 search steps  12 s  <note>`` redrawn on a terminal, and in
  logs one line every ``open_log_seconds`` (default 10 s) while work is
  being done (and a last one at the end; runs shorter than that print
  nothing).  ``note`` says what is being done (a phase, a curve).
* A Progress is also a callback, ``progress(done, note)``: the library's
  long studies take ``progress=`` (None: silent) and call it.
* Under ``mpiexec`` only rank 0 reports (a command that every rank runs
  alike would otherwise draw one bar per rank).
* :func:`configure` (``quiet=True``, the command line's ``--quiet``)
  silences every bar and line of the process.
* ``delay`` (seconds): a bar is drawn only once the work has lasted that
  long, so a command that is usually fast (``control``: its global search
  runs only when the local solve stalls) prints nothing when it is.
  :func:`configure` (``delay=``) overrides every bar's delay for the process
  (the command line reads it from ``ELASTICA_PETSC_PROGRESS_DELAY_S``).
* Once a bar is due, a new stage of open-ended work (a ``note`` whose text
  before its first comma differs from the last one drawn) is drawn at once,
  not at the next tick: a short stage is never missed.
"""
from __future__ import annotations

import os
import shutil
import sys
import threading
import time

_SETTINGS: dict = {"quiet": False, "delay": None, "log_seconds": None}
_OPEN: set = set()


def configure(*, quiet: bool = False, delay: float | None = None,
              log_seconds: float | None = None) -> None:
    """Process-wide switches: ``quiet=True`` turns every later Progress off;
    ``delay`` (seconds, None: each bar's own) replaces every later bar's delay;
    ``log_seconds`` (None: each one's own) the least time between log lines,
    which is also how long a run lasts before it logs anything."""
    _SETTINGS["quiet"] = bool(quiet)
    _SETTINGS["delay"] = None if delay is None else float(delay)
    _SETTINGS["log_seconds"] = None if log_seconds is None else float(log_seconds)


def quiet() -> bool:
    """Whether :func:`configure` silenced progress (for a child process's flag)."""
    return _SETTINGS["quiet"]


def close_all() -> None:
    """Stop the redraw threads of every bar still open (on errors and interrupts)."""
    for bar in list(_OPEN):
        bar.stop()


MPI_RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK")


def _launcher_on_terminal() -> bool:
    """Whether the process that started us (mpiexec) writes to a terminal.
    OpenMPI gives every rank's stdout a pseudo-terminal of its own, whether
    or not mpiexec's output goes to a terminal, so a rank's isatty() says
    nothing; mpiexec's own stdout does (Linux /proc; False elsewhere)."""
    try:
        target = os.readlink(f"/proc/{os.getppid()}/fd/1")
    except OSError:
        return False
    return target.startswith(("/dev/pts/", "/dev/tty", "/dev/console"))


def _rank() -> int:
    """This process's MPI rank as its launcher tells it (0 outside mpiexec): a
    serial command run on several ranks draws one bar, not one per rank."""
    for name in MPI_RANK_VARIABLES:
        if os.environ.get(name, "").isdigit():
            return int(os.environ[name])
    return 0


def _terminal():
    """The stream to draw a bar on, or None: stderr or stdout if a terminal;
    under an MPI launcher, stdout only if the launcher itself writes to one."""
    under_mpi = any(v in os.environ for v in MPI_RANK_VARIABLES)
    for stream in (sys.stderr, sys.stdout):
        try:
            if stream.isatty() and not (under_mpi and not _launcher_on_terminal()):
                return stream
        except (AttributeError, ValueError):
            continue
    return None


def _stage(note: str) -> str:
    """The stage a note names: its text before the first comma (a count may follow)."""
    return note.split(",", 1)[0]


class Progress:
    """``update(done)`` after each unit of work; ``close(done)`` at the end
    (or use it as a context manager).  ``already``: units done before this
    run started (a resume), left out of the rate.  ``total=None``: the total
    is not known (module docstring); ``unit`` names what ``done`` counts."""

    def __init__(self, total: int | None, label: str, *, stream=None, interval: float = 1.0,
                 already: int = 0, log_percent: float = 5.0, log_seconds: float = 2.0,
                 unit: str = "", open_log_seconds: float = 10.0, delay: float = 0.0):
        self.total = None if total is None else int(total)
        self.label, self.unit, self.note = label, unit, ""
        if _SETTINGS["log_seconds"] is not None:
            log_seconds = _SETTINGS["log_seconds"]
        self.interval, self.log_percent, self.log_seconds = interval, log_percent, log_seconds
        self.delay = float(delay if _SETTINGS["delay"] is None else _SETTINGS["delay"])
        self.open_log_seconds = open_log_seconds
        self._drawn = 0
        self._drawn_stage = ""
        self.already = self.done = already
        self.start = time.monotonic()
        self.mode = "off"
        if not _SETTINGS["quiet"] and (stream is not None or _rank() == 0):
            if stream is not None:
                self.stream, self.mode = stream, ("bar" if stream.isatty() else "log")
            else:
                tty = _terminal()
                self.stream, self.mode = (tty, "bar") if tty is not None else (sys.stderr, "log")
        self.enabled = self.mode == "bar"
        self._lock = threading.Lock()
        self._logged_step, self._logged_at = 0, self.start
        self._halt = threading.Event()
        self._thread = None
        if self.mode == "bar":
            if self.delay <= 0:
                self._draw()
            self._thread = threading.Thread(target=self._tick, daemon=True, name="progress")
            _OPEN.add(self)
            self._thread.start()

    # --- the caller's side -----------------------------------------------------
    def update(self, done: int, force: bool = False, total: int | None = None,
               note: str | None = None) -> None:
        """Record ``done`` units (of a new ``total`` when given; ``note``: what is
        being done); draw or log if due."""
        self.done = int(done)
        if total is not None:
            self.total = int(total)
        if note is not None:
            self.note = note
        new_stage = self.total is None and _stage(self.note) != self._drawn_stage
        if self.mode == "bar" and (force or new_stage) and self._due():
            self._draw()
        elif self.mode == "log":
            self._log(force)

    def __call__(self, done: int, note: str | None = None) -> None:
        """The callback form of :meth:`update` (what the library's ``progress=`` calls)."""
        self.update(done, note=note)

    def close(self, done: int | None = None) -> None:
        if done is not None:
            self.done = int(done)
        if self.total is None:
            self.note = "done"
        if self.mode == "bar":
            self.stop()
            if self._drawn:                         # nothing was drawn within ``delay``
                self._draw()
                with self._lock:
                    self.stream.write("\n")
                    self.stream.flush()
        elif self.mode == "log" and self.total is None:
            if self._logged_step and self.done != self._logged_step:   # closes a run it logged
                self._log_open(force=True)
        elif self.mode == "log":
            final = int(100.0 * self.done / max(self.total, 1) // self.log_percent)
            self._log(force=self.done > self.already and self._logged_step < final
                      and time.monotonic() - self.start >= self.log_seconds)
        self.mode = "off"

    def stop(self) -> None:
        """Stop redrawing (the line is left as it is)."""
        self._halt.set()
        _OPEN.discard(self)
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2 * self.interval)

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        if exc[0] is None:
            self.close()
        else:
            self.stop()
            if self.mode == "bar" and self._drawn:
                with self._lock:
                    self.stream.write("\n")
                    self.stream.flush()
            self.mode = "off"

    # --- drawing ---------------------------------------------------------------
    def status(self) -> tuple[float, float]:
        """(elapsed, estimated seconds left; NaN while nothing new is done or
        when the total is not known)."""
        elapsed = time.monotonic() - self.start
        if self.total is None:
            return elapsed, float("nan")
        fresh = self.done - self.already
        left = (self.total - self.done) * elapsed / fresh if fresh > 0 else float("nan")
        return elapsed, left

    def _due(self) -> bool:
        """Past the ``delay`` (or already drawn)."""
        return self._drawn > 0 or time.monotonic() - self.start >= self.delay

    def _tick(self) -> None:
        while not self._halt.wait(self.interval if self._drawn or self.delay <= 0
                                  else min(self.interval, self.delay)):
            if self._due():
                self._draw()

    def _count(self) -> str:
        return f"{self.done} {self.unit}".rstrip()

    def _line(self) -> str:
        """The bar's text (without the carriage return)."""
        elapsed, left = self.status()
        if self.total is None:
            text = f"{self.label}: {self._count()}  {elapsed:.0f} s"
            return text + (f"  {self.note}" if self.note else "")
        width = 30
        filled = int(width * min(self.done, self.total) / max(self.total, 1))
        eta = f"~{left:.0f} s left" if left == left else "estimating"
        return (f"{self.label} [{'#' * filled}{'.' * (width - filled)}] "
                f"{self.done}/{self.total}  {elapsed:.0f} s  {eta}")

    def _draw(self) -> None:
        text = self._line()
        width = max(shutil.get_terminal_size((100, 24)).columns - 1, 20)   # never wrap
        if len(text) > width:
            text = text[:width - 3] + "..."
        with self._lock:
            if self._halt.is_set() and self.mode != "bar":
                return
            pad = min(max(self._drawn - len(text), 0) + 3, width - len(text))  # wipe the rest
            self.stream.write(f"\r{text}{' ' * pad}")
            self.stream.flush()
            self._drawn = len(text)
            self._drawn_stage = _stage(self.note)

    def _log_open(self, force: bool) -> None:
        """Open-ended work in a log: one line every ``open_log_seconds`` of work."""
        now = time.monotonic()
        if not force and (now - self._logged_at < self.open_log_seconds
                          or self.done == self._logged_step):
            return
        self._logged_step, self._logged_at = self.done, now
        note = f"; {self.note}" if self.note else ""
        self.stream.write(f"{self.label}: {self._count()}, {now - self.start:.0f} s "
                          f"elapsed{note}\n")
        self.stream.flush()

    def _log(self, force: bool) -> None:
        if self.total is None:
            self._log_open(force)
            return
        now = time.monotonic()
        step = int(100.0 * self.done / max(self.total, 1) // self.log_percent)
        due = step > self._logged_step and now - self._logged_at >= self.log_seconds
        if not (due or force):
            return
        self._logged_step, self._logged_at = step, now
        elapsed, left = self.status()
        eta = f", ~{left:.0f} s left" if left == left and self.done < self.total else ""
        self.stream.write(f"{self.label}: {self.done}/{self.total} "
                          f"({100.0 * self.done / max(self.total, 1):.0f} %), "
                          f"{elapsed:.0f} s elapsed{eta}\n")
        self.stream.flush()
