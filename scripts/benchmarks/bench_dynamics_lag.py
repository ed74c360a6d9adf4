"""The PC kept while the step and the cables' branches hold, under a motor schedule (issue 22).

Runs `simulate --schedule CSV` (the schedule of `trace --shape paper-triangle --schedule`)
over its first DURATION seconds twice per repeat, interleaved: with the PC refreshed at
every Newton iteration (``-sim_snes_lag_jacobian 1``, the code before) and with the
default (kept for up to 10 iterations while the shifts, the stage and the cables'
branches are unchanged, docs/model.md §16.4).  Prints the median CPU per step, Newton
iterations per step, steps, switches and the final tip of each, and their ratio.

    python scripts/benchmarks/bench_dynamics_lag.py S.csv [--elements 180]
        [--duration-s 0.5] [--repeats 3]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from petsc4py import PETSc

from elastica_petsc.core.model import Arm
from elastica_petsc.solvers.dynamics import Trajectory
from elastica_petsc.studies.simulate import simulate


def run(csv, elements, duration_s, lag):
    """(CPU s, trajectory, result) of one run with ``-sim_snes_lag_jacobian lag``."""
    opts = PETSc.Options()
    if lag is not None:
        opts["sim_snes_lag_jacobian"] = lag
    traj = Trajectory()
    try:
        start = time.process_time()
        res = simulate(Arm.paper(), elements=elements, schedule_csv=csv,
                       duration_s=duration_s, trajectory=traj)
        cpu = time.process_time() - start
    finally:
        if lag is not None:
            opts.delValue("sim_snes_lag_jacobian")
    return cpu, traj, res


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--duration-s", type=float, default=0.5)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cases = {"every iteration (lag 1)": 1, "kept (default lag 10)": None}
    cpu = {name: [] for name in cases}
    last = {}
    for _ in range(args.repeats):
        for name, lag in cases.items():
            c, traj, res = run(args.csv, args.elements, args.duration_s, lag)
            cpu[name].append(c / traj.steps)
            last[name] = (c, traj, res)
    print(f"N = {args.elements}, first {args.duration_s} s of the schedule, "
          f"median of {args.repeats}")
    for name in cases:
        c, traj, res = last[name]
        print(f"{name:>26}: {1e3 * statistics.median(cpu[name]):.3f} ms CPU/step, "
              f"{traj.newton_iterations / traj.steps:.2f} Newton it./step, {traj.steps} steps, "
              f"{traj.rejected} rejected, {len(traj.events)} switches, last run {c:.2f} s CPU, "
              f"tip {res.x_mm[-1, -1, 0]:.9f} {res.x_mm[-1, -1, 1]:.9f} mm")
    (old, new), tips = cases, [last[name][2].x_mm[-1, -1] for name in cases]
    print(f"ratio (lag 1 / kept): {statistics.median(cpu[old]) / statistics.median(cpu[new]):.2f}; "
          f"|tip difference| {np.linalg.norm(tips[0] - tips[1]):.3g} mm; same events: "
          f"{last[old][1].events == last[new][1].events}")


if __name__ == "__main__":
    main()
