"""Coverage of calibrate's 95 % intervals (issue 23): 50 noise draws (0.5 mm) on the
40 rows of the perturbed paper arm (B x 1.15, routing points moved 3-5 mm, motor
offsets 2 mm; 30 elements); prints the share of intervals that hold the truth,
per parameter and pooled (should be 90-99 %).

    .venv/bin/python scripts/studies/calibration_coverage.py [draws] [first_seed]
"""
from __future__ import annotations

import sys
import time

import numpy as np

sys.path.insert(0, "tests")
from test_calibrate import ARM, VARY, forty_rows, perturbed_truth  # noqa: E402

from elastica_petsc.core.calibration_params import ParameterModel  # noqa: E402
from elastica_petsc.studies.calibrate import CalibrationProblem, fit  # noqa: E402
from elastica_petsc.studies.calibrate_report import uncertainty  # noqa: E402
from elastica_petsc.studies.calibration_synthetic import synthesize  # noqa: E402


def main(draws: int = 50, first_seed: int = 1000) -> None:
    model = ParameterModel(ARM, VARY)
    truth = perturbed_truth(model)
    commands = forty_rows()
    clean = synthesize(ARM, VARY, truth, commands).points_mm()
    hits, t0 = [], time.perf_counter()
    for seed in range(draws):
        noise = 0.5 * np.random.default_rng(first_seed + seed).standard_normal(clean.shape)
        problem = CalibrationProblem(model, commands.with_points(clean + noise))
        result = fit(problem)
        sigma = np.array(uncertainty(problem, result)["sigma"], float)
        hits.append(np.abs(result.theta - truth) <= 1.96 * sigma)
    hits = np.array(hits)
    print(f"{draws} draws (seeds {first_seed}..{first_seed + draws - 1}) in {time.perf_counter() - t0:.1f} s")
    for name, share in zip(model.names, hits.mean(axis=0)):
        print(f"  {name:20s} {100 * share:5.1f} %")
    print(f"pooled: {100 * hits.mean():.1f} % of {hits.size} intervals")


if __name__ == "__main__":
    main(*(int(v) for v in sys.argv[1:3]))
