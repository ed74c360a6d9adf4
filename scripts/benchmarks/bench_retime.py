#!/usr/bin/env python3
"""Benchmark the motor-aware re-timing of a schedule (issue 26, core/motion.py).

The paper's triangle drawing (Fig. 3a) about (400, 200) mm, traced with its
approach at 1 mm steps on the paper's arm, then re-timed under motor limits
(default 1500 microsteps/s, 5000 microsteps/s^2): the time of the re-timing
against the time of the tracing it follows (a ratio, median of repeated runs),
the passes' outcome (total time against the speed-only lower bound, rows the
motors slowed) and a check of every row from the written CSV's columns.

Usage: python scripts/benchmarks/bench_retime.py [--repeat 5] [--step 1.0] [--elements 180]
       [--speed-mm-s 50] [--max-speed 1500] [--max-accel 5000]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import median_time  # noqa: E402


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--step", type=float, default=1.0)
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--speed-mm-s", type=float, default=50.0)
    ap.add_argument("--max-speed", type=float, default=1500.0)
    ap.add_argument("--max-accel", type=float, default=5000.0)
    args = ap.parse_args(argv)

    from elastica_petsc.core.model import load_config
    from elastica_petsc.core.motion import MotorLimits, retime
    from elastica_petsc.core.schedule import read_schedule_csv, schedule_from_trace
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.studies.schedule import trace_schedule
    from elastica_petsc.studies.trace import densify, paper_triangle

    arm = load_config()
    path = densify(paper_triangle((400.0, 200.0)), args.step)
    with TipController(arm, n_elements=args.elements) as ctl:
        t0 = time.perf_counter()
        plan = trace_schedule(ctl, path, step_mm=args.step, speed_mm_s=args.speed_mm_s)
        trace_s = time.perf_counter() - t0
    sched = plan.schedule
    limits = MotorLimits(np.full(arm.n_tendons, args.max_speed),
                         np.full(arm.n_tendons, args.max_accel))
    q = sched.positions_steps

    def run():
        return retime(q, limits, tips_mm=sched.tips_mm, speed_mm_s=args.speed_mm_s)

    retime_s = median_time(run, args.repeat, warmup=True)
    timing = run()
    slowed = sum(1 for x in timing.limited_by if x.startswith(("speed_", "accel_")))
    motor = replace(arm.motor, max_speed_steps_s=args.max_speed,
                    max_accel_steps_s2=args.max_accel)
    retimed = replace(arm, motor=motor)
    out = schedule_from_trace(plan.path, retimed, approach=plan.approach,
                              speed_mm_s=args.speed_mm_s)
    with tempfile.TemporaryDirectory() as tmp:
        out.write_csv(Path(tmp) / "s.csv")
        back = read_schedule_csv(Path(tmp) / "s.csv", motor)
        bad = back.motor_check()
    print(f"rows {sched.n_rows}; tracing {trace_s:.2f} s (one run), re-timing "
          f"{1e3 * retime_s:.2f} ms (median of {args.repeat}): ratio "
          f"{retime_s / trace_s:.2e}")
    print(f"constant {args.speed_mm_s:g} mm/s: {sched.duration_s:.2f} s; re-timed "
          f"{timing.time_s[-1]:.2f} s, speed-only lower bound {timing.speed_bound_s:.2f} s "
          f"(ratio {timing.time_s[-1] / timing.speed_bound_s:.4f}); rows slowed by a motor "
          f"{slowed}; rows the CSV check finds unplayable {len(bad)}")


if __name__ == "__main__":
    main()
