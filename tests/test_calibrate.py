"""Calibration (issue 23): exact Jacobians, recovery of a perturbed arm,
honest uncertainties, identifiability, both input kinds, two branches."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from elastica_petsc.core.calibration_params import ParameterModel
from elastica_petsc.core.model import Arm, Tendon
from elastica_petsc.solvers.calibration import RowSolver
from elastica_petsc.studies.calibrate import CalibrationProblem, fit
from elastica_petsc.studies.calibrate_report import uncertainty
from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize

ELEMENTS = 30
ARM = dataclasses.replace(Arm.paper(), elements=ELEMENTS)
VARY = ["bending_stiffness", "tendon1.route", "tendon2.route", "motor1.offset", "motor2.offset"]


def perturbed_truth(model: ParameterModel) -> np.ndarray:
    """B x 1.15, routing points moved by 3-5 mm, motor offsets of 2 mm (issue 23)."""
    truth = model.start().copy()
    truth[0] *= 1.15
    truth[1:5] += [3.0, -4.0, -3.5, 4.5]
    truth[5:7] = 2.0
    return truth


def forty_rows(seed: int = 1):
    rng = np.random.default_rng(seed)
    P = np.column_stack((rng.uniform(1, 9, 40), rng.uniform(0.5, 5, 40)))
    return command_rows(ARM, P, ["tension"] * 20 + ["length"] * 20)


def taylor_remainders(f, df, x0, dx, steps=(0.2, 0.1, 0.05)):
    f0 = f(x0)
    return [np.linalg.norm(f(x0 + h * dx) - f0 - h * (df @ dx)) for h in steps]


def assert_order_two(rem):
    rates = np.log2(np.array(rem[:-1]) / np.array(rem[1:]))
    assert np.all(rates > 1.8), (rem, rates)


@pytest.mark.parametrize("case", ["tension", "length", "length_slack"])
def test_row_derivatives_taylor(case):
    """d points / d(routes, drive) by the implicit function theorem: remainder O(h^2)."""
    marks = (150.0, 310.0)
    p = ARM.tensions_from_N([4.4, 1.7])

    def solve(q):
        rho = ARM.routes() * 600 + q[:4].reshape(2, 2)
        arm = dataclasses.replace(ARM, tendons=tuple(
            Tendon(t.attach_mm, tuple(r)) for t, r in zip(ARM.tendons, rho)))
        rs = RowSolver(arm)
        drive = q[4:] if case == "tension" else q[4:] / 600
        state = rs.solve("tension" if case == "tension" else "length", drive)
        assert state.converged, state.message
        return rs, state, drive

    if case == "tension":
        drive0 = p
    else:
        rs = RowSolver(ARM)
        state = rs.solve("tension", p)
        drive0 = rs.len.lengths_of(state.u) * 600 + (0.0 if case == "length" else [0.0, 20.0])
    q0 = np.concatenate((np.zeros(4), drive0))
    rs, state, drive = solve(q0)
    assert (state.p[1] == 0.0) == (case == "length_slack")
    D = rs.derivatives("tension" if case == "tension" else "length", state,
                       None if case == "tension" else drive, marks).reshape(-1, 6)
    dq = np.random.default_rng(0).normal(size=6)
    rem = taylor_remainders(lambda q: solve(q)[0].points_mm(solve(q)[1].u, marks).ravel(), D,
                            q0, dq, steps=(1.0, 0.5, 0.25))
    assert_order_two(rem)


def test_parameter_jacobian_taylor_every_kind():
    """Every parameter kind, tension, length (one cable slack) and steps rows,
    tip and two markers: the residual's Jacobian passes a Taylor test."""
    vary = VARY + ["motor.spool_radius", "clamp.angle", "clamp.position", "frame.rotation",
                   "frame.offset"]
    rng = np.random.default_rng(1)
    P = np.column_stack((rng.uniform(1, 9, 6), rng.uniform(0.5, 5, 6)))
    slack = np.zeros((6, 2))
    slack[3, 1] = 40.0
    cmd = command_rows(ARM, P, ["tension"] * 2 + ["length"] * 2 + ["steps"] * 2, slack_mm=slack)
    model = ParameterModel(ARM, vary)
    data = synthesize(ARM, vary, model.start(), cmd, marker_s_mm=(200.0, 450.0))
    problem = CalibrationProblem(model, data)
    theta = model.start() + 0.1 * model.scales() * rng.normal(size=model.size)
    ev = problem.evaluate(theta)
    assert not ev.taut.all()                      # one length row has a slack cable
    for j, name in enumerate(model.names):
        e = np.zeros(model.size)
        e[j] = model.scales()[j]
        rem = taylor_remainders(lambda t: problem.evaluate(t, jacobian=False).residual,
                                ev.jacobian, theta, e)
        if name.startswith("frame.offset"):       # linear: the remainder is round-off
            assert max(rem) < 1e-6, (name, rem)
        else:
            assert_order_two(rem)


@pytest.mark.slow
def test_synthetic_recovery_noise_free():
    """40 rows of the perturbed paper arm, no noise: recovered to 1e-6 relative."""
    model = ParameterModel(ARM, VARY)
    truth = perturbed_truth(model)
    data = synthesize(ARM, VARY, truth, forty_rows())
    result = fit(CalibrationProblem(model, data))
    scale = np.maximum(np.abs(truth), 1.0)
    assert np.max(np.abs(result.theta - truth) / scale) < 1e-6, (result.theta, truth)


@pytest.mark.slow
def test_synthetic_noise_within_three_sigma():
    model = ParameterModel(ARM, VARY)
    truth = perturbed_truth(model)
    data = synthesize(ARM, VARY, truth, forty_rows(), noise_mm=0.5, seed=3)
    problem = CalibrationProblem(model, data)
    result = fit(problem)
    report = uncertainty(problem, result)
    sigma = np.array(report["sigma"], float)
    assert np.all(np.abs(result.theta - truth) < 3 * sigma), (result.theta - truth) / sigma
    assert report["undetermined"] == []
    assert 0.4 < np.sqrt(report["residual_variance_mm2"]) < 0.6      # the noise, 0.5 mm
    assert report["remaining_step_sigma"] < 1e-3


@pytest.mark.slow
def test_coverage_small():
    """A small honest version of the coverage study (scripts/studies/calibration_coverage.py:
    50 draws): over 4 noise draws the 95 % intervals of 7 parameters contain
    the truth in at least 85 % of the 28 cases (binomial: P(< 85 %) ~ 4 %)."""
    model = ParameterModel(ARM, VARY)
    truth = perturbed_truth(model)
    commands = forty_rows()
    clean = synthesize(ARM, VARY, truth, commands).points_mm()
    hits = []
    for seed in range(4):
        noise = 0.5 * np.random.default_rng(100 + seed).standard_normal(clean.shape)
        problem = CalibrationProblem(model, commands.with_points(clean + noise))
        result = fit(problem)
        sigma = np.array(uncertainty(problem, result)["sigma"], float)
        hits += list(np.abs(result.theta - truth) <= 1.96 * sigma)
    assert 0.85 <= np.mean(hits) <= 1.0, np.mean(hits)


def test_identifiability_slack_tendon_named():
    """Tendon 2 slack in every row, its routing point varied: reported by name,
    the rest still fitted."""
    rng = np.random.default_rng(2)
    P = np.column_stack((rng.uniform(1, 9, 20), np.zeros(20)))
    vary = ["bending_stiffness", "tendon1.route", "tendon2.route"]
    model = ParameterModel(ARM, vary)
    truth = model.start().copy()
    truth[0] *= 1.1
    truth[1:3] += [3.0, -2.0]
    data = synthesize(ARM, vary, truth, command_rows(ARM, P, "tension"))
    problem = CalibrationProblem(model, data)
    result = fit(problem)
    report = uncertainty(problem, result)
    assert report["undetermined"] == ["tendon2.route.x", "tendon2.route.y"]
    assert report["sigma"][3:] == [None, None]
    assert all(s is not None for s in report["sigma"][:3])
    assert any("tendon2.route" in w for w in report["undetermined_combinations"])
    np.testing.assert_allclose(result.theta[:3], truth[:3], rtol=1e-6)
    np.testing.assert_allclose(result.theta[3:], model.start()[3:])   # left where it was


def test_steps_rows_with_slack_cables():
    """Motor positions as microsteps, some cables slack: offsets, spool radius and a
    routing point recovered (noise-free)."""
    rng = np.random.default_rng(4)
    P = np.column_stack((rng.uniform(1, 9, 16), rng.uniform(0.5, 5, 16)))
    slack = np.zeros((16, 2))
    slack[::4, 1] = 30.0                            # tendon 2 paid out far: slack
    vary = ["tendon1.route", "motor1.offset", "motor2.offset", "motor.spool_radius"]
    model = ParameterModel(ARM, vary)
    truth = model.start() + [2.0, -3.0, 1.5, -2.0, 0.4]
    data = synthesize(ARM, vary, truth, command_rows(ARM, P, "steps", slack_mm=slack))
    problem = CalibrationProblem(model, data)
    result = fit(problem)
    taut = result.evaluation.taut
    assert 2 <= np.count_nonzero(~taut[::4, 1]) and taut[1::4].all()   # slack and taut rows
    np.testing.assert_allclose(result.theta, truth, rtol=1e-6, atol=1e-6)


def test_two_branches_and_matching():
    """Fig. 8: at P = (14, 6) N loading order 2,1 gives state 1, 1,2 state 3.  Rows
    on both branches are fitted; rows without a loading order are matched to
    the branch that explains them."""
    vary = ["tendon1.route", "tendon2.route"]
    model = ParameterModel(ARM, vary)
    truth = model.start() + [1.5, -1.0, -1.0, 1.5]
    P = np.array([[14.0, 6.0], [14.2, 6.1], [13.9, 6.0], [14.0, 6.2]] * 2
                 + [[5.0, 2.0], [8.0, 1.0], [3.0, 4.0], [14.0, 6.0], [14.1, 6.1]])
    loading = [(2, 1)] * 4 + [(1, 2)] * 4 + [None] * 3 + [(1, 2), (2, 1)]
    cmd = command_rows(ARM, P, "tension", loading=loading)
    data = synthesize(ARM, vary, truth, cmd)
    tips = data.tips_mm
    assert np.linalg.norm(tips[0] - tips[4]) > 300        # two different states
    given = list(loading[:11]) + [None, None]              # the last two: not said
    data = dataclasses.replace(data, loading=tuple(given))
    problem = CalibrationProblem(model, data)
    result = fit(problem)
    assert result.branches[11] == "matched: order 1,2"
    assert result.branches[12] == "matched: proportional"   # = order 2,1's state 1
    assert result.branches[0] == "given: order 2,1"
    np.testing.assert_allclose(result.theta, truth, rtol=1e-6)


def test_huber_down_weights_the_outlier_row():
    """One tip off by 32 mm: the Huber fit reports that row and keeps the
    parameters within 3 of its standard deviations; plain least squares does not."""
    rng = np.random.default_rng(6)
    P = np.column_stack((rng.uniform(1, 9, 16), rng.uniform(0.5, 5, 16)))
    vary = ["bending_stiffness", "tendon1.route"]
    model = ParameterModel(ARM, vary)
    truth = model.start() * [1.1, 1.0, 1.0] + [0.0, 3.0, -2.0]
    data = synthesize(ARM, vary, truth, command_rows(ARM, P, "tension"), noise_mm=0.2, seed=2)
    tips = data.tips_mm.copy()
    tips[5] += [30.0, -10.0]
    data = dataclasses.replace(data, tips_mm=tips)
    plain = fit(CalibrationProblem(model, data))
    problem = CalibrationProblem(model, data)
    robust = fit(problem, huber_mm=1.0)
    assert np.flatnonzero(robust.row_weights < 0.5).tolist() == [5]
    assert np.all(robust.row_weights[np.arange(16) != 5] > 0.5)
    sigma = np.array(uncertainty(problem, robust)["sigma"], float)
    assert np.all(np.abs(robust.theta - truth) < 3 * sigma)
    assert np.max(np.abs(plain.theta - truth) / sigma) > 3     # the outlier biases plain LS


def test_next_measurements_prefer_rows_that_load_tendon_2():
    """With tendon 2 slack in every row, the D-optimal choice among candidates is a
    command that tensions tendon 2 (the only one that informs its routing point)."""
    from elastica_petsc.studies.calibrate_report import next_measurements

    rng = np.random.default_rng(7)
    P = np.column_stack((rng.uniform(1, 9, 12), np.zeros(12)))
    vary = ["tendon1.route", "tendon2.route"]
    model = ParameterModel(ARM, vary)
    data = synthesize(ARM, vary, model.start(), command_rows(ARM, P, "tension"),
                      noise_mm=0.2, seed=4)
    problem = CalibrationProblem(model, data)
    result = fit(problem)
    report = uncertainty(problem, result)
    candidates = command_rows(ARM, [[5.0, 0.0], [3.0, 0.0], [4.0, 3.0], [8.0, 0.0]], "tension")
    chosen = next_measurements(problem, result, report, candidates, count=2)
    assert chosen[0]["inputs"] == [4.0, 3.0]
    assert chosen[0]["log_det_gain"] > 10 * max(chosen[1]["log_det_gain"], 1e-3)


def test_pounders_derivative_free_finds_the_same_optimum():
    """TAO POUNDERS (residuals only) and BRGN (exact Jacobian) agree on noisy data."""
    rng = np.random.default_rng(1)
    P = np.column_stack((rng.uniform(1, 9, 12), rng.uniform(0.5, 5, 12)))
    vary = ["bending_stiffness", "tendon1.route"]
    model = ParameterModel(ARM, vary)
    data = synthesize(ARM, vary, model.start() + [0.02, 2.0, -1.0],
                      command_rows(ARM, P, "tension"), noise_mm=0.3)
    brgn = fit(CalibrationProblem(model, data))
    pounders = fit(CalibrationProblem(model, data), method="pounders")
    assert pounders.reason.startswith("CONVERGED"), pounders.reason
    np.testing.assert_allclose(pounders.theta, brgn.theta, rtol=1e-6)
    assert pounders.evaluations > brgn.evaluations
