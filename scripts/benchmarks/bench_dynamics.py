"""Cost per time step of `simulate` against the number of elements (issue 22: O(N)).

Runs a fixed number of equal steps of the paper's arm released from the equilibrium at
P = (0, 0.05) N (the free vibration of the issue's first command), on one core, and prints
the median wall time per step over repeated runs, per element and relative to N = 180,
and the real-time factor at 180 elements; then, at 180 elements, the step time with the
PC refreshed at every Newton iteration (lag_jacobian=1) against the default (10, persisting
across steps), in the same run.

    python scripts/benchmarks/bench_dynamics.py [--repeats 3] [--steps 40]
"""
from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from elastica_petsc.core.drive import TensionDrive
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import Arm
from elastica_petsc.solvers.dynamics import DynamicsSolver
from elastica_petsc.solvers.equilibrium import solve_equilibrium
from elastica_petsc.studies.simulate import build_inertia, time_scale_s

SIZES = (180, 720, 2880, 11520, 20160)


def per_step(arm, N, steps, repeats, dt_s, lag_jacobian=10):
    disc = Discretisation.from_arm(arm, N)
    tau = time_scale_s(arm)
    eq = solve_equilibrium(disc, arm.tensions_from_N([0.0, 0.05]))
    inertia = build_inertia(arm, disc)
    times = []
    for _ in range(repeats):
        sim = DynamicsSolver(disc, inertia, dt0=dt_s / tau, adaptive=False,
                             lag_jacobian=lag_jacobian)
        start = time.perf_counter()
        tr = sim.run(eq.theta, np.zeros(N), np.zeros(2), TensionDrive.constant([0.0, 0.0]),
                     None, steps * dt_s / tau)
        times.append((time.perf_counter() - start) / tr.steps)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=40)
    args = ap.parse_args()
    arm = Arm.paper()
    dt_s = 1.0 / (1.83 * 200)          # the default: first period / 200
    base = None
    print(f"{'N':>6} {'ms/step':>9} {'us/step/element':>16} {'ratio to N=180':>15}")
    for N in SIZES:
        t = per_step(arm, N, args.steps, args.repeats, dt_s)
        base = base or t
        print(f"{N:>6} {1e3 * t:>9.3f} {1e6 * t / N:>16.3f} {t / base:>15.2f}")
        if N == 180:
            print(f"       real-time factor at 180 elements: {dt_s / t:.3g} "
                  f"({1 / t:.0f} steps/s, {1 / dt_s:.0f} steps per simulated second)")
    fresh = per_step(arm, 180, args.steps, args.repeats, dt_s, lag_jacobian=1)
    lagged = per_step(arm, 180, args.steps, args.repeats, dt_s)
    print(f"N = 180: {1e3 * fresh:.3f} ms/step with a fresh PC every Newton iteration, "
          f"{1e3 * lagged:.3f} with the default lag (ratio {fresh / lagged:.2f})")


if __name__ == "__main__":
    main()
