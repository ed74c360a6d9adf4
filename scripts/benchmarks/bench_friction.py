"""Benchmark of capstan friction at the guides (issue 24, docs/model.md §27).

    .venv/bin/python scripts/benchmarks/bench_friction.py [--repeats 7]

configs/guided.toml (5 guides per tendon).  For each N (multiples of 12: the guides
every 25 mm on nodes), CPU time per Newton iteration of
- one friction increment (`CapstanSolver.increment`, mu = 0.3) from the slip state at
  p = (20, 10) to p = (21, 10.5), every guide slipping toward its motor;
- the frictionless Newton solve (`EquilibriumSolver.newton`) between the same tensions;
median over repeats, the ratio friction / frictionless, and each one's growth against
the first N (O(N): it grows like N).  Prints a markdown table for BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.friction import CapstanKernel
from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.friction import CapstanSolver
from elastica_petsc.studies.friction import friction_path
from timing import median_time

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "guided.toml"
P_FROM, P_TO = np.array([20.0, 10.0]), np.array([21.0, 10.5])


def per_iteration(n: int, repeats: int) -> tuple[float, float, int, int]:
    disc = Discretisation.from_arm(load_config(CONFIG), n)
    path = friction_path(disc, 0.3, np.vstack((0 * P_FROM, P_FROM)))
    assert path.converged, path.message
    kernel = CapstanKernel.of(disc, 0.3)
    w = path.states[-1]
    start = kernel.start_of(w, P_FROM)
    with CapstanSolver(kernel) as solver, EquilibriumSolver(disc) as plain:
        u0 = plain.solve(P_FROM).u
        _, its_f, _, ok = solver.increment(w, P_TO, start)
        _, its_p, reason = plain.newton(u0, P_TO)
        assert ok and reason.startswith("CONVERGED")
        friction = median_time(lambda: solver.increment(w, P_TO, start), repeats,
                               warmup=True, clock=time.process_time) / its_f
        frictionless = median_time(lambda: plain.newton(u0, P_TO), repeats, warmup=True,
                                   clock=time.process_time) / its_p
    return friction, frictionless, its_f, its_p


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--sizes", type=int, nargs="+", default=[120, 480, 1920])
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}")
    print("| N | friction: ms per Newton iteration (iterations) | frictionless: ms per iteration "
          "(iterations) | ratio | friction / first N | frictionless / first N |")
    print("|---|---|---|---|---|---|")
    first = None
    for n in args.sizes:
        f, p, its_f, its_p = per_iteration(n, args.repeats)
        first = first or (f, p)
        print(f"| {n} | {f * 1e3:.3f} ({its_f}) | {p * 1e3:.3f} ({its_p}) | {f / p:.2f} | "
              f"{f / first[0]:.1f} | {p / first[1]:.1f} |")


if __name__ == "__main__":
    main()
