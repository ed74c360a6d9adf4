#!/usr/bin/env python3
"""`lengths --all` at L = (147.1, 472.5) mm and `boundary` on the paper's arm
as a user runs them (fresh process: start-up included), before and after a
change (issue 25, branch lenspeed).

    .venv/bin/python scripts/benchmarks/bench_lenspeed.py --before REV [--repeat 5]

REV is put in a temporary directory (``git archive``, this checkout's compiled
kernels copied beside it).  Each command runs with ``--json`` in REV and here,
interleaved, ``--repeat`` times: median wall time and median CPU time (user +
system of the child), the ratios before/after, and whether the JSON outputs
are equal (the states, polygons, areas and counts, as printed; the run time
"seconds" left out).  The load
average is printed (the machine is shared).
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
import time

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
COMMANDS = {"lengths --all L = (147.1, 472.5) mm": ["lengths", "--lengths", "147.1", "472.5",
                                                    "--all", "--json"],
            "boundary (paper's arm)": ["boundary", "--json"]}


NODES = r"""
import pickle, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from elastica_petsc.core.model import load_config
from elastica_petsc.studies.boundary import trace_boundary
r = trace_boundary(load_config(None), restricted=True)
curves = [c for reg in r.regions.values() for c in reg.curves] + list(r.fold_curves)
nodes = np.array([np.concatenate((q.w, q.t, [q.det_sign, q.tip_det]))
                  for c in curves for q in c.points])
sys.stdout.buffer.write(pickle.dumps((nodes, r.areas_mm2, r.solves)))
"""


def same_nodes(trees: dict) -> str:
    """Whether the traced boundary's nodes (w, t, det sign, tip-map test of every
    point of every curve), areas and solve counts are bit-identical in the trees."""
    import pickle

    import numpy as np

    got = [pickle.loads(subprocess.run([sys.executable, "-c", NODES, tree], check=True,
                                       cwd=tempfile.gettempdir(), capture_output=True).stdout)
           for tree in trees.values()]
    (a, area_a, n_a), (b, area_b, n_b) = got
    same = a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    return (f"boundary: {len(a)} and {len(b)} nodes, "
            f"{'bit-identical' if same else 'NOT bit-identical'}; areas {area_a} / {area_b}; "
            f"solves {n_a} / {n_b}")


def comparable(out: str) -> str:
    """The JSON output without its run time (key "seconds")."""
    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k != "seconds"}
        return [strip(v) for v in x] if isinstance(x, list) else x
    return json.dumps(strip(json.loads(out)), sort_keys=True)


def run(tree: str, argv: list[str]) -> tuple[float, float, str]:
    """(wall, CPU, stdout) of the command with the package of ``tree``."""
    code = (f"import sys; sys.path.insert(0, {tree!r}); import elastica_petsc; "
            f"assert elastica_petsc.__file__.startswith({tree!r}); "
            f"from elastica_petsc.cli import main; "
            f"sys.argv = ['elastica-petsc'] + {argv!r}; sys.exit(main())")
    before = os.times()
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code], check=True, cwd=tempfile.gettempdir(),
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = os.times()
    return wall, (after.children_user - before.children_user
                  + after.children_system - before.children_system), done.stdout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    load = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory() as tmp:
        old = os.path.join(tmp, "before")
        os.makedirs(old)
        archive = subprocess.run(["git", "-C", HERE, "archive", args.before, "elastica_petsc",
                                  "configs"], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", old], input=archive, check=True)
        for so in glob.glob(os.path.join(HERE, "elastica_petsc", "core", "*.so")):
            shutil.copy(so, os.path.join(old, "elastica_petsc", "core"))
        trees = {"before": old, "after": HERE}
        times, outputs = {}, {}
        for _ in range(args.repeat):
            for name, argv in COMMANDS.items():
                for which, tree in trees.items():
                    wall, cpu, out = run(tree, argv)
                    times.setdefault((name, which), []).append((wall, cpu))
                    outputs.setdefault((name, which), set()).add(comparable(out))
            load.append(os.getloadavg()[0])
        nodes_note = same_nodes(trees)
    print(f"load average {min(load):.2f}-{max(load):.2f}; median of {args.repeat} fresh "
          "processes, interleaved\n")
    print("| command | before wall [s] | after wall [s] | ratio | before CPU [s] | "
          "after CPU [s] | ratio | outputs equal |")
    print("|---|---|---|---|---|---|---|---|")
    for name in COMMANDS:
        (bw, bc), (aw, ac) = ((statistics.median(t[0] for t in times[(name, w)]),
                               statistics.median(t[1] for t in times[(name, w)]))
                              for w in trees)
        same = outputs[(name, "before")] == outputs[(name, "after")] \
            and len(outputs[(name, "after")]) == 1
        print(f"| {name} | {bw:.2f} | {aw:.2f} | {bw / aw:.2f} | {bc:.2f} | {ac:.2f} | "
              f"{bc / ac:.2f} | {'yes' if same else 'NO'} |")
    print()
    print(nodes_note)


if __name__ == "__main__":
    main()
