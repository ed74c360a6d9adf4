"""Closed forms for cables through guides and the arm's weight (docs/model.md §11).

- a cable through n equally spaced guides at offset d along the arm, pulled at the
  tip: the tip angle tends to p d (constant curvature kappa = P d / B) at the rate
  n^-2 of §11.4, with the leading term p d (p/12 - (p d)^2/8) / n^2;
- the paper's arm in the guided kernel gives today's equilibrium to 1e-12;
- a cantilever under its own weight: the tip deflection q l^4/(8B) for small q and an
  independent shooting solution (solve_ivp) to 1e-8 l at N = 800, converging at O(h^2);
- a vertical column: standing above the clamp it buckles under its own weight at
  q l^3/B = (9/4) j^2 (j the first zero of J_{-1/3}; 7.837), found by the inertia
  count of the stability analysis within 1e-6 relative; hanging below it stays stable.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import jv

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.guided import GuidedDiscretisation
from elastica_petsc.core.model import Arm, Guide, Tendon
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.inertia import InertiaCounter

OFFSET = 0.05          # d / l
TENSION = 20.0         # p = P l^2 / B: p d = 1 rad of tip rotation


def guided_column(n_guides: int, elements: int) -> Arm:
    """l = 1000 mm, B = 1 N m^2; one cable from (0, d) through n-1 guides at
    s = j l / n and offset d to the tip, offset d."""
    d_mm = 1000.0 * OFFSET
    guides = tuple(Guide(1000.0 * j / n_guides, d_mm) for j in range(1, n_guides))
    return Arm(length_mm=1000.0, bending_stiffness_Nm2=1.0, guide_radius_mm=d_mm, elements=elements,
               tendons=(Tendon(1000.0, (0.0, d_mm), attach_offset_mm=d_mm, guides=guides),))


def test_closely_spaced_guides_give_constant_curvature():
    counts = (4, 8, 16, 32)
    errors = []
    for n in counts:
        with EquilibriumSolver(Discretisation.from_arm(guided_column(n, 480))) as solver:
            eq = solver.solve([TENSION])
        assert eq.converged and eq.stable
        errors.append(eq.theta[-1] - TENSION * OFFSET)
    errors = np.array(errors)
    orders = np.log2(errors[:-1] / errors[1:])
    assert np.all(np.abs(orders[1:] - 2.0) < 0.15), orders
    pd = TENSION * OFFSET
    leading = pd * (TENSION / 12 - pd**2 / 8) / counts[-1] ** 2     # docs/model.md §11.4
    assert abs(errors[-1] / leading - 1.0) < 0.02, (errors[-1], leading)
    # the curvature is uniform to the same order
    assert np.max(np.abs(eq.curvature - pd)) < 2.0 * TENSION / 8 * pd / counts[-1] ** 2


def test_paper_arm_in_guided_kernel_matches_today(paper_arm):
    p = np.array([25.2, 10.8])
    results = []
    for disc in (Discretisation.from_arm(paper_arm), GuidedDiscretisation.from_arm(paper_arm)):
        with EquilibriumSolver(disc) as solver:
            results.append(solver.solve(p, order=(2, 1)))
    plain, guided = results
    assert plain.converged and guided.converged
    assert np.max(np.abs(plain.theta - guided.theta)) < 1e-12
    assert np.max(np.abs(plain.cable_lengths - guided.cable_lengths)) < 1e-12


def weighted_arm(q: float, elements: int, direction=(0.0, -1.0)) -> Arm:
    """l = 1 m, B = 1 N m^2, |g| = 1 m/s^2: q = rho_A g l^3 / B = mass per length."""
    return Arm(length_mm=1000.0, bending_stiffness_Nm2=1.0, elements=elements,
               mass_per_length_kg_m=q, gravity_m_s2=direction,
               tendons=(Tendon(1000.0, (1000.0, 1e6)),))


def shooting_tip(q: float) -> np.ndarray:
    """Tip of the cantilever under its weight q (downwards): B theta'' = q (l - s) cos theta,
    theta(0) = 0, theta'(l) = 0, by shooting on theta'(0) with solve_ivp."""
    def rhs(s, z):
        return [z[1], q * (1 - s) * np.cos(z[0]), np.cos(z[0]), np.sin(z[0])]

    def end(k0):
        return solve_ivp(rhs, (0, 1), [0, k0, 0, 0], method="DOP853", rtol=1e-13,
                         atol=1e-14).y[:, -1]
    k0 = brentq(lambda k: end(k)[1], -q, 0.0, xtol=1e-15)
    return end(k0)[2:]


def cantilever_tip(q: float, elements: int) -> np.ndarray:
    with EquilibriumSolver(Discretisation.from_arm(weighted_arm(q, elements))) as solver:
        eq = solver.solve([0.0])
    assert eq.converged and eq.stable
    return eq.tip


def test_self_weight_small_deflection():
    q = 1e-3
    tip = cantilever_tip(q, 100)
    assert abs(-tip[1] / (q / 8) - 1.0) < 2e-3          # O(q) + O(h^2)


def test_self_weight_large_deflection_against_shooting():
    q = 3.0
    reference = shooting_tip(q)
    errors = [np.linalg.norm(cantilever_tip(q, n) - reference) for n in (200, 400, 800)]
    assert errors[-1] < 1e-8
    assert np.all(np.abs(np.log2(np.array(errors[:-1]) / errors[1:]) - 2.0) < 0.05), errors


def critical_weight(elements: int, direction) -> float:
    """Smallest q at which the straight column has a negative eigenvalue of K
    (inertia count, bisection)."""
    def unstable(q):
        disc = Discretisation.from_arm(weighted_arm(q, elements, direction))
        counter = InertiaCounter(disc)
        try:
            return counter.negative_eigenvalues(disc.consistent_state(
                np.zeros(elements + 1)), [0.0]) > 0
        finally:
            counter.destroy()
    lo, hi = 5.0, 10.0
    assert not unstable(lo) and unstable(hi)
    while hi - lo > 1e-11:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if unstable(mid) else (mid, hi)
    return 0.5 * (lo + hi)


def test_column_buckles_under_its_own_weight():
    j = brentq(lambda x: jv(-1.0 / 3.0, x), 1.0, 2.5, xtol=1e-15)
    exact = 2.25 * j * j
    assert abs(exact - 7.837) < 1e-3
    coarse, fine = (critical_weight(n, (-1.0, 0.0)) for n in (200, 400))
    extrapolated = (4.0 * fine - coarse) / 3.0          # O(h^2) error, docs/model.md §11.5
    assert abs(fine / exact - 1.0) < 2e-5
    assert abs(extrapolated / exact - 1.0) < 1e-6
    # hanging below the clamp: no negative eigenvalue at ten times the load
    disc = Discretisation.from_arm(weighted_arm(10 * exact, 200, (1.0, 0.0)))
    counter = InertiaCounter(disc)
    try:
        assert counter.negative_eigenvalues(disc.straight(), [0.0]) == 0
    finally:
        counter.destroy()
