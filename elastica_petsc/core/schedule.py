"""Motor schedule: cable lengths along a path -> spool revolutions and steps.

The experiments of Sec. 4.1 impose cable lengths, not tensions: each cable
is reeled on a spool of radius r (paper: 31 mm) driven by a stepper motor.
Relative to the first point of a path, a change of cable length
dL_i = L_i - L_i(first) [mm] (positive: cable paid out) needs

    revolutions_i = dL_i / (2 pi r)
    steps_i       = round(revolutions_i * steps_per_rev * microsteps)   (integer)

and the length actually imposed differs from the requested one by the
rounding error steps_i (2 pi r) / (steps_per_rev microsteps) - dL_i, at
most half a microstep of cable (pi r / (steps_per_rev microsteps), 0.03 mm
for the paper's motors at 200 x 16 steps).  Steps are rounded from the
absolute position, so rounding errors never accumulate along a path.
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


@dataclass(frozen=True)
class MotorSchedule:
    """Per point k of a path and tendon i (numbered from 1 in the CSV)."""

    targets_mm: np.ndarray          # (k, 2)
    tips_mm: np.ndarray             # (k, 2)
    tensions_N: np.ndarray          # (k, n)
    lengths_mm: np.ndarray          # (k, n) cable length L_i = |r_i - x_i|
    delta_mm: np.ndarray            # (k, n) L_i - L_i(first point)
    revolutions: np.ndarray         # (k, n) spool revolutions from the first point
    steps: np.ndarray               # (k, n) int microsteps from the first point
    rounding_error_mm: np.ndarray   # (k, n) imposed minus requested length change
    spool_radius_mm: float
    steps_per_revolution: int       # full steps x microsteps

    @property
    def n_tendons(self) -> int:
        return self.lengths_mm.shape[1]

    @property
    def mm_per_step(self) -> float:
        return 2.0 * math.pi * self.spool_radius_mm / self.steps_per_revolution

    def columns(self) -> list[str]:
        cols = ["index", "target_x_mm", "target_y_mm", "tip_x_mm", "tip_y_mm"]
        for i in range(1, self.n_tendons + 1):
            cols += [f"tension_{i}_N", f"length_{i}_mm", f"revolutions_{i}", f"steps_{i}",
                     f"rounding_error_{i}_mm"]
        return cols

    def rows(self) -> list[list]:
        out = []
        for k in range(len(self.lengths_mm)):
            row = [k, *self.targets_mm[k], *self.tips_mm[k]]
            for i in range(self.n_tendons):
                row += [self.tensions_N[k, i], self.lengths_mm[k, i], self.revolutions[k, i],
                        int(self.steps[k, i]), self.rounding_error_mm[k, i]]
            out.append(row)
        return out

    def write_csv(self, path) -> Path:
        """Write the schedule (header + one row per point), atomically."""
        path = Path(path)
        directory = path.parent if str(path.parent) else Path(".")
        if not directory.is_dir():
            raise InputError(f"{path}: directory {directory} does not exist")
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
        try:
            with os.fdopen(fd, "w", newline="") as fh:
                writer = csv.writer(fh)
                writer.writerow(self.columns())
                for row in self.rows():
                    writer.writerow([v if isinstance(v, (int, np.integer)) else f"{v:.10g}"
                                     for v in row])
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
        return path


def motor_schedule(lengths_mm, motor: Motor, *, targets_mm=None, tips_mm=None,
                   tensions_N=None) -> MotorSchedule:
    """Revolutions and integer microsteps of each spool, relative to the first
    point, for cable lengths ``lengths_mm`` (k, n)."""
    L = np.asarray(lengths_mm, dtype=float)
    if L.ndim != 2 or len(L) == 0:
        raise InputError(f"cable lengths must have shape (points, tendons), got {L.shape}")
    k, n = L.shape

    def optional(a, shape, name):
        if a is None:
            return np.full(shape, np.nan)
        a = np.asarray(a, dtype=float)
        if a.shape != shape:
            raise InputError(f"{name} must have shape {shape}, got {a.shape}")
        return a

    spr = int(motor.steps_per_rev) * int(motor.microsteps)
    circumference = 2.0 * math.pi * motor.spool_radius_mm
    delta = L - L[0]
    revolutions = delta / circumference
    steps = np.rint(revolutions * spr).astype(np.int64)
    error = steps * (circumference / spr) - delta
    return MotorSchedule(
        targets_mm=optional(targets_mm, (k, 2), "targets"),
        tips_mm=optional(tips_mm, (k, 2), "tips"),
        tensions_N=optional(tensions_N, (k, n), "tensions"),
        lengths_mm=L.copy(), delta_mm=delta, revolutions=revolutions, steps=steps,
        rounding_error_mm=error, spool_radius_mm=float(motor.spool_radius_mm),
        steps_per_revolution=spr)


def schedule_from_trace(trace, arm: Arm) -> MotorSchedule:
    """The motor schedule of a :class:`~elastica_petsc.studies.trace.TraceResult`."""
    return motor_schedule(trace.cable_lengths_mm, arm.motor, targets_mm=trace.targets_mm,
                          tips_mm=trace.tips_mm, tensions_N=trace.tensions_N)


def write_schedule_csv(path, trace, arm: Arm) -> MotorSchedule:
    """Motor schedule of a traced path written to ``path`` (CSV); returns it."""
    schedule = schedule_from_trace(trace, arm)
    schedule.write_csv(path)
    return schedule
