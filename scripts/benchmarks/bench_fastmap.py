#!/usr/bin/env python3
"""The boundary-filled workspace map (the default sampler) of this tree against
another source tree (e.g. a ``git worktree`` of the commit before a change):
wall and CPU time, ratios and agreement, in one run.

Runs ``elastica-petsc workspace --spacing S --elements 180`` (S = 11.67 mm: the
Fig. 4 map, 4202 targets; S = 25 mm: 921 targets) with ``PYTHONPATH`` set to
each tree, on 1 and 2 ranks, all interleaved, ``--repeat`` times, and prints a
markdown table: median wall and CPU (user + sys of the command and its
children) seconds, the ratios before / after and the 1 -> 2 rank speed-up of
each tree (from the medians of this run), the load average during the runs,
and the agreement of the two trees' maps: every sample's class, the largest
tension difference over reached samples, the largest relative difference of
lambda_min and lambda_min_raw.

Usage: bench_fastmap.py --before TREE [--spacings 11.67 25] [--ranks 1 2]
                        [--repeat 3] [--dir DIR]
The other tree needs the compiled kernels (copy elastica_petsc/core/fem_kernels*.so).
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def run(tree: Path, spacing: float, ranks: int, out: Path) -> tuple[float, float]:
    """(wall, cpu) seconds of one map made with the sources of ``tree``."""
    cli = [sys.executable, "-m", "elastica_petsc.cli", "workspace", "--spacing", str(spacing),
           "--elements", "180", "--out", str(out), "--overwrite", "--quiet"]
    if ranks > 1:
        cli = [shutil.which("mpiexec") or "mpiexec", "-n", str(ranks), "--oversubscribe", *cli]
    env = dict(os.environ, PYTHONPATH=str(tree), OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cli, cwd=tree, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cli)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def agreement(a_path: Path, b_path: Path) -> str:
    with h5py.File(a_path, "r") as fa, h5py.File(b_path, "r") as fb:
        a, b = fa["samples"], fb["samples"]
        status = a["status"][()]
        same = int(np.count_nonzero(status == b["status"][()]))
        both = (status == 1) & (b["status"][()] == 1)
        dp = float(np.max(np.abs(a["tensions"][()][both] - b["tensions"][()][both]), initial=0))
        rel = [float(np.max(np.abs(a[k][()][both] - b[k][()][both]) / np.abs(a[k][()][both]),
                            initial=0)) for k in ("lambda_min", "lambda_min_raw")]
    return (f"{same} of {len(status)} classes equal; reached {int(both.sum())}: max |dp| {dp:.2g}, "
            f"max rel. d lambda_min {rel[0]:.2g}, d lambda_min_raw {rel[1]:.2g}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="the other source tree")
    parser.add_argument("--spacings", type=float, nargs="+", default=[11.67, 25.0])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--dir", help="keep the HDF5 files here (default: a temporary folder)")
    args = parser.parse_args(argv)
    folder = Path(args.dir) if args.dir else Path(tempfile.mkdtemp(prefix="bench_fastmap_"))
    folder.mkdir(parents=True, exist_ok=True)
    trees = {"before": Path(args.before).resolve(), "after": ROOT}
    keys = [(s, r, t) for s in args.spacings for r in args.ranks for t in trees]
    times = {k: [] for k in keys}
    loads = []
    for _ in range(args.repeat):
        for key in keys:
            s, r, t = key
            times[key].append(run(trees[t], s, r, folder / f"{t}_{s}_{r}.h5"))
            loads.append(os.getloadavg()[0])
    med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
           for k, v in times.items()}
    print(f"load average (1 min) during the runs: {min(loads):.2f} .. {max(loads):.2f}\n")
    print("| spacing mm | ranks | before wall s | after wall s | wall ratio | "
          "before CPU s | after CPU s | CPU ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for s in args.spacings:
        for r in args.ranks:
            (bw, bc), (aw, ac) = med[(s, r, "before")], med[(s, r, "after")]
            print(f"| {s:g} | {r} | {bw:.2f} | {aw:.2f} | {bw / aw:.2f}x | {bc:.2f} | {ac:.2f} "
                  f"| {bc / ac:.2f}x |")
    if 1 in args.ranks and 2 in args.ranks:
        print()
        for s in args.spacings:
            for t in trees:
                print(f"- {s:g} mm, {t}: 1 -> 2 ranks wall speed-up "
                      f"{med[(s, 1, t)][0] / med[(s, 2, t)][0]:.2f}")
    print()
    for s in args.spacings:
        for r in args.ranks:
            print(f"- {s:g} mm, {r} rank(s), before vs after: "
                  + agreement(folder / f"before_{s}_{r}.h5", folder / f"after_{s}_{r}.h5"))


if __name__ == "__main__":
    main()
