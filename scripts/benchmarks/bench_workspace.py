#!/usr/bin/env python3
"""Timing of the paper's workspace sampling (Fig. 4, Sec. 4.3) on 1 and 2 ranks.

Runs ``elastica-petsc workspace`` (mode targets: tip control to every target,
then the smallest eigenvalue of every equilibrium reached) on the default
region, the half-disc y >= 0 within reach l = 600 mm, with --spacing chosen so
that about 4201 targets lie in it (the paper's Fig. 4 count; 11.67 mm gives
4202), at the paper's 180 elements, once per rank count (``mpiexec -n R`` for
R > 1).  Prints markdown tables: wall time and speed-up; the per-sample cost
split (tip control by outcome, eigen solve, I/O) from the files'
/samples/seconds_* and /timing attributes; counts per status and per mask
(W_0 .. W_P, Eqs. (18)-(22)); the smallest raw eigenvalue lambda_min(K)/(B/l) over
the reached samples (paper: ~1.8e-3) and the largest l*kappa_max.  Also checks
that the files of all rank counts hold identical /samples (except seconds_*).

Wall times are medians over ``--repeat`` runs per rank count, the rank
counts interleaved (min and max shown); the cost split is read from the last
1-rank file.

``--samplers global local`` times the map with the global search (the default
sampler: targets local tip control does not reach are searched from the seed
library before they are classed) and without it (``--local-only``, the local
verdicts), all runs interleaved, and prints the tables for each.

Usage: bench_workspace.py [--spacing MM] [--elements N] [--ranks 1 2] [--chunk K]
                          [--repeat R] [--dir DIR] [--samplers global local]
(about 4 minutes with the default 5 repeats on 2 shared cores; as root, Open
MPI's run-as-root variables are set for mpiexec).
"""
from __future__ import annotations

import argparse
import json
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
STATUS = {1: "reached (W_0)", 2: "ended on P_i = 0 (local verdict)", 3: "not converged",
          4: "undecided after the global search", 5: "beyond reach |x| > l"}


def run(ranks: int, args, out: Path, sampler: str = "global") -> tuple[float, dict]:
    cli = [sys.executable, "-m", "elastica_petsc.cli", "workspace", "--spacing", str(args.spacing),
           "--elements", str(args.elements), "--chunk", str(args.chunk), "--out", str(out),
           "--overwrite", "--json", *(["--local-only"] if sampler == "local" else [])]
    if ranks > 1:
        cli = [shutil.which("mpiexec") or "mpiexec", "-n", str(ranks), "--oversubscribe", *cli]
    env = dict(os.environ)
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    t0 = time.perf_counter()
    done = subprocess.run(cli, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        sys.exit(f"{' '.join(cli)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
    return wall, json.loads(done.stdout)


def read(path: Path) -> tuple[dict, dict, dict, dict]:
    with h5py.File(path, "r") as fh:
        samples = {k: fh["samples"][k][()] for k in fh["samples"]}
        masks = {k: fh["masks"][k][()] for k in fh["masks"]}
        return samples, masks, dict(fh["timing"].attrs), dict(fh.attrs)


def same_samples(a: dict, b: dict) -> bool:
    for name in a:
        if name.startswith("seconds_"):
            continue
        x, y = a[name], b[name]
        same = np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f" else np.array_equal(x, y)
        if not same:
            return False
    return True


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, default=11.67)
    parser.add_argument("--elements", type=int, default=180)
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--chunk", type=int, default=24)
    parser.add_argument("--repeat", type=int, default=5, help="runs per rank count (median)")
    parser.add_argument("--dir", help="keep the HDF5 files here (default: a temporary folder)")
    parser.add_argument("--samplers", nargs="+", choices=("global", "local"), default=["global"])
    parser.add_argument("--report-only", action="store_true",
                        help="no runs: the tables of the files kept in --dir by an earlier run "
                             "(wall times: the files' sampling times, seconds_wall)")
    args = parser.parse_args(argv)
    if args.report_only and not args.dir:
        sys.exit("--report-only needs --dir")

    folder = Path(args.dir) if args.dir else Path(tempfile.mkdtemp(prefix="bench_ws_"))
    folder.mkdir(parents=True, exist_ok=True)
    keys = [(m, r) for m in args.samplers for r in args.ranks]
    walls, summaries = {k: [] for k in keys}, {}
    if args.report_only:
        for sampler, ranks in keys:
            path = folder / f"ws_{sampler}_{ranks}.h5"
            walls[sampler, ranks].append(read(path)[2]["seconds_wall"])
            summaries[sampler, ranks] = None
    for _ in range(0 if args.report_only else max(1, args.repeat)):   # interleaved
        for sampler, ranks in keys:
            wall, summaries[sampler, ranks] = run(ranks, args, folder / f"ws_{sampler}_{ranks}.h5",
                                                  sampler)
            walls[sampler, ranks].append(wall)
            print(f"# {sampler}, {ranks} rank(s): {wall:.1f} s (load average "
                  f"{os.getloadavg()[0]:.1f})", file=sys.stderr)
    ok = True
    for sampler in args.samplers:
        print(f"\n### Sampler: {sampler}\n")
        runs = {r: (statistics.median(walls[sampler, r]), summaries[sampler, r],
                    *read(folder / f"ws_{sampler}_{r}.h5")) for r in args.ranks}
        ok &= report(args, runs, {r: walls[sampler, r] for r in args.ranks})
    if not ok:
        sys.exit("the rank counts gave different samples")


def report(args, runs: dict, walls: dict) -> bool:
    """The tables of one sampler; True if every rank count gave the same samples."""

    first = args.ranks[0]
    s, masks, _, attrs = runs[first][2:]
    n = len(s["status"])
    grid = json.loads(attrs["grid_json"])
    print(f"Grid: {grid['region']}, spacing {args.spacing:g} mm: {n} targets "
          f"(all with y >= 0), chunks of {args.chunk}; {args.elements} elements; "
          f"PETSc {attrs['petsc_version']}, SLEPc {attrs.get('slepc_version', '?')}.\n")

    print(f"| ranks | wall time of the command, median of {args.repeat} (min-max) "
          "| sampling (file: seconds_wall, last run) | I/O (checkpoints) "
          "| speed-up (command, medians) | speed-up (sampling) |")
    print("|---|---|---|---|---|---|")
    base_cmd, base_smp = runs[first][0], runs[first][4]["seconds_wall"]
    for ranks, (wall, _, _, _, timing, _) in runs.items():
        print(f"| {ranks} | {wall:.1f} s ({min(walls[ranks]):.1f}-{max(walls[ranks]):.1f}) | "
              f"{timing['seconds_wall']:.1f} s | "
              f"{timing['seconds_io']:.2f} s | {base_cmd / wall:.2f} | "
              f"{base_smp / timing['seconds_wall']:.2f} |")
    identical = all(same_samples(s, runs[r][2]) for r in args.ranks[1:])
    print(f"\n/samples identical across rank counts (except seconds_*): {identical}\n")

    print(f"Per-sample cost ({first} rank(s); sums of /samples/seconds_*):\n")
    print("| part | samples | total | mean | median | max |")
    print("|---|---|---|---|---|---|")
    control, eigen, status = s["seconds_control"], s["seconds_eigen"], s["status"]
    local = s["strategy"] == b"local" if "strategy" in s else np.ones(n, bool)
    parts = [(status == code, name) for code, name in STATUS.items()]
    if "strategy" in s:                 # reached: by the local passes / by the global search
        parts[0:1] = [((status == 1) & local, "reached by local tip control"),
                      ((status == 1) & ~local, "reached by the global search")]
    for sel, name in parts:
        if sel.any():
            t = control[sel]
            print(f"| tip control, {name} | {sel.sum()} | {t.sum():.1f} s | {1e3 * t.mean():.1f} ms "
                  f"| {1e3 * np.median(t):.1f} ms | {t.max():.2f} s |")
    ok = np.isfinite(eigen)
    print(f"| eigen solve (SLEPc), reached | {ok.sum()} | {eigen[ok].sum():.1f} s | "
          f"{1e3 * eigen[ok].mean():.2f} ms | {1e3 * np.median(eigen[ok]):.2f} ms | "
          f"{eigen[ok].max():.3f} s |")
    total = control.sum() + eigen[ok].sum()
    timing = runs[first][4]
    print(f"| I/O (all checkpoints but the last) | | {timing['seconds_io']:.2f} s | | | |")
    print(f"| sum of the above | {n} | {total + timing['seconds_io']:.1f} s | "
          f"{1e3 * total / n:.1f} ms | | |")

    reasons = {}
    for code, reason in zip(status, s["reason"]):
        reasons.setdefault((int(code), reason.decode()), 0)
        reasons[(int(code), reason.decode())] += 1
    print("\n| status | count | stopping reasons |")
    print("|---|---|---|")
    for code, name in STATUS.items():
        parts = ", ".join(f"{r} {c}" for (k, r), c in sorted(reasons.items()) if k == code)
        print(f"| {name} | {int((status == code).sum())} | {parts} |")
    print("\n| mask | " + " | ".join(masks) + " |")
    print("|---|" + "---|" * len(masks))
    print("| samples | " + " | ".join(str(int(m.sum())) for m in masks.values()) + " |")

    reached = status == 1
    raw = s["lambda_min_raw"][reached]
    lam = s["lambda_min"][reached]
    k_raw = int(np.flatnonzero(reached)[np.nanargmin(raw)])
    print(f"\nsmallest raw eigenvalue lambda_min(K)/(B/l) over the reached samples: "
          f"{np.nanmin(raw):.3e} at target {tuple(np.round(s['target'][k_raw], 2))} mm "
          f"(paper: ~1.8e-3); mesh-independent lambda_min l^2/B: {np.nanmin(lam):.4f}; "
          f"unstable reached samples: {int(np.sum(lam <= 0))}")
    print(f"largest l*kappa_max: {np.nanmax(s['kappa_max'][reached]):.2f}; largest strain "
          f"energy: {np.nanmax(s['strain_energy'][reached]):.1f} SE_0; largest tensions: "
          f"p = {tuple(np.round(np.nanmax(s['tensions'][reached], axis=0), 1))}; "
          f"largest tip error of reached targets: {np.nanmax(s['tip_error'][reached]):.1e} mm")
    green_spacing = args.spacing * np.sqrt(reached.sum() / 4201)
    print(f"({reached.sum()} reached targets; about 4201 reached targets, the paper's green "
          f"count, would need a spacing of ~{green_spacing:.2f} mm)")
    return identical


if __name__ == "__main__":
    main()
