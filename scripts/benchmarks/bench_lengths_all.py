#!/usr/bin/env python3
"""`lengths --all` at L = (147.1, 472.5) mm in the same process (issue 25):
``ep.length_equilibria(ep.Arm.paper(), lengths_mm=[147.1, 472.5])``, median of
``--repeat`` runs after one warm-up, wall and CPU (process) time, and the
states found (their count and tensions, which must not change).

    .venv/bin/python scripts/benchmarks/bench_lengths_all.py [--repeat 3]
"""
from __future__ import annotations

import argparse
import os
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    import elastica_petsc as ep

    arm = ep.Arm.paper()
    ep.length_equilibria(arm, lengths_mm=[147.1, 472.5])          # warm-up (imports, caches)
    walls, cpus, result = [], [], None
    for _ in range(args.repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        result = ep.length_equilibria(arm, lengths_mm=[147.1, 472.5])
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    print(f"load average {os.getloadavg()[0]:.2f}; {len(result.states)} states; "
          f"wall median {statistics.median(walls):.3f} s (runs {', '.join(f'{t:.3f}' for t in walls)}); "
          f"CPU median {statistics.median(cpus):.3f} s (runs {', '.join(f'{t:.3f}' for t in cpus)})")
    for s in result.states:
        print("  p =", [f"{v:.12f}" for v in s.state.p])


if __name__ == "__main__":
    main()
