"""The fastest constant tip speed at which a schedule stays within D mm (docs/model.md §16.8).

A motor schedule (the rows of ``trace --schedule``: cable lengths and the
quasi-static tips along an approach and a path) is re-timed so that the tip
moves from row to row at a candidate speed v (core/schedule.py
``retimed``: under [motor] limits, also no faster than the motors
allow), played under length control from rest by the dynamics of §16
(studies/simulate.py, the schedule's own cables, slack and taut decided in
every step), and judged by two numbers:

- ``max_deviation_mm``: the largest distance, while the motors move
  (0 <= t <= T(v)), between the simulated tip and the quasi-static tip of the
  schedule at the same time (linear in time between rows);
- ``end_deviation_mm``: the distance of the tip from the schedule's last
  quasi-static tip at the end of the settling window T(v) + ``settle_s``,
  and ``settling_s``: the time after T(v) from which the tip stays within D
  of it to the end of the window (None: it does not).

A speed passes when the run completes, max_deviation_mm <= D and the tip has
settled within D in the window.  The search starts at ``start_mm_s``
(default the schedule's own tip speed), doubles (or halves) it until one
speed passes and one fails, then bisects geometrically until the failing
speed is within ``rel_tol`` of the passing one.  The deviation need not be
monotone in v: the answer is the fastest passing speed of the bracket found,
and every candidate is reported.
"""
from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.model import Arm
from ..core.schedule import MotorSchedule, retimed, tip_speed_max_mm_s
from ..solvers.stability import max_tracing_speed_mm_s
from .simulate import simulate

SETTLE_S = 2.0          # default settling window after the motors stop [s]
MAX_DOUBLINGS = 8       # bracket search: at most 2^8 faster or slower than the start


@dataclass(frozen=True)
class SpeedTrial:
    """One candidate speed, played and judged (mm, s)."""

    speed_mm_s: float
    duration_s: float           # the motors' time T(v)
    max_deviation_mm: float     # from the quasi-static tip while the motors move
    max_deviation_at_s: float   # when it happened
    end_deviation_mm: float     # from the last quasi-static tip at T(v) + settle
    settling_s: float | None    # after T(v), within D from then on (None: not in the window)
    completed: bool
    passed: bool
    steps: int
    wall_s: float

    def to_json(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class SpeedStudy:
    """The fastest passing speed found (None: no speed passed), the bracket and every trial
    (``summary()``: what ``schedule --max-deviation-mm --json`` prints; no HDF5 form)."""

    max_deviation_mm: float
    elements: int
    settle_s: float
    fastest_mm_s: float | None
    failing_mm_s: float | None      # the slowest failing speed above it (None: none failed)
    schedule_speed_mm_s: float | None
    f1_hz: float                    # first frequency of the start state (tensions held)
    rule_of_thumb_mm_s: float       # 2 pi f1 D (solvers/stability.py)
    trials: tuple

    def summary(self) -> dict:
        best = next((t for t in self.trials if t.speed_mm_s == self.fastest_mm_s), None)
        return {"max_deviation_mm": self.max_deviation_mm, "elements": self.elements,
                "settle_s": self.settle_s, "fastest_mm_s": self.fastest_mm_s,
                "failing_mm_s": self.failing_mm_s,
                "schedule_speed_mm_s": self.schedule_speed_mm_s, "f1_hz": self.f1_hz,
                "rule_of_thumb_mm_s": self.rule_of_thumb_mm_s,
                "fastest": None if best is None else best.to_json(),
                "trials": [t.to_json() for t in self.trials]}


def judge(run, schedule: MotorSchedule, max_deviation_mm: float, speed_mm_s: float) -> SpeedTrial:
    """One played schedule (a ``SimulationResult``) measured against ``max_deviation_mm``."""
    T = schedule.duration_s
    t, tip = run.time_s, run.tip_mm
    moving = t <= T * (1 + 1e-12)
    off = np.linalg.norm(tip[moving] - run.planned_tip_mm[moving], axis=1)
    dev, at = float(off.max()), float(t[moving][np.argmax(off)])
    end = np.linalg.norm(tip - schedule.tips_mm[-1], axis=1)
    after = ~moving
    settling = None
    if run.completed and after.any() and end[-1] <= max_deviation_mm:
        out = np.flatnonzero(after & (end > max_deviation_mm))
        settling = 0.0 if len(out) == 0 else float(t[out[-1] + 1] - T)
    passed = bool(run.completed and dev <= max_deviation_mm and settling is not None)
    return SpeedTrial(speed_mm_s=float(speed_mm_s), duration_s=float(T), max_deviation_mm=dev,
                      max_deviation_at_s=at, end_deviation_mm=float(end[-1]), settling_s=settling,
                      completed=bool(run.completed), passed=passed, steps=int(run.steps),
                      wall_s=float(run.wall_s))


def play(arm: Arm, schedule: MotorSchedule, speed_mm_s: float, max_deviation_mm: float, *,
         elements: int | None, settle_s: float):
    """(trial, simulation) of ``schedule`` re-timed to ``speed_mm_s``, from rest."""
    timed = retimed(schedule, arm.motor, speed_mm_s)
    with tempfile.TemporaryDirectory(prefix="ep-speed-") as d:
        path = timed.write_csv(Path(d) / "schedule.csv")
        run = simulate(arm, elements=elements, schedule_csv=path, settle_s=settle_s)
    return judge(run, timed, max_deviation_mm, speed_mm_s), run


def check_study(max_deviation_mm, settle_s, rel_tol) -> float:
    """D [mm] as a float, or InputError (one line) for D, the window or the tolerance."""
    D = float(max_deviation_mm)
    if not (D > 0 and math.isfinite(D)):
        raise InputError(f"the largest tip deviation must be a positive number of mm, got {D:g}")
    if not (settle_s > 0 and math.isfinite(settle_s)):
        raise InputError(f"the settling window must be a positive number of seconds, "
                         f"got {settle_s:g}")
    if not 0 < rel_tol < 1:
        raise InputError(f"the relative tolerance must be in (0, 1), got {rel_tol:g}")
    return D


def fastest_speed(arm: Arm, schedule: MotorSchedule, max_deviation_mm: float, *,
                  elements: int | None = None, settle_s: float = SETTLE_S,
                  start_mm_s: float | None = None, rel_tol: float = 0.05,
                  on_trial=None) -> SpeedStudy:
    """The fastest constant tip speed [mm/s] at which ``schedule`` (e.g.
    ``read_schedule_csv`` or ``trace_schedule(...).schedule``), played from rest
    on a mesh of ``elements``, stays within ``max_deviation_mm`` of its quasi-static
    tips and settles within it in ``settle_s`` (module docstring);
    ``on_trial(trial)`` after each candidate."""
    D = check_study(max_deviation_mm, settle_s, rel_tol)
    if schedule.n_rows < 2 or not np.all(np.isfinite(schedule.tips_mm)):
        raise InputError("the schedule needs at least two rows with tip_x_mm, tip_y_mm")
    own = tip_speed_max_mm_s(schedule)
    v = start_mm_s if start_mm_s is not None else own
    if v is None or not (v > 0 and math.isfinite(v)):
        raise InputError("give a starting speed (--speed-mm-s): the schedule has no time column")
    trials, f1 = [], []

    def trial(speed):
        t, run = play(arm, schedule, speed, D, elements=elements, settle_s=settle_s)
        if run.reason == "INTERRUPTED":          # a stop, not a failing speed
            raise KeyboardInterrupt
        trials.append(t)
        f1.append(run.f1_hz)
        if on_trial is not None:
            on_trial(t)
        return t.passed

    lo, hi = _bracket(trial, v)
    while lo is not None and hi is not None and hi > lo * (1 + rel_tol):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if trial(mid) else (lo, mid)
    elements_used = int(elements or arm.elements)
    return SpeedStudy(max_deviation_mm=D, elements=elements_used, settle_s=float(settle_s),
                      fastest_mm_s=lo, failing_mm_s=hi, schedule_speed_mm_s=own,
                      f1_hz=float(f1[0]), rule_of_thumb_mm_s=float(
                          max_tracing_speed_mm_s(f1[0], D)), trials=tuple(trials))


def _bracket(trial, v: float):
    """(passing, failing) speeds a factor 2 apart around ``v`` (None where none found)."""
    if trial(v):
        lo = v
        for _ in range(MAX_DOUBLINGS):
            if not trial(2 * lo):
                return lo, 2 * lo
            lo *= 2
        return lo, None
    hi = v
    for _ in range(MAX_DOUBLINGS):
        if trial(hi / 2):
            return hi / 2, hi
        hi /= 2
    return None, hi
