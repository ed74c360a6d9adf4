#!/usr/bin/env python3
"""Timing of the SLEPc stability solve (elastica_petsc.solvers.stability), O(N) check.

For the paper's arm (configs/paper.toml) at the Fig. 8 state p = (25.2, 10.8)
(order (2, 1)), prints markdown tables of the median wall time of:
  * one eigen solve (nev smallest eigenvalues of K v = lambda M v, no raw solve),
  * the full ``StabilitySolver.solve`` (adds the raw lambda_min(K) solve, the
    LDL^T inertia count and the asymmetry probes),
  * the 3 lowest eigenfrequencies (shell operator K^{-1} M_phys),
at 180 elements and for N = 1002 .. 100002 (multiples of 3: s_1 = l/3 must be a
node).  The equilibrium solves at large N dominate the run time (~4 min in
total with the default --max-n 100002).
Usage: bench_stability.py [--repeats R] [--max-n N] [PETSc options]
"""
from __future__ import annotations

import argparse
import sys
import time

import petsc4py
from timing import median_time




def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--max-n", type=int, default=100002)
    args, petsc_args = parser.parse_known_args(argv)
    petsc4py.init([sys.argv[0]] + petsc_args)

    import numpy as np
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.equilibrium import EquilibriumSolver
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.solvers.stability import StabilitySolver

    arm = load_config()
    p = (25.2, 10.8)
    sizes = [180] + [n for n in (1002, 3000, 10002, 30000, 100002) if n <= args.max_n]
    rows = []
    for N in sizes:
        disc = Discretisation.from_arm(arm, N)
        with EquilibriumSolver(disc) as eq:
            e = eq.solve(p, order=(2, 1))
        if not e.converged:
            print(f"N = {N}: equilibrium failed: {e.message}", file=sys.stderr)
            continue
        repeats = args.repeats if N <= 10002 else max(3, args.repeats // 4)
        with StabilitySolver(disc) as solver:
            solver.solve(e.u, e.p)
            t_eig = median_time(lambda: solver.solve(e.u, e.p, raw=False), repeats, warmup=True)
            t_full = median_time(lambda: solver.solve(e.u, e.p), repeats, warmup=True)
            t_freq = median_time(lambda: solver.frequencies(e.u, e.p, arm, nev=3),
                                 max(3, repeats // 3), warmup=True)
            r = solver.solve(e.u, e.p)
            f = solver.frequencies(e.u, e.p, arm, nev=3)
        rows.append((N, t_eig, t_full, t_freq, r, f))

    print(f"Stability solve, paper arm at p = {p} (Fig. 8, state 1), median of repeats\n")
    print("| N | eigen solve [ms] | per element [us] | full solve() [ms] | frequencies [ms] "
          "| lambda_1 l^2/B | raw lambda_min(K) / (B/l) | N * raw | f_1 [Hz] | asymmetry |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for N, t_eig, t_full, t_freq, r, f in rows:
        print(f"| {N} | {1e3 * t_eig:.2f} | {1e6 * t_eig / N:.2f} | {1e3 * t_full:.2f} "
              f"| {1e3 * t_freq:.2f} | {r.eigenvalues[0]:.6f} | {r.raw_min:.4e} "
              f"| {N * r.raw_min:.6f} | {f.hz[0]:.5f} | {r.asymmetry:.1e} |")
    big = [(N, t) for N, t, *_ in rows if N >= 1002]
    if len(big) >= 2:
        slope = np.polyfit(np.log([n for n, _ in big]), np.log([t for _, t in big]), 1)[0]
        print(f"\nfitted exponent of eigen-solve time vs N (N >= 1002): {slope:.2f}")


if __name__ == "__main__":
    main()
