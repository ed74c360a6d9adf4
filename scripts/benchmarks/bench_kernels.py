"""This tree against another (e.g. main before the compiled kernels), same machine, interleaved.

    .venv/bin/python scripts/benchmarks/bench_kernels.py --base /tmp/base [--rounds 3]

``--base``: a source tree of elastica_petsc (``git archive <commit> | tar -x -C
/tmp/base``; its compiled kernels, if it has any, built there with
``python setup.py build_ext --inplace``).  Each round runs one child process
per tree, the base first, with the tree's package first on ``sys.path``; each
child measures, on the paper's arm at 180 elements:

1. the warm forward solve (p = (25.2, 10.8) from the equilibrium at p + 0.1)
   and the cold one (from the straight arm): median wall time of single calls;
2. Fig. 2: tip control to x_d = (535.8, 222.6) mm from P = 0 (BLMVM), median;
3. Fig. 3a path tracing: ``--targets`` warm-started targets of the drawing
   about (400, 200) mm in 1 mm steps, targets per second of wall time and of
   the process's CPU time (a shared machine preempts; CPU time does not count
   the waits).

The report gives the median over rounds of each quantity and the base/new
ratio of each round (the speed-up; the rounds interleave the trees, so each
ratio compares runs under the same load).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def measure(calls: int, n_targets: int) -> dict:
    """The child: every quantity of the module docstring, in seconds or targets/s."""
    import numpy as np
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.solvers.equilibrium import EquilibriumSolver
    from elastica_petsc.studies import trace as paths
    sys.path.insert(0, HERE)
    from timing import median_time

    p = np.array([25.2, 10.8])
    arm = load_config()
    out = {}
    with EquilibriumSolver(Discretisation.from_arm(arm)) as solver:
        near = solver.solve(p + 0.1)
        out["warm_s"] = median_time(lambda: solver.solve(p, start=near), calls, warmup=True)
        out["cold_s"] = median_time(lambda: solver.solve(p), max(5, calls // 20), warmup=True)
    with TipController(arm, n_elements=180) as ctl:
        out["fig2_s"] = median_time(lambda: ctl.solve_mm((535.8, 222.6), p0=[0.0, 0.0]),
                                    max(5, calls // 20), warmup=True)
        targets = paths.densify(paths.paper_triangle([400.0, 200.0]), 1.0)[: n_targets + 1]
        first = ctl.solve_mm(targets[0])
        cpu, wall = time.process_time(), time.perf_counter()
        trace = paths.trace(ctl, targets[1:], p0=first.p, start=first.equilibrium)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        assert trace.all_converged
        out["path_wall_per_s"] = n_targets / wall
        out["path_cpu_per_s"] = n_targets / cpu
    return out


def child(tree: str, calls: int, n_targets: int) -> dict:
    env = dict(os.environ, PYTHONPATH=tree)
    cmd = [sys.executable, os.path.abspath(__file__), "--child", "--calls", str(calls),
           "--targets", str(n_targets)]
    done = subprocess.run(cmd, env=env, cwd=tree, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


ROWS = [("warm forward solve", "warm_s", "ms"), ("cold forward solve", "cold_s", "ms"),
        ("Fig. 2 control from P = 0 (BLMVM)", "fig2_s", "ms"),
        ("Fig. 3a path, targets/s (wall)", "path_wall_per_s", "/s"),
        ("Fig. 3a path, targets/s (CPU)", "path_cpu_per_s", "/s")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", help="the other source tree")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--calls", type=int, default=400)
    parser.add_argument("--targets", type=int, default=400)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure(args.calls, args.targets)))
        return
    if not args.base:
        parser.error("--base DIR is required")
    load = os.getloadavg()[0]
    base, new = [], []
    for _ in range(args.rounds):
        base.append(child(os.path.abspath(args.base), args.calls, args.targets))
        new.append(child(ROOT, args.calls, args.targets))
    print(f"load average {load:.2f} -> {os.getloadavg()[0]:.2f}; {args.rounds} interleaved "
          f"rounds; base {args.base}, new {ROOT}\n")
    print("| quantity | base (median) | new (median) | speed-up per round |")
    print("|---|---|---|---|")
    for label, key, unit in ROWS:
        b = statistics.median(r[key] for r in base)
        n = statistics.median(r[key] for r in new)
        if unit == "ms":
            ups = [rb[key] / rn[key] for rb, rn in zip(base, new)]
            cells = f"{b * 1e3:.3f} ms | {n * 1e3:.3f} ms"
        else:
            ups = [rn[key] / rb[key] for rb, rn in zip(base, new)]
            cells = f"{b:.0f} | {n:.0f}"
        print(f"| {label} | {cells} | {', '.join(f'{u:.2f}' for u in ups)} |")


if __name__ == "__main__":
    main()
