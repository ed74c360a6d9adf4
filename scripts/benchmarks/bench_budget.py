#!/usr/bin/env python3
"""Benchmark of issue 25's "answers within a budget" part: `lengths --all` at
Fig. 8's lengths, `equilibria` at Fig. 8's tensions, and `control` of a target
in a hole of W_0 once the boundary is traced, against an earlier revision,
interleaved, median of repeats.

    python scripts/benchmarks/bench_budget.py [--repeats 3] [--before 3e5e6c1] [--elements 180]

Each measurement is a fresh process on the paper's arm: imports and one
untimed warm-up (for control: the boundary trace, which the process then
keeps, and a first control of the target), then the timed call; wall and
CPU seconds, and what was found (states and their tensions; control's
verdict).  The earlier revision is taken with `git archive` into a
temporary directory.  Ratios are what to compare on a shared machine; the
load average is printed before and after.
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

from bench_boundary import HERE, extract

SNIPPET = r"""
import json, sys, time
import numpy as np
import elastica_petsc as ep
from elastica_petsc.core.model import load_config
case, elements = sys.argv[1], int(sys.argv[2])
arm = load_config()
if case == "lengths --all":
    run = lambda: ep.length_equilibria(arm, (147.1, 472.5), elements=elements)
elif case == "equilibria":
    run = lambda: ep.equilibria(arm, tensions=(25.2, 10.8), elements=elements)
else:                                     # control of the hole around r_1, boundary traced
    target = (387.4, -261.1) if case == "control (387.4, -261.1)" else (100.0, -200.0)
    run = lambda: ep.control(arm, target, elements=elements)
    run()                                 # traces the boundary (kept by the process)
w0, c0 = time.perf_counter(), time.process_time()
r = run()
wall, cpu = time.perf_counter() - w0, time.process_time() - c0
if case.startswith("control"):
    found = [r.reason, bool(r.reachable) if r.reachable is not None else None]
else:
    found = sorted(np.round(f.state.p, 2).tolist() for f in r.states)
print(json.dumps({"wall": wall, "cpu": cpu, "found": found}))
"""

CASES = ("lengths --all", "equilibria", "control (387.4, -261.1)", "control (100, -200)")


def measure(root: str, case: str, elements: int) -> dict:
    env = dict(os.environ, PYTHONPATH=root)
    out = subprocess.run([sys.executable, "-c", SNIPPET, case, str(elements)], cwd=root,
                         env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def with_kernels(root: str) -> str:
    """The compiled kernels of this tree (core/fem_kernels*.so, built by
    scripts/setup.sh) copied into an extracted revision that has the same C
    source but no build; a revision without kernels ignores them."""
    core = os.path.join(root, "elastica_petsc", "core")
    if os.path.exists(os.path.join(core, "fem_kernels.c")):
        for built in glob.glob(os.path.join(HERE, "elastica_petsc", "core", "fem_kernels*.so")):
            shutil.copy(built, core)
    return root


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--before", default="3e5e6c1", help="earlier revision (git)")
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    args = ap.parse_args()
    print(f"load average: {os.getloadavg()}")
    print("| case | revision | wall s (median) | cpu s (median) | found |")
    print("|---|---|---|---|---|", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        roots = {"before": with_kernels(extract(args.before, tmp)), "after": HERE}
        for case in args.cases:
            runs = {"before": [], "after": []}
            for _ in range(args.repeats):
                for label, root in roots.items():           # interleaved
                    runs[label].append(measure(root, case, args.elements))
            report(case, runs)
    print(f"load average after: {os.getloadavg()}")


def report(case: str, runs: dict) -> None:
    """Rows of one case: medians per revision, what was found, the ratios."""
    med = {k: {q: statistics.median(r[q] for r in v) for q in ("wall", "cpu")}
           for k, v in runs.items()}
    for label in ("before", "after"):
        found = runs[label][-1]["found"]
        same = all(r["found"] == found for r in runs[label])
        print(f"| {case} | {label} | {med[label]['wall']:.3f} | {med[label]['cpu']:.3f} | "
              f"{found}{'' if same else ' (varied)'} |")
    print(f"| {case} | ratio before/after | {med['before']['wall'] / med['after']['wall']:.2f}"
          f" | {med['before']['cpu'] / med['after']['cpu']:.2f} | |", flush=True)


if __name__ == "__main__":
    main()
