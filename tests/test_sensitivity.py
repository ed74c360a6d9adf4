"""Load sensitivities (Eqs. (13)-(17)): Taylor tests, closed form, reciprocity.

Non-dimensional: lengths / l, p = P l^2 / B.
"""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.sensitivity import (SensitivityError, SensitivitySolver, compute_sensitivity,
                                        objective_gradient)


@pytest.fixture(scope="module")
def paper():
    arm = load_config()
    disc = Discretisation.from_arm(arm, 90)
    solver = EquilibriumSolver(disc)
    sens = SensitivitySolver(disc)
    yield arm, disc, solver, sens
    sens.destroy()
    solver.destroy()


def observed_order(ts, remainders) -> float:
    """Slope of log(remainder) against log(t)."""
    return float(np.polyfit(np.log(ts), np.log(remainders), 1)[0])


@pytest.mark.parametrize("p", [(10.0, 5.0), (25.2, 10.8), (2.0, 7.5)])
def test_tip_sensitivity_taylor(paper, p):
    """|x_t(p + t v) - x_t(p) - t S v| falls as t^2 (S = d x_t/dp exact), while
    the zeroth-order remainder falls as t."""
    _, _, solver, sens = paper
    eq = solver.solve(p)
    assert eq.converged and eq.stable
    S = sens.compute(eq)
    v = np.array([0.6, -0.8])
    ts = 0.2 * 0.5 ** np.arange(6)
    r0, r1 = [], []
    for t in ts:
        x = solver.solve(np.asarray(p) + t * v, start=eq).tip
        r0.append(np.linalg.norm(x - eq.tip))
        r1.append(np.linalg.norm(x - eq.tip - t * (v @ S.tip)))
    assert abs(observed_order(ts, r0) - 1.0) < 0.1
    assert abs(observed_order(ts, r1) - 2.0) < 0.15
    assert r1[-1] < 1e-2 * r0[-1]


def test_attachment_and_cable_sensitivities_taylor(paper):
    """Attachment points and cable lengths: second-order remainders too."""
    _, _, solver, sens = paper
    p = np.array([10.0, 5.0])
    eq = solver.solve(p)
    S = sens.compute(eq)
    v = np.array([-0.3, 1.0])
    ts = 0.1 * 0.5 ** np.arange(5)
    rx, rL = [], []
    for t in ts:
        e = solver.solve(p + t * v, start=eq)
        rx.append(np.linalg.norm(e.attachments - eq.attachments
                                 - t * np.einsum("i,ijc->jc", v, S.attachments)))
        rL.append(np.linalg.norm(e.cable_lengths - eq.cable_lengths - t * v @ S.cable_lengths))
    assert abs(observed_order(ts, rx) - 2.0) < 0.15
    assert abs(observed_order(ts, rL) - 2.0) < 0.15


def test_state_derivative_taylor_and_euler_predictor(paper):
    """du/dp of the whole bordered state (the Euler predictor of the equilibrium
    solver): second-order remainder; as the first predictor of a warm start it gives
    the same equilibrium as the plain warm start, in fewer Newton iterations."""
    _, disc, solver, sens = paper
    p = np.array([25.2, 10.8])
    eq = solver.solve(p)
    du = sens.compute(eq).state_derivative
    assert du.shape == (2, disc.size)
    v = np.array([1.0, -0.4])
    ts = 0.2 * 0.5 ** np.arange(5)
    r1 = [np.linalg.norm(solver.solve(p + t * v, start=eq).u - eq.u - t * (v @ du)) for t in ts]
    assert abs(observed_order(ts, r1) - 2.0) < 0.15
    plain = solver.solve(p + 0.05 * v, start=eq)
    euler = solver.solve(p + 0.05 * v, start=eq, tangent=du)
    np.testing.assert_allclose(euler.u, plain.u, atol=1e-10)
    assert euler.iterations < plain.iterations


def test_bordered_unknowns_agree_with_midpoint_rule(paper):
    """d y_j/dp_i from the bordered solve equals the midpoint-rule integral of
    n alpha_i up to x_j (Eq. (13) at the attachment points); the tip entry of
    tendon 2 (s_2 = l) is the tip sensitivity itself."""
    _, _, solver, sens = paper
    S = sens.compute(solver.solve([25.2, 10.8]))
    np.testing.assert_allclose(S.attachments_border, S.attachments, atol=1e-13)
    np.testing.assert_allclose(S.attachments[:, 1], S.tip, atol=1e-15)
    assert np.all(S.alpha[:, 0] == 0.0)            # clamp: alpha_i(0) = 0
    assert S.tip_jacobian.shape == (2, 2)


@pytest.mark.parametrize("p", [(10.0, 5.0), (25.2, 10.8), (0.0, 12.0)])
def test_cable_length_sensitivity_is_symmetric_negative_definite(paper, p):
    """L_i = dPi*/dp_i for the potential at equilibrium Pi*(p) (docs/model.md §2), so
    dL/dp = d^2 Pi*/dp^2 is symmetric (reciprocity) and, at a stable state,
    negative definite."""
    _, _, solver, sens = paper
    eq = solver.solve(p)
    assert eq.stable
    dL = sens.compute(eq).cable_lengths
    assert abs(dL[0, 1] - dL[1, 0]) < 1e-10 * np.abs(dL).max()
    assert np.all(np.linalg.eigvalsh(0.5 * (dL + dL.T)) < 0)


def test_straight_arm_closed_form():
    """At p = 0 the tendons act as small point loads on the straight cantilever:
    only the transverse component moves the tip, d y_t/dp_i = d_iy s_i^2 (3 - s_i)/6
    (linear beam theory), and the midpoint discretisation converges at O(h^2)."""
    arm = load_config()
    errors, hs = [], []
    for n in (30, 60, 120):
        disc = Discretisation.from_arm(arm, n)
        with EquilibriumSolver(disc) as solver:
            S = compute_sensitivity(solver, solver.solve([0.0, 0.0]))
        s = np.asarray(disc.attach_nodes) / n
        chord = disc.routes - np.column_stack((s, 0 * s))
        d_y = chord[:, 1] / np.linalg.norm(chord, axis=1)
        exact = d_y * s**2 * (3 - s) / 6
        assert np.all(S.tip[:, 0] == 0.0)
        errors.append(np.max(np.abs(S.tip[:, 1] - exact) / np.abs(exact)))
        hs.append(1.0 / n)
    assert abs(observed_order(hs, errors) - 2.0) < 0.1
    assert errors[-1] < 1e-4


def test_objective_gradient_matches_eq12(paper):
    _, _, solver, sens = paper
    eq = solver.solve([10.0, 5.0])
    S = sens.compute(eq)
    target = eq.tip + np.array([0.01, -0.02])
    E, g = objective_gradient(eq, S, target)
    assert E == pytest.approx(0.5 * (0.01**2 + 0.02**2))
    np.testing.assert_allclose(g, [(eq.tip - target) @ S.tip[i] for i in range(2)])


def test_unconverged_equilibrium_is_refused(paper):
    _, _, solver, sens = paper
    bad = solver.solve([0.0, 40.0])        # tendon 2 pulls the tip onto its routing point
    assert not bad.converged
    with pytest.raises(SensitivityError, match="converged"):
        sens.compute(bad)
