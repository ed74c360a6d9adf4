"""Load-controlled forward statics on PETSc SNES (docs/model.md §4.1, §6; paper Eq. (9), Fig. 8).

Every converged state is re-checked here independently of SNES's own test:
the bordered residual of Eq. (9) evaluated by the numpy kernel must vanish.
"""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.solvers import control
from elastica_petsc.solvers.equilibrium import CABLE_COLLAPSE, EquilibriumSolver
from elastica_petsc.core.fem import Discretisation, DiscretisationError

from conftest import make_arm

R1, R2 = (46.3, -97.1), (26.1, 51.1)      # paper routing points, mm (docs/model.md §5)
L_MM = 600.0


def assert_equilibrium(eq, tol=1e-8):
    assert eq.converged, eq.message
    np.testing.assert_allclose(eq.p, eq.p_requested, rtol=0, atol=0)
    res = eq.disc.residual(eq.u, eq.p)
    assert np.max(np.abs(res)) <= tol, f"residual {np.max(np.abs(res)):.2e}"


def assert_moment_balance(eq, tol=1e-9):
    """Eq. (5), integrated form of Eq. (8): B theta'(s) = sum_i H(s_i - s)
    (x_i - x(s)) x F_i.  The P1/midpoint discretisation satisfies it exactly on
    every element e (theta' = element curvature, x(s) = element midpoint), so
    this is an independent check of a converged state, not a mesh-error one."""
    x_mid = 0.5 * (eq.x[:-1] + eq.x[1:])
    moment = np.zeros(eq.disc.n_elements)
    for i, m in enumerate(eq.disc.attach_nodes):
        lever = eq.attachments[i] - x_mid[:m]
        force = eq.p[i] * eq.directions[i]
        moment[:m] += lever[:, 0] * force[1] - lever[:, 1] * force[0]
    err = np.max(np.abs(eq.curvature - moment))
    assert err <= tol * max(1.0, np.max(np.abs(moment))), f"moment balance error {err:.2e}"


def solve(arm, p, n=None, **kw):
    disc = Discretisation.from_arm(arm, n)
    solver = EquilibriumSolver(disc)
    try:
        return solver.solve(p, **kw)
    finally:
        solver.destroy()


# --- paper's Fig. 8 (docs/model.md §6) ---------------------------------------------------

@pytest.mark.parametrize("order, expected_mm", [
    ((2, 1), (147.1, 472.5)),   # state 1: tendon 2 tensioned first
    (None, (147.1, 472.5)),     # state 1: both proportionally from zero
    ((1, 2), (96.2, 454.3)),    # state 3: tendon 1 tensioned first
])
def test_fig8_load_path_selects_equilibrium(paper_solver, order, expected_mm):
    """Fig. 8: p = (25.2, 10.8) (the paper's tensions, rounded to 0.1); the
    loading order selects state 1 or state 3; both are stable under load
    control (K positive definite, docs/model.md §2)."""
    eq = paper_solver.solve([25.2, 10.8], order=order)
    assert_equilibrium(eq)
    assert_moment_balance(eq)
    lengths_mm = eq.cable_lengths * L_MM
    # measured: (147.21, 472.48) and (96.30, 454.33)
    np.testing.assert_allclose(lengths_mm, expected_mm, rtol=0, atol=0.5)
    assert eq.unstable_modes == 0
    assert eq.stable


def test_fig8_states_1_and_3_differ(paper_solver):
    """Same tensions, two distinct equilibria (solution multiplicity, Fig. 8)."""
    s1 = paper_solver.solve([25.2, 10.8], order=(2, 1))
    s1p = paper_solver.solve([25.2, 10.8])
    s3 = paper_solver.solve([25.2, 10.8], order=(1, 2))
    # states 1 reached along two paths coincide
    np.testing.assert_allclose(s1.u, s1p.u, rtol=0, atol=1e-8)
    assert np.linalg.norm(s1.tip - s3.tip) * L_MM > 20.0


def test_result_units_and_derived_quantities(paper_solver):
    eq = paper_solver.solve([25.2, 10.8])
    disc = eq.disc
    # Eq. (2): nodes from theta; attachments are nodes m_i; tip is the last node
    np.testing.assert_allclose(eq.x, disc.node_positions(eq.theta))
    np.testing.assert_allclose(eq.attachments, eq.x[[60, 180]])
    np.testing.assert_array_equal(eq.tip, eq.x[-1])
    # bordered y equals the attachment positions at convergence
    np.testing.assert_allclose(disc.split(eq.u)[1], eq.attachments, atol=1e-10)
    # Eq. (3): unit directions from the attachment to the routing point
    np.testing.assert_allclose(np.linalg.norm(eq.directions, axis=1), 1.0)
    np.testing.assert_allclose(eq.attachments + eq.cable_lengths[:, None] * eq.directions,
                               disc.routes, atol=1e-12)
    # Eq. (21) in units of SE_0 = B / (2l): 2 * int theta'^2 / 2 ds
    assert eq.strain_energy == pytest.approx(np.sum(np.diff(eq.theta) ** 2) * 180, rel=1e-12)
    assert eq.kappa_max == pytest.approx(np.max(np.abs(np.diff(eq.theta))) * 180, rel=1e-12)
    # inextensible: arc length of the node polygon is l (midpoint rule, Eq. (2))
    assert np.sum(np.linalg.norm(np.diff(eq.x, axis=0), axis=1)) == pytest.approx(1.0, rel=1e-12)


# --- geometries (docs/model.md §1, §7) -------------------------------------------------------

@pytest.mark.parametrize("p", [(5.0, 5.0), (2.0, 12.0)])
def test_both_tendons_at_tip(p):
    """s_1 = s_2 = l: the cable lengths are the radii of the circles centred at
    r_1, r_2 that meet at the tip (docs/model.md §7 last item; paper Sec. 4.5 (viii))."""
    arm = make_arm([(600.0, R1), (600.0, R2)])
    eq = solve(arm, p)
    assert_equilibrium(eq)
    assert eq.disc.attach_nodes == (180, 180)
    routes = np.array([R1, R2]) / L_MM
    np.testing.assert_allclose(eq.cable_lengths, np.linalg.norm(routes - eq.tip, axis=1),
                               rtol=1e-12)
    # both forces act at the tip: B theta'(s) = (x_t - x(s)) x (F_1 + F_2)
    assert_moment_balance(eq)


def test_second_tendon_short_of_the_tip():
    """s_2 < l (400 mm): the paper's 'straightforward generalisation' (Sec. 2)."""
    arm = make_arm([(200.0, R1), (400.0, R2)])
    eq = solve(arm, [10.0, 10.0])
    assert_equilibrium(eq)
    assert eq.disc.attach_nodes == (60, 120)
    assert_moment_balance(eq)
    # no load beyond s_2: the arm is straight there (theta' = 0 on (s_2, l])
    assert np.max(np.abs(np.diff(eq.theta[120:]))) <= 1e-10


def test_three_tendons():
    """n = 3 tendons (docs/model.md §1: any n >= 1), every loading order."""
    arm = make_arm([(200.0, R1), (300.0, (350.0, 120.0)), (600.0, R2)])
    results = [solve(arm, [10.0, 3.0, 8.0], order=order)
               for order in (None, (1, 2, 3), (3, 2, 1))]
    for eq in results:
        assert_equilibrium(eq)
        assert eq.unstable_modes == 0
        assert eq.cable_lengths.shape == (3,)
        assert_moment_balance(eq)


def test_single_tendon():
    arm = make_arm([(600.0, R2)])
    eq = solve(arm, [5.0])
    assert_equilibrium(eq)
    assert_moment_balance(eq)


@pytest.mark.parametrize("attach, number", [((201.0, 600.0), 1), ((200.0, 600.0, 250.5), 3)])
def test_attachment_off_node_is_refused(attach, number):
    routes = [R1, R2, (0.0, 100.0)]
    arm = make_arm(list(zip(attach, routes)))
    with pytest.raises(DiscretisationError, match=rf"^tendon {number}: .*not on a node"):
        Discretisation.from_arm(arm, 180)


def test_invalid_tensions_and_order_are_refused(paper_solver):
    with pytest.raises(ValueError, match="tendon 2 is negative"):
        paper_solver.solve([1.0, -1.0])
    with pytest.raises(ValueError, match="2 tensions"):
        paper_solver.solve([1.0])
    with pytest.raises(ValueError, match="permutation"):
        paper_solver.solve([1.0, 1.0], order=(1, 1))


# --- collapse -------------------------------------------------------------------

def test_collapse_onto_routing_point_is_reported(paper_solver):
    """Paper arm, p = (0, 30): tendon 2 pulls the tip onto r_2 before p_2 = 30
    (at p_2 ~ 22.7; the cable direction of Eq. (3) is then undefined).  The
    solve must not report success and must say why."""
    eq = paper_solver.solve([0.0, 30.0])
    assert not eq.converged
    assert eq.reason == CABLE_COLLAPSE == control.CABLE_COLLAPSE    # one name everywhere
    assert "tendon 2 pulled its attachment point onto its routing point" in eq.message
    np.testing.assert_array_equal(eq.p_requested, [0.0, 30.0])
    assert eq.p[0] == 0.0 and 20.0 < eq.p[1] < 23.5    # measured 22.73
    assert eq.cable_lengths[1] < 2e-3                   # COLLAPSE_LENGTH, units of l
    np.testing.assert_allclose(eq.tip, np.array(R2) / L_MM, atol=2e-3)


# --- warm start -------------------------------------------------------------------

def test_warm_start_from_nearby_equilibrium(paper_solver):
    """docs/model.md §4.4 / Sec. 4.5 (v): a nearby converged state is a good start: one
    load step, <= 3 Newton iterations, and the same branch (state 1) as a cold
    solve at the new tensions."""
    base = paper_solver.solve([25.2, 10.8], order=(2, 1))
    target = [25.4, 10.9]
    warm = paper_solver.solve(target, start=base)
    assert_equilibrium(warm)
    assert warm.load_steps == 1
    assert warm.iterations <= 3
    cold = paper_solver.solve(target, order=(2, 1))
    np.testing.assert_allclose(warm.u, cold.u, rtol=0, atol=1e-8)
    # restarting at the same tensions needs no Newton step at all
    same = paper_solver.solve(base.p, start=base)
    assert same.converged and same.iterations <= 1
    np.testing.assert_allclose(same.u, base.u, rtol=0, atol=1e-9)
