"""Designing the arm for a task (issue 13): a circle of radius 80 mm about
(420, 260) mm leaves the paper's workspace W_0; moving the routing points
(within 100 mm of where they are, off the arm) makes all of it reachable.

Run: python examples/design_task.py [designed.toml]
(60 elements and a 37-point circle, to stay quick; the command line
`elastica-petsc design` and `trace --config` do the same at full resolution.)
"""
import sys

import numpy as np

import elastica_petsc as ep
from elastica_petsc.studies.trace import circle

arm = ep.Arm.paper()
task = circle((420.0, 260.0), 80.0, n=37)
design = ep.design(arm, task, vary=["tendon1.route", "tendon2.route"], elements=60)
before, after = design.misfit_before, design.misfit_after
print(f"paper's arm: {before.reached.sum()} of {len(task)} targets reached, "
      f"largest miss {before.errors_mm.max():.2f} mm")
for k, t in enumerate(design.arm_after.tendons, start=1):
    print(f"r_{k} -> ({t.route_mm[0]:.2f}, {t.route_mm[1]:.2f}) mm")
check = ep.trace(design.arm_after, task, step_mm=10.0, elements=60)
print(f"designed arm, traced again: all reached: {check.all_converged}, "
      f"largest tip error {check.tip_errors_mm.max():.1e} mm, "
      f"smallest tension {np.min(check.tensions_N):.3f} N")
if len(sys.argv) > 1:
    from elastica_petsc.io.design import write_config
    print("written to", write_config(sys.argv[1], design.arm_after, overwrite=True))
