"""The quasi-static limit of `simulate` on the Fig. 3a schedule (issue 22, docs/model.md §16.7).

Writes the Fig. 3a motor schedule (`trace --shape paper-triangle --schedule`, its time
column at the suggested tracing speed), plays it at several speeds (the time column
divided by a speed factor: 0.01 is 100 times slower, 4 is 4 times faster) through
`simulate` on the same mesh, and reports the tip's deviation from the schedule's
quasi-static tip columns at the rows' times (where the played cable lengths are the
schedule's own; between rows the drive interpolates the lengths by cubics, the tips
would be compared with a straight line): its maximum over the run, over the path phase,
and at the last row.  Saves a figure of deviation against time and of the maxima
against speed.  The step: the straight arm's first period / --steps-per-period (it must
resolve the first mode: with steps of a period or more the cables' velocity-level law
admits spurious step solutions, docs/model.md §16.7).  Speeds below 1 play only the
schedule's first --slow-seconds (of its own time; the whole of it 100 times slower is
18,800 s simulated).

    python scripts/studies/quasi_static_limit.py [--speeds 0.01 1 2 4] [--elements 180]
        [--steps-per-period 100] [--slow-seconds 2] [--slow-steps-per-period 20]
        [--png docs/quasi_static_limit.png]
"""
from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import elastica_petsc as ep
from elastica_petsc.core.model import Arm


def write_schedule(folder: Path, elements: int) -> Path:
    path = folder / "fig3a.csv"
    subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "trace", "--shape",
                    "paper-triangle", "--elements", str(elements), "--schedule", str(path),
                    "--quiet", "--overwrite"], check=True, capture_output=True)
    return path


def played_at(schedule: Path, speed: float, folder: Path) -> tuple[Path, int]:
    """A copy of the schedule whose time column is divided by ``speed``; its row count."""
    with open(schedule, newline="") as fh:
        rows = list(csv.reader(fh))
    j = rows[0].index("time_s")
    for r in rows[1:]:
        r[j] = repr(float(r[j]) / speed)
    out = folder / f"fig3a_x{speed:g}.csv"
    with open(out, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return out, len(rows) - 1


def run(arm, schedule, speed, folder, args):
    path, _ = played_at(schedule, speed, folder)
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    t_rows = np.array([float(r["time_s"]) for r in rows])
    tips = np.array([[float(r["tip_x_mm"]), float(r["tip_y_mm"])] for r in rows])
    path_start = t_rows[[r["phase"] == "path" for r in rows].index(True)]
    f1_hz = 1.83                                # the straight arm's first frequency
    dt = 1.0 / (f1_hz * (args.steps_per_period if speed >= 1 else args.slow_steps_per_period))
    duration = args.slow_seconds / speed if speed < 1 else None
    wall = time.perf_counter()
    res = ep.simulate(arm, schedule_csv=str(path), elements=args.elements, dt_s=dt,
                      duration_s=duration)
    wall = time.perf_counter() - wall
    played = t_rows <= res.time_s[-1]
    sim_tip = np.column_stack([np.interp(t_rows[played], res.time_s, res.tip_mm[:, c])
                               for c in (0, 1)])
    dev = np.linalg.norm(sim_tip - tips[played], axis=1)
    on_path = t_rows[played] >= path_start
    return {"speed": speed, "duration_s": float(res.time_s[-1]), "dt_s": dt,
            "steps": int(res.steps), "completed": bool(res.completed), "wall_s": round(wall, 1),
            "switches": len(res.events), "max_deviation_mm": float(dev.max()),
            "max_deviation_path_mm": float(dev[on_path].max()) if on_path.any() else None,
            "end_deviation_mm": float(dev[-1]), "min_tension_N": float(res.tensions_N.min())
            }, (t_rows[played] / t_rows[-1], dev)


def plot(results, curves, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for r, (s, dev) in zip(results, curves):
        part = "" if r["speed"] >= 1 else " (its first seconds)"
        a.semilogy(s, np.maximum(dev, 1e-6), lw=0.8, label=f"x{r['speed']:g}{part}")
    a.axhline(0.05, color="k", ls=":", lw=0.8)
    a.set_xlabel("time / duration of the schedule at its speed")
    a.set_ylabel("tip deviation from the quasi-static trace [mm]")
    a.legend(title="speed")
    v = np.array([r["speed"] for r in results])
    for key, mark, label in (("max_deviation_mm", "o", "max over the run"),
                             ("max_deviation_path_mm", "s", "max on the path"),
                             ("end_deviation_mm", "^", "at the last row played")):
        y = np.array([np.nan if r[key] is None else max(r[key], 1e-8) for r in results])
        b.loglog(v, y, mark, label=label)
    b.axhline(0.05, color="k", ls=":", lw=0.8)
    b.set_xlabel("speed / suggested speed (8.8 mm/s)")
    b.set_ylabel("tip deviation [mm]")
    b.legend()
    fig.suptitle("Fig. 3a schedule played by `simulate` (paper's arm, undamped, rho_inf = 0.5)")
    fig.tight_layout()
    fig.savefig(png, dpi=120)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", type=float, nargs="+", default=[0.01, 1.0, 2.0, 4.0])
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--steps-per-period", type=int, default=100)
    ap.add_argument("--slow-seconds", type=float, default=2.0)
    ap.add_argument("--slow-steps-per-period", type=int, default=20)
    ap.add_argument("--png", default="docs/quasi_static_limit.png")
    args = ap.parse_args()
    arm = Arm.paper()
    results, curves = [], []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        schedule = write_schedule(folder, args.elements)
        for speed in args.speeds:
            r, c = run(arm, schedule, speed, folder, args)
            print(json.dumps(r), flush=True)
            results.append(r)
            curves.append(c)
    plot(results, curves, args.png)
    print(f"figure: {args.png}")


if __name__ == "__main__":
    main()
