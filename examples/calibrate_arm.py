"""Calibrating the arm to measured tips (issue 23), on SYNTHETIC data.

The data are not measurements: the tool makes them.  It takes the paper's arm
with B x 1.15, routing points moved by 3-5 mm and motor zeros off by 2 mm,
solves 20 tension-controlled and 20 motor-controlled (cable length) states,
and adds Gaussian noise of 0.5 mm to every tip and to a marker at s = 300 mm.
It then fits the nominal arm to them and prints what it found, with standard
deviations.  The data set is written first, so the command line can be tried
on it:

    elastica-petsc calibrate --data calibration_data.csv --elements 60 \\
        --vary bending_stiffness tendon1.route tendon2.route motor1.offset motor2.offset \\
        --out fitted.toml --plot fit.png

Run: python examples/calibrate_arm.py [folder]   (60 elements, to stay quick)
"""
import sys
from pathlib import Path

import numpy as np

import elastica_petsc as ep
from elastica_petsc.core.calibration_data import write_calibration_csv
from elastica_petsc.core.calibration_params import ParameterModel
from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize

folder = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
arm = ep.Arm.paper()
vary = ["bending_stiffness", "tendon1.route", "tendon2.route", "motor1.offset", "motor2.offset"]
truth = ParameterModel(arm, vary).start() * [1.15, 1, 1, 1, 1, 1, 1] \
    + [0.0, 3.0, -4.0, -3.5, 4.5, 2.0, 2.0]
rng = np.random.default_rng(1)
tensions_N = np.column_stack((rng.uniform(1, 9, 40), rng.uniform(0.5, 5, 40)))
commands = command_rows(arm, tensions_N, ["tension"] * 20 + ["length"] * 20, elements=60)
data = synthesize(arm, vary, truth, commands, noise_mm=0.5, seed=3, marker_s_mm=(300.0,),
                  elements=60)
path = write_calibration_csv(folder / "calibration_data.csv", data, [
    "SYNTHETIC data made by examples/calibrate_arm.py, not measurements: the paper's arm",
    "with B x 1.15, routing points moved by (3, -4) and (-3.5, 4.5) mm, motor offsets 2 mm,",
    "Gaussian noise 0.5 mm on every coordinate."])
print(f"synthetic data: {data.n_rows} rows written to {path.name}")

result = ep.calibrate(arm, path, vary=vary, folds=3, elements=60)
print(f"{'parameter':18s} {'truth':>10s} {'fitted':>10s} {'sigma':>8s}  |error|/sigma")
for p, t in zip(result.parameters(), truth):
    print(f"{p['name']:18s} {t:10.4f} {p['value']:10.4f} {p['sigma']:8.4f}  "
          f"{abs(p['value'] - t) / p['sigma']:.2f}")
s = result.summary()
print(f"residual RMS {s['residual']['rms_mm']:.3f} mm; cross-validation RMS "
      f"{s['cross_validation']['rms_mm']:.3f} mm")
print("undetermined:", s["undetermined"] or "none")
