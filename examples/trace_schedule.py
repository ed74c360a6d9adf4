"""Tip control along a circle, warm-started point to point, and the motor
schedule a controller can send to the spools (Sec. 4.5, Fig. 3).

Run: python examples/trace_schedule.py [schedule.csv]
"""
import sys

import numpy as np

import elastica_petsc as ep

arm = ep.Arm.paper()
angles = np.linspace(0.0, 2.0 * np.pi, 25)
circle_mm = np.column_stack((450.0 + 40.0 * np.cos(angles), 250.0 + 40.0 * np.sin(angles)))
path = ep.trace(arm, circle_mm, step_mm=5.0)
print(f"{path.n_points} targets, all reached: {path.all_converged}, "
      f"largest tip error {path.tip_errors_mm.max():.1e} mm")
print("tensions at the start [N]:", path.tensions_N[0].round(3))
print("largest tension along the path [N]:", path.tensions_N.max().round(3))
# For the motors: an approach from the straight arm, then the path, timed at 5 mm/s.
plan = ep.schedule(arm, circle_mm, step_mm=5.0, speed_mm_s=5.0)
print(f"schedule: {plan.schedule.n_rows} rows, {plan.schedule.duration_s:.1f} s at 5 mm/s")
if len(sys.argv) > 1:
    print("schedule written to", plan.schedule.write_csv(sys.argv[1]))
