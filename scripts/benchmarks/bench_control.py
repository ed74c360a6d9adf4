#!/usr/bin/env python3
"""Benchmark tip control (issue 3): warm-started path tracing and cold Fig. 2 solves.

1. The drawing of Fig. 3a (triangle, incircle, circumcircle) about a centre
   in the workspace, densified to 1 mm steps, traced with warm starts
   (Sec. 4.5 (v)) on the paper's arm at 180 elements: targets per second and
   iterations per point, median of repeated runs.  Targets: >= 300 targets/s,
   <= 5 iterations per point.
   The paper's gradient descent (Algorithm 1) on the same path, one run.
2. Fig. 2 (x_d = (535.8, 222.6) mm from P = 0), cold: wall time and
   iterations, BLMVM against the paper's gradient descent.
3. Where the time goes on the path: equilibrium solves (SNES with load
   stepping), sensitivities (assembly + LU), the rest (TAO, Python).

Usage: python scripts/benchmarks/bench_control.py [--repeat 5] [--step 1.0] [--center 400,200]
       [--elements 180] [--method blmvm|brgn|gd] [--no-gd] [PETSc options, e.g. -ctl_tao_monitor]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time


def parse(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--step", type=float, default=1.0, help="path spacing [mm]")
    ap.add_argument("--center", default="400,200", help="drawing centre x,y [mm]")
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--method", default="blmvm", help="tip-control method of the path")
    ap.add_argument("--no-gd", action="store_true", help="skip the gd run on the path")
    return ap.parse_known_args(argv)


class Timer:
    """Wrap an instance method and accumulate its wall time and call count."""

    def __init__(self, obj, name):
        self.obj, self.name = obj, name
        self.inner = getattr(obj, name)
        self.seconds, self.calls = 0.0, 0
        setattr(obj, name, self)

    def __call__(self, *args, **kw):
        t = time.perf_counter()
        try:
            return self.inner(*args, **kw)
        finally:
            self.seconds += time.perf_counter() - t
            self.calls += 1

    def reset(self):
        self.seconds, self.calls = 0.0, 0


def main(argv=None) -> int:
    args, petsc_args = parse(sys.argv[1:] if argv is None else argv)
    import petsc4py
    petsc4py.init([sys.argv[0], *petsc_args])
    import numpy as np

    from elastica_petsc.studies import trace as paths
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import TipController

    arm = load_config()
    center = [float(v) for v in args.center.split(",")]
    targets = paths.densify(paths.paper_triangle(center), args.step)

    # --- 1. warm-started path ---------------------------------------------------------
    rates, per_point_ms, all_its, all_evals, first_its = [], [], None, None, None
    prof = {}
    with TipController(arm, n_elements=args.elements, method=args.method) as ctl:
        # tip control's equilibrium solves (``follow`` since the solver contract)
        t_solve = Timer(ctl.solver, "follow" if hasattr(ctl.solver, "follow") else "solve")
        t_sens = Timer(ctl.sens, "compute")
        for run in range(args.repeat):
            first = ctl.solve_mm(targets[0])          # cold start, not timed
            if not first.converged:
                print(f"first point {targets[0]} not reached: {first.message}")
                return 1
            t_solve.reset(), t_sens.reset()
            trace = paths.trace(ctl, targets[1:], p0=first.p, start=first.equilibrium)
            if not trace.all_converged:
                bad = np.flatnonzero(~trace.converged)
                print(f"{len(bad)} path points not reached, first {trace.targets_mm[bad[0]]}")
                return 1
            n = trace.n_points
            rates.append(n / trace.seconds)
            per_point_ms.append(1e3 * trace.seconds / n)
            all_its, all_evals, first_its = trace.iterations, trace.evaluations, first.iterations
            prof[run] = (trace.seconds, t_solve.seconds, t_solve.calls, t_sens.seconds,
                         t_sens.calls, int(trace.evaluations.sum()))
            max_err = trace.tip_errors_mm.max()
            mono = trace.monotonic_fraction()
    median_run = sorted(prof, key=lambda r: prof[r][0])[len(prof) // 2]
    total, s_solve, n_solve, s_sens, n_sens, n_evals = prof[median_run]

    # the paper's gradient descent on the same path (one run: it is slow)
    gd_trace = None
    if not args.no_gd:
        with TipController(arm, method="gd", n_elements=args.elements) as ctl:
            first_gd = ctl.solve_mm(targets[0])
            gd_trace = paths.trace(ctl, targets[1:], p0=first_gd.p, start=first_gd.equilibrium)

    # --- 2. cold Fig. 2 -----------------------------------------------------------------
    fig2 = {}
    from elastica_petsc.solvers.control import METHODS
    for method in METHODS:
        times, res = [], None
        with TipController(arm, method=method, n_elements=args.elements) as ctl:
            for _ in range(args.repeat):
                t = time.perf_counter()
                res = ctl.solve_mm((535.8, 222.6), p0=[0.0, 0.0])
                times.append(time.perf_counter() - t)
        fig2[method] = (statistics.median(times), res)

    # --- report ---------------------------------------------------------------------------
    print(f"## Tip control benchmark ({args.elements} elements, paper arm, {args.method} on "
          f"the path, median of {args.repeat} runs)\n")
    print(f"Path: Fig. 3a drawing about ({center[0]:g}, {center[1]:g}) mm, "
          f"{args.step:g} mm steps, {len(targets) - 1} warm-started targets "
          f"(first point cold: {first_its} iterations); tolerance 1e-5 mm, "
          f"max tip error {max_err:.1e} mm.\n")
    print("| quantity | value | target |")
    print("|---|---|---|")
    print(f"| targets per second | {statistics.median(rates):.0f} | >= 300 |")
    print(f"| time per target | {statistics.median(per_point_ms):.2f} ms | paper: < 1 s |")
    print(f"| iterations per point (median / max) | {np.median(all_its):.0f} / "
          f"{all_its.max()} | <= 5 |")
    print(f"| equilibrium solves per point (median / max) | "
          f"{np.median(all_evals - 1):.0f} / {(all_evals - 1).max()} | |")
    if gd_trace is not None:
        print(f"| gd (Algorithm 1), same path, 1 run: targets/s; iterations median / max | "
              f"{gd_trace.n_points / gd_trace.seconds:.0f}; "
              f"{np.median(gd_trace.iterations):.0f} / {gd_trace.iterations.max()} "
              f"({int(gd_trace.converged.sum())}/{gd_trace.n_points} reached) | |")
    print(f"| per-tendon monotonic dL dP < 0 (fraction of steps) | "
          f"{', '.join(f'{m:.2f}' for m in mono)} | |")
    print()
    print("| Fig. 2 cold, from P = 0 | wall time | iterations | evaluations | tip error |")
    print("|---|---|---|---|---|")
    for method, (sec, res) in fig2.items():
        print(f"| {method} | {1e3 * sec:.1f} ms | {res.iterations} | {res.evaluations} | "
              f"{res.tip_error_mm:.1e} mm |")
    print()
    rest = total - s_solve - s_sens
    print("| where the path time goes | share | per call |")
    print("|---|---|---|")
    print(f"| equilibrium (SNES + load-step checks) | {100 * s_solve / total:.0f} % | "
          f"{1e3 * s_solve / max(n_solve, 1):.3f} ms x {n_solve} |")
    print(f"| sensitivities (assembly + LU + solves) | {100 * s_sens / total:.0f} % | "
          f"{1e3 * s_sens / max(n_sens, 1):.3f} ms x {n_sens} |")
    print(f"| TAO, callbacks, bookkeeping | {100 * rest / total:.0f} % | "
          f"{1e3 * rest / (len(targets) - 1):.3f} ms per target |")
    print(f"\n({n_evals} objective evaluations, {n_evals - n_solve} served from the "
          "warm-start cache)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
