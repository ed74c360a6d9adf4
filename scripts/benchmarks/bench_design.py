#!/usr/bin/env python3
"""Timing of ``design`` (issue 13): the sweep on 1 and 2 ranks, and the
optimisers' iterations and time.

``sweep``: ``elastica-petsc design --sweep tendon2.route.y=A:B:S
tendon1.attach=...`` (area objective at the default P_max = 10 N) at
--elements, on 1 rank and under ``mpiexec -n 2``, rank counts interleaved,
median wall time of --repeat runs each; checks that both files hold the same
areas.  ``optimise``: one ``design --objective area`` and one
``design --objective path:CSV`` (the circle of radius 80 mm about (420, 260)
mm of examples/design_task.py), reporting iterations, evaluations, seconds
and the outcome from their --json.

``area``: ``design --vary tendon1.route tendon2.route --objective area``
(the paper's arm, CLI defaults: 180 elements, 10 N, re-sampling at 32
cells) in this tree and in an earlier revision (``git archive``, default
``main``), interleaved, fresh processes, median wall and CPU (user + sys of
the child) of --repeat runs, and the optimisation alone (``design_for_area``
without the re-sampling, in-process after a warm-up): ratios before/after
in one run, and the optimum of each (areas, routes, re-sampled areas).

Usage: bench_design.py sweep [--elements N] [--repeat R]
       bench_design.py optimise [--elements N]
       bench_design.py area [--repeat R] [--before REV]
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

import h5py
import numpy as np

SWEEP = ["tendon2.route.y=30:60:10", "tendon1.attach=150:250:50"]   # 12 designs
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")
CLI = [sys.executable, "-m", "elastica_petsc.cli", "design"]


def _run(cmd, cwd) -> float:
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, env=ENV)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed: {done.stderr}")
    return time.perf_counter() - t0


def sweep(elements: int, repeat: int) -> None:
    times = {1: [], 2: []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):
            for ranks in (1, 2):
                cmd = (["mpiexec", "-n", "2"] if ranks == 2 else []) + CLI + [
                    "--sweep", *SWEEP, "--elements", str(elements), "--out", f"r{ranks}.h5",
                    "--overwrite", "--json"]
                times[ranks].append(_run(cmd, tmp))
        areas = [h5py.File(Path(tmp) / f"r{r}.h5", "r")["samples/area"][()] for r in (1, 2)]
    same = np.array_equal(areas[0], areas[1])
    t1, t2 = statistics.median(times[1]), statistics.median(times[2])
    print(f"design --sweep {' '.join(SWEEP)} --elements {elements}: {len(areas[0])} designs")
    print("| ranks | median wall s | min | max | speed-up |")
    print("|---|---|---|---|---|")
    for r, t in ((1, t1), (2, t2)):
        print(f"| {r} | {t:.1f} | {min(times[r]):.1f} | {max(times[r]):.1f} | {t1 / t:.2f} |")
    print(f"identical areas on 1 and 2 ranks: {same}")


def optimise(elements: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        theta = np.linspace(0, 2 * np.pi, 37)
        circle = np.column_stack((420 + 80 * np.cos(theta), 260 + 80 * np.sin(theta)))
        np.savetxt(Path(tmp) / "circle.csv", circle, delimiter=",", fmt="%.4f")
        for objective in ("area", "path:circle.csv"):
            cmd = CLI + ["--vary", "tendon1.route", "tendon2.route", "--objective", objective,
                         "--elements", str(elements), "--json"]
            done = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, env=ENV)
            s = json.loads(done.stdout)
            keys = ("iterations", "evaluations", "seconds", "tao_reason")
            extra = (("area_before_mm2", "area_after_mm2", "confirmed") if objective == "area"
                     else ("reached_before", "reached_after"))
            print(objective, "exit", done.returncode,
                  {k: s[k] for k in keys + extra},
                  {k: s[k] for k in ("resampled_before", "resampled_after") if k in s})


AREA_CMD = ["-m", "elastica_petsc.cli", "design", "--vary", "tendon1.route", "tendon2.route",
            "--objective", "area", "--json", "--quiet"]
OPTIMISE_ONLY = r"""
import json, time
from elastica_petsc.core.model import load_config
from elastica_petsc.studies.design_area import design_for_area
arm = load_config()
p_max = 10.0 / arm.force_scale_N
design_for_area(arm, (0, 1), p_max, resample_cells=None, max_iterations=1)     # warm-up
w, c = time.perf_counter(), time.process_time()
r = design_for_area(arm, (0, 1), p_max, resample_cells=None)
print(json.dumps({"wall": time.perf_counter() - w, "cpu": time.process_time() - c,
                  "evaluations": len(r.history), "area": r.after.area_mm2}))
"""


def _child(cmd, root) -> tuple[float, float, str]:
    """(wall s, CPU s of the child, stdout) of one fresh process in ``root``."""
    import resource

    env = dict(ENV, PYTHONPATH=root)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=root, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(cmd)} failed in {root}: {done.stderr[-2000:]}")
    return wall, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime), done.stdout


def area(repeat: int, before: str) -> None:
    here = str(Path(__file__).resolve().parents[2])
    print(f"load average: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        archive = subprocess.run(["git", "archive", before, "elastica_petsc"], cwd=here,
                                 capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", tmp], input=archive, check=True)
        roots = {"before": tmp, "after": here}
        cli = {k: [] for k in roots}
        alone = {k: [] for k in roots}
        for _ in range(repeat):
            for label, root in roots.items():                      # interleaved
                wall, cpu, out = _child([sys.executable, *AREA_CMD], root)
                cli[label].append((wall, cpu, json.loads(out)))
                _, _, out = _child([sys.executable, "-c", OPTIMISE_ONLY], root)
                alone[label].append(json.loads(out.strip().splitlines()[-1]))
    print(f"load average after: {os.getloadavg()}")
    print("| revision | CLI wall s | CLI CPU s | optimisation wall s | optimisation CPU s "
          "| evaluations | area after mm^2 | routes after mm | re-sampled before / after mm^2 |")
    print("|---|---|---|---|---|---|---|---|---|")
    med = {}
    for label in roots:
        s = cli[label][0][2]
        med[label] = [statistics.median(r[0] for r in cli[label]),
                      statistics.median(r[1] for r in cli[label]),
                      statistics.median(r["wall"] for r in alone[label]),
                      statistics.median(r["cpu"] for r in alone[label])]
        routes = [[round(x, 3) for x in r] for r in s["routes_after_mm"]]
        print(f"| {label} ({before if label == 'before' else 'this tree'}) | "
              + " | ".join(f"{v:.2f}" for v in med[label])
              + f" | {s['evaluations']} | {s['area_after_mm2']:.2f} | {routes} | "
              f"{s['resampled_before']['area_mm2']:.1f} / {s['resampled_after']['area_mm2']:.1f} |")
    print("| ratio before/after | " + " | ".join(
        f"{b / a:.2f}" for b, a in zip(med["before"], med["after"])) + " | | | | |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("sweep", "optimise", "area"))
    parser.add_argument("--elements", type=int, default=60)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--before", default="main", help="area: the earlier revision (git)")
    args = parser.parse_args()
    if args.what == "area":
        area(args.repeat, args.before)
    elif args.what == "sweep":
        sweep(args.elements, args.repeat)
    else:
        optimise(args.elements)


if __name__ == "__main__":
    main()
