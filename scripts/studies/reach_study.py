#!/usr/bin/env python3
"""Reachability study (issue 11): targets made as tips of forward solves at
random admissible tensions (P >= 0, proportional loading from the straight arm,
stable, no collapsed cable) are each given to tip control from its default start
(p = 0), local solve then the global search of solvers/reach.py.  Every target
is in W_0, so each should be reached; none may be reported reachable: false.
Prints the counts, the strategy that reached the hard ones, the total time and
the mean time per target of the hardest 5 %.

Usage: python scripts/studies/reach_study.py [--targets 200] [--p-max 60] [--elements 180]
       [--seed 1] [--local] [--config configs/three_tendon.toml]
"""
from __future__ import annotations

import argparse
import time


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", type=int, default=200)
    ap.add_argument("--p-max", type=float, default=60.0, help="tensions drawn in [0, p_max]")
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--local", action="store_true", help="local solve only (the old behaviour)")
    ap.add_argument("--config", default=None, help="arm TOML (default: the paper's arm)")
    args = ap.parse_args()
    import numpy as np

    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.solvers.reach import Reacher

    arm = load_config(args.config)
    rng = np.random.default_rng(args.seed)
    times, failed, hard = [], [], []
    with TipController(arm, n_elements=args.elements) as ctl:
        targets = []
        while len(targets) < args.targets:
            eq = ctl.forward(rng.uniform(0.0, args.p_max, ctl.n))
            if eq.converged and eq.stable and np.min(eq.cable_lengths) > 0.01:
                targets.append(eq.tip)
        reacher = Reacher(ctl)
        for target in targets:
            t0 = time.perf_counter()
            res = reacher.reach(target, global_search=not args.local)
            times.append(time.perf_counter() - t0)
            if res.strategy != "local":
                hard.append((np.round(target * arm.length_mm, 1), res.strategy))
            if not res.converged:
                failed.append((np.round(target * arm.length_mm, 1), res.reason,
                               res.reachable, round(res.tip_error_mm, 3)))
    n = len(times)
    worst = sorted(times)[-max(1, n // 20):]
    print(f"{n} targets ({arm.n_tendons} "
          f"tendons, p in [0, {args.p_max:g}]^n, {args.elements} elements, seed "
          f"{args.seed}): {n - len(failed)} reached ({100 * (n - len(failed)) / n:.1f} %), "
          f"{sum(1 for f in failed if f[2] is False)} reported reachable: false")
    print(f"total {sum(times):.1f} s; median {1e3 * float(np.median(times)):.1f} ms per target; "
          f"hardest 5 %: mean {np.mean(worst):.2f} s per target")
    print(f"{len(hard)} needed the global search:")
    for target, strategy in hard:
        print(f"  {target.tolist()} mm: {strategy}")
    for f in failed:
        print("NOT reached:", f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
