#!/usr/bin/env python3
"""Benchmark tension sharing along a trace (issue 11).

Parts (``--part``):

``share``  configs/three_tendon.toml, a circle of radius 40 mm about
           (450, 290) mm at ``--step`` mm, ``--elements``: time per point of
           plain tracing, of shared tracing with the SQP on the KKT system
           (``newton``: min-norm, min-energy, min-norm with P >= 1 N), and of
           the TAO ALMM sharer (reach, then ALMM, per point) on the first
           ``--almm-points`` points; the closure of the loop in cable space.
``fig3a``  the paper's arm (n = 2), the Fig. 3a drawing about (400, 200) mm
           at 1 mm steps, plain tracing: targets per second.  Uses only the
           API that predates sharing, so it can run against an older tree
           (``PYTHONPATH=OLD python scripts/benchmarks/bench_share.py --part fig3a``)
           interleaved with this one.

Median of ``--repeat`` runs.  Usage:
    python scripts/benchmarks/bench_share.py --part share [--elements 180] [--step 1] [--repeat 3]
    python scripts/benchmarks/bench_share.py --part fig3a [--repeat 3]
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "three_tendon.toml"


def parse():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("share", "fig3a"), required=True)
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--step", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--almm-points", type=int, default=10)
    return ap.parse_args()


def timed_trace(ctl, targets, first, sharer=None, repeat=3):
    """Median seconds per point over ``repeat`` traces warm-started at ``first``."""
    from elastica_petsc.studies import trace as paths

    times, res = [], None
    for _ in range(repeat):                     # each trace starts its own warm start
        kw = {} if sharer is None else {"sharer": sharer}
        res = paths.trace(ctl, targets, p0=first.p, start=first.equilibrium,
                          start_loading=first.loading, **kw)
        times.append(res.seconds / res.n_points)
    return statistics.median(times), res


def share_part(args) -> None:
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.solvers.share import TensionSharer
    from elastica_petsc.studies import trace as paths

    arm = load_config(CONFIG)
    targets = paths.densify(paths.circle((450.0, 290.0), 40.0), args.step)
    print(f"## Tension sharing along a trace ({args.elements} elements, {CONFIG.name}, "
          f"circle r = 40 mm about (450, 290) mm, {args.step:g} mm steps, {len(targets)} points, "
          f"median of {args.repeat})\n")
    print("| tracing | ms per point | SQP/TAO iterations per point (mean, max) | "
          "equilibrium solves per point (mean) | all reached | closure in cable space [mm] |")
    print("|---|---|---|---|---|---|")
    with TipController(arm, n_elements=args.elements) as ctl:
        first = ctl.solve_mm(targets[0])
        runs = [("plain (no sharing)", None, targets)]
        for share, floor in (("min-norm", 0.0), ("min-energy", 0.0), ("min-norm", 1.0)):
            sharer = TensionSharer(ctl, share, floor / arm.force_scale_N)
            runs.append((f"newton {share}, P >= {floor:g} N", sharer, targets))
        k = args.almm_points
        runs.append((f"almm min-norm, first {k} points", TensionSharer(ctl, "min-norm",
                                                                       method="almm"),
                     targets[:k]))
        runs.append((f"newton min-norm, first {k} points", TensionSharer(ctl, "min-norm"),
                     targets[:k]))
        for label, sharer, pts in runs:
            rep = 1 if sharer is not None and sharer.method == "almm" else args.repeat
            sec, res = timed_trace(ctl, pts, first, sharer, rep)
            closure = np.max(np.abs(res.cable_lengths_mm[-1] - res.cable_lengths_mm[0]))
            print(f"| {label} | {1e3 * sec:.1f} | {res.iterations.mean():.2f}, "
                  f"{res.iterations.max()} | {res.evaluations.mean():.2f} | "
                  f"{res.all_converged} | "
                  f"{f'{closure:.2g}' if len(pts) == len(targets) else '(open path)'} |")


def fig3a_part(args) -> None:
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.studies import trace as paths

    arm = load_config()
    targets = paths.densify(paths.paper_triangle((400.0, 200.0)), 1.0)
    rates = []
    with TipController(arm, n_elements=args.elements) as ctl:
        first = ctl.solve_mm(targets[0])
        for _ in range(args.repeat):
            res = paths.trace(ctl, targets[1:], p0=first.p, start=first.equilibrium)
            assert res.all_converged
            rates.append(res.n_points / res.seconds)
    print(f"fig3a plain n=2: {len(targets) - 1} targets, targets/s "
          f"{', '.join(f'{r:.0f}' for r in rates)} (median {statistics.median(rates):.0f})")


def main() -> int:
    args = parse()
    (share_part if args.part == "share" else fig3a_part)(args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
