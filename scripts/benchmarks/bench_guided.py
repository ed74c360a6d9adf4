"""Benchmark of cables through guides (issue 24) against the paper's arm.

    .venv/bin/python scripts/benchmarks/bench_guided.py [--repeats 7] [--rounds 5]

1. Warm forward solve (from the equilibrium at a nearby load, p + 0.1), both at
   N = 180: the paper's arm at p = (25.2, 10.8) against configs/guided.toml (5 guides
   per tendon, 12 arm points) at p = (40, 30), and the paper's arm in a vertical
   plane (configs/paper_vertical.toml).  Rounds interleave the arms (the machine is
   shared); reported: the median over rounds of each round's median, and the ratio
   of the medians.  Target: guided / paper <= 1.5.
2. Time per Newton iteration of the guided robot against N (a multiple of 12, so
   that the guides every 25 mm fall on nodes), beside the paper's arm at the same N:
   one Newton solve from a perturbed state, divided by its iterations.  O(N): the
   ratio to the first size grows like N.
Prints markdown tables for BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import statistics
from pathlib import Path

import numpy as np

from elastica_petsc.core.model import load_config
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from timing import median_time

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
ARMS = {  # name: (config, tensions)
    "paper (no guides)": (CONFIGS / "paper.toml", np.array([25.2, 10.8])),
    "guided.toml (5 guides per tendon)": (CONFIGS / "guided.toml", np.array([40.0, 30.0])),
    "paper_vertical.toml (weight)": (CONFIGS / "paper_vertical.toml", np.array([25.2, 10.8])),
}


def warm_solves(repeats: int, rounds: int) -> None:
    solvers, cases = {}, {}
    for name, (path, p) in ARMS.items():
        disc = Discretisation.from_arm(load_config(path), 180)
        solver = EquilibriumSolver(disc)
        near = solver.solve(p + 0.1)
        warm = solver.solve(p, start=near)
        assert near.converged and warm.converged, name
        solvers[name], cases[name] = solver, (p, near, warm, disc)
    times = {name: [] for name in ARMS}
    for _ in range(rounds):
        for name, solver in solvers.items():
            p, near, _, _ = cases[name]
            times[name].append(median_time(lambda: solver.solve(p, start=near), 20 * repeats))
    base = statistics.median(times["paper (no guides)"])
    print("| warm solve, N = 180 | border unknowns | median of round medians | rounds [ms] "
          "| Newton iterations | ratio to the paper's arm |")
    print("|---|---|---|---|---|---|")
    for name, t in times.items():
        _, _, warm, disc = cases[name]
        med = statistics.median(t)
        print(f"| {name} | {disc.size - disc.n_elements} | {med * 1e3:.3f} ms | "
              + ", ".join(f"{v * 1e3:.3f}" for v in t)
              + f" | {warm.iterations} | {med / base:.2f} |")
    for solver in solvers.values():
        solver.destroy()


def per_iteration(name: str, n: int, repeats: int) -> tuple[float, int]:
    """Median time of one Newton solve from a perturbed equilibrium, and its iterations."""
    path, p = ARMS[name]
    disc = Discretisation.from_arm(load_config(path), n)
    with EquilibriumSolver(disc) as solver:
        eq = solver.solve(p)
        assert eq.converged, name
        start = eq.u.copy()
        start[: disc.n_elements] *= 0.98
        its = []

        def newton():
            _, k, _ = solver.newton(start, p)
            its.append(k)
        return median_time(newton, repeats), its[-1]


def scaling(sizes, repeats: int) -> None:
    """Per Newton iteration against N, the guided robot beside the paper's arm (same N)."""
    rows = []
    for n in sizes:
        tg, kg = per_iteration("guided.toml (5 guides per tendon)", n, repeats)
        tp, kp = per_iteration("paper (no guides)", n, repeats)
        rows.append((n, tg / kg, kg, tp / kp, kp))
    print("| N | guided: time / iteration | iterations | paper: time / iteration | iterations "
          "| guided / paper | guided ratio to first | N ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for n, g, kg, pp, kp in rows:
        print(f"| {n} | {g * 1e3:.3f} ms | {kg} | {pp * 1e3:.3f} ms | {kp} | {g / pp:.2f} "
              f"| {g / rows[0][1]:.2f} | {n / rows[0][0]:.1f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--sizes", type=int, nargs="+",
                        default=[1200, 2400, 6000, 12000, 24000, 48000])
    args = parser.parse_args()
    warm_solves(args.repeats, args.rounds)
    print()
    scaling(args.sizes, args.repeats)


if __name__ == "__main__":
    main()
