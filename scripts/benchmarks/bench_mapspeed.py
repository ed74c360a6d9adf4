#!/usr/bin/env python3
"""The workspace maps of issue 25 before and after branch mapspeed, as a user
runs them (fresh process: start-up, trace, file included).

    .venv/bin/python scripts/benchmarks/bench_mapspeed.py --before REV [--repeat 3]
        [--ranks 1 2] [--spacings 11.67 25]

REV is put in a temporary directory (``git archive``, this checkout's compiled
kernels copied beside it).  For each map (spacing, 180 elements, the default
boundary-fill sampler) and rank count, ``elastica-petsc workspace`` runs in REV
and here, interleaved, ``--repeat`` times: median wall time and median CPU time
(user + system of the command and its children, so both ranks), the ratios
before/after, the speed-up from 1 to 2 ranks, and the agreement of the maps:
classes, and over the samples reached in both the largest tension and tip
differences.  The load average is printed (the machine is shared).
"""
from __future__ import annotations

import argparse
import glob
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")


def run(tree: str, spacing: float, ranks: int, out: str) -> tuple[float, float]:
    """(wall, CPU) seconds of the workspace command with the package of ``tree``."""
    code = (f"import sys; sys.path.insert(0, {tree!r}); import elastica_petsc; "
            f"assert elastica_petsc.__file__.startswith({tree!r}); "
            f"from elastica_petsc.cli import main; "
            f"sys.argv = ['elastica-petsc', 'workspace', '--spacing', '{spacing}', "
            f"'--elements', '180', '--quiet', '--overwrite', '--out', {out!r}]; "
            f"sys.exit(main())")
    cmd = [sys.executable, "-c", code]
    if ranks > 1:
        cmd = ["mpiexec", "-n", str(ranks)] + cmd
    before = os.times()
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=tempfile.gettempdir(), env=ENV,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = os.times()
    return wall, (after.children_user - before.children_user
                  + after.children_system - before.children_system)


def agreement(a_path: str, b_path: str) -> str:
    with h5py.File(a_path) as a, h5py.File(b_path) as b:
        sa, sb = a["samples/status"][()], b["samples/status"][()]
        both = (sa == 1) & (sb == 1)
        dp = np.abs(a["samples/tensions"][()][both] - b["samples/tensions"][()][both]).max()
        dx = np.linalg.norm(a["samples/tip"][()][both] - b["samples/tip"][()][both], axis=1).max()
    return (f"{int(np.sum(sa == sb))} of {len(sa)} classes equal, {int(both.sum())} reached in "
            f"both: max |dp| {dp:.2g}, max |dx_t| {dx:.2g} mm")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--spacings", type=float, nargs="+", default=[11.67, 25.0])
    args = ap.parse_args()
    load = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory() as tmp:
        old = os.path.join(tmp, "before")
        os.makedirs(old)
        archive = subprocess.run(["git", "-C", HERE, "archive", args.before],
                                 check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", old], input=archive, check=True)
        for so in glob.glob(os.path.join(HERE, "elastica_petsc", "core", "*.so")):
            shutil.copy(so, os.path.join(old, "elastica_petsc", "core"))
        trees = {"before": old, "after": HERE}
        times = {}
        for _ in range(args.repeat):
            for spacing in args.spacings:
                for ranks in args.ranks:
                    for name, tree in trees.items():
                        out = os.path.join(tmp, f"{name}_{spacing}_{ranks}.h5")
                        times.setdefault((spacing, ranks, name), []).append(
                            run(tree, spacing, ranks, out))
            load.append(os.getloadavg()[0])
        print(f"load average {min(load):.2f}-{max(load):.2f}; median of {args.repeat}, "
              "interleaved\n")
        print("| map | ranks | before wall s | after wall s | ratio | before CPU s | "
              "after CPU s | ratio |")
        print("|---|---|---|---|---|---|---|---|")
        med = {k: (statistics.median(t[0] for t in v), statistics.median(t[1] for t in v))
               for k, v in times.items()}
        for spacing in args.spacings:
            for ranks in args.ranks:
                (bw, bc), (aw, ac) = med[(spacing, ranks, "before")], med[(spacing, ranks, "after")]
                print(f"| {spacing} mm | {ranks} | {bw:.2f} | {aw:.2f} | {bw / aw:.2f} | "
                      f"{bc:.2f} | {ac:.2f} | {bc / ac:.2f} |")
        print()
        for spacing in args.spacings:
            if 1 in args.ranks and 2 in args.ranks:
                for name in trees:
                    print(f"{spacing} mm {name}: speed-up 1 -> 2 ranks (wall) "
                          f"{med[(spacing, 1, name)][0] / med[(spacing, 2, name)][0]:.2f}")
            for ranks in args.ranks:
                print(f"{spacing} mm, {ranks} rank(s), before vs after: " + agreement(
                    os.path.join(tmp, f"before_{spacing}_{ranks}.h5"),
                    os.path.join(tmp, f"after_{spacing}_{ranks}.h5")))
            if 1 in args.ranks and 2 in args.ranks:
                print(f"{spacing} mm after, 1 vs 2 ranks: " + agreement(
                    os.path.join(tmp, f"after_{spacing}_1.h5"),
                    os.path.join(tmp, f"after_{spacing}_2.h5")))


if __name__ == "__main__":
    main()
