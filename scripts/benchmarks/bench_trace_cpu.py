#!/usr/bin/env python3
"""Fig. 3a path tracing in CPU time (issue 25: >= 2,000 targets/s on one core).

The drawing of Fig. 3a (triangle, incircle, circumcircle about (400, 200) mm,
1 mm steps, 1349 warm-started targets after the cold first one) on the
paper's arm at 180 elements, traced ``--repeat`` times with one controller:
targets per CPU second (``time.process_time``: the shared machine's load
does not count) and per wall second, median of the runs; iterations and
equilibrium solves per target; the largest tip error.

``--against DIR`` compares with another source tree (e.g. ``git archive`` of
the base commit, with the compiled kernels copied in): rounds alternate
between DIR and this tree, each in its own process, and the ratio of the
medians is printed with the largest difference of the traced tensions.

``--shape convoluted`` (our Fig. 3b stand-in) and ``--step`` (mm) trace other paths.

Usage: python scripts/benchmarks/bench_trace_cpu.py [--repeat 5] [--rounds 2] [--against DIR]
                                                    [--shape triangle|convoluted] [--step MM]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def shape_targets(shape: str, step_mm: float):
    """The targets (mm) of ``shape`` about (400, 200) mm at ``step_mm`` spacing."""
    from elastica_petsc.studies import trace as paths

    points = (paths.paper_triangle([400.0, 200.0]) if shape == "triangle"
              else paths.convoluted_curve([400.0, 200.0]))
    return paths.densify(points, step_mm)


def run_here(repeat: int, save: str | None, shape: str = "triangle", step_mm: float = 1.0) -> dict:
    """The trace measured in this process (this interpreter's elastica_petsc)."""
    import numpy as np

    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.studies import trace as paths

    arm = load_config()
    targets = shape_targets(shape, step_mm)
    cpu, wall = [], []
    with TipController(arm, n_elements=180) as ctl:
        first = ctl.solve_mm(targets[0])                  # cold, not timed
        for _ in range(repeat):
            c0, w0 = time.process_time(), time.perf_counter()
            tr = paths.trace(ctl, targets[1:], p0=first.p, start=first.equilibrium)
            cpu.append(tr.n_points / (time.process_time() - c0))
            wall.append(tr.n_points / (time.perf_counter() - w0))
    if save:
        np.save(save, tr.p)
    return {"cpu": statistics.median(cpu), "wall": statistics.median(wall),
            "n": int(tr.n_points), "all_converged": bool(tr.all_converged),
            "its": float(np.mean(tr.iterations)), "its_max": int(tr.iterations.max()),
            "evals": float(np.mean(tr.evaluations)),
            "max_tip_error_mm": float(tr.tip_errors_mm.max())}


def run_tree(tree: str | None, repeat: int, save: str, shape: str, step_mm: float) -> dict:
    """One round in a fresh process on ``tree`` (None: this tree)."""
    env = dict(os.environ)
    if tree is not None:
        env["PYTHONPATH"] = str(Path(tree).resolve())
    out = subprocess.run([sys.executable, __file__, "--repeat", str(repeat), "--json",
                          "--save", save, "--shape", shape, "--step", str(step_mm)], env=env, check=True, capture_output=True,
                         text=True, cwd=tempfile.gettempdir())
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(tree: str, repeat: int, rounds: int, shape: str, step_mm: float) -> None:
    import numpy as np

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(rounds):
            base = run_tree(tree, repeat, f"{tmp}/base.npy", shape, step_mm)
            new = run_tree(None, repeat, f"{tmp}/new.npy", shape, step_mm)
            rows.append((k + 1, base, new, os.getloadavg()[0]))
        dp = float(np.max(np.abs(np.load(f"{tmp}/base.npy") - np.load(f"{tmp}/new.npy"))))
    print("| round (load) | base targets/s CPU (wall) | new targets/s CPU (wall) | ratio CPU |")
    print("|---|---|---|---|")
    for k, b, n, load in rows:
        print(f"| {k} ({load:.1f}) | {b['cpu']:.0f} ({b['wall']:.0f}) | "
              f"{n['cpu']:.0f} ({n['wall']:.0f}) | {n['cpu'] / b['cpu']:.2f} |")
    for name, r in (("base", rows[-1][1]), ("new", rows[-1][2])):
        print(f"{name}: {r['n']} targets, all reached {r['all_converged']}, iterations mean "
              f"{r['its']:.2f} (max {r['its_max']}), evaluations {r['evals']:.2f} "
              f"per target (the start's, cached, included), max tip error {r['max_tip_error_mm']:.2e} mm")
    print(f"max |p_new - p_base| = {dp:.2e} (non-dimensional tensions)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--against", help="source tree to compare with (base)")
    ap.add_argument("--shape", choices=("triangle", "convoluted"), default="triangle",
                    help="Fig. 3a (default) or our Fig. 3b stand-in")
    ap.add_argument("--step", type=float, default=1.0, help="target spacing [mm]")
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--save", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.against:
        compare(args.against, args.repeat, args.rounds, args.shape, args.step)
        return 0
    res = run_here(args.repeat, args.save, args.shape, args.step)
    print(json.dumps(res) if args.json else
          f"{res['cpu']:.0f} targets/s CPU, {res['wall']:.0f} wall (median of {args.repeat})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
