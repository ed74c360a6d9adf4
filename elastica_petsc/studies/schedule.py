"""A motor schedule ready for the motors: approach move, traced path, timing.

:func:`trace_schedule` traces (tip control, warm-started point to point,
Sec. 4.5 (v)) an *approach* — a straight tip line from the unloaded straight
arm (or the load-controlled state at given tensions) to the first target —
and then the path itself, warm-started from the end of the approach, and
turns both into one timed :class:`~elastica_petsc.core.schedule.MotorSchedule`
(cable lengths -> spool revolutions and microsteps, Sec. 4.1).  The motors
start where they can be zeroed, at the straight arm, and the approach gives
the length-controlled arm a continuous way onto the planned branch (Sec.
4.6: the same cable lengths can hold several equilibria, Fig. 8); whether it
stays there is checked by replaying the schedule under length control
(:func:`elastica_petsc.studies.replay.replay`, ``elastica-petsc replay``;
tests/test_schedule.py does it for a path from the straight arm).

The default tip speed is :func:`suggested_speed` (Sec. 4.5 (vi)).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.results import Result
from ..core.errors import InputError
from ..core.schedule import MotorSchedule, schedule_from_trace
from ..solvers.control import TipController
from .trace import TraceResult, trace


@dataclass(frozen=True, repr=False)
class TracedSchedule(Result):
    """The approach (None if not asked for), the traced path, the timed
    schedule and how its speed was chosen (``speed``: the keys of
    :func:`suggested_speed`, plus ``speed_mm_s`` and ``speed_source``)."""

    approach: TraceResult | None
    path: TraceResult
    schedule: MotorSchedule
    speed: dict

    @property
    def arm(self):
        """The arm traced (the path's; saved as provenance)."""
        return self.path.arm

    def to_vtk(self, directory) -> list:
        """The approach and the path, one state per point timed by the schedule
        (``trace.pvd``, ``trace_path.vtu``), as ``trace --vtk`` writes them."""
        from ..io.vtk import write_trace
        from ..solvers.tip_problem import needs_arm

        rows = self.schedule.path_rows()
        return write_trace(directory, needs_arm(self.path), self.path,
                           times_s=self.schedule.time_s[rows], approach=self.approach,
                           approach_times_s=self.schedule.time_s[:rows[0]])

    def summary(self) -> dict:
        """What ``trace --json`` prints: the path, its approach and the schedule's timing."""
        from ..io.summaries import schedule_summary, trace_summary

        return {**trace_summary(self.path, self.schedule), **schedule_summary(self)}


APPROACH_TOL_MM = 0.05


def approach_targets(start_tip_mm, first_mm, step_mm: float,
                     tol_mm: float = APPROACH_TOL_MM) -> np.ndarray:
    """Tip targets [mm] from ``start_tip_mm`` (included) along a straight line
    towards ``first_mm`` (excluded: it is the path's first point).

    Spacing: at distance d from the start, h(d) = min(step, max(tol,
    sqrt(10 tol d))).  Near the straight arm a cable along the arm shortens
    with the square of the tip's deflection, so a motor that interpolates
    cable lengths linearly between two rows moves the tip off the planned
    line by about 0.1 h^2 / d (measured on the paper's arm); with uniform
    10 mm steps the first interval strays 11 mm.  With this grading the
    tip stays within ~2.5 tol (measured 0.13 mm for tol = 0.05 mm) of the
    line between rows."""
    a, b = np.asarray(start_tip_mm, float), np.asarray(first_mm, float)
    if not (step_mm > 0 and tol_mm > 0):
        raise InputError(f"approach step and tolerance must be positive, got {step_mm}, {tol_mm}")
    D = float(np.linalg.norm(b - a))
    d = [0.0]
    while True:
        h = min(step_mm, max(tol_mm, np.sqrt(10.0 * tol_mm * d[-1])))
        if d[-1] + h >= D * (1 - 1e-12):
            break
        d.append(d[-1] + h)
    t = np.array(d)[:, None] / max(D, 1e-300)
    return a + t * (b - a)


def trace_schedule(controller: TipController, targets_mm, *, step_mm: float = 1.0,
                   speed_mm_s: float | None = None, amplitude_mm: float = 1.0,
                   approach: bool = True, p0=None, on_point=None,
                   sharer=None) -> TracedSchedule:
    """Trace ``targets_mm`` (k, 2) [mm] after an approach move and build the
    timed motor schedule.

    speed_mm_s : tip speed [mm/s]; default the suggested safe speed
        v_max = 2 pi f_1 * ``amplitude_mm`` (Sec. 4.5 (vi), :func:`suggested_speed`),
        or no time column (NaN) when the arm has no mass per length.
    approach : start at the unloaded straight arm, or at the load-controlled
        equilibrium at non-dimensional tensions ``p0`` (p = P l^2/B) when
        given, and reach the first target along a straight tip line
        (:func:`approach_targets`: steps graded from 0.05 mm up to ``step_mm``).
        False: the schedule starts at the first target.
    on_point(done, total) : called after each traced point (approach and
        path together: ``done`` and ``total`` count both).
    sharer : a :class:`~elastica_petsc.solvers.share.TensionSharer` (n >= 3
        tendons): approach and path use the shared tensions; along the approach
        the floor p_min grows linearly with the distance travelled, from 0 at
        the straight arm (whose tensions are 0) to the sharer's at the first target.
    Results are kept per point (``path.results``) for figures and HDF5."""
    targets = np.asarray(targets_mm, float)
    if targets.ndim != 2 or targets.shape[1:] != (2,) or len(targets) == 0:
        raise InputError(f"targets must have shape (k, 2) in mm, got {targets.shape}")
    if speed_mm_s is not None and not speed_mm_s > 0:
        raise InputError(f"the tracing speed must be positive, got {speed_mm_s} mm/s")
    before, start = None, None
    if approach:
        start = None if p0 is None else controller.forward(p0)
        l_mm = controller.length_mm
        tip0 = np.array([l_mm, 0.0]) if start is None else start.tip * l_mm
        first = approach_targets(tip0, targets[0], step_mm)
        total = len(first) + len(targets)
        floors = None
        if sharer is not None:
            gone = np.linalg.norm(first - tip0, axis=1)
            floors = sharer.min_tension * gone / max(float(np.linalg.norm(targets[0] - tip0)),
                                                     1e-300)
        before = trace(controller, first, p0=p0, start=start, keep_results=True,
                       sharer=sharer, floors=floors,
                       on_point=None if on_point is None else (lambda k: on_point(k, total)))
        p0, start = before.p[-1], before.results[-1].equilibrium
    done = 0 if before is None else before.n_points
    path = trace(controller, targets, p0=p0, start=start, keep_results=True, sharer=sharer,
                 on_point=None if on_point is None
                 else (lambda k: on_point(done + k, done + len(targets))))
    speed = suggested_speed(controller.arm, controller.disc, path, amplitude_mm)
    if speed_mm_s is not None:
        speed.update(speed_mm_s=float(speed_mm_s), speed_source="given")
    elif speed:
        speed.update(speed_mm_s=speed["max_tracing_speed_mm_s"], speed_source="suggested")
    else:
        speed.update(speed_mm_s=None, speed_source="none (the arm has no mass per length)")
    schedule = schedule_from_trace(path, controller.arm, approach=before,
                                   speed_mm_s=speed["speed_mm_s"])
    return TracedSchedule(before, path, schedule, speed)


def suggested_speed(arm, disc, result: TraceResult, amplitude_mm: float = 1.0,
                    snapshots: int = 6) -> dict:
    """Suggested maximum tracing speed (Sec. 4.5 (vi)): the lowest first
    natural frequency f_1 [Hz] over ``snapshots`` states along the path,
    tensions held (the lower, conservative one), and v_max = 2 pi f_1 *
    amplitude [mm/s] — a jump dv of the tip velocity excites a vibration of
    amplitude dv / (2 pi f_1).  Needs ``result.results`` (trace with
    ``keep_results=True``) and the arm's mass per length; returns {} without it."""
    from ..solvers.stability import StabilitySolver, max_tracing_speed_mm_s

    if arm.mass_per_length_kg_m is None:
        return {}
    if not amplitude_mm > 0:
        raise InputError(f"the vibration amplitude must be positive, got {amplitude_mm}")
    picks = np.unique(np.linspace(0, result.n_points - 1, snapshots).round().astype(int))
    with StabilitySolver(disc, nev=1) as stab:
        f1 = min(stab.frequencies(result.results[k].equilibrium.u, result.results[k].p,
                                  arm, nev=1).f1_hz for k in picks)
    steps = np.linalg.norm(np.diff(result.targets_mm, axis=0), axis=1)
    return {"f1_min_hz": round(f1, 4),
            "max_tracing_speed_mm_s": round(max_tracing_speed_mm_s(f1, amplitude_mm), 4),
            "path_length_mm": round(float(steps.sum()), 3),
            "amplitude_mm": amplitude_mm}
