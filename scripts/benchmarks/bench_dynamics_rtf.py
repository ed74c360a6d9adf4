"""Real-time factor and cost per step of `simulate` (issue 22): this tree against another
revision (default: the commit before the compiled dynamics kernels), interleaved in one run.

Measured, CPU time of one process (``time.process_time``: the host is shared), median
over ``--repeats`` runs and then over ``--rounds`` interleaved rounds:

* cost per step against N (180 ... 20,160 elements) of the issue's free vibration (the
  paper's arm released from the equilibrium at P = (0, 0.05) N, fixed steps of a 200th of
  the first period, force control);
* the real-time factor at 180 elements (simulated seconds per CPU second) of that free
  vibration and of the force-controlled path (the Fig. 3a schedule of ``trace --shape
  paper-triangle --schedule``, its tensions played as a tension history), at 200 and at 50
  steps per first period;
* (this tree only, ``--accuracy``) the tip error at t = 12 s of the free vibration against
  a run with 1600 steps per period, and the energy drift, at 50, 100, 200 steps per period.

    python scripts/benchmarks/bench_dynamics_rtf.py [--baseline REV] [--rounds 2] [--repeats 3]

The baseline is checked out with ``git worktree`` into /tmp and its kernels built in place;
each measurement runs in a fresh interpreter (``--worker``) with that tree first on the path.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[2]
BASELINE = "22793a6"                  # main before the compiled dynamics kernels
SIZES = (180, 720, 2880, 11520, 20160)
F1_HZ = 1.829                         # first frequency of the released state (simulate prints it)


# --- the measurements (run in a worker process, in the tree being measured) --------------
def _setup(N, release=True):
    import numpy as np

    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.core.model import Arm
    from elastica_petsc.solvers.equilibrium import solve_equilibrium
    from elastica_petsc.studies.simulate import build_inertia, time_scale_s

    arm = Arm.paper()
    disc = Discretisation.from_arm(arm, N)
    theta = solve_equilibrium(disc, arm.tensions_from_N([0.0, 0.05])).theta if release \
        else np.zeros(N + 1)
    return arm, disc, build_inertia(arm, disc), time_scale_s(arm), theta


def _run(disc, inertia, tau, theta, drive, spp, duration_s):
    """(CPU seconds, steps, trajectory) of one fixed-step run."""
    import numpy as np

    from elastica_petsc.solvers.dynamics import DynamicsSolver

    sim = DynamicsSolver(disc, inertia, dt0=1.0 / (F1_HZ * spp) / tau, adaptive=False)
    start = time.process_time()
    tr = sim.run(theta, np.zeros(disc.n_elements), drive.tensions(0.0), drive, None,
                 duration_s / tau)
    return time.process_time() - start, tr.steps, tr


def _median(fn, repeats):
    return statistics.median(fn() for _ in range(repeats))


def worker(args) -> dict:
    import numpy as np

    import elastica_petsc
    from elastica_petsc.core.drive import TensionDrive, read_tension_history

    out = {"module": str(Path(elastica_petsc.__file__).parent), "per_step_us": {}, "rtf": {}}
    free = TensionDrive.constant([0.0, 0.0])
    for N in args.sizes:
        arm, disc, inertia, tau, theta = _setup(N)
        steps = args.steps if N <= 2880 else max(10, args.steps // 5)
        duration = steps / (F1_HZ * 200)

        def one():
            cpu, done, _ = _run(disc, inertia, tau, theta, free, 200, duration)
            return 1e6 * cpu / done

        one()                                            # warm-up (imports, first factor)
        out["per_step_us"][N] = _median(one, args.repeats)
    arm, disc, inertia, tau, theta = _setup(180)
    t_h, P_h = read_tension_history(args.history, 2)
    path = TensionDrive((t_h - t_h[0]) / tau, arm.tensions_from_N(P_h))
    straight = np.zeros(181)
    for name, start, drive, duration in (("free vibration", theta, free, 4.0),
                                         ("Fig. 3a tensions", straight, path, 20.0)):
        for spp in (200, 50):
            cpu = _median(lambda: _run(disc, inertia, tau, start, drive, spp, duration)[0],
                          args.repeats)
            out["rtf"][f"{name}, {spp} steps/period"] = duration / cpu
    if args.accuracy:
        out["accuracy"] = accuracy(disc, inertia, tau, theta, free, arm.length_mm)
    return out


def accuracy(disc, inertia, tau, theta, drive, length_mm) -> dict:
    """Tip error [mm] at 12 s against 1600 steps per period, and the relative drift of
    kinetic + strain energy, at 50, 100 and 200 steps per period."""
    import numpy as np

    def tip_and_drift(spp):
        _, _, tr = _run(disc, inertia, tau, theta, drive, spp, 12.0)
        E = np.array(tr.kinetic) + np.array(tr.strain)
        return disc.node_positions(tr.theta[-1])[-1] * length_mm, float(np.max(np.abs(E - E[0])) / E[0])

    ref, _ = tip_and_drift(1600)
    result = {}
    for spp in (50, 100, 200):
        tip, drift = tip_and_drift(spp)
        result[spp] = {"tip_error_mm": float(np.linalg.norm(tip - ref)), "energy_drift": drift}
    return result


# --- the driver --------------------------------------------------------------------------
def baseline_tree(rev: str) -> Path:
    """A worktree of ``rev`` in /tmp with its kernels built in place (reused if present)."""
    tree = Path(f"/tmp/elastica-bench-{rev}")
    if not tree.exists():
        subprocess.run(["git", "-C", str(HERE), "worktree", "add", "--detach", str(tree), rev],
                       check=True, capture_output=True)
        subprocess.run([sys.executable, "setup.py", "-q", "build_ext", "--inplace"], cwd=tree,
                       check=True, capture_output=True)
    return tree


def measure(tree: Path, args, accuracy_too: bool) -> dict:
    cmd = [sys.executable, str(HERE / "scripts/benchmarks/bench_dynamics_rtf.py"), "--worker",
           "--repeats", str(args.repeats), "--steps", str(args.steps), "--history", args.history,
           "--sizes", *map(str, args.sizes)] + (["--accuracy"] if accuracy_too else [])
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1")
    done = subprocess.run(cmd, cwd=tree, env=env, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default=BASELINE)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    ap.add_argument("--history", default="/tmp/elastica-bench-fig3a.csv",
                    help="the Fig. 3a schedule CSV (written by trace if missing)")
    ap.add_argument("--accuracy", action="store_true")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args)))
        return
    if not Path(args.history).exists():
        subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "trace", "--shape",
                        "paper-triangle", "--schedule", args.history, "--quiet"], check=True,
                       capture_output=True)
    trees = {"old": baseline_tree(args.baseline), "new": HERE}
    runs = {"old": [], "new": []}
    for k in range(args.rounds):
        for name, tree in trees.items():
            runs[name].append(measure(tree, args, args.accuracy and name == "new" and k == 0))
            print(f"round {k + 1} {name}: {runs[name][-1]['module']}", file=sys.stderr)
    report(args, runs)


def report(args, runs):
    def med(name, part, key):
        return statistics.median(r[part][key] for r in runs[name])

    print(f"load average {os.getloadavg()[0]:.2f}; baseline {args.baseline}; medians of "
          f"{args.repeats} runs x {args.rounds} rounds, CPU time\n")
    print("| N | old µs/step | new µs/step | old/new | new µs/step/element | new, ratio to N=180 |")
    print("|---:|---:|---:|---:|---:|---:|")
    base = med("new", "per_step_us", str(args.sizes[0]))
    for N in map(str, args.sizes):
        old, new = med("old", "per_step_us", N), med("new", "per_step_us", N)
        print(f"| {N} | {old:.0f} | {new:.0f} | {old / new:.2f} | {new / int(N):.3f} | "
              f"{new / base:.1f} |")
    print("\n| run (180 elements) | old real-time factor | new real-time factor | new/old |")
    print("|---|---:|---:|---:|")
    for key in runs["new"][0]["rtf"]:
        old, new = med("old", "rtf", key), med("new", "rtf", key)
        print(f"| {key} | {old:.2f} | {new:.2f} | {new / old:.2f} |")
    acc = runs["new"][0].get("accuracy")
    if acc:
        print("\n| steps per period | tip error at 12 s [mm] | energy drift (relative) |")
        print("|---:|---:|---:|")
        for spp, a in acc.items():
            print(f"| {spp} | {a['tip_error_mm']:.3g} | {a['energy_drift']:.2g} |")


if __name__ == "__main__":
    main()
