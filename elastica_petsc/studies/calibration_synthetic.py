"""Synthetic calibration data: the states a perturbed arm would show, plus
Gaussian measurement noise (for tests, the worked example and coverage
studies; every file written from here says it is synthetic)."""
from __future__ import annotations

import numpy as np

from ..core.calibration_data import CalibrationData
from ..core.calibration_params import ParameterModel
from ..core.model import Arm
from .calibrate import CalibrationProblem


def command_rows(arm: Arm, tensions_N, kinds, *, slack_mm=None, loading=None,
                 elements: int | None = None) -> CalibrationData:
    """Commands (no measurements yet) for the rows ``tensions_N`` (m, n) [N]:
    a "tension" row uses them as they are; a "length" row commands the cable
    lengths that the nominal ``arm`` has at those tensions (plus ``slack_mm``
    (m, n) if given: a longer cable, slack when the slack exceeds the
    stretch); a "steps" row the same lengths as microsteps from the straight
    arm on the nominal spool."""
    from ..solvers.calibration import RowSolver

    P = np.atleast_2d(np.asarray(tensions_N, float))
    m, n = P.shape
    kinds = np.asarray(kinds if not isinstance(kinds, str) else [kinds] * m)
    slack = np.zeros((m, n)) if slack_mm is None else np.asarray(slack_mm, float)
    loading = tuple(loading) if loading is not None else (None,) * m
    inputs = P.copy()
    motor = arm.motor
    per_step = 2 * np.pi * motor.spool_radius_mm / (motor.steps_per_rev * motor.microsteps)
    with RowSolver(arm, elements) as rs:
        straight = rs.len.lengths_of(rs.disc.straight()) * arm.length_mm
        for r in np.flatnonzero(kinds != "tension"):
            state = rs.solve("tension", arm.tensions_from_N(P[r]), loading[r])
            if not state.converged:
                raise RuntimeError(f"row {r}: {state.message}")
            L = rs.len.lengths_of(state.u) * arm.length_mm + slack[r]
            inputs[r] = L if kinds[r] == "length" else np.rint((L - straight) / per_step)
    return CalibrationData(kinds, inputs, np.zeros((m, 2)), np.zeros(0),
                           np.zeros((m, 0, 2)), loading, tuple(range(2, m + 2)), "synthetic")


def synthesize(arm: Arm, vary, theta_true, commands: CalibrationData, *, noise_mm: float = 0.0,
               seed: int | None = 0, marker_s_mm=(), elements: int | None = None
               ) -> CalibrationData:
    """Measurements of ``commands`` on the arm that ``vary`` = ``theta_true``
    describes (about ``arm``), with N(0, noise_mm^2) added to every coordinate."""
    marks = np.asarray(marker_s_mm, float)
    shaped = CalibrationData(commands.kinds, commands.inputs, commands.tips_mm, marks,
                             np.zeros((commands.n_rows, len(marks), 2)), commands.loading,
                             commands.lines, "synthetic")
    problem = CalibrationProblem(ParameterModel(arm, vary), shaped, elements)
    problem.orders = [o for o in commands.loading]
    points = problem.evaluate(theta_true, jacobian=False).points_mm
    rng = np.random.default_rng(seed)
    return shaped.with_points(points + noise_mm * rng.standard_normal(points.shape))
