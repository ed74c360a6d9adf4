"""Motor schedule: cable lengths along a path -> timed spool revolutions and steps.

The experiments of Sec. 4.1 impose cable lengths, not tensions: each cable
is reeled on a spool of radius r (paper: 31 mm) driven by a stepper motor.
A schedule is a table of rows k = 0, 1, ... in the order the motors play
them: first the *approach* (from the unloaded straight arm, or a given
state, along a straight tip line to the first point of the path), then the
*path*.  Relative to the first row (the reference: the motors are zeroed
there), a change of cable length dL_i = L_i - L_i(row 0) [mm] needs

    revolutions_i = dL_i / (2 pi r)
    steps_i       = round(revolutions_i * steps_per_rev * microsteps)   (integer)

Step signs: dL_i > 0 (positive steps) pays cable i out (lengthens it);
dL_i < 0 (negative steps) reels it in (shortens it), which pulls the arm
harder.  ``step_increment_i`` is the move from the previous row
(steps_i(k) - steps_i(k-1)), what a relative motor command sends.  The
length actually imposed differs from the requested one by the rounding
error steps_i (2 pi r) / (steps_per_rev microsteps) - dL_i, at most half a
microstep of cable (pi r / (steps_per_rev microsteps), 0.03 mm for the
paper's motors at 200 x 16 steps).  Steps are rounded from the absolute
position, so rounding errors never accumulate along a path.

Time: the tip moves between rows at a constant speed v [mm/s], so
``time_s`` (k) = sum over rows j <= k of |tip_j - tip_{j-1}| / v, 0 at row 0.
A row is ``reached`` if tip control put the tip within its tolerance of the
row's target; rows not reached are kept (the tip listed is where the arm
goes) so the motors still follow a continuous plan.

CSV columns (one header line, one row per schedule row; booleans written
``true``/``false``)::

    row, phase (approach|path), point (index within its phase; for the path
    the index of path/ in the trace HDF5), time_s, reached,
    target_x_mm, target_y_mm, tip_x_mm, tip_y_mm, then per tendon i = 1..n:
    tension_i_N, tension_i_p (p = P l^2/B), length_i_mm, revolutions_i,
    steps_i, step_increment_i, rounding_error_i_mm
"""
from __future__ import annotations

import csv
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError
from .model import Arm, Motor

PHASES = ("approach", "path")


@dataclass(frozen=True)
class MotorSchedule:
    """Per row k of the schedule and tendon i (numbered from 1 in the CSV); mm, N, s."""

    targets_mm: np.ndarray          # (k, 2)
    tips_mm: np.ndarray             # (k, 2)
    tensions_N: np.ndarray          # (k, n)
    p: np.ndarray                   # (k, n) non-dimensional tensions P l^2 / B
    lengths_mm: np.ndarray          # (k, n) cable length L_i = |r_i - x_i|
    delta_mm: np.ndarray            # (k, n) L_i - L_i(row 0)
    revolutions: np.ndarray         # (k, n) spool revolutions from row 0
    steps: np.ndarray               # (k, n) int microsteps from row 0 (> 0: cable paid out)
    step_increments: np.ndarray     # (k, n) int microsteps from the previous row
    rounding_error_mm: np.ndarray   # (k, n) imposed minus requested length change
    reached: np.ndarray             # (k,) bool: tip within tolerance of the target
    phase: np.ndarray               # (k,) str: "approach" or "path"
    point: np.ndarray               # (k,) int: index within the phase
    time_s: np.ndarray              # (k,) s at speed_mm_s (NaN without a speed)
    speed_mm_s: float               # tip speed along the schedule (NaN: none given)
    spool_radius_mm: float
    steps_per_revolution: int       # full steps x microsteps

    @property
    def n_tendons(self) -> int:
        return self.lengths_mm.shape[1]

    @property
    def n_rows(self) -> int:
        return self.lengths_mm.shape[0]

    @property
    def mm_per_step(self) -> float:
        return 2.0 * math.pi * self.spool_radius_mm / self.steps_per_revolution

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1])

    def lengths_at(self, time_s) -> np.ndarray:
        """Cable lengths [mm] at times ``time_s`` (scalar or (m,)) when every
        motor moves at constant speed from row to row (linear interpolation
        in time), shape (m, n)."""
        if not np.all(np.isfinite(self.time_s)):
            raise InputError("this schedule has no time column (no tracing speed was given)")
        t = np.atleast_1d(np.asarray(time_s, float))
        return np.column_stack([np.interp(t, self.time_s, self.lengths_mm[:, i])
                                for i in range(self.n_tendons)])

    def path_rows(self) -> np.ndarray:
        """Row numbers of the path (the approach excluded)."""
        return np.flatnonzero(self.phase == "path")

    def columns(self) -> list[str]:
        cols = ["row", "phase", "point", "time_s", "reached", "target_x_mm", "target_y_mm",
                "tip_x_mm", "tip_y_mm"]
        for i in range(1, self.n_tendons + 1):
            cols += [f"tension_{i}_N", f"tension_{i}_p", f"length_{i}_mm", f"revolutions_{i}",
                     f"steps_{i}", f"step_increment_{i}", f"rounding_error_{i}_mm"]
        return cols

    def rows(self) -> list[list]:
        out = []
        for k in range(self.n_rows):
            row = [k, str(self.phase[k]), int(self.point[k]), self.time_s[k],
                   "true" if self.reached[k] else "false", *self.targets_mm[k], *self.tips_mm[k]]
            for i in range(self.n_tendons):
                row += [self.tensions_N[k, i], self.p[k, i], self.lengths_mm[k, i],
                        self.revolutions[k, i], int(self.steps[k, i]),
                        int(self.step_increments[k, i]), self.rounding_error_mm[k, i]]
            out.append(row)
        return out

    def write_csv(self, path) -> Path:
        """Write the schedule (header + one row per row), atomically, with the
        file mode of any new file (0666 less the umask)."""
        path = Path(path)
        directory = path.parent if str(path.parent) else Path(".")
        if not directory.is_dir():
            raise InputError(f"{path}: directory {directory} does not exist")
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
        try:
            os.fchmod(fd, 0o666 & ~_umask())
            with os.fdopen(fd, "w", newline="") as fh:
                writer = csv.writer(fh)
                writer.writerow(self.columns())
                for row in self.rows():
                    writer.writerow([v if isinstance(v, (int, np.integer, str)) else f"{v:.12g}"
                                     for v in row])
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
        return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _optional(a, shape, name, fill=np.nan, dtype=float):
    if a is None:
        return np.full(shape, fill, dtype=dtype)
    a = np.asarray(a, dtype=dtype)
    if a.shape != shape:
        raise InputError(f"{name} must have shape {shape}, got {a.shape}")
    return a


def schedule_times(tips_mm, speed_mm_s: float | None) -> np.ndarray:
    """Time of each row [s] when the tip moves from row to row at ``speed_mm_s``
    (NaN everywhere when no speed is given)."""
    tips = np.asarray(tips_mm, float)
    if speed_mm_s is None or not np.all(np.isfinite(tips)):
        return np.full(len(tips), np.nan)
    if not (speed_mm_s > 0 and math.isfinite(speed_mm_s)):
        raise InputError(f"the tracing speed must be a positive number of mm/s, got {speed_mm_s}")
    steps = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    return np.concatenate(([0.0], np.cumsum(steps))) / speed_mm_s


def motor_schedule(lengths_mm, motor: Motor, *, targets_mm=None, tips_mm=None,
                   tensions_N=None, p=None, reached=None, phase=None, point=None,
                   speed_mm_s: float | None = None) -> MotorSchedule:
    """Revolutions and integer microsteps of each spool, relative to the first
    row, for cable lengths ``lengths_mm`` (k, n) [mm]; times from the tip
    positions at ``speed_mm_s`` [mm/s].  Missing columns are NaN (reached:
    True, phase: "path", point: the row number)."""
    L = np.asarray(lengths_mm, dtype=float)
    if L.ndim != 2 or len(L) == 0:
        raise InputError(f"cable lengths must have shape (points, tendons), got {L.shape}")
    k, n = L.shape
    spr = int(motor.steps_per_rev) * int(motor.microsteps)
    circumference = 2.0 * math.pi * motor.spool_radius_mm
    delta = L - L[0]
    revolutions = delta / circumference
    steps = np.rint(revolutions * spr).astype(np.int64)
    tips = _optional(tips_mm, (k, 2), "tips")
    phases = _optional(phase, (k,), "phase", "path", object).astype(str)
    if not set(phases) <= set(PHASES):
        raise InputError(f"phase must be one of {PHASES}, got {sorted(set(phases))}")
    return MotorSchedule(
        targets_mm=_optional(targets_mm, (k, 2), "targets"), tips_mm=tips,
        tensions_N=_optional(tensions_N, (k, n), "tensions"), p=_optional(p, (k, n), "p"),
        lengths_mm=L.copy(), delta_mm=delta, revolutions=revolutions, steps=steps,
        step_increments=np.diff(steps, axis=0, prepend=steps[:1]),
        rounding_error_mm=steps * (circumference / spr) - delta,
        reached=_optional(reached, (k,), "reached", True, bool), phase=phases,
        point=np.arange(k) if point is None else _optional(point, (k,), "point", 0, np.int64),
        time_s=schedule_times(tips, speed_mm_s),
        speed_mm_s=math.nan if speed_mm_s is None else float(speed_mm_s),
        spool_radius_mm=float(motor.spool_radius_mm), steps_per_revolution=spr)


def schedule_from_trace(trace, arm: Arm, *, approach=None,
                        speed_mm_s: float | None = None) -> MotorSchedule:
    """The timed motor schedule of a traced path
    (:class:`~elastica_petsc.studies.trace.TraceResult`), preceded by the rows
    of ``approach`` (another TraceResult, e.g. from
    :func:`elastica_petsc.studies.schedule.trace_schedule`) when given; the
    tip moves at ``speed_mm_s`` [mm/s] (no times without it)."""
    parts = [t for t in (approach, trace) if t is not None]

    def stack(name):
        return np.concatenate([np.asarray(getattr(t, name)) for t in parts])

    phase = np.concatenate([np.full(t.n_points, name, dtype=object)
                            for t, name in zip(parts, PHASES[-len(parts):])])
    return motor_schedule(stack("cable_lengths_mm"), arm.motor, targets_mm=stack("targets_mm"),
                          tips_mm=stack("tips_mm"), tensions_N=stack("tensions_N"),
                          p=stack("p"), reached=stack("converged"), phase=phase,
                          point=np.concatenate([np.arange(t.n_points) for t in parts]),
                          speed_mm_s=speed_mm_s)


def write_schedule_csv(path, trace, arm: Arm, **kw) -> MotorSchedule:
    """Motor schedule of a traced path written to ``path`` (CSV); returns it.
    Keywords as :func:`schedule_from_trace`."""
    schedule = schedule_from_trace(trace, arm, **kw)
    schedule.write_csv(path)
    return schedule
