#!/usr/bin/env python3
"""Start-up of a command with and without Open MPI's settings of solvers/runtime.py
(SINGLETON_MCA for one rank, SINGLE_NODE_MCA under ``mpiexec -n 2``):
``elastica-petsc control`` to the Fig. 2 target, fresh processes, interleaved,
median of ``--repeat``.  "Without" sets PMI_SIZE=1 for one rank (Open MPI
ignores it; runtime.init then leaves MPI's defaults alone, as under another
launcher) and, under mpiexec, OMPI_MCA_pml=^none and OMPI_MCA_osc=^none (Open
MPI's default choice, excluding nothing, which runtime.init does not
override).  The time of ``MPI_Init`` alone (``from mpi4py import MPI``) is also
shown.

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
MPIEXEC = ["mpiexec", "-n", "2"]
DEFAULTS = {"OMPI_MCA_pml": "^none", "OMPI_MCA_osc": "^none"}


def wall(cmd, env) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    from elastica_petsc.solvers.runtime import SINGLE_NODE_MCA, SINGLETON_MCA

    base = {k: v for k, v in os.environ.items() if k not in SINGLETON_MCA}
    base.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                OMPI_MCA_rmaps_base_oversubscribe="1")
    cases = {   # what: (command, environment with the settings, without)
        "control, one rank": (CONTROL, base, dict(base, PMI_SIZE="1")),
        "MPI_Init, one rank": (MPI_ONLY, dict(base, **SINGLETON_MCA), base),
        "control, mpiexec -n 2": (MPIEXEC + CONTROL, base, dict(base, **DEFAULTS)),
        "MPI_Init, mpiexec -n 2": (MPIEXEC + MPI_ONLY, dict(base, **SINGLE_NODE_MCA), base),
    }
    load = [os.getloadavg()[0]]
    times = {}
    for _ in range(args.repeat):
        for what, (cmd, with_env, without_env) in cases.items():
            times.setdefault((what, 0), []).append(wall(cmd, with_env))
            times.setdefault((what, 1), []).append(wall(cmd, without_env))
    load.append(os.getloadavg()[0])
    print(f"load average {min(load):.2f}-{max(load):.2f}; median of {args.repeat}\n")
    print("| command | with the settings [s] | Open MPI's defaults [s] | saved [s] |")
    print("|---|---|---|---|")
    for what in cases:
        a, b = (statistics.median(times[(what, k)]) for k in (0, 1))
        print(f"| {what} | {a:.3f} | {b:.3f} | {b - a:.3f} |")


if __name__ == "__main__":
    main()
