"""Benchmark: `boundary` (workspace boundary by continuation, issue 13) against
an earlier revision, interleaved, median of repeats.

    python scripts/benchmarks/bench_boundary.py [--repeats 5] [--before main] [--map MAP.h5]
                                               [--refine 8] [--config configs/aluminium.toml]

Each measurement is a fresh process that traces once to warm up (imports,
PETSc start-up) and then times a second trace_boundary of the paper's arm
(180 elements; or the arm of --config): wall and CPU seconds, and the continuation solves (each a
nonlinear solve of the extended system).  Cases: the W_0 loop alone
(tip_folds=False), W_0 with the tip-map folds and the scan rays (the
default, and the boundary tip control uses as proof), and W_0 plus the
restricted workspace (the CLI default).  The earlier revision's code is
taken with
`git archive` into a temporary directory.  With --map (a 4,202-target
`workspace` file), the solve counts are also compared with the map's: its
targets and its optimiser iterations (each at least one equilibrium solve).
Ratios are what to compare on a shared machine; the load is printed.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

SNIPPET = r"""
import json, sys, time
from elastica_petsc.core.model import load_config
from elastica_petsc.studies.boundary import trace_boundary
arm = load_config(sys.argv[2] or None)
kw = json.loads(sys.argv[1])
trace_boundary(arm, **kw)
w0, c0 = time.perf_counter(), time.process_time()
r = trace_boundary(arm, **kw)
print(json.dumps({"wall": time.perf_counter() - w0, "cpu": time.process_time() - c0,
                  "solves": r.solves, "area": r.areas_mm2["W0"]}))
"""

CASES = {"W0 loop only": {"restricted": False, "tip_folds": False},
         "W0 + tip-map folds": {"restricted": False},
         "W0 + folds + restricted": {"restricted": True}}


def measure(root: str, kwargs: dict, config: str = "") -> dict:
    env = dict(os.environ, PYTHONPATH=root)
    out = subprocess.run([sys.executable, "-c", SNIPPET, json.dumps(kwargs), config], cwd=root,
                         env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def extract(revision: str, target: str) -> str:
    archive = subprocess.run(["git", "archive", revision, "elastica_petsc", "configs"], cwd=HERE,
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", target], input=archive, check=True)
    return target


def map_counts(path: str) -> dict:
    import h5py
    import numpy as np

    with h5py.File(path, "r") as fh:
        iterations = fh["samples/iterations"][()] if "samples/iterations" in fh else None
        n = len(iterations) if iterations is not None else None
    return {"targets": n, "iterations": int(np.sum(iterations)) if n else None}


ACCURACY = r"""
import json, sys
from elastica_petsc.core.model import load_config
from elastica_petsc.studies.boundary import compare_traces, trace_boundary
arm = load_config()
print(json.dumps(compare_traces(trace_boundary(arm), trace_boundary(arm, refine=float(sys.argv[1])))))
"""


def accuracy(root: str, refine: float) -> dict:
    """The default trace of ``root``'s code against its trace with every step
    limit divided by ``refine`` (:func:`compare_traces`)."""
    env = dict(os.environ, PYTHONPATH=root)
    out = subprocess.run([sys.executable, "-c", ACCURACY, str(refine)], cwd=root, env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--before", default="main", help="earlier revision (git)")
    ap.add_argument("--map", help="a workspace file (targets) to compare solve counts with")
    ap.add_argument("--refine", type=float, default=0.0,
                    help="also compare this tree's default trace with one whose step limits "
                         "are divided by REFINE (e.g. 8): relative area differences and "
                         "Hausdorff distances of the curves (mm)")
    ap.add_argument("--config", default="", help="an arm's TOML (default: the paper's arm)")
    args = ap.parse_args()
    config = os.path.abspath(args.config) if args.config else ""
    print(f"load average: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        roots = {"before": extract(args.before, tmp), "after": HERE}
        rows = {}
        for case, kwargs in CASES.items():
            runs = {"before": [], "after": []}
            for _ in range(args.repeats):
                for label, root in roots.items():           # interleaved
                    runs[label].append(measure(root, kwargs, config))
            rows[case] = runs
    print(f"load average after: {os.getloadavg()}")
    print(f"{'case':26s} {'':6s} {'wall s':>8s} {'cpu s':>8s} {'solves':>7s} {'area mm^2':>10s}")
    for case, runs in rows.items():
        med = {k: {q: statistics.median(r[q] for r in v) for q in ("wall", "cpu", "solves", "area")}
               for k, v in runs.items()}
        for label in ("before", "after"):
            m = med[label]
            print(f"{case:26s} {label:6s} {m['wall']:8.3f} {m['cpu']:8.3f} {m['solves']:7.0f} "
                  f"{m['area']:10.0f}")
        print(f"{'':26s} ratio  {med['before']['wall'] / med['after']['wall']:8.2f} "
              f"{med['before']['cpu'] / med['after']['cpu']:8.2f}   (before / after)")
    if args.refine:
        for name, row in accuracy(HERE, args.refine).items():
            print(f"against refine={args.refine:g}: {name}: {row}")
    if args.map:
        counts = map_counts(args.map)
        after = statistics.median(r["solves"] for r in rows["W0 + tip-map folds"]["after"])
        print(f"map {args.map}: {counts['targets']} targets, {counts['iterations']} optimiser "
              f"iterations; W0 + folds: {after:.0f} solves = {100 * after / counts['targets']:.1f} % "
              f"of the targets, {100 * after / counts['iterations']:.2f} % of the iterations")


if __name__ == "__main__":
    main()
