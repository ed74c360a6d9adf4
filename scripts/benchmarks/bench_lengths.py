"""Benchmark of length control (issue 5: lengths.py).

    .venv/bin/python scripts/benchmarks/bench_lengths.py [--repeats 7] [--elements 180]

1. The paper's arm, Fig. 8 lengths L = (147.1, 472.5) mm: median wall time
   of a warm length-controlled solve (SNES vinewtonrsls from the state at
   L + 0.1 mm), of a cold solve from the straight arm, and of a length
   continuation from the straight arm; plus the same for the stability
   count under length control (bordered LDL^T inertia).
2. The full search on the Fig. 8 case (length control at
   L = (147.1, 472.5) mm, load control at p = (25.2, 10.8)): time, number
   of starts, attempts, distinct equilibria found, and which start/method
   found each (the log of every attempt).
3. (issue 12) The cost of the complete search: the default search (deflated
   continuation + multi-start) against the multi-start alone (steps=0, the
   search before issue 12), interleaved, median of ``--search-repeats`` runs
   each, process time (the machine is shared): ratio of times and states found.
4. (issue 12) The cost of crossing a bifurcation: `solve` on the column of
   tests/test_bifurcation.py (l = 1000 mm, B = 1 N m^2, cable through
   (500, 0) mm, 400 elements) at p = 18.0 (below p_cr = 18.27: no crossing)
   and at p = 18.6 (crossing, both branches followed), median of ``--repeats``.
Prints markdown.
"""
from __future__ import annotations

import argparse
import collections
import statistics
import time

import numpy as np

from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.lengths import LengthSolver
from elastica_petsc.studies.search import equilibria, length_equilibria, tension_starts
from timing import median_time

L_MM = np.array([147.1, 472.5])
P = np.array([25.2, 10.8])


def single_solves(arm, n: int, repeats: int) -> None:
    with LengthSolver.from_arm(arm, n) as ls:
        L = L_MM / arm.length_mm
        near = ls.solve(L + 0.1 / arm.length_mm)
        warm = ls.solve(L, near)
        cold = ls.solve(L)
        cont = ls.follow(L)
        assert warm.converged and cold.converged and cont.converged
        t_warm = median_time(lambda: ls.solve(L, near), 20 * repeats)
        t_cold = median_time(lambda: ls.solve(L), repeats)
        t_cont = median_time(lambda: ls.follow(L), repeats)
        t_inert = median_time(lambda: ls.inertia.negative_eigenvalues(warm.u, warm.p),
                              20 * repeats)
    print(f"| length-controlled solve (N = {n}, L = (147.1, 472.5) mm) | median time "
          "| iterations | steps | p found |")
    print("|---|---|---|---|---|")
    for name, t, s in (("warm (from L + 0.1 mm), incl. both inertia counts", t_warm, warm),
                       ("cold VI Newton from the straight arm", t_cold, cold),
                       ("continuation from the straight arm", t_cont, cont)):
        print(f"| {name} | {t * 1e3:.3f} ms | {s.iterations} | {s.load_steps} | "
              f"({s.p[0]:.4f}, {s.p[1]:.4f}) |")
    print(f"| constrained inertia count alone | {t_inert * 1e3:.3f} ms | | | |")
    print()


def searches(arm, n: int) -> None:
    disc = Discretisation.from_arm(arm, n)
    with EquilibriumSolver(disc) as eqs, LengthSolver(disc, length_mm=arm.length_mm) as ls:
        t0 = time.perf_counter()
        starts = tension_starts(eqs)
        t_starts = time.perf_counter() - t0
        t0 = time.perf_counter()
        res_len = length_equilibria(ls, L_MM / arm.length_mm, starts)
        t_len = time.perf_counter() - t0
        t0 = time.perf_counter()
        res_load = equilibria(eqs, P, starts, length_mm=arm.length_mm)
        t_load = time.perf_counter() - t0
    print(f"| search (N = {n}) | time | starts | attempts | failed | re-found | distinct |")
    print("|---|---|---|---|---|---|---|")
    print(f"| building the starts (load-controlled grid, all orders) | {t_starts:.3f} s | "
          f"{len(starts)} | | | | |")
    for name, t, r in (("length control, L = (147.1, 472.5) mm", t_len, res_len),
                       ("load control, p = (25.2, 10.8)", t_load, res_load)):
        print(f"| {name} | {t:.3f} s | {len(r.starts)} | {r.attempts} | {r.failures} | "
              f"{r.duplicates} | {len(r)} |")
    print()
    for title, r in (("Length control", res_len), ("Load control", res_load)):
        print(f"**{title}** (not a proof that no other equilibrium exists):\n")
        print("| # | p | L [mm] | tip [mm] | unstable modes load / length | first found "
              "| attempts reaching it |")
        print("|---|---|---|---|---|---|---|")
        for k, f in enumerate(r.states, 1):
            s = f.state
            Lmm, tip = s.cable_lengths * arm.length_mm, s.tip * arm.length_mm
            print(f"| {k} | ({s.p[0]:.3f}, {s.p[1]:.3f}) | ({Lmm[0]:.2f}, {Lmm[1]:.2f}) | "
                  f"({tip[0]:.1f}, {tip[1]:.1f}) | {s.unstable_modes} / "
                  f"{s.length_unstable_modes} | {f.start} ({f.method}) | {f.hits} |")
        outcome = collections.Counter((m, o.split(" (")[0].split(" ")[0]) for _, m, o in r.log)
        print("\nattempts by method and outcome: "
              + ", ".join(f"{m} {o}: {c}" for (m, o), c in sorted(outcome.items())) + "\n")


def search_cost(arm, n: int, repeats: int) -> None:
    disc = Discretisation.from_arm(arm, n)
    L = L_MM / arm.length_mm
    times = {"multi-start only (steps=0)": [], "default (deflated continuation + multi-start)": []}
    counts = {}
    with EquilibriumSolver(disc) as eqs, LengthSolver(disc, length_mm=arm.length_mm) as ls:
        for _ in range(repeats):
            for name, steps in zip(times, (0, None)):
                t0 = time.process_time()
                counts[name] = len(length_equilibria(ls, L, eq_solver=eqs, steps=steps))
                times[name].append(time.process_time() - t0)
    print(f"| length control, L = (147.1, 472.5) mm, N = {n} | median process time "
          f"({repeats} runs, interleaved) | states found |")
    print("|---|---|---|")
    med = {k: statistics.median(v) for k, v in times.items()}
    for name in times:
        print(f"| {name} | {med[name]:.2f} s | {counts[name]} |")
    base, new = med.values()
    print(f"\nratio default / multi-start only: {new / base:.2f} (time), "
          f"{list(counts.values())[1]} / {list(counts.values())[0]} (states)\n")


def bifurcation_cost(repeats: int) -> None:
    from elastica_petsc.core.model import Arm, Tendon

    arm = Arm(1000.0, 1.0, (Tendon(1000.0, (500.0, 0.0)),), elements=400)
    with EquilibriumSolver(Discretisation.from_arm(arm)) as solver:
        below, above = solver.solve([18.0]), solver.solve([18.6])
        assert below.converged and not below.bifurcations and above.bifurcations
        t_below = median_time(lambda: solver.solve([18.0]), repeats)
        t_above = median_time(lambda: solver.solve([18.6]), repeats)
    print("| `solve`, cable through (500, 0) mm, N = 400 | median time | tip [mm] |")
    print("|---|---|---|")
    print(f"| p = 18.0 (straight, stable) | {t_below * 1e3:.1f} ms | "
          f"({below.tip[0] * 1e3:.3f}, {below.tip[1] * 1e3:.3f}) |")
    print(f"| p = 18.6 (bifurcation at {above.bifurcations[0].p_critical[0]:.4f} crossed, "
          f"{above.bifurcations[0].side} branch) | {t_above * 1e3:.1f} ms | "
          f"({above.tip[0] * 1e3:.3f}, {above.tip[1] * 1e3:.3f}) |")
    print(f"\nratio crossing / no crossing: {t_above / t_below:.1f}\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--search-repeats", type=int, default=3)
    ap.add_argument("--only-search-cost", action="store_true")
    args = ap.parse_args()
    arm = load_config()
    if not args.only_search_cost:
        single_solves(arm, args.elements, args.repeats)
        searches(arm, args.elements)
    search_cost(arm, args.elements, args.search_repeats)
    bifurcation_cost(args.repeats)


if __name__ == "__main__":
    main()
