#!/usr/bin/env python3
"""How far the motor-aware re-timing (core/motion.py ``retime``) is from the
time-optimal schedule under the same limits (issue 26 must-show: "within 10 %
of the time-optimal bound"), per case and tip speed.

For a traced schedule (its rows' motor positions q_k in microsteps and tips),
three numbers bracket the optimum T* of the discrete problem that ``check``
enforces (rates dq_k / d_k within V_i, finite-difference accelerations between
rows within A_i, from rest to rest, tip speed within v):

* the speed-only lower bound  sum_k max(|dtip_k| / v, max_i |dq_ik| / V_i)
  (what tests/test_motion.py compares with; it ignores A);
* a run lower bound: each motor's positions split into monotone runs (its rate
  passes through zero between runs); run r of motor i covering D steps takes
  at least the rest-to-rest trapezoid time D / V + V / A (2 sqrt(D / A) if
  D < V^2 / A), and at least the speed-only bound of its rows; summed over the
  runs, the largest over the motors (a continuous-time argument: a discrete
  schedule may beat it by up to about one row's time per run);
* an upper bound: a feasible schedule found by SLSQP (scipy) started from the
  re-timed durations, minimising sum_k d_k under the same constraints
  (feasible to the printed violation, not a proven optimum).

Usage: python scripts/studies/schedule_optimality.py [--speeds 50 200 500] [--step 4]
       [--elements 30]
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np


def run_bound(dq: np.ndarray, rows_s: np.ndarray, V: float, A: float) -> float:
    """The run lower bound of one motor (module docstring)."""
    def trapezoid(D):
        return D / V + V / A if D >= V * V / A else 2.0 * np.sqrt(D / A)

    runs, start, sign = [], 0, 0.0
    for k, d in enumerate(dq):
        s = np.sign(d)
        if s != 0 and sign != 0 and s != sign:
            runs.append((start, k))
            start = k
        if s != 0:
            sign = s
    runs.append((start, len(dq)))
    return float(sum(max(trapezoid(np.sum(np.abs(dq[a:b]))), np.sum(rows_s[a:b]))
                     for a, b in runs))


def polished(q, tips, limits, speed, durations):
    """(total [s], largest constraint violation [steps/s]) of SLSQP's schedule."""
    from scipy.optimize import minimize

    dq = np.diff(q, axis=0)
    dtip = np.linalg.norm(np.diff(tips, axis=0), axis=1)
    V, A = limits.speed_steps_s, limits.accel_steps_s2
    lowest = np.maximum(dtip / speed, np.max(np.abs(dq) / V, axis=1))

    def accel(d):
        rates = np.vstack([np.zeros(q.shape[1]), dq / d[:, None], np.zeros(q.shape[1])])
        padded = np.concatenate(([0.0], d, [0.0]))
        change = np.diff(rates, axis=0)
        cap = A[None, :] * 0.5 * (padded[:-1] + padded[1:])[:, None]
        return np.concatenate([(cap - change).ravel(), (cap + change).ravel()])

    res = minimize(lambda d: d.sum(), durations, jac=lambda d: np.ones_like(d),
                   method="SLSQP", bounds=[(b, None) for b in lowest],
                   constraints=[{"type": "ineq", "fun": accel}],
                   options={"maxiter": 300, "ftol": 1e-10})
    return float(res.x.sum()), float(max(0.0, -accel(res.x).min()))


USER_TOML = """
[arm]
length_mm = 450.0
bending_stiffness_Nm2 = 0.15
[[tendon]]
attach_mm = 150.0
route_mm = [40.0, -70.0]
[[tendon]]
attach_mm = 450.0
route_mm = [-20.0, 60.0]
[motor]
spool_radius_mm = 20.0
microsteps = 8
max_speed_steps_s = [2500.0, 1200.0]
max_accel_steps_s2 = [8000.0, 3000.0]
"""


def cases():
    """The two cases of tests/test_motion.py: the paper's arm (motors limited to
    1500 microsteps/s and 5000 microsteps/s^2) on the Fig. 3a triangle, and an
    asymmetric user arm with different motors on a circle."""
    import tempfile
    from pathlib import Path

    from elastica_petsc.core.model import load_config
    from elastica_petsc.studies.trace import circle, paper_triangle

    arm = load_config()
    paper = replace(arm, motor=replace(arm.motor, max_speed_steps_s=1500.0,
                                       max_accel_steps_s2=5000.0))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "user.toml"
        path.write_text(USER_TOML)
        user = load_config(path)
    return {"paper-triangle": (paper, paper_triangle((400.0, 200.0))),
            "user-circle": (user, circle((300.0, 150.0), 60.0))}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", type=float, nargs="+", default=[50.0, 200.0, 500.0])
    ap.add_argument("--step", type=float, default=4.0)
    ap.add_argument("--elements", type=int, default=30)
    args = ap.parse_args(argv)
    from elastica_petsc.core.motion import MotorLimits, check
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.studies.schedule import trace_schedule
    from elastica_petsc.studies.trace import densify

    print("| case | tip speed [mm/s] | rows | speed-only bound | run bound | re-timed | SLSQP "
          "(feasible) | re-timed / best lower bound | re-timed / SLSQP |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, (arm, path) in cases().items():
        limits = MotorLimits.of(arm.motor, arm.n_tendons)
        for speed in args.speeds:
            with TipController(arm, n_elements=args.elements) as controller:
                plan = trace_schedule(controller, densify(path, args.step), step_mm=args.step,
                                      speed_mm_s=speed)
            s = plan.schedule
            q, tips, d = s.positions_steps, s.tips_mm, np.diff(s.time_s)
            assert not check(q, d, limits)
            dq = np.diff(q, axis=0)
            rows_s = np.maximum(np.linalg.norm(np.diff(tips, axis=0), axis=1) / speed,
                                np.max(np.abs(dq) / limits.speed_steps_s, axis=1))
            runs = max(run_bound(dq[:, i], rows_s, limits.speed_steps_s[i],
                                 limits.accel_steps_s2[i]) for i in range(q.shape[1]))
            t0 = time.perf_counter()
            best, violation = polished(q, tips, limits, speed, d)
            lower = max(rows_s.sum(), runs)
            print(f"| {name} | {speed:g} | {len(q)} | {rows_s.sum():.3f} s | {runs:.3f} s | "
                  f"{d.sum():.3f} s | {best:.3f} s (violation {violation:.1e}, "
                  f"{time.perf_counter() - t0:.0f} s) | {d.sum() / lower:.3f} | "
                  f"{d.sum() / best:.3f} |", flush=True)


if __name__ == "__main__":
    main()
