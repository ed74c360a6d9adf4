#!/usr/bin/env python3
"""The full tension-sharing study of issue 11 (minutes; the fast version is
tests/test_share_trace.py).

configs/three_tendon.toml (the paper's arm with a third tendon at 400 mm) at
``--elements``; a circle of radius ``--radius`` mm about ``--center`` traced
with ``--step`` mm spacing after an approach from the straight arm (as
``elastica-petsc trace --shape circle`` does), for min-norm, min-energy and
min-norm with every P >= 1 N.  Per rule: points reached, closure of the loop
in cable space (cable lengths at the end minus at the start), lowest tension,
the KKT residual at every point (least-squares multipliers,
:func:`elastica_petsc.solvers.share.kkt_residual`), and a brute force over
the one-parameter family of tension sets on the target at ``--picks``
points (:func:`elastica_petsc.solvers.share.family`): the shared objective
must not exceed any family member with P >= the floor.  Plain tracing
(no sharing) of the same circle for comparison.

Usage: python scripts/studies/share_study.py [--elements 180] [--step 1] [--picks 6]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "three_tendon.toml"


def brute_force(ctl, sharer, result, k):
    """(f*, min f over the family with P >= floor, members checked) at point k."""
    from elastica_petsc.solvers.control import Evaluation
    from elastica_petsc.solvers.share import family, objective

    r = result.results[k]
    ev = Evaluation(r.p, r.equilibrium, r.sensitivity)
    on_floor = np.flatnonzero(r.p <= sharer.min_tension + 1e-9)
    j = int(on_floor[0]) if on_floor.size else 1
    fam = (family(ctl, ev, r.target, j, r.p[j] + np.linspace(0.01, 1.0, 15))
           + family(ctl, ev, r.target, j, r.p[j] - np.linspace(0.01, 1.0, 15)))
    fam = [e for e in fam if np.min(e.p) >= sharer.min_tension - 1e-12]
    f_star = objective(sharer.share, ev)[0]
    return f_star, min(objective(sharer.share, e)[0] for e in fam), len(fam)


def study(ctl, arm, targets, share, floor_N, picks):
    from elastica_petsc.solvers.control import Evaluation
    from elastica_petsc.solvers.share import TensionSharer, kkt_residual
    from elastica_petsc.studies.schedule import trace_schedule

    sharer = None if share is None else TensionSharer(ctl, share, floor_N / arm.force_scale_N)
    t0 = time.perf_counter()
    planned = trace_schedule(ctl, targets, sharer=sharer)
    res = planned.path
    out = {"share": share or "none", "min_tension_floor_N": floor_N,
           "points": res.n_points, "reached": int(res.converged.sum()),
           "approach_reached": f"{int(planned.approach.converged.sum())}/"
                               f"{planned.approach.n_points}",
           "seconds": round(time.perf_counter() - t0, 2),
           "ms_per_path_point": round(1e3 * res.seconds / res.n_points, 2),
           "max_tip_error_mm": float(res.tip_errors_mm.max()),
           "closure_mm": np.abs(res.cable_lengths_mm[-1] - res.cable_lengths_mm[0]).tolist(),
           "lowest_tension_N": res.tensions_N.min(axis=0).tolist(),
           "cable_length_range_mm": [[float(a), float(b)] for a, b in
                                     zip(res.cable_lengths_mm.min(0), res.cable_lengths_mm.max(0))]}
    if sharer is None:
        return out
    kkt = [kkt_residual(share, Evaluation(r.p, r.equilibrium, r.sensitivity),
                        sharer.min_tension, upper=ctl.upper) for r in res.results]
    out["max_kkt_residual"] = float(max(kkt))
    out["points_all_tensions_above_floor"] = int(np.sum(np.all(
        res.p > sharer.min_tension + 1e-6, axis=1)))
    ks = np.linspace(0, res.n_points - 1, picks + 2)[1:-1].round().astype(int)
    checks = [brute_force(ctl, sharer, res, int(k)) for k in ks]
    out["brute_force"] = [{"point": int(k), "f_shared": f, "f_family_min": m, "members": n,
                           "ok": bool(m >= f - 1e-9 * abs(f))}
                          for k, (f, m, n) in zip(ks, checks)]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--step", type=float, default=1.0)
    ap.add_argument("--center", type=float, nargs=2, default=(450.0, 290.0))
    ap.add_argument("--radius", type=float, default=40.0)
    ap.add_argument("--picks", type=int, default=6)
    args = ap.parse_args()
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.studies import trace as paths

    arm = load_config(CONFIG)
    targets = paths.densify(paths.circle(args.center, args.radius), args.step)
    rows = []
    with TipController(arm, n_elements=args.elements) as ctl:
        for share, floor_N in ((None, 0.0), ("min-norm", 0.0), ("min-energy", 0.0),
                               ("min-norm", 1.0)):
            rows.append(study(ctl, arm, targets, share, floor_N, args.picks))
            print(json.dumps(rows[-1]), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
