"""What the motors do in a simulation (docs/model.md §16.3): tensions or cable lengths in time.

Two drives, both in the solvers' units (lengths in l, tensions p = P l^2/B,
time in tau = sqrt(rho_A l^4 / B)):

* :class:`TensionDrive` - force-controlled motors, p_i(t) piecewise linear
  through the rows of a tension history (constant before the first and after
  the last row; one row: constant tensions).
* :class:`LengthDrive` - the paper's steppers: cable lengths Lbar_i(t)
  through the rows of a motor schedule, interpolated by a monotone C^1 cubic
  (PCHIP slopes inside, zero slopes at the first and last rows: the motors
  start from rest and stop) so that the cable speeds are continuous (a rigid
  cable whose speed jumps would need an infinite tension, an impact); held
  after the last row.

The CSV files (one header line, ``,``-separated, numbers only in the columns
read; other columns are ignored):

* tension history: ``time_s``, ``tension_1_N`` .. ``tension_n_N``;
* motor schedule (as written by ``trace --schedule``, core/schedule.py):
  ``time_s`` and ``length_1_mm`` .. ``length_n_mm``, or ``steps_1`` .. ``steps_n``
  (microsteps from row 0, > 0 pays cable out); ``tension_i_N`` of row 0, when
  present, gives the state the run starts from.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicHermiteSpline, PchipInterpolator

from .errors import InputError


@dataclass(frozen=True)
class TensionDrive:
    """p_i(t), piecewise linear through (times, values (k, n))."""

    times: np.ndarray
    values: np.ndarray

    @property
    def n_tendons(self) -> int:
        return self.values.shape[1]

    def tensions(self, t: float) -> np.ndarray:
        """p(t): linear between the rows, the first/last row's before/after them (called
        at every residual of the integrator: one search, no per-tendon loop)."""
        k = int(np.searchsorted(self.times, t, side="right"))
        if k == 0 or k == len(self.times):
            return self.values[max(k - 1, 0)].copy()
        w = (t - self.times[k - 1]) / (self.times[k] - self.times[k - 1])
        return (1.0 - w) * self.values[k - 1] + w * self.values[k]

    @classmethod
    def constant(cls, p) -> "TensionDrive":
        p = np.asarray(p, float)
        return cls(np.zeros(1), p[None, :])


class LengthDrive:
    """Lbar_i(t) and its rate, PCHIP through (times, lengths (k, n)), held after the end."""

    def __init__(self, times: np.ndarray, lengths: np.ndarray):
        self.times = np.asarray(times, float)
        self.values = np.asarray(lengths, float)
        self._spline = None
        if len(self.times) > 1:
            slopes = PchipInterpolator(self.times, self.values, axis=0)(self.times, 1)
            slopes[0] = slopes[-1] = 0.0          # from rest, to rest
            self._spline = CubicHermiteSpline(self.times, self.values, slopes, axis=0)

    @property
    def n_tendons(self) -> int:
        return self.values.shape[1]

    def _clip(self, t: float) -> float:
        return min(max(t, self.times[0]), self.times[-1])

    def lengths(self, t: float) -> np.ndarray:
        if self._spline is None:
            return self.values[0].copy()
        return self._spline(self._clip(t))

    def rates(self, t: float, order: int = 1) -> np.ndarray:
        """d^order Lbar / dt^order (order 1 or 2); 0 outside the rows."""
        if self._spline is None or not self.times[0] <= t < self.times[-1]:
            return np.zeros(self.n_tendons)
        return self._spline(t, order)


# --- CSV files -----------------------------------------------------------------------
def _read_rows(path) -> tuple[list[str], list[list[str]]]:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such CSV file")
    try:
        with open(p, newline="") as fh:
            rows = [r for r in csv.reader(fh) if r]
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise InputError(f"{p}: cannot read it as CSV ({err})") from None
    if len(rows) < 2:
        raise InputError(f"{p}: needs a header line and at least one row")
    return [h.strip() for h in rows[0]], rows[1:]


def _column(path, header, rows, name) -> np.ndarray:
    if name not in header:
        raise InputError(f"{path}: missing column {name!r}")
    j = header.index(name)
    try:
        values = np.array([float(r[j]) for r in rows])
    except (ValueError, IndexError):
        raise InputError(f"{path}: column {name!r} has a value that is not a number") from None
    bad = np.flatnonzero(~np.isfinite(values))
    if len(bad):
        raise InputError(f"{path}: column {name!r} row {bad[0] + 1} is not finite "
                         f"({values[bad[0]]})")
    return values


def _times(path, header, rows) -> np.ndarray:
    t = _column(path, header, rows, "time_s")
    back = np.flatnonzero(np.diff(t) <= 0)
    if len(back):
        raise InputError(f"{path}: time_s must increase strictly, but row {back[0] + 2} "
                         f"({t[back[0] + 1]:g} s) does not come after row {back[0] + 1} "
                         f"({t[back[0]]:g} s)")
    return t


def _per_tendon(path, header, rows, pattern: str, n: int) -> np.ndarray:
    extra = pattern.format(n + 1)
    if extra in header:
        raise InputError(f"{path}: has a column {extra!r}: written for an arm with more than "
                         f"{n} tendons")
    return np.column_stack([_column(path, header, rows, pattern.format(i))
                            for i in range(1, n + 1)])


def read_tension_history(path, n_tendons: int) -> tuple[np.ndarray, np.ndarray]:
    """(time_s (k,), tensions_N (k, n)) of a tension-history CSV; tensions >= 0."""
    header, rows = _read_rows(path)
    t = _times(path, header, rows)
    P = _per_tendon(path, header, rows, "tension_{}_N", n_tendons)
    if np.any(P < 0):
        raise InputError(f"{path}: a cable cannot push: every tension must be >= 0 N")
    return t, P


@dataclass(frozen=True)
class ScheduleRows:
    """The rows of a motor schedule CSV that a simulation plays (mm, s, N)."""

    time_s: np.ndarray             # (k,)
    lengths_mm: np.ndarray | None  # (k, n) or None (steps only)
    steps: np.ndarray | None       # (k, n) microsteps from row 0, or None
    start_tensions_N: np.ndarray | None   # (n,) tensions of row 0, if given
    tips_mm: np.ndarray | None = None     # (k, 2) quasi-static tip of each row, if given

    def lengths_from(self, start_lengths_mm, mm_per_step: float) -> np.ndarray:
        """Cable lengths of every row: the length columns, else the start
        state's lengths plus the steps times the cable per microstep."""
        if self.lengths_mm is not None:
            return self.lengths_mm
        return np.asarray(start_lengths_mm, float)[None, :] + self.steps * mm_per_step


def read_schedule(path, n_tendons: int) -> ScheduleRows:
    """The timed rows of a motor schedule CSV (``trace --schedule``)."""
    header, rows = _read_rows(path)
    if len(rows) < 2:
        raise InputError(f"{path}: a schedule needs at least two rows")
    t = _times(path, header, rows)
    lengths = steps = None
    if "length_1_mm" in header or "steps_1" not in header:
        lengths = _per_tendon(path, header, rows, "length_{}_mm", n_tendons)
        if np.any(lengths <= 0):
            raise InputError(f"{path}: cable lengths must be positive")
    else:
        steps = _per_tendon(path, header, rows, "steps_{}", n_tendons)
    start = None
    if all(f"tension_{i}_N" in header for i in range(1, n_tendons + 1)):
        start = _per_tendon(path, header, rows[:1], "tension_{}_N", n_tendons)[0]
        if np.any(start < 0) or not math.isfinite(float(np.sum(start))):
            raise InputError(f"{path}: the tensions of row 0 must be finite and >= 0")
    tips = None
    if "tip_x_mm" in header and "tip_y_mm" in header:
        tips = np.column_stack([_column(path, header, rows, c) for c in ("tip_x_mm", "tip_y_mm")])
    return ScheduleRows(t, lengths, steps, start, tips)
