"""Forward solver against closed-form solutions (docs/model.md §7).

(a) Pure end moment m = M l / B, no tendon tension: circular arc
    theta(s) = m s (exact at the nodes for P1), tip (sin m / m, (1 - cos m) / m).
(b) Tip tendon routed very far away: a dead tip load of fixed direction.
    Small load: tip deflection p / 3 (P l^3 / (3B)); large load: the classical
    cantilever elastica (elliptic integrals), computed here independently.
(c) Mesh convergence of the tip position: second order.
(d) Buckling of the straight arm (docs/model.md §7): dead compressive tip load
    p_cr = pi^2 / 4; load aimed at the clamp p_cr = pi^2.  The number of
    negative eigenvalues of K changes there (energy criterion, docs/model.md §2).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.inertia import InertiaCounter

from conftest import reduced_tangent, tip_tendon_arm

# A tip tendon routed 1e9 l straight below the tip: its direction changes by
# at most |x_tip - (1, 0)| / 1e9 ~ 1e-9 rad, far below the discretisation
# errors measured here (>= 1e-7).  (1e6 l, as in route_mm = (1000, -1e9) for a
# 1000 mm arm, tilts it by ~1e-6 rad, which is visible in the h^2 fit at N = 80.)
DOWN = (1.0, -1e9)


def cantilever_elastica(p: float):
    """Clamped-free elastica under a dead transverse tip load p = P l^2 / B.

    With psi = -theta in [0, alpha] (alpha the tip rotation), Eq. (8) reads
    psi'' = -p cos psi, psi(0) = 0, psi'(1) = 0, with first integral
    psi'^2 = 2 p (sin alpha - sin psi).  Substituting
    1 + sin psi = 2 k^2 sin^2 phi, k^2 = (1 + sin alpha) / 2,
    sin phi_0 = 1 / (k sqrt 2) gives (Bisshopp & Drucker 1945)
        sqrt(p)  = K(k) - F(phi_0, k),
        x_tip    = sqrt(2 sin alpha / p),
        -y_tip   = 1 - 2 (E(k) - E(phi_0, k)) / sqrt(p).
    scipy's elliptic integrals take the parameter m = k^2.
    Returns (alpha, x_tip, y_tip) in units of l.
    """
    def parts(alpha):
        m = (1.0 + np.sin(alpha)) / 2.0
        return m, np.arcsin(1.0 / np.sqrt(2.0 * m))

    def length_mismatch(alpha):
        m, phi0 = parts(alpha)
        return ellipk(m) - ellipkinc(phi0, m) - np.sqrt(p)

    alpha = brentq(length_mismatch, 1e-14, np.pi / 2 - 1e-14, xtol=1e-15, rtol=1e-15)
    m, phi0 = parts(alpha)
    x_tip = np.sqrt(2.0 * np.sin(alpha) / p)
    y_tip = -(1.0 - 2.0 * (ellipe(m) - ellipeinc(phi0, m)) / np.sqrt(p))
    return alpha, x_tip, y_tip


def test_elastica_reference_is_self_consistent():
    """Guards the reference itself: small-load limit y = -p/3, x = 1 - p^2/15
    (Euler-Bernoulli + inextensibility: int_0^1 w'^2/2 with w' = p(s - s^2/2)),
    tip angle p/2, and the known tabulated value for p = 1 (Bisshopp & Drucker:
    delta / l = 0.3017 at P l^2 / (EI) = 1)."""
    p = 1e-3
    alpha, x, y = cantilever_elastica(p)
    assert y == pytest.approx(-p / 3, rel=1e-5)
    assert alpha == pytest.approx(p / 2, rel=1e-5)
    assert 1 - x == pytest.approx(p**2 / 15, rel=1e-3)
    alpha, x, y = cantilever_elastica(1.0)
    assert -y == pytest.approx(0.3017, abs=5e-5)
    assert x == pytest.approx(0.9436, abs=5e-5)


def solve_tip_load(route, p, n_elements):
    disc = Discretisation.from_arm(tip_tendon_arm(route, n_elements), n_elements)
    solver = EquilibriumSolver(disc)
    try:
        eq = solver.solve([p])
    finally:
        solver.destroy()
    assert eq.converged, eq.message
    return eq


# --- (a) pure end moment ------------------------------------------------------

@pytest.mark.parametrize("m", [0.4, 2.0, 4.0])
def test_pure_end_moment_circular_arc(m):
    """docs/model.md §7: M at the tip, p = 0: theta(s) = m s.  The P1 solution is exact
    at the nodes (the exact solution is in the P1 space); the tip is the
    midpoint-rule sum of Eq. (2), whose error is exactly
    h^2 / 24 |f'(1) - f'(0)| + O(h^4) with f = e^{i m s}, i.e.
    |x_tip - x_exact| = h^2 m sin(m/2) / 12 + O(h^4)."""
    exact_tip = np.array([np.sin(m) / m, (1.0 - np.cos(m)) / m])
    for n in (10, 40, 160):
        # a single tendon with zero tension; routed anywhere off the arm
        disc = Discretisation.from_arm(tip_tendon_arm((1.0, -0.5), n), n)
        solver = EquilibriumSolver(disc, tip_moment=m)
        try:
            eq = solver.solve([0.0])
        finally:
            solver.destroy()
        assert eq.converged, eq.message
        s = np.arange(n + 1) / n
        np.testing.assert_allclose(eq.theta, m * s, rtol=0, atol=1e-10)
        assert eq.strain_energy == pytest.approx(m**2, rel=1e-10)     # units of SE_0 (Eq. (21))
        assert eq.kappa_max == pytest.approx(abs(m), rel=1e-10)
        assert eq.unstable_modes == 0
        err = np.linalg.norm(eq.tip - exact_tip)
        predicted = m * np.sin(m / 2) / 12 / n**2
        assert err == pytest.approx(predicted, rel=0.02), (n, err, predicted)


# --- (b) dead tip load --------------------------------------------------------

@pytest.mark.parametrize("p", [1e-3, 1e-2])
def test_small_tip_load_deflection(p):
    """docs/model.md §7: small-load deflection P l^3 / (3B), i.e. y_tip = -p / 3."""
    eq = solve_tip_load(DOWN, p, 100)
    # direction of the far-routed load stays fixed: d = (0, -1)
    np.testing.assert_allclose(eq.directions[0], [0.0, -1.0], atol=1e-8)
    # relative O(p) nonlinearity (~1e-5 p) plus O(h^2) discretisation (~3e-5)
    assert eq.tip[1] == pytest.approx(-p / 3, rel=1e-4)
    # axial shortening of second order: 1 - x_tip = p^2 / 15 (inextensibility)
    assert 1.0 - eq.tip[0] == pytest.approx(p**2 / 15, rel=1e-3)


@pytest.mark.parametrize("p", [1.0, 2.0, 5.0, 10.0])
def test_large_tip_load_against_elastica(p):
    """docs/model.md §7: large deflection against the classical elastica (elliptic integrals)."""
    n = 100
    eq = solve_tip_load(DOWN, p, n)
    alpha, x_ref, y_ref = cantilever_elastica(p)
    np.testing.assert_allclose(eq.directions[0], [0.0, -1.0], atol=1e-8)
    # The deflection is O(1); the discretisation errors are C h^2 with measured
    # constants (N = 50..200, stable to 0.1 %): tip 0.066, 0.089, 0.098, 0.115 and
    # tip angle 0.022, 0.092, 0.255, 0.317 for p = 1, 2, 5, 10.
    h2 = 1.0 / n**2
    assert np.hypot(eq.tip[0] - x_ref, eq.tip[1] - y_ref) <= 0.13 * h2
    assert abs(-eq.theta[-1] - alpha) <= 0.35 * h2
    assert eq.unstable_modes == 0


def test_route_mm_1e9_far_is_a_dead_load_to_1e6():
    """The route of the brief (1000, -1e9) mm on a 1000 mm arm: the load direction
    tilts by ~|x_tip| / 1e6 only; the tip matches the elastica to ~1e-5."""
    p = 2.0
    eq = solve_tip_load((1.0, -1e6), p, 100)
    tilt = abs(np.arctan2(eq.directions[0][0], -eq.directions[0][1]))
    assert tilt < 1e-6
    _, x_ref, y_ref = cantilever_elastica(p)
    assert np.hypot(eq.tip[0] - x_ref, eq.tip[1] - y_ref) <= 1.5e-5


# --- (c) mesh convergence -----------------------------------------------------

def test_tip_position_converges_at_second_order():
    """Fit log(err) = q log(h) + c over N = 10, 20, 40, 80 against the closed
    form (p = 2): q = 2 within 0.2 (P1 + midpoint rule), and an absolute cap."""
    p = 2.0
    _, x_ref, y_ref = cantilever_elastica(p)
    ns = np.array([10, 20, 40, 80])
    errors = []
    for n in ns:
        eq = solve_tip_load(DOWN, p, int(n))
        errors.append(np.hypot(eq.tip[0] - x_ref, eq.tip[1] - y_ref))
    errors = np.array(errors)
    order = np.polyfit(np.log(1.0 / ns), np.log(errors), 1)[0]
    assert abs(order - 2.0) <= 0.2, f"fitted order {order:.3f}, errors {errors}"
    assert np.all(np.diff(errors) < 0)
    assert errors[-1] <= 2e-5          # N = 80: measured 1.4e-5
    assert errors[0] <= 1.5e-3         # N = 10: measured 8.9e-4


# --- (d) buckling of the straight arm -----------------------------------------

@pytest.mark.parametrize("route, p_cr, label", [
    ((-1e9, 0.0), np.pi**2 / 4, "dead compressive load"),
    ((0.0, 0.0), np.pi**2, "load aimed at the clamp"),
])
def test_buckling_inertia_crosses_at_critical_load(route, p_cr, label):
    """docs/model.md §7: the smallest eigenvalue of K crosses zero at p_cr; the inertia
    count goes 0 -> 1 (N = 200, relative discretisation error ~1e-5)."""
    n = 200
    disc = Discretisation.from_arm(tip_tendon_arm(route, n), n)
    counter = InertiaCounter(disc)
    u = disc.straight()   # an equilibrium for every p (the load is axial)
    try:
        assert np.max(np.abs(disc.residual(u, [1.3 * p_cr]))) <= 1e-12
        below = counter.negative_eigenvalues(u, [0.95 * p_cr])
        above = counter.negative_eigenvalues(u, [1.05 * p_cr])
        assert (below, above) == (0, 1), label
        assert counter.negative_eigenvalues(u, [0.0]) == 0
        # same count from the dense reduced tangent
        for f, expected in ((0.95, 0), (1.05, 1)):
            ev = np.linalg.eigvalsh(reduced_tangent(disc, u, [f * p_cr]))
            assert int(np.sum(ev < 0)) == expected
        # smallest eigenvalue of the continuous problem vanishes at p_cr:
        # lambda_min(K) changes sign between 0.999 p_cr and 1.001 p_cr
        lo = np.linalg.eigvalsh(reduced_tangent(disc, u, [0.999 * p_cr]))[0]
        hi = np.linalg.eigvalsh(reduced_tangent(disc, u, [1.001 * p_cr]))[0]
        assert lo > 0 > hi
    finally:
        counter.destroy()


def test_dead_load_second_mode():
    """Dead compressive load: the second buckling load is 9 pi^2 / 4."""
    n = 200
    disc = Discretisation.from_arm(tip_tendon_arm((-1e9, 0.0), n), n)
    counter = InertiaCounter(disc)
    try:
        u = disc.straight()
        assert counter.negative_eigenvalues(u, [0.95 * 9 * np.pi**2 / 4]) == 1
        assert counter.negative_eigenvalues(u, [1.05 * 9 * np.pi**2 / 4]) == 2
    finally:
        counter.destroy()
