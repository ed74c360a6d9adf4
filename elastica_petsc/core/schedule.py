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

Time: without motor limits the tip moves between rows at a constant speed
v [mm/s], so ``time_s`` (k) = sum over rows j <= k of |tip_j - tip_{j-1}| / v,
0 at row 0.  With [motor] ``max_speed_steps_s`` / ``max_accel_steps_s2`` the
rows are re-timed (core/motion.py) to the shortest durations under which no
motor exceeds its limits and the tip is never faster than v; ``limited_by``
names what sets each move's duration (``tip_speed``, ``speed_I``, ``accel_I``
for motor I, ``none``; ``start`` at row 0), so the rows where a motor slowed
the tip are those not ``tip_speed``.
A row is ``reached`` if tip control put the tip within its tolerance of the
row's target; rows not reached are kept (the tip listed is where the arm
goes) so the motors still follow a continuous plan.

CSV columns (one header line, one row per schedule row; booleans written
``true``/``false``)::

    row, phase (approach|path), point (index within its phase; for the path
    the index of path/ in the trace HDF5), time_s, duration_s (of the move
    into this row, 0 at row 0), limited_by, reached,
    target_x_mm, target_y_mm, tip_x_mm, tip_y_mm, then per tendon i = 1..n:
    tension_i_N, tension_i_p (p = P l^2/B), length_i_mm, revolutions_i,
    steps_i, step_increment_i, rounding_error_i_mm
"""
from __future__ import annotations

import csv
import math
import os
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .errors import InputError
from .model import Arm, Motor
from .motion import MotorLimits, Violation, check, retime, step_events

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
    limited_by: np.ndarray          # (k,) str: what sets the move into each row
    limits: MotorLimits | None      # the motors' speed and acceleration limits
    speed_bound_s: float            # no schedule under the limits is shorter (NaN: untimed)

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

    @property
    def durations_s(self) -> np.ndarray:
        """(k,) duration of the move into each row, 0 at row 0."""
        return np.diff(self.time_s, prepend=self.time_s[:1])

    @property
    def positions_steps(self) -> np.ndarray:
        """(k, n) planned motor positions in microsteps from row 0, before rounding."""
        return self.delta_mm / self.mm_per_step

    def motor_check(self, limits: MotorLimits | None = None) -> list[Violation]:
        """Rows a motor cannot play under ``limits`` (default: the schedule's own)."""
        limits = limits or self.limits
        if limits is None or not np.all(np.isfinite(self.time_s)):
            return []
        return check(self.positions_steps, self.durations_s[1:], limits)

    def step_table(self, motor: int) -> np.ndarray:
        """Step/direction timing of motor ``motor`` (0-based): (time_s, direction,
        position_steps) per microstep (core/motion.py ``step_events``)."""
        return step_events(self.positions_steps, self.time_s, motor)

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
        cols = ["row", "phase", "point", "time_s", "duration_s", "limited_by", "reached",
                "target_x_mm", "target_y_mm", "tip_x_mm", "tip_y_mm"]
        for i in range(1, self.n_tendons + 1):
            cols += [f"tension_{i}_N", f"tension_{i}_p", f"length_{i}_mm", f"revolutions_{i}",
                     f"steps_{i}", f"step_increment_{i}", f"rounding_error_{i}_mm"]
        return cols

    def rows(self) -> list[list]:
        out = []
        for k in range(self.n_rows):
            row = [k, str(self.phase[k]), int(self.point[k]), self.time_s[k],
                   self.durations_s[k], str(self.limited_by[k]),
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
        return write_table(path, self.columns(), self.rows())

    def write_step_tables(self, stem) -> list[Path]:
        """One step/direction table per motor, ``STEM_motorI.csv`` (I from 1):
        columns time_s, direction (+1 pays cable out, -1 reels it in),
        position_steps (after the step, from row 0)."""
        stem = Path(stem)
        paths = []
        for i in range(self.n_tendons):
            events = self.step_table(i)
            rows = [[float(t), int(d), int(q)] for t, d, q in events]
            paths.append(write_table(stem.with_name(f"{stem.name}_motor{i + 1}.csv"),
                                     ["time_s", "direction", "position_steps"], rows))
        return paths


def tip_speed_max_mm_s(schedule: MotorSchedule) -> float | None:
    """The fastest tip speed [mm/s] of a schedule's own time column (None: untimed)."""
    d = np.diff(schedule.time_s)
    step = np.linalg.norm(np.diff(schedule.tips_mm, axis=0), axis=1)
    moving = d > 0
    if not np.all(np.isfinite(d)) or not moving.any():
        return None
    return float(np.max(step[moving] / d[moving]))


def write_table(path, header: list[str], rows: list[list]) -> Path:
    """A CSV written atomically (floats exactly, as Python's repr), with the
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
            writer.writerow(header)
            for row in rows:
                writer.writerow([v if isinstance(v, (int, np.integer, str)) else
                                 repr(float(v)) for v in row])
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


def schedule_times(tips_mm, speed_mm_s: float | None, positions_steps=None,
                   limits: MotorLimits | None = None):
    """(time of each row [s], what bounds each move, lower bound of the total
    time [s]): the tip moves from row to row at ``speed_mm_s``, re-timed under
    the motor ``limits`` when given (core/motion.py); NaN times when there is
    neither a speed nor limits (or the tips are unknown)."""
    tips = np.asarray(tips_mm, float)
    k = len(tips)
    if speed_mm_s is not None and not (speed_mm_s > 0 and math.isfinite(speed_mm_s)):
        raise InputError(f"the tracing speed must be a positive number of mm/s, got {speed_mm_s}")
    untimed = (np.full(k, np.nan), np.full(k, "", dtype=object), math.nan)
    if limits is not None and k >= 2 and np.all(np.isfinite(tips)):
        timing = retime(positions_steps, limits, tips_mm=tips, speed_mm_s=speed_mm_s)
        return (timing.time_s, np.concatenate((["start"], timing.limited_by)).astype(object),
                timing.speed_bound_s)
    if speed_mm_s is None or not np.all(np.isfinite(tips)):
        return untimed
    steps = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    time_s = np.concatenate(([0.0], np.cumsum(steps))) / speed_mm_s
    labels = np.array(["start"] + ["tip_speed"] * (k - 1), dtype=object)
    return time_s, labels, float(time_s[-1])


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
    limits = MotorLimits.of(motor, n)
    time_s, limited_by, bound_s = schedule_times(tips, speed_mm_s, delta / (circumference / spr),
                                                 limits)
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
        time_s=time_s, speed_mm_s=math.nan if speed_mm_s is None else float(speed_mm_s),
        spool_radius_mm=float(motor.spool_radius_mm), steps_per_revolution=spr,
        limited_by=limited_by, limits=limits, speed_bound_s=bound_s)


def retimed(schedule: MotorSchedule, motor: Motor, speed_mm_s: float | None) -> MotorSchedule:
    """``schedule``'s rows with the tip moving at ``speed_mm_s`` [mm/s] between rows, under
    ``motor``'s limits when it has any (``schedule --retime``)."""
    return motor_schedule(schedule.lengths_mm, motor, targets_mm=schedule.targets_mm,
                          tips_mm=schedule.tips_mm, tensions_N=schedule.tensions_N,
                          p=schedule.p, reached=schedule.reached, phase=schedule.phase,
                          point=schedule.point, speed_mm_s=speed_mm_s)


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


def read_schedule_csv(path, motor: Motor) -> MotorSchedule:
    """A schedule CSV (any writer's, in the columns documented above;
    ``duration_s`` and ``limited_by`` optional) for the spools of ``motor``,
    with the file's own time column; refused if its steps do not match ``motor``."""
    try:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    except OSError as err:
        raise InputError(f"{path}: cannot read it ({err.strerror})") from None
    if not rows:
        raise InputError(f"{path}: no schedule rows")
    n = sum(1 for c in rows[0] if c.startswith("length_") and c.endswith("_mm"))

    def column(name, kind=float):
        try:
            return np.array([kind(r[name]) for r in rows])
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: column {name} missing or not {kind.__name__}") from None

    def pairs(fmt):
        return np.column_stack([column(fmt.format(i)) for i in range(1, n + 1)])

    if n == 0:
        raise InputError(f"{path}: no length_I_mm columns: not a schedule CSV")
    schedule = motor_schedule(
        pairs("length_{}_mm"), motor, targets_mm=np.column_stack([column("target_x_mm"),
                                                                  column("target_y_mm")]),
        tips_mm=np.column_stack([column("tip_x_mm"), column("tip_y_mm")]),
        tensions_N=pairs("tension_{}_N"), p=pairs("tension_{}_p"),
        reached=column("reached", str) == "true", phase=column("phase", str),
        point=column("point", int))
    if not np.array_equal(schedule.steps, pairs("steps_{}").astype(np.int64)):
        raise InputError(f"{path}: its steps columns do not match this config's motor "
                         f"({motor.spool_radius_mm:g} mm spool, {schedule.steps_per_revolution} "
                         "microsteps per revolution): give the --config it was made for")
    labels = (column("limited_by", str) if "limited_by" in rows[0]
              else np.full(len(rows), "", dtype=object))
    return replace(schedule, time_s=column("time_s"), limited_by=labels.astype(object),
                   speed_bound_s=math.nan)
