"""Kernels of the P1 elastica (elastica_petsc.core.fem) against finite differences.

What is checked (docs/model.md §1-2, paper Eqs. (2)-(4), (9), (14)):
- the consistent Jacobian of the bordered residual F(u) = (F_theta, y - X(theta))
  equals central finite differences of F, at loaded, non-equilibrium states
  with 2 and 3 tendons;
- restricted to consistent states (y_i = X_i(theta)), F_theta is the gradient
  of the discrete total potential Pi = int theta'^2/2 + sum_i p_i L_i - m theta(l)
  (docs/model.md §2: the tendon load with prescribed tensions is conservative);
- the reduced tangent K (Schur complement of the bordered Jacobian on y) is the
  Hessian of Pi: equal to FD of the reduced gradient and symmetric to round-off
  (docs/model.md §2; the paper's Sec. 4.3 calls its K "in general non symmetric");
- the Schur complement T + W W^T of the stability matrix H equals K, and the
  inertia counted from H equals the number of negative eigenvalues of K;
- dF/dp (right-hand sides of Eq. (14)) equals FD of F in p.
"""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.inertia import InertiaCounter

from conftest import csr_to_dense, make_arm, reduced_tangent, stability_dense

# Paper routing points (docs/model.md §5) plus a third tendon for the n >= 1 generality of docs/model.md §1.
TWO = [(200.0, (46.3, -97.1)), (600.0, (26.1, 51.1))]
THREE = TWO[:1] + [(300.0, (350.0, 120.0))] + TWO[1:]

CASES = {
    # name: (tendons, elements, tensions p = P l^2 / B)
    "two-tendons": (TWO, 18, [25.2, 10.8]),
    "three-tendons": (THREE, 12, [7.0, 3.0, 12.0]),
    "interior-only": ([(300.0, (250.0, -150.0)), (400.0, (0.0, 200.0))], 12, [4.0, 9.0]),
}


def smooth_theta(rng, n_elements: int) -> np.ndarray:
    """A random smooth angle field with theta(0) = 0 (clamp), O(1) rotations."""
    s = np.linspace(0.0, 1.0, n_elements + 1)
    a, b, c, d = rng.uniform(-1.5, 1.5, size=4)
    return a * s + b * s**2 + c * np.sin(np.pi * s) + d * s**3 * (1 - s)


def loaded_states(disc, seed: int, count: int = 3):
    """Bordered states with random smooth theta and y perturbed off X(theta)."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        u = disc.consistent_state(smooth_theta(rng, disc.n_elements))
        u[disc.n_elements:] += 0.05 * rng.standard_normal(2 * disc.n_tendons)
        yield u


def fd_jacobian(fun, u, eps=1e-6) -> np.ndarray:
    cols = []
    for j in range(u.size):
        e = np.zeros_like(u)
        e[j] = eps
        cols.append((fun(u + e) - fun(u - e)) / (2 * eps))
    return np.column_stack(cols)


@pytest.fixture(params=sorted(CASES))
def case(request):
    tendons, n, p = CASES[request.param]
    disc = Discretisation.from_arm(make_arm(tendons, elements=n), n)
    return request.param, disc, np.array(p)


def test_layout(case):
    _, disc, _ = case
    # u = (theta_1..theta_N, y_1x, y_1y, ...): N + 2n unknowns (fem.py docstring)
    assert disc.size == disc.n_elements + 2 * disc.n_tendons
    u = disc.straight()
    assert u.shape == (disc.size,)
    theta, y = disc.split(u)
    assert theta[0] == 0.0 and np.all(theta == 0.0)
    # straight arm: X_i = (s_i, 0)  (Eq. (2))
    s = np.asarray(disc.attach_nodes) / disc.n_elements
    np.testing.assert_allclose(y, np.column_stack((s, 0 * s)), atol=1e-15)
    np.testing.assert_array_equal(disc.join(*disc.split(u)), u)


def test_jacobian_matches_central_differences(case):
    """dF/du (consistent linearisation of Eq. (9) + the y-rows) vs FD, loaded states."""
    name, disc, p = case
    for k, u in enumerate(loaded_states(disc, seed=sorted(CASES).index(name))):
        J = csr_to_dense(disc, disc.jacobian_values(u, p))
        J_fd = fd_jacobian(lambda v: disc.residual(v, p, tip_moment=0.7), u)
        scale = np.max(np.abs(J))
        err = np.max(np.abs(J - J_fd))
        assert err <= 1e-7 * scale, f"{name} state {k}: |J - J_fd|_max = {err:.3e} (|J| {scale:.3g})"
        # the pattern must hold every structural nonzero (no entry of J_fd lost)
        assert np.max(np.abs(J_fd[J == 0.0])) <= 1e-7 * scale


def test_residual_is_gradient_of_potential(case):
    """docs/model.md §2: on consistent states F_theta = dPi/dtheta (t x F_i = P_i n.d_i)."""
    name, disc, p = case
    rng = np.random.default_rng(7)
    m = 0.7  # applied tip moment enters Pi as -m theta_N
    for _ in range(3):
        theta = smooth_theta(rng, disc.n_elements)
        F = disc.residual(disc.consistent_state(theta), p, tip_moment=m)
        # consistent state: the y-rows vanish (to round-off)
        assert np.max(np.abs(F[disc.n_elements:])) <= 1e-14

        def pot(t1):
            return disc.potential(np.concatenate(([0.0], t1)), p, tip_moment=m)

        eps = 1e-6
        grad = np.array([(pot(theta[1:] + eps * e) - pot(theta[1:] - eps * e)) / (2 * eps)
                         for e in np.eye(disc.n_elements)])
        scale = max(1.0, np.max(np.abs(grad)))
        assert np.max(np.abs(F[: disc.n_elements] - grad)) <= 1e-7 * scale


def test_reduced_tangent_is_symmetric_hessian(case):
    """K (Schur complement on y) = Hessian of Pi: FD of the reduced gradient, and
    symmetric to round-off (docs/model.md §2)."""
    name, disc, p = case
    N = disc.n_elements
    rng = np.random.default_rng(11)
    for _ in range(3):
        theta = smooth_theta(rng, N)
        u = disc.consistent_state(theta)
        K = reduced_tangent(disc, u, p)
        asym = np.linalg.norm(K - K.T) / np.linalg.norm(K)
        assert asym <= 1e-14, f"{name}: ||K - K^T|| / ||K|| = {asym:.2e}"

        def reduced_gradient(t1):
            return disc.residual(disc.consistent_state(np.concatenate(([0.0], t1))), p)[:N]

        K_fd = fd_jacobian(reduced_gradient, theta[1:])
        assert np.max(np.abs(K - K_fd)) <= 1e-7 * np.max(np.abs(K))


def test_reduced_tangent_symmetric_off_consistency(case):
    """Also symmetric when y is off X(theta) (Newton iterates)."""
    name, disc, p = case
    for u in loaded_states(disc, seed=3):
        K = reduced_tangent(disc, u, p)
        assert np.linalg.norm(K - K.T) / np.linalg.norm(K) <= 1e-14


def test_stability_matrix_schur_complement_is_K(case):
    """H = [[T, W], [W^T, -I]]: T - W (-I)^{-1} W^T = T + W W^T = K (docs/model.md §2)."""
    name, disc, p = case
    N, n = disc.n_elements, disc.n_tendons
    for u in loaded_states(disc, seed=5):
        H = stability_dense(disc, u, p)
        assert H.shape == (N + n, N + n)
        np.testing.assert_array_equal(H[N:, N:], -np.eye(n))
        T, W = H[:N, :N], H[:N, N:]
        K = reduced_tangent(disc, u, p)
        np.testing.assert_allclose(T + W @ W.T, K, rtol=0, atol=1e-12 * np.max(np.abs(K)))


def test_inertia_counter_matches_dense_eigenvalues(case):
    """Haynsworth: In(H) = In(K) + (0, n, 0); compare with numpy's eigvalsh of K,
    including states where K is indefinite (large p)."""
    name, disc, p = case
    counter = InertiaCounter(disc)
    try:
        seen = set()
        for scale in (0.0, 1.0, 4.0, 15.0):
            for u in loaded_states(disc, seed=13):
                K = reduced_tangent(disc, u, scale * p)
                ev = np.linalg.eigvalsh(0.5 * (K + K.T))
                if np.min(np.abs(ev)) < 1e-8 * np.max(np.abs(ev)):
                    continue  # too close to singular for a sign count
                expected = int(np.sum(ev < 0))
                seen.add(expected)
                assert counter.negative_eigenvalues(u, scale * p) == expected
        assert len(seen) >= 2, f"{name}: test states never produced an indefinite K"
    finally:
        counter.destroy()


def test_load_derivative_matches_fd(case):
    """dF/dp_i (Eq. (14) right-hand sides) vs central differences in p."""
    name, disc, p = case
    for u in loaded_states(disc, seed=17):
        D = disc.load_derivative(u)
        assert D.shape == (disc.n_tendons, disc.size)
        for i in range(disc.n_tendons):
            e = np.zeros_like(p)
            e[i] = 1e-4
            fd = (disc.residual(u, p + e) - disc.residual(u, p - e)) / 2e-4
            np.testing.assert_allclose(D[i], fd, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(fd))))
        # dF_y/dp = 0 and, for tendon i, dF_theta/dp_i vanishes beyond its attachment
        assert np.all(D[:, disc.n_elements:] == 0.0)
        for i, m in enumerate(disc.attach_nodes):
            assert np.all(D[i, m:disc.n_elements] == 0.0)


def test_potential_and_energy_of_a_circular_arc():
    """theta = m s: strain energy m^2/2 in units of B/l (Eq. (21)) exactly for P1."""
    disc = Discretisation.from_arm(make_arm(TWO, elements=30), 30)
    s = np.linspace(0, 1, 31)
    for m in (0.3, 2.0, -4.0):
        assert disc.strain_energy(m * s) == pytest.approx(m**2 / 2, rel=1e-13)
        np.testing.assert_allclose(disc.curvature(m * s), m, rtol=1e-12)
        x = disc.node_positions(m * s)
        # midpoint rule of Eq. (2): |x_k - x_{k-1}| = h exactly (inextensible)
        np.testing.assert_allclose(np.linalg.norm(np.diff(x, axis=0), axis=1), 1 / 30, rtol=1e-13)
