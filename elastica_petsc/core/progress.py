"""A one-line progress bar with time left, shown only on a terminal."""
from __future__ import annotations

import sys
import time


class Progress:
    """``update(done)`` redraws ``[#####.....] done/total  elapsed  ~left`` on stderr
    (at most every ``interval`` seconds); silent when stderr is not a terminal."""

    def __init__(self, total: int, label: str, *, stream=None, interval: float = 0.5,
                 already: int = 0):
        self.total, self.label = total, label
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = self.stream.isatty()
        self.interval = interval
        self.start = time.monotonic()
        self.already = already        # done before this run started (resume): not in the rate
        self._last = 0.0

    def update(self, done: int, force: bool = False) -> None:
        now = time.monotonic()
        if not self.enabled or (not force and now - self._last < self.interval):
            return
        self._last = now
        elapsed = now - self.start
        fresh = done - self.already
        left = (self.total - done) * elapsed / fresh if fresh > 0 else float("nan")
        width = 30
        filled = int(width * done / max(self.total, 1))
        eta = f"~{left:.0f} s left" if left == left else "estimating"
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] "
                          f"{done}/{self.total}  {elapsed:.0f} s  {eta}   ")
        self.stream.flush()

    def close(self, done: int) -> None:
        if self.enabled:
            self.update(done, force=True)
            self.stream.write("\n")
            self.stream.flush()
