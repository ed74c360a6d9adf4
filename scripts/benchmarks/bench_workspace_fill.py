#!/usr/bin/env python3
"""The boundary-filled workspace map (sampler boundary-fill, issue 25) against
the global-search sampler: wall times, ratios and agreement, in one run.

Runs ``elastica-petsc workspace --spacing S --elements 180 --sampler X`` (the
paper's half-disc; S = 11.67 mm: the Fig. 4 map, 4202 targets; S = 25 mm: 921
targets) for each spacing, each sampler and each rank count, all interleaved,
``--repeat`` times (``--global-repeat`` for the slow global-search runs), and
prints markdown tables: the median wall time of the command and of the
sampling alone (the file's /timing seconds_wall), the ratio global-search /
boundary-fill and the 1 -> 2 rank speed-up (each from the medians of this one
run), the load average while the runs ran, and the agreement: every sample's
class, and the largest tension and tip differences over the reached samples.

Usage: bench_workspace_fill.py [--spacings 11.67 25] [--ranks 1 2] [--repeat 3]
                               [--global-repeat 1] [--dir DIR]
"""
from __future__ import annotations

import argparse
import os
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


def run(spacing: float, sampler: str, ranks: int, out: Path, elements: int) -> float:
    cli = [sys.executable, "-m", "elastica_petsc.cli", "workspace", "--spacing", str(spacing),
           "--elements", str(elements), "--sampler", sampler, "--out", str(out), "--overwrite",
           "--quiet"]
    if ranks > 1:
        cli = [shutil.which("mpiexec") or "mpiexec", "-n", str(ranks), "--oversubscribe", *cli]
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    t0 = time.perf_counter()
    done = subprocess.run(cli, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        sys.exit(f"{' '.join(cli)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
    return wall


def read(path: Path) -> tuple[dict, float]:
    with h5py.File(path, "r") as fh:
        return ({k: fh["samples"][k][()] for k in ("status", "tensions", "tip")},
                float(fh["timing"].attrs["seconds_wall"]))


def agreement(a: dict, b: dict) -> str:
    """Classes equal, and the largest |dp| and |dx_t| (mm) over samples reached in both."""
    same = int(np.count_nonzero(a["status"] == b["status"]))
    both = (a["status"] == 1) & (b["status"] == 1)
    dp = np.abs(a["tensions"][both] - b["tensions"][both]).max() if both.any() else 0.0
    dx = np.linalg.norm(a["tip"][both] - b["tip"][both], axis=1).max() if both.any() else 0.0
    return (f"{same} of {len(a['status'])} classes equal; reached {int(both.sum())}: "
            f"max |dp| {dp:.2g}, max |dx_t| {dx:.2g} mm")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacings", type=float, nargs="+", default=[11.67, 25.0])
    parser.add_argument("--elements", type=int, default=180)
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeat", type=int, default=3, help="boundary-fill runs (median)")
    parser.add_argument("--global-repeat", type=int, default=1,
                        help="global-search runs, one rank (median; 0: none, no ratio)")
    parser.add_argument("--dir", help="keep the HDF5 files here (default: a temporary folder)")
    args = parser.parse_args(argv)
    folder = Path(args.dir) if args.dir else Path(tempfile.mkdtemp(prefix="bench_fill_"))
    folder.mkdir(parents=True, exist_ok=True)
    keys = [(s, "global-search", 1) for s in args.spacings if args.global_repeat > 0] + \
        [(s, "boundary-fill", r) for s in args.spacings for r in args.ranks]
    walls, sampling, loads = {k: [] for k in keys}, {k: [] for k in keys}, []
    for i in range(max(args.repeat, args.global_repeat)):              # interleaved
        for key in keys:
            if i >= (args.global_repeat if key[1] == "global-search" else args.repeat):
                continue
            path = folder / f"ws_{key[0]:g}_{key[1]}_{key[2]}.h5"
            walls[key].append(run(*key, path, args.elements))
            sampling[key].append(read(path)[1])
            loads.append(os.getloadavg()[0])
            print(f"# {key}: {walls[key][-1]:.2f} s (load {loads[-1]:.1f})", file=sys.stderr)
    print(f"\nLoad average during the runs: {min(loads):.1f}-{max(loads):.1f} "
          f"(2 cores); {args.elements} elements.\n")
    print("| spacing | sampler | ranks | runs | wall time of the command, median (min-max) "
          "| sampling (seconds_wall), median | global / fill (sampling) | speed-up 1 -> 2 |")
    print("|---|---|---|---|---|---|---|---|")
    for s, sampler, ranks in keys:
        w, t = walls[s, sampler, ranks], statistics.median(sampling[s, sampler, ranks])
        fill1 = statistics.median(sampling[s, "boundary-fill", args.ranks[0]])
        ratio = (f"{statistics.median(sampling[s, 'global-search', 1]) / t:.1f}"
                 if sampler == "boundary-fill" and args.global_repeat > 0 else "")
        speedup = (f"{fill1 / t:.2f}" if sampler == "boundary-fill" and ranks > args.ranks[0]
                   else "")
        print(f"| {s:g} mm | {sampler} | {ranks} | {len(w)} | {statistics.median(w):.2f} s "
              f"({min(w):.2f}-{max(w):.2f}) | {t:.2f} s | {ratio} | {speedup} |")
    print()
    for s in args.spacings if args.global_repeat > 0 else ():
        ref = read(folder / f"ws_{s:g}_global-search_1.h5")[0]
        for r in args.ranks:
            fill = read(folder / f"ws_{s:g}_boundary-fill_{r}.h5")[0]
            print(f"- {s:g} mm, boundary-fill on {r} rank(s) against global-search: "
                  f"{agreement(ref, fill)}")


if __name__ == "__main__":
    main()
