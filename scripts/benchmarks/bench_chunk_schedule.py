#!/usr/bin/env python3
"""Does the order in which a map's chunks are handed out matter?  (Issue 25:
the 1 -> 2 rank speed-up of the Fig. 4 map.)

    .venv/bin/python scripts/benchmarks/bench_chunk_schedule.py [--spacing 11.67] [--repeat 2]

Measures every chunk's time of the boundary-filled map in one process (the
trace and the seed library built first, as on two ranks; each chunk timed
``--repeat`` times, the median kept), then replays the chunk engine's dynamic
hand-out (studies/chunks.py: the next chunk to the first rank free) for 2 and
3 ranks with these costs, in three orders: the grid's (what the engine does),
by a cost predicted from the traced boundary before any solve (longest
predicted first: N = 1 targets weight 1, N >= 2 or undecided targets weight
``--search-weight``, proven ones 0), and by the measured costs (the best a
prediction could do).  Prints the makespan, the imbalance (last rank's end
minus the first's) and the ideal (total / ranks), and how well the prediction
correlates with the measured costs.
"""
from __future__ import annotations

import argparse
import heapq
import os
import statistics
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, HERE)


def makespan(costs: np.ndarray, order: np.ndarray, ranks: int) -> tuple[float, float]:
    """(makespan, imbalance) of the dynamic hand-out of ``order`` to ``ranks`` ranks."""
    free = [(0.0, r) for r in range(ranks)]
    for chunk in order:
        t, r = heapq.heappop(free)
        heapq.heappush(free, (t + costs[chunk], r))
    ends = sorted(t for t, _ in free)
    return ends[-1], ends[-1] - ends[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spacing", type=float, default=11.67)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--search-weight", type=float, default=13.0)
    args = ap.parse_args()

    from elastica_petsc.solvers import runtime
    runtime.init("bench", [])
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.reach import beyond_reach
    from elastica_petsc.studies.workspace.fill import BoundaryFillSampler
    from elastica_petsc.studies.workspace.grids import make_grid

    load = [os.getloadavg()[0]]
    arm = load_config()
    disc = Discretisation.from_arm(arm, 180)
    grid = make_grid(arm, disc, "targets", args.spacing, None, 2.0, 40.0, 24, "half-disc")
    sampler = BoundaryFillSampler(arm, disc)
    boundary = sampler.boundary()
    sampler.library.seeds()
    seconds = [[] for _ in grid.chunks]
    for _ in range(args.repeat):
        for k, chunk in enumerate(grid.chunks):
            t0 = time.perf_counter()
            sampler.solve_chunk(grid.points[chunk], lambda: False)
            seconds[k].append(time.perf_counter() - t0)
    costs = np.array([statistics.median(s) for s in seconds])
    predicted = []
    for chunk in grid.chunks:
        points = grid.points[chunk]
        predicted.append(sum(0.0 if beyond_reach(p / arm.length_mm) or n == 0
                             else 1.0 if n == 1 else args.search_weight
                             for p, n in zip(points, boundary.preimage_counts(points))))
    predicted = np.array(predicted)
    sampler.destroy()
    load.append(os.getloadavg()[0])
    print(f"load average {min(load):.2f}-{max(load):.2f}; {len(costs)} chunks, "
          f"total {costs.sum():.3f} s, largest {costs.max():.3f} s, last five in grid order "
          + ", ".join(f"{c:.3f}" for c in costs[-5:]) + " s")
    print(f"correlation of the predicted and measured chunk costs: "
          f"{np.corrcoef(predicted, costs)[0, 1]:.2f}\n")
    print("| order | ranks | makespan [s] | imbalance [s] | ideal [s] |")
    print("|---|---|---|---|---|")
    orders = {"grid (the engine's)": np.arange(len(costs)),
              "predicted cost, largest first": np.argsort(-predicted, kind="stable"),
              "measured cost, largest first": np.argsort(-costs, kind="stable")}
    for name, order in orders.items():
        for ranks in (2, 3):
            span, imbalance = makespan(costs, order, ranks)
            print(f"| {name} | {ranks} | {span:.3f} | {imbalance:.4f} | "
                  f"{costs.sum() / ranks:.3f} |")


if __name__ == "__main__":
    main()
