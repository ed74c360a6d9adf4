"""Tip control (Eqs. (10)-(12), Algorithm 1): gradient, Fig. 2, known answers, bounds.

Targets in mm (paper units); the controller works with lengths / l and
p = P l^2 / B.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from petsc4py import PETSc

from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.control import (CABLE_COLLAPSE, COLLAPSE_STOP, STATIONARY, TARGET_REACHED,
                                    TipController, default_eps)
from elastica_petsc.solvers.equilibrium import COLLAPSE_LENGTH
from elastica_petsc.core.errors import InputError
from elastica_petsc.core.model import Tendon
from elastica_petsc.solvers.sensitivity import objective_gradient

FIG2_TARGET_MM = (535.8, 222.6)
TOL_MM = 1e-5


@pytest.fixture(scope="module")
def arm():
    return load_config()


@pytest.fixture(scope="module")
def fig2(arm):
    """Fig. 2 from p = (0, 0) with both methods, 180 elements (the paper's mesh)."""
    out = {}
    for method in ("blmvm", "gd"):
        with TipController(arm, method=method) as ctl:
            out[method] = ctl.solve_mm(FIG2_TARGET_MM, p0=[0.0, 0.0])
    return out


def observed_order(ts, remainders) -> float:
    return float(np.polyfit(np.log(ts), np.log(remainders), 1)[0])


def test_default_tolerance_is_a_tip_within_1e5_mm(arm):
    assert default_eps(arm.length_mm) == pytest.approx(0.5 * (1e-5 / 600.0) ** 2)
    with TipController(arm, n_elements=30, tip_tol_mm=1e-3) as ctl:
        assert ctl.eps == pytest.approx(0.5 * (1e-3 / 600.0) ** 2)


@pytest.mark.parametrize("p", [(2.0, 7.0), (20.0, 9.0)])
def test_gradient_of_E_taylor(arm, p):
    """|E(p + t v) - E(p) - t grad E . v| falls as t^2 (Eq. (12) is exact)."""
    with TipController(arm, n_elements=90) as ctl:
        base = ctl.evaluate(p)
        target = np.array(FIG2_TARGET_MM) / arm.length_mm
        E0, g = objective_gradient(base.equilibrium, base.sensitivity, target)
        v = np.array([0.8, 0.6])
        ts = 0.2 * 0.5 ** np.arange(6)
        r0, r1 = [], []
        for t in ts:
            eq = ctl.solver.solve(np.asarray(p) + t * v, start=base.equilibrium)
            E = 0.5 * np.sum((eq.tip - target) ** 2)
            r0.append(abs(E - E0))
            r1.append(abs(E - E0 - t * g @ v))
    assert abs(observed_order(ts, r0) - 1.0) < 0.1
    assert abs(observed_order(ts, r1) - 2.0) < 0.15


@pytest.mark.parametrize("method", ["blmvm", "gd"])
def test_fig2_target_reached(fig2, method):
    """Fig. 2: x_d = (535.8, 222.6) mm from P = (0, 0); tip within 1e-5 mm."""
    res = fig2[method]
    assert res.converged and res.reachable is True
    assert res.reason == TARGET_REACHED and res.tao_reason == "CONVERGED_USER"
    assert res.E < res.eps
    assert res.tip_error_mm < TOL_MM
    np.testing.assert_allclose(res.tip_mm, FIG2_TARGET_MM, atol=TOL_MM)
    # the result is self-consistent: E, tip, cable lengths all of the equilibrium returned
    assert res.E == pytest.approx(0.5 * np.sum((res.tip - res.target) ** 2))
    np.testing.assert_array_equal(res.cable_lengths, res.equilibrium.cable_lengths)
    np.testing.assert_array_equal(res.p, res.equilibrium.p)
    # history: iterations 0..k, from the initial guess to the answer, E decreasing (Fig. 2c)
    assert len(res.history_E) == res.iterations + 1
    np.testing.assert_array_equal(res.history_p[0], [0.0, 0.0])
    np.testing.assert_array_equal(res.history_p[-1], res.p)
    assert np.all(np.diff(res.history_E) <= 0)
    assert res.failed_evaluations == 0
    assert np.all(res.p > 0) and res.on_bound == ()


def test_fig2_methods_agree_and_blmvm_is_faster(fig2):
    """Measured at 180 elements: BLMVM (Gauss-Newton metric) 5 iterations, the
    paper's gradient descent 17 ("over a dozen", Sec. 3)."""
    blmvm, gd = fig2["blmvm"], fig2["gd"]
    np.testing.assert_allclose(blmvm.p, gd.p, rtol=1e-5)
    # pinned answer (non-dimensional tensions, 180 elements): P ~ (1.21, 4.20) N
    np.testing.assert_allclose(blmvm.p, [2.17053, 7.56245], rtol=1e-5)
    assert blmvm.iterations <= 8
    assert 10 <= gd.iterations <= 40
    assert 2 * blmvm.iterations <= gd.iterations


def test_known_answer_recovers_tip_and_tensions(arm):
    """Forward at p*, then control to that tip from another guess: recovers p*."""
    p_star = np.array([20.0, 9.0])
    with TipController(arm, n_elements=90) as ctl:
        eq = ctl.forward(p_star)
        assert eq.converged and eq.stable
        res = ctl.solve(eq.tip, p0=[5.0, 5.0])
    assert res.converged
    assert res.tip_error_mm < TOL_MM
    np.testing.assert_allclose(res.p, p_star, atol=1e-4)
    np.testing.assert_allclose(res.cable_lengths, eq.cable_lengths, atol=1e-7)
    np.testing.assert_allclose(res.tensions_N, p_star * arm.force_scale_N, atol=1e-4)


def test_warm_start_from_a_previous_equilibrium(arm):
    """start= an equilibrium: its tensions are the initial guess and its state
    the SNES start; a nearby target takes a couple of iterations."""
    with TipController(arm, n_elements=90) as ctl:
        first = ctl.solve_mm((450.0, 250.0))
        assert first.converged
        nxt = ctl.solve_mm((451.0, 250.0), start=first.equilibrium)
    assert nxt.converged and nxt.tip_error_mm < TOL_MM
    np.testing.assert_array_equal(nxt.history_p[0], first.p)
    assert nxt.iterations <= 3


def test_both_tendons_at_the_tip_cable_lengths_are_circle_radii(arm):
    """s_1 = s_2 = l (Sec. 4.5 (viii)): L_i = |r_i - x_d|."""
    tip_arm = dataclasses.replace(
        arm, tendons=(Tendon(600.0, (46.3, -97.1)), Tendon(600.0, (26.1, 51.1))))
    with TipController(tip_arm, n_elements=60) as ctl:
        target_mm = ctl.forward([2.0, 8.0]).tip * 600.0     # a reachable target
        res = ctl.solve_mm(target_mm)
    assert res.converged
    radii = np.linalg.norm(np.array([[46.3, -97.1], [26.1, 51.1]]) - target_mm, axis=1)
    np.testing.assert_allclose(res.cable_lengths_mm, radii, atol=TOL_MM)


def test_unreachable_target(arm):
    """(0, 700) mm lies beyond the arm's length: a stationary point with
    tendon 1 slack (on its lower bound); the closest tip is returned.  The
    local solve proves nothing about the whole workspace: reachable is None
    (the verdict False with its evidence comes from solvers.reach)."""
    with TipController(arm, n_elements=60) as ctl:
        res = ctl.solve_mm((0.0, 700.0))
    assert not res.converged and res.reachable is None
    assert res.reason == STATIONARY and res.tao_reason == "CONVERGED_GATOL"
    assert (1, "lower") in res.on_bound and res.p[0] == 0.0
    assert res.tip_error_mm > 300.0
    assert np.linalg.norm(res.tip) <= 1.0                 # the tip is where an arm can be
    assert res.tip_error == pytest.approx(np.linalg.norm(res.tip - res.target))
    assert "from the target" in res.message


def test_motor_limit_is_an_upper_bound(arm):
    """With P_crit below the tension Fig. 2 needs, tendon 2 stops on its upper bound."""
    limit_p = 5.0                                       # Fig. 2 needs p_2 = 7.56
    weak = dataclasses.replace(
        arm, motor=dataclasses.replace(arm.motor, max_tension_N=limit_p * arm.force_scale_N))
    with TipController(weak, n_elements=60) as ctl:
        res = ctl.solve_mm(FIG2_TARGET_MM)
    assert res.reachable is None and not res.converged
    assert (2, "upper") in res.on_bound
    assert res.p[1] == pytest.approx(limit_p)


def test_failed_equilibria_are_penalised_not_fatal(arm):
    """Stock BLMVM's first step on Fig. 2 asks for tensions whose equilibrium
    does not exist (tendon 2 pulls the tip onto its routing point); the
    penalty makes the line search back off and the target is still reached."""
    with TipController(arm, n_elements=60, gauss_newton=False) as ctl:
        res = ctl.solve_mm(FIG2_TARGET_MM)
        assert ctl.evaluate([0.0, 40.0]) is None          # the same failure, directly
    assert res.failed_evaluations >= 1
    assert res.converged and res.tip_error_mm < TOL_MM


def test_heading_for_a_cable_collapse_stops_there(arm):
    """(81.69, 11.67) mm, under tendon 2's routing point r_2 = (26.1, 51.1) mm, from the
    head guess p = (2, 2): the optimiser curls the arm over until tendon 2 (attached at
    the tip) would pull the tip onto r_2.  The step box and the cable-length limit let it
    approach that corner without a single failed equilibrium, and it stops there
    (before: a line-search failure after 18 failed equilibria, 0.27 s)."""
    l_mm = arm.length_mm
    with TipController(arm) as ctl:
        res = ctl.solve_mm((81.69, 11.67), p0=[2.0, 2.0])
        # the step box of the last iteration does not outlive the solve
        assert np.all(ctl.lb.getArray() == 0.0) and np.all(ctl.ub.getArray() == arm.max_tension)
    assert res.reason == CABLE_COLLAPSE and res.tao_reason == "DIVERGED_USER"
    assert not res.converged and res.reachable is None
    assert res.failed_evaluations == 0 and res.iterations <= 20
    L2 = res.cable_lengths_mm[1]
    assert COLLAPSE_LENGTH * l_mm <= L2 < COLLAPSE_STOP * COLLAPSE_LENGTH * l_mm
    assert np.linalg.norm(res.tip_mm - [26.1, 51.1]) == pytest.approx(L2)
    assert "tendon 2's cable" in res.message


def test_closest_boundary_point_in_a_few_iterations(arm):
    """Targets outside W_0 far from its boundary: the Gauss-Newton step overshoots the
    closest boundary point (large residual), and the line search's curvature condition
    (0.1) refines it: the neighbouring target, warm-started from the first one's end
    state, is classified in a few iterations (47 with TAO's default 0.9)."""
    with TipController(arm, stationary_rtol=1e-5) as ctl:
        first = ctl.solve_mm((-93.36, 466.8), p0=[2.0, 2.0])
        res = ctl.solve_mm((-81.69, 466.8), start=first.equilibrium)
    for r in (first, res):
        assert r.reason == STATIONARY and (1, "lower") in r.on_bound and r.p[0] == 0.0
    assert first.iterations <= 10 and res.iterations <= 6


def test_options_and_input_errors(arm):
    with pytest.raises(InputError, match="method"):
        TipController(arm, method="newton")
    with TipController(arm, n_elements=30, max_it=2) as ctl:
        res = ctl.solve_mm(FIG2_TARGET_MM)
        assert res.iterations == 2 and not res.converged and res.reachable is None
        assert res.reason == "MAX_ITERATIONS" and res.tao_reason == "DIVERGED_MAXITS"
        with pytest.raises(InputError, match="target"):
            ctl.solve([np.nan, 0.0])
        with pytest.raises(InputError, match="initial tensions"):
            ctl.solve([0.5, 0.5], p0=[1.0])
    # PETSc options under the ctl_ prefix reach the TAO (here: its line search)
    with TipController(arm, n_elements=30, petsc_options={"tao": {"ls_type": "armijo"}}) as ctl:
        assert ctl.tao.getType() == "blmvm"
        res = ctl.solve_mm(FIG2_TARGET_MM)
        assert res.converged
    # options given in code are pushed only while the TAO is configured
    assert not PETSc.Options().hasName("ctl_tao_ls_type")
