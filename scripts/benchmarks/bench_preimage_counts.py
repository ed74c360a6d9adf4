"""Benchmark: BoundaryResult.preimage_counts with its k-d tree built once per
result against one built per call (as before), on the Fig. 4 map.

    python scripts/benchmarks/bench_preimage_counts.py [--repeats 7] [--before REV]

In-process: trace the paper arm's boundary (180 elements), split the 4,202
targets of the Fig. 4 map (spacing 11.67 mm) into the 204 chunks the map's
fill works on, and time the 204 ``preimage_counts`` calls with the cached
tree and with the cache emptied before each call (the earlier cost),
interleaved, median of repeats; the counts must be equal.  With --before
REV, also time ``elastica-petsc workspace --spacing 11.67 --elements 180
--quiet`` in REV (``git archive`` into a temporary directory, this
checkout's compiled kernels copied beside it) and in this checkout,
interleaved, and check that the maps' ``samples/*`` datasets (timings
aside) are bit-identical.  Ratios are what to compare; the load is printed.
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

import numpy as np

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLI = ["workspace", "--spacing", "11.67", "--elements", "180", "--quiet", "--overwrite"]
CHUNKS = 204


def run_map(tree: str, out: str) -> float:
    """Wall seconds of the workspace command with the package of ``tree``."""
    code = (f"import sys; sys.path.insert(0, {tree!r}); import elastica_petsc; "
            f"assert elastica_petsc.__file__.startswith({tree!r}); "
            f"from elastica_petsc.cli import main; "
            f"sys.argv = ['elastica-petsc'] + {CLI + ['--out', out]!r}; sys.exit(main())")
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tempfile.gettempdir(),
                   stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def differing_samples(a_path: str, b_path: str) -> list[str]:
    import h5py

    with h5py.File(a_path) as a, h5py.File(b_path) as b:
        assert sorted(a["samples"]) == sorted(b["samples"])
        return [n for n in a["samples"] if not n.startswith("seconds")
                and not np.array_equal(a["samples"][n][()], b["samples"][n][()],
                                       equal_nan=a["samples"][n].dtype.kind == "f")]


def cli_runs(before: str, repeats: int, tmp: str) -> str:
    """The workspace command in ``before`` and here, interleaved."""
    old = os.path.join(tmp, "before")
    os.makedirs(old)
    archive = subprocess.run(["git", "archive", before, "elastica_petsc"], cwd=HERE,
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", old], input=archive, check=True)
    for so in glob.glob(os.path.join(HERE, "elastica_petsc", "core", "*.so")):
        shutil.copy(so, os.path.join(old, "elastica_petsc", "core"))
    times = {"before": [], "after": []}
    for _ in range(repeats):
        times["before"].append(run_map(old, os.path.join(tmp, "before.h5")))
        times["after"].append(run_map(HERE, os.path.join(tmp, "after.h5")))
    for k, v in times.items():
        print(f"workspace ({k}): " + " ".join(f"{x:.2f}" for x in v)
              + f"  median {statistics.median(v):.3f} s")
    print(f"ratio before/after: {statistics.median(times['before']) / statistics.median(times['after']):.3f}"
          f"; samples/* differing (timings aside): {differing_samples(*(os.path.join(tmp, f) for f in ('before.h5', 'after.h5')))}")
    return os.path.join(tmp, "after.h5")


def in_process(map_path: str, repeats: int) -> None:
    import h5py

    import elastica_petsc as ep

    with h5py.File(map_path) as fh:
        chunks = np.array_split(fh["samples/target"][()], CHUNKS)
    result = ep.boundary(ep.Arm.paper(), elements=180)
    reference = [result.preimage_counts(c) for c in chunks]
    times = {"tree per call (before)": [], "tree once (after)": []}
    for _ in range(repeats):
        t0 = time.perf_counter()
        for c in chunks:
            result._trees.clear()          # the earlier cost: the tree rebuilt every call
            result.preimage_counts(c)
        times["tree per call (before)"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        counts = [result.preimage_counts(c) for c in chunks]
        times["tree once (after)"].append(time.perf_counter() - t0)
        assert counts == reference
    for k, v in times.items():
        print(f"{CHUNKS} preimage_counts calls, {k}: median {statistics.median(v):.4f} s")
    a, b = (statistics.median(v) for v in times.values())
    print(f"ratio {a / b:.1f}, saving {a - b:.3f} s per map")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--before", help="an earlier revision to time the workspace command in")
    args = parser.parse_args()
    print("load average:", os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp:
        if args.before:
            map_path = cli_runs(args.before, args.repeats, tmp)
        else:
            map_path = os.path.join(tmp, "map.h5")
            run_map(HERE, map_path)
        in_process(map_path, args.repeats)
    print("load average:", os.getloadavg())


if __name__ == "__main__":
    main()
