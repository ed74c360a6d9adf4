#!/usr/bin/env python3
"""Wall time of the commands issue 25 puts a number on, as a user runs them
(fresh process each time: start-up, tracing and writing included).

    .venv/bin/python scripts/benchmarks/bench_commands.py [--repeat 3] [--ranks 1 2]

Median wall time over ``--repeat`` runs (interleaved), the load average
before and after, and each command's exit status (a run that fails is
reported, not timed).  Prints a markdown table for BENCHMARKS.md.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLI = [sys.executable, "-m", "elastica_petsc.cli"]
MPI_ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")


def commands(tmp: Path, ranks) -> dict[str, list[str]]:
    out = {
        "boundary (paper's arm)": CLI + ["boundary", "--quiet"],
        "design --objective area (both routes)": CLI + ["design", "--vary", "tendon1.route",
                                                   "tendon2.route", "--objective", "area",
                                                   "--quiet"],
        "lengths --all L = (147.1, 472.5) mm": CLI + ["lengths", "--lengths", "147.1", "472.5",
                                                      "--all", "--quiet"],
        "control (387.4, -261.1) mm, a hole of W_0": CLI + ["control", "--target", "387.4",
                                                           "-261.1", "--quiet"],
        "control, Fig. 2 target (535.8, 222.6) mm": CLI + ["control", "--target", "535.8",
                                                            "222.6", "--quiet"],
    }
    for spacing, name in ((25.0, "25 mm map"), (11.67, "Fig. 4 map (4202 targets)")):
        for n in ranks:
            cmd = CLI + ["workspace", "--spacing", str(spacing), "--elements", "180", "--out",
                         str(tmp / f"w{spacing}_{n}.h5"), "--overwrite", "--quiet"]
            if n > 1:
                cmd = ["mpiexec", "-n", str(n)] + cmd
            out[f"workspace, {name}, {n} rank(s)"] = cmd
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    load_before = os.getloadavg()[0]
    times: dict[str, list[float]] = {}
    status: dict[str, int] = {}
    with tempfile.TemporaryDirectory() as tmp:
        cmds = commands(Path(tmp), args.ranks)
        for _ in range(args.repeat):
            for name, cmd in cmds.items():
                t0 = time.perf_counter()
                done = subprocess.run(cmd, env=MPI_ENV, cwd=tmp, capture_output=True, text=True)
                seconds = time.perf_counter() - t0
                status[name] = done.returncode
                times.setdefault(name, []).append(seconds)
    print(f"load average before {load_before:.2f}, after {os.getloadavg()[0]:.2f}; "
          f"median of {args.repeat} fresh processes\n")
    print("| command | median wall [s] | runs [s] | exit status |")
    print("|---|---|---|---|")
    for name, ts in times.items():
        runs = ", ".join(f"{t:.2f}" for t in ts)
        print(f"| {name} | {statistics.median(ts):.2f} | {runs} | {status[name]} |")


if __name__ == "__main__":
    main()
