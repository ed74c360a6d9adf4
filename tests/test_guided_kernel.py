"""Kernels of cables through guides, offsets and weight (core/guided.py,
docs/model.md §11) against finite differences.

- F_theta at consistent states is the gradient of the discrete potential Pi of §11
  (Taylor remainder of order 2);
- the consistent Jacobian (guides with offsets, weight) passes the Taylor test
  |F(u + e v) - F(u) - e J v| = O(e^2) at states off equilibrium;
- the Schur complement of the Jacobian is the Hessian of Pi, symmetric, and equals
  T + W W^T of the stability matrix H (one border column per segment), whose
  inertia counts the negative eigenvalues of K;
- dF/dp is the FD of F in p, dL/dy the FD of the path lengths;
- a guide-free arm in the guided kernel gives the paper kernel's numbers.
"""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.guided import GuidedDiscretisation
from elastica_petsc.core.model import Arm, Guide, Tendon

from conftest import csr_to_dense, reduced_tangent, stability_dense


def guided_arm(elements=12, gravity=(0.0, -9.81), tip_mass_kg=0.05) -> Arm:
    """Two tendons through guides with offsets, weight of a 0.144 kg/m strip."""
    t1 = Tendon(600.0, (0.0, 15.0), attach_offset_mm=15.0,
                guides=(Guide(100.0, 15.0), Guide(300.0, 12.0), Guide(450.0, 15.0)))
    t2 = Tendon(400.0, (-50.0, -20.0), attach_offset_mm=-10.0,
                guides=(Guide(200.0, -18.0), Guide(550.0, -5.0)))
    return Arm(length_mm=600.0, bending_stiffness_Nm2=0.2, tendons=(t1, t2), elements=elements,
               mass_per_length_kg_m=0.144, gravity_m_s2=gravity, tip_mass_kg=tip_mass_kg,
               guide_radius_mm=20.0)


def states(disc, seed, count=2):
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, disc.n_elements + 1)
    for _ in range(count):
        a, b, c = rng.uniform(-1.0, 1.0, 3)
        u = disc.consistent_state(a * s + b * s**2 + c * np.sin(np.pi * s))
        u[disc.n_elements:] += 0.01 * rng.standard_normal(2 * disc.n_points)
        yield u


def taylor_orders(fun, dfun_v, u, v, eps=(1e-2, 5e-3, 2.5e-3)):
    """Observed orders of |fun(u + e v) - fun(u) - e dfun_v| for halving e."""
    f0 = fun(u)
    rem = [np.linalg.norm(fun(u + e * v) - f0 - e * dfun_v) for e in eps]
    return np.log2(np.array(rem[:-1]) / np.array(rem[1:])), rem


@pytest.fixture(scope="module")
def disc():
    d = Discretisation.from_arm(guided_arm())
    assert isinstance(d, GuidedDiscretisation) and d.n_points == 7
    return d


P = np.array([6.0, 4.0])


def test_residual_is_gradient_of_potential(disc):
    rng = np.random.default_rng(1)
    for u in states(disc, 2):
        theta = disc.split(u)[0]
        g = disc.residual(disc.consistent_state(theta), P)[: disc.n_elements]
        v = np.concatenate(([0.0], rng.standard_normal(disc.n_elements)))
        orders, rem = taylor_orders(lambda th: np.array([disc.potential(th, P)]),
                                    np.array([g @ v[1:]]), theta, v)
        assert np.all(orders > 1.9), (orders, rem)


def test_jacobian_taylor_order_two(disc):
    rng = np.random.default_rng(3)
    indptr, indices, _ = disc.pattern
    for u in states(disc, 4):
        J = csr_to_dense(disc, disc.jacobian_values(u, P))
        v = rng.standard_normal(disc.size)
        orders, rem = taylor_orders(lambda w: disc.residual(w, P), J @ v, u, v)
        assert np.all(orders > 1.9), (orders, rem)


def test_jacobian_pattern_holds_every_entry(disc):
    """The dense FD Jacobian has no entry outside the stored pattern."""
    u = next(states(disc, 5))
    eps = 1e-6
    fd = np.column_stack([(disc.residual(u + eps * e, P) - disc.residual(u - eps * e, P))
                          / (2 * eps) for e in np.eye(disc.size)])
    J = csr_to_dense(disc, disc.jacobian_values(u, P))
    assert np.max(np.abs(fd - J)) < 1e-6 * np.max(np.abs(J))


def test_tangent_is_symmetric_hessian_and_stability_border(disc):
    for u in states(disc, 6):
        theta = disc.split(u)[0]
        uc = disc.consistent_state(theta)
        K = reduced_tangent(disc, uc, P)
        assert np.linalg.norm(K - K.T) < 1e-11 * np.linalg.norm(K)
        H = stability_dense(disc, uc, P)
        N = disc.n_elements
        schur = H[:N, :N] + H[:N, N:] @ H[N:, :N]
        assert np.allclose(schur, K, rtol=0, atol=1e-10 * np.abs(K).max())
        # K v of the Hessian of Pi: Taylor test of the gradient
        rng = np.random.default_rng(7)
        v = np.concatenate(([0.0], rng.standard_normal(N)))
        grad = lambda th: disc.residual(disc.consistent_state(th), P)[:N]
        orders, rem = taylor_orders(grad, K @ v[1:], theta, v)
        assert np.all(orders > 1.9), (orders, rem)


def test_inertia_counts_negative_eigenvalues():
    from elastica_petsc.solvers.inertia import InertiaCounter
    disc = Discretisation.from_arm(guided_arm(gravity=(-9.81, 0.0)))
    counter = InertiaCounter(disc)
    try:
        for p in ([0.0, 0.0], [30.0, 0.0], [60.0, 50.0]):
            u = disc.consistent_state(np.zeros(disc.n_elements + 1))
            K = reduced_tangent(disc, u, np.array(p))
            expected = int(np.sum(np.linalg.eigvalsh(0.5 * (K + K.T)) < 0))
            assert counter.negative_eigenvalues(u, p) == expected
        assert expected > 0                       # the test meets a negative count
    finally:
        counter.destroy()


def test_load_derivative_and_length_gradients(disc):
    u = next(states(disc, 8))
    eps = 1e-6
    dFdp = disc.load_derivative(u)
    for i in range(disc.n_tendons):
        e = np.zeros(disc.n_tendons)
        e[i] = eps
        fd = (disc.residual(u, P + e) - disc.residual(u, P - e)) / (2 * eps)
        assert np.allclose(dFdp[i], fd, atol=1e-8)
    y = disc.split(u)[1].ravel()
    G = disc.length_gradients(y.reshape(-1, 2))
    fd = np.column_stack([(disc.cables((y + eps * e).reshape(-1, 2))[0]
                           - disc.cables((y - eps * e).reshape(-1, 2))[0]) / (2 * eps)
                          for e in np.eye(y.size)])
    assert np.allclose(G, fd, atol=1e-8)


def test_guide_free_arm_matches_paper_kernel(paper_arm):
    """The paper's arm in the guided kernel (border: chords z_i = r_i - y_i instead of
    the attachment points y_i): the same angle residual, tangent K, H and dF/dp."""
    plain = Discretisation.from_arm(paper_arm, 18)
    assert not isinstance(plain, GuidedDiscretisation)
    guided = GuidedDiscretisation.from_arm(paper_arm, 18)
    rng = np.random.default_rng(9)
    s = np.linspace(0, 1, 19)
    u = plain.consistent_state(0.8 * s + 0.5 * np.sin(np.pi * s))
    u[18:] += 0.01 * rng.standard_normal(4)
    theta, y = plain.split(u)
    v = guided.join(theta, plain.routes - y)
    p = np.array([25.2, 10.8])
    Fp, Fg = plain.residual(u, p), guided.residual(v, p)
    assert np.allclose(Fg[:18], Fp[:18], rtol=0, atol=1e-13)
    assert np.allclose(Fg[18:], -Fp[18:], rtol=0, atol=1e-15)
    assert np.allclose(reduced_tangent(guided, v, p), reduced_tangent(plain, u, p), atol=1e-11)
    assert np.allclose(stability_dense(guided, v, p), stability_dense(plain, u, p), atol=1e-12)
    assert np.allclose(guided.load_derivative(v), plain.load_derivative(u), atol=1e-13)


def test_design_derivatives_of_offsets_and_routes(disc):
    """dF/ddelta_a and dF/dr_i against the residual of a perturbed arm."""
    from dataclasses import replace
    u = next(states(disc, 10))
    rng = np.random.default_rng(11)
    for a in (0, 2, 3, 6):
        v = 1.0
        step = np.zeros(disc.n_points)
        step[a] = v

        def F(eps):
            return replace(disc, point_offsets=disc.point_offsets + eps * step).residual(u, P)
        orders, rem = taylor_orders(F, disc.offset_derivative(u, P, a), 0.0, 1.0,
                                    eps=(1e-2, 5e-3, 2.5e-3))
        assert np.all(orders > 1.9) or max(rem) < 1e-13, (a, orders, rem)
    for i in range(disc.n_tendons):
        v = rng.standard_normal(2)

        def F(eps):
            routes = disc.routes.copy()
            routes[i] += eps * v
            return replace(disc, routes=routes).residual(u, P)
        orders, rem = taylor_orders(F, disc.route_derivative(u, P, i) @ v, 0.0, 1.0)
        assert np.all(orders > 1.9) or max(rem) < 1e-13, (i, orders, rem)


def test_tip_sensitivity_to_guide_offsets_taylor():
    """d x_t/d delta_a from one more right-hand side of the tangent (J du = -dF/ddelta)
    against equilibria re-solved with the offset changed: remainder O(eps^2)."""
    import dataclasses
    from elastica_petsc.solvers.equilibrium import EquilibriumSolver
    from elastica_petsc.solvers.sensitivity import SensitivitySolver
    arm = guided_arm(elements=24)
    disc = Discretisation.from_arm(arm)
    with EquilibriumSolver(disc) as solver, SensitivitySolver(disc) as sens:
        eq = solver.solve(P)
        assert eq.converged
        for a in (1, 5):
            du, dtip = sens.parameter_derivative(eq, disc.offset_derivative(eq.u, P, a))
            rem = []
            for eps in (4e-3, 2e-3, 1e-3):
                offsets = disc.point_offsets.copy()
                offsets[a] += eps
                moved = dataclasses.replace(disc, point_offsets=offsets)
                with EquilibriumSolver(moved) as other:
                    u, _, _ = other.newton(eq.u, P)
                tip = moved.node_positions(moved.split(u)[0])[-1]
                rem.append(np.linalg.norm(tip - eq.tip - eps * dtip))
            orders = np.log2(np.array(rem[:-1]) / rem[1:])
            assert np.all(orders > 1.9), (a, orders, rem)
            assert np.linalg.norm(dtip) > 1e-3            # the offset moves the tip


def test_cable_length_sensitivities_through_guides():
    """dL/dp from the sensitivities (docs/model.md §11.3) is symmetric (reciprocity),
    negative definite at a stable state, and matches re-solved cable lengths; the
    end points' derivatives match too."""
    from elastica_petsc.solvers.equilibrium import EquilibriumSolver
    from elastica_petsc.solvers.sensitivity import SensitivitySolver
    disc = Discretisation.from_arm(guided_arm(elements=24))
    with EquilibriumSolver(disc) as solver, SensitivitySolver(disc) as sens:
        eq = solver.solve(P)
        s = sens.compute(eq)
        assert eq.converged and eq.stable
        assert np.allclose(s.cable_lengths, s.cable_lengths.T, atol=1e-12)
        assert np.all(np.linalg.eigvalsh(s.cable_lengths) < 0)
        eps = 1e-5
        for i in range(2):
            dp = np.zeros(2)
            dp[i] = eps
            hi, lo = (solver.newton(eq.u, P + sgn * dp)[0] for sgn in (1, -1))
            th = [disc.split(u)[0] for u in (hi, lo)]
            dL = (disc.cable_lengths_of(th[0]) - disc.cable_lengths_of(th[1])) / (2 * eps)
            dX = (disc.attachment_points(th[0]) - disc.attachment_points(th[1])) / (2 * eps)
            assert np.allclose(s.cable_lengths[i], dL, atol=1e-7)
            assert np.allclose(s.attachments[i], dX, atol=1e-7)


def test_every_stored_entry_is_written(disc):
    """The values are written slot by slot into the CSR patterns: every stored entry
    of the Jacobian and of H has exactly one source."""
    for slots, pattern in ((disc._jacobian_slots, disc.pattern),
                           (disc._stability_slots, disc.stability_pattern)):
        band_slots, _, cols, rows, corner = slots
        written = np.concatenate([a[a >= 0] for a in (band_slots, cols.ravel(), rows.ravel(),
                                                      corner)])
        assert np.array_equal(np.sort(written), np.arange(len(pattern[1])))


def test_length_control_inertia_through_guides():
    """Negative eigenvalues of K on null(C^T) (taut cables; docs/model.md §4.7, §11.3)
    from the bordered LDL^T against the dense projection."""
    from scipy.linalg import null_space
    from elastica_petsc.solvers.lengths import LengthInertia
    disc = Discretisation.from_arm(guided_arm(gravity=(-9.81, 0.0)))
    counter = LengthInertia(disc)
    N = disc.n_elements
    rng = np.random.default_rng(12)
    counts = []
    try:
        for p in ([0.0, 0.0], [60.0, 0.0], [60.0, 50.0], [200.0, 150.0]):
            p = np.array(p)
            u = disc.consistent_state(np.concatenate(([0.0], 0.05 * rng.standard_normal(N))))
            K = reduced_tangent(disc, u, p)
            C = disc.load_derivative(u)[p > 1e-8, :N].T
            Z = null_space(C.T) if C.shape[1] else np.eye(N)
            expected = int(np.sum(np.linalg.eigvalsh(Z.T @ (0.5 * (K + K.T)) @ Z) < 0))
            counts.append(expected)
            assert counter.negative_eigenvalues(u, p) == expected
        assert max(counts) > 0
    finally:
        counter.destroy()


def test_tip_sensitivity_to_routing_points_taylor():
    """d x_t/d r_i of a cable through guides (J du = -dF/dr_i, the first chord's rows)
    against equilibria re-solved with the routing point moved: remainder O(eps^2)."""
    import dataclasses
    from elastica_petsc.solvers.equilibrium import EquilibriumSolver
    from elastica_petsc.solvers.sensitivity import SensitivitySolver
    disc = Discretisation.from_arm(guided_arm(elements=24))
    rng = np.random.default_rng(13)
    with EquilibriumSolver(disc) as solver, SensitivitySolver(disc) as sens:
        eq = solver.solve(P)
        for i in range(disc.n_tendons):
            v = rng.standard_normal(2)
            _, dtip = sens.parameter_derivative(eq, disc.route_derivative(eq.u, P, i) @ v)
            rem = []
            for eps in (4e-3, 2e-3, 1e-3):
                routes = disc.routes.copy()
                routes[i] += eps * v
                moved = dataclasses.replace(disc, routes=routes)
                with EquilibriumSolver(moved) as other:
                    u, _, _ = other.newton(eq.u, P)
                rem.append(np.linalg.norm(moved.node_positions(moved.split(u)[0])[-1]
                                          - eq.tip - eps * dtip))
            assert np.all(np.log2(np.array(rem[:-1]) / rem[1:]) > 1.9), (i, rem)
