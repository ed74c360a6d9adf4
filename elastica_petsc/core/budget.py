"""A wall-clock allowance for a search (``--max-seconds``, ``max_seconds=``).

Searches (tip control's global search, ``lengths --all``, ``equilibria``,
``design``) ask their :class:`TimeBudget` between steps, never inside a
PETSc callback: a step that is running finishes, so the overshoot is at
most one step (one local solve, one continuation curve, one design
evaluation).  A search stopped by its budget returns what it has with the
verdict :data:`TIME_LIMIT` and says what it did not decide; it never turns
"not found in time" into "does not exist".
"""
from __future__ import annotations

import math
import time

from .errors import ElasticaError
from .inputs import positive

TIME_LIMIT = "TIME_LIMIT"        # reason/outcome of a search stopped by its time budget


class TimeLimitReached(ElasticaError):
    """Raised by :meth:`TimeBudget.check` once the allowance is spent; the
    search that owns the budget catches it and returns what it has."""


def check_max_seconds(value, name: str = "max_seconds") -> float | None:
    """None (no limit) or a positive finite number of seconds (else InputError)."""
    if value is None:
        return None
    return positive(value, name, "s")


class TimeBudget:
    """``max_seconds`` of wall-clock time from construction (None: unlimited).

    :meth:`expired` is a query; :meth:`check` raises :class:`TimeLimitReached`
    whenever it finds the budget spent (a search that must wrap up, e.g.
    polish the states it already holds, stops asking)."""

    def __init__(self, max_seconds: float | None = None, clock=time.monotonic):
        self.max_seconds = check_max_seconds(max_seconds)
        self._clock = clock
        self._t0 = clock()
        self.reached = False          # True once the budget was found spent

    @property
    def elapsed_s(self) -> float:
        return self._clock() - self._t0

    @property
    def remaining_s(self) -> float:
        return math.inf if self.max_seconds is None else self.max_seconds - self.elapsed_s

    def expired(self) -> bool:
        """True (and remembered in ``reached``) once the allowance is spent."""
        if self.max_seconds is not None and self.elapsed_s >= self.max_seconds:
            self.reached = True
        return self.reached

    def check(self, what: str = "") -> None:
        """Raise :class:`TimeLimitReached` if the budget is spent."""
        if not self.expired():
            return
        raise TimeLimitReached(f"{TIME_LIMIT}: stopped after {self.elapsed_s:.3g} s "
                               f"(budget {self.max_seconds:g} s)" + (f" at {what}" if what else ""))

    def note(self) -> str:
        """One phrase for reports: how long the search ran against its budget."""
        return (f"stopped by its time budget ({TIME_LIMIT}): {self.elapsed_s:.3g} s of "
                f"max_seconds = {self.max_seconds:g}")

