#!/usr/bin/env python3
"""Start-up of a one-rank command with and without Open MPI's singleton settings
(solvers/runtime.py: SINGLETON_MCA): ``elastica-petsc control`` to the Fig. 2
target, fresh processes, interleaved, median of ``--repeat``.  "Without" sets
PMI_SIZE=1, which Open MPI ignores and which makes runtime.init leave MPI's
defaults alone (as under a launcher); the time of ``MPI_Init`` alone is also
shown (``from mpi4py import MPI`` with and without the settings).

    .venv/bin/python scripts/benchmarks/bench_startup.py [--repeat 7]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

CONTROL = [sys.executable, "-m", "elastica_petsc.cli", "control", "--target", "535.8", "222.6",
           "--quiet"]
MPI_ONLY = [sys.executable, "-c", "from mpi4py import MPI"]


def wall(cmd, env) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    from elastica_petsc.solvers.runtime import SINGLETON_MCA

    base = {k: v for k, v in os.environ.items() if k not in SINGLETON_MCA}
    envs = {"with the singleton settings": base,
            "without (Open MPI's defaults)": dict(base, PMI_SIZE="1")}
    mpi_envs = {"with the singleton settings": dict(base, **SINGLETON_MCA),
                "without (Open MPI's defaults)": base}
    load = [os.getloadavg()[0]]
    times = {}
    for _ in range(args.repeat):
        for name in envs:
            times.setdefault(("control", name), []).append(wall(CONTROL, envs[name]))
            times.setdefault(("MPI_Init", name), []).append(wall(MPI_ONLY, mpi_envs[name]))
    load.append(os.getloadavg()[0])
    print(f"load average {min(load):.2f}-{max(load):.2f}; median of {args.repeat}\n")
    print("| command | with the singleton settings [s] | without [s] | saved [s] |")
    print("|---|---|---|---|")
    for what in ("control", "MPI_Init"):
        a, b = (statistics.median(times[(what, n)]) for n in envs)
        print(f"| {what} | {a:.3f} | {b:.3f} | {b - a:.3f} |")


if __name__ == "__main__":
    main()
