"""Cost of one calibration evaluation (residuals + exact Jacobian, warm rows) on a
guided arm under its weight against the paper's arm (issues 23/24): the same
number of rows, elements and parameters (B and both routing points), ratio of
medians measured in one run.

    .venv/bin/python scripts/benchmarks/bench_calibrate_guided.py [rows] [elements] [repeats]

The guided arm is configs/guided3.toml with gravity (0, -9.81) m/s^2: its state has
2 x 4 chords more (3 guides and an end per tendon) and one more right-hand side
(the weight's 1/B) per row.
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import median_time  # noqa: E402

from elastica_petsc.core.calibration_params import ParameterModel  # noqa: E402
from elastica_petsc.core.model import Arm, load_config  # noqa: E402
from elastica_petsc.studies.calibrate import CalibrationProblem  # noqa: E402
from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize  # noqa: E402

VARY = ["bending_stiffness", "tendon1.route", "tendon2.route"]
ROOT = Path(__file__).resolve().parents[2]


def problem(arm: Arm, rows: int):
    rng = np.random.default_rng(1)
    P = np.column_stack((rng.uniform(1, 9, rows), rng.uniform(0.5, 5, rows)))
    model = ParameterModel(arm, VARY)
    kinds = ["tension"] * (rows // 2) + ["length"] * (rows - rows // 2)
    data = synthesize(arm, VARY, model.start(), command_rows(arm, P, kinds), noise_mm=0.1)
    prob = CalibrationProblem(model, data)
    prob.match_branches(model.start())
    theta = model.start() * (1 + 1e-3)
    prob.evaluate(theta)                                  # rows warm from here on
    return prob, theta


def main(rows: int = 20, elements: int = 120, repeats: int = 5) -> None:
    paper = dataclasses.replace(Arm.paper(), elements=elements)
    guided = dataclasses.replace(load_config(ROOT / "configs" / "guided3.toml"),
                                 elements=elements, gravity_m_s2=(0.0, -9.81))
    times = {}
    for name, arm in (("paper", paper), ("guided+weight", guided)):
        prob, theta = problem(arm, rows)
        times[name] = median_time(lambda: prob.evaluate(theta), repeats)
        print(f"{name}: {rows} rows, {elements} elements: median {1e3 * times[name]:.1f} ms "
              f"per evaluation ({1e3 * times[name] / rows:.2f} ms per row)")
    print(f"ratio guided+weight / paper: {times['guided+weight'] / times['paper']:.2f}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
