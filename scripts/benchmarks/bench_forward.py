"""Benchmark of the forward (load-controlled) solve, issue "Forward statics".

    .venv/bin/python scripts/benchmarks/bench_forward.py [--repeats 7]

1. The paper's arm at 180 elements, p = (25.2, 10.8): median wall time of a
   warm-started solve (from the equilibrium at a nearby load, p + 0.1) and of
   a cold solve from the straight arm (proportional load stepping).
2. Time per Newton iteration against the element count (N a multiple of 3 so
   that s_1 = l/3 falls on a node): one Newton solve from a perturbed state,
   time divided by the iterations.  Cost must grow linearly:
   t(20001)/t(2001) <= 11 is the acceptance bound (issue 25; CPU time beside wall time).
Prints markdown tables for BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.core.fem import Discretisation
from timing import median_time

P = np.array([25.2, 10.8])




def paper_arm(repeats: int) -> None:
    arm = load_config()
    with EquilibriumSolver(Discretisation.from_arm(arm)) as solver:
        near = solver.solve(P + 0.1)
        warm = solver.solve(P, start=near)
        cold = solver.solve(P)
        assert warm.converged and cold.converged
        t_warm = median_time(lambda: solver.solve(P, start=near), 20 * repeats)
        t_cold = median_time(lambda: solver.solve(P), repeats)
    print("| solve (N = 180, p = (25.2, 10.8)) | median time | Newton iterations | load steps |")
    print("|---|---|---|---|")
    print(f"| warm (from p + 0.1) | {t_warm * 1e3:.3f} ms | {warm.iterations} | {warm.load_steps} |")
    print(f"| cold (straight arm) | {t_cold * 1e3:.3f} ms | {cold.iterations} | {cold.load_steps} |")


def scaling(sizes, repeats: int) -> None:
    arm = load_config()
    rows = []
    for n in sizes:
        disc = Discretisation.from_arm(arm, n)
        with EquilibriumSolver(disc) as solver:
            eq = solver.solve(P)
            start = eq.u.copy()
            start[: disc.n_elements] *= 0.98           # a nearby state: a few Newton steps
            its = []

            def newton():
                _, k, _ = solver.newton(start, P)
                its.append(k)
            t = median_time(newton, repeats)
            cpu = median_time(newton, repeats, clock=time.process_time)
        rows.append((n, t, its[-1], t / its[-1], cpu / its[-1]))
    print("| N | Newton solve | iterations | time / iteration | ratio to first | "
          "CPU time / iteration | ratio to first |")
    print("|---|---|---|---|---|---|---|")
    for n, t, k, per, cpu in rows:
        print(f"| {n} | {t * 1e3:.2f} ms | {k} | {per * 1e3:.3f} ms | {per / rows[0][3]:.2f} | "
              f"{cpu * 1e3:.3f} ms | {cpu / rows[0][4]:.2f} |")
    per = {n: (r, c) for n, _, _, r, c in rows}
    if 2001 in per and 20001 in per:
        print(f"\nt(20001)/t(2001) per iteration = {per[20001][0] / per[2001][0]:.2f} wall, "
              f"{per[20001][1] / per[2001][1]:.2f} CPU (bound 11)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--sizes", type=int, nargs="+",
                        default=[1002, 2001, 5001, 10002, 20001, 50001, 100002])
    args = parser.parse_args()
    paper_arm(args.repeats)
    print()
    scaling(args.sizes, args.repeats)


if __name__ == "__main__":
    main()
