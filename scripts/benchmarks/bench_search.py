"""Benchmark of the complete equilibrium searches (issue 12).

    cd scripts && ../.venv/bin/python bench_search.py [--repeats 3] [--elements 180]

The paper's arm; length control at L = (147.1, 472.5) mm and load control at
p = (25.2, 10.8).  Variants, interleaved (one run of each per round), median
of ``--repeats`` rounds, *process* time (the machine is shared, so wall time
measures the neighbours): the default search (curve search around the
deflated continuation and multi-start), the same without the curve search
(``curves=False``: the search before this change), and the curve search
alone (studies.preimage.CurveSearch, no multi-start).  Prints markdown:
time, ratio to the search without curves, and states found.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from elastica_petsc.core.model import load_config
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.lengths import LengthSolver
from elastica_petsc.studies.preimage import CurveSearch, SearchTracer
from elastica_petsc.studies.search import equilibria, length_equilibria, search_box

L_MM = np.array([147.1, 472.5])
P = np.array([25.2, 10.8])


def variants(disc, arm):
    L = L_MM / arm.length_mm
    box = search_box(arm)

    def length(curves):
        with LengthSolver(disc, length_mm=arm.length_mm) as ls, EquilibriumSolver(disc) as eq:
            return len(length_equilibria(ls, L, eq_solver=eq, curves=curves, p_max=box))

    def load(curves):
        with EquilibriumSolver(disc) as eq:
            return len(equilibria(eq, P, curves=curves, p_max=box, length_mm=arm.length_mm))

    def curves_only(target, control):
        with SearchTracer(disc) as tr:
            return len(CurveSearch(tr, target, control=control, p_max=box).run().in_box)

    return {"lengths --all, default (curves + multi-start)": lambda: length(True),
            "lengths --all, without curves (before)": lambda: length(False),
            "length curve search alone": lambda: curves_only(L, "length"),
            "equilibria, default (curves + multi-start)": lambda: load(True),
            "equilibria, without curves (before)": lambda: load(False),
            "load curve search alone": lambda: curves_only(P, "load")}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--elements", type=int, default=180)
    args = ap.parse_args()
    arm = load_config()
    disc = Discretisation.from_arm(arm, args.elements)
    runs = variants(disc, arm)
    times = {k: [] for k in runs}
    found = {}
    for _ in range(args.repeats):
        for name, fn in runs.items():
            t0 = time.process_time()
            found[name] = fn()
            times[name].append(time.process_time() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"| search (N = {args.elements}) | process time (median of {args.repeats}) "
          "| vs. without curves | states found |")
    print("|---|---|---|---|")
    for name in runs:
        base = med["lengths --all, without curves (before)" if name.startswith(("lengths", "length "))
                   else "equilibria, without curves (before)"]
        print(f"| {name} | {med[name]:.2f} s | {med[name] / base:.2f}x | {found[name]} |")


if __name__ == "__main__":
    main()
