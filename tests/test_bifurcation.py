"""Symmetric bifurcations under load control and the post-buckled states
(solvers/bifurcation.py; docs/model.md §7, buckling of the straight arm).

One cable attached at the tip of an arm along +x, routed through a point r on
the x axis: the straight arm is an equilibrium for every tension, and loses
stability at p_cr with tan(k l) = k (l - c), k = sqrt(p_cr) (non-dimensional,
l = 1), c the distance from the tip to r measured towards the clamp
(c -> infinity: a dead load, p_cr = pi^2/4; c = l: a cable aimed at the
clamp, p_cr = pi^2).  The post-buckled states are checked against a shooting
solution of the elastica written here with scipy:

    theta'' = -(t x F),  t = (cos theta, sin theta),  F = p (r - x(1)) / |r - x(1)|,
    theta(0) = 0,  theta'(1) = 0,  x' = t,  x(0) = 0        (Eqs. (2), (8)-(9), B = 1).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, fsolve

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import Arm, Tendon
from elastica_petsc.solvers.bifurcation import critical_mode, orthogonality
from elastica_petsc.solvers.equilibrium import (BIFURCATION, Equilibrium, EquilibriumSolver,
                                                 newton_converged)

DEAD = (-1e9, 0.0)          # routing point (mm) far behind the clamp: a dead load
CLAMP = (0.0, 0.0)          # aimed at the clamp
MIDDLE = (500.0, 0.0)       # through (0.5 l, 0)


def on_axis_arm(route_mm, elements: int) -> Arm:
    """l = 1000 mm, B = 1 N m^2 (so p = P l^2/B equals P in newtons), one tip cable."""
    return Arm(1000.0, 1.0, (Tendon(1000.0, route_mm),), elements=elements)


def solve(route_mm, p: float, elements: int, side=None):
    disc = Discretisation.from_arm(on_axis_arm(route_mm, elements))
    with EquilibriumSolver(disc) as solver:
        return solver.solve([p], side=side)


def p_critical(route_mm) -> float:
    """Smallest root of tan(k) = k (1 - c) = k r_x (units of l), as
    sin k - k r_x cos k = 0: in (pi, 3 pi/2) for r_x > 0, in (pi/2, pi] for
    r_x <= 0 (pi^2 at the clamp, -> pi^2/4 for a dead load)."""
    rx = route_mm[0] / 1000.0
    bracket = (math.pi + 1e-9, 1.5 * math.pi - 1e-9) if rx > 0 else \
        (0.5 * math.pi + 1e-9, math.pi + 1e-6)
    return brentq(lambda k: math.sin(k) - k * rx * math.cos(k), *bracket, xtol=1e-14) ** 2


def shooting(route_mm, p: float, guess_tip, guess_kappa0: float) -> tuple[np.ndarray, float]:
    """Tip of the elastica under the cable force (module docstring), by shooting on
    (theta'(0), x_tip): returns (tip, theta'(0))."""
    r = np.asarray(route_mm, float) / 1000.0

    def force(tip):
        chord = r - tip
        return p * chord / np.linalg.norm(chord)

    def integrate(kappa0, tip):
        F = force(tip)

        def rhs(s, z):
            theta, kappa = z[0], z[1]
            return [kappa, -(math.cos(theta) * F[1] - math.sin(theta) * F[0]),
                    math.cos(theta), math.sin(theta)]
        sol = solve_ivp(rhs, (0.0, 1.0), [0.0, kappa0, 0.0, 0.0], rtol=1e-12, atol=1e-13,
                        method="DOP853")
        return sol.y[:, -1]

    def residual(z):
        end = integrate(z[0], z[1:])
        return [end[1], end[2] - z[1], end[3] - z[2]]

    z, info, ok, msg = fsolve(residual, [guess_kappa0, *guess_tip], xtol=1e-13,
                              full_output=True)
    assert ok == 1, msg
    assert np.max(np.abs(residual(z))) < 1e-11
    return z[1:], z[0]


# --- detection: the critical load ---------------------------------------------------------
@pytest.mark.parametrize("route", [MIDDLE, CLAMP, DEAD])
def test_critical_load_converges_to_closed_form(route):
    """The critical load reported when the straight arm is crossed converges at
    second order to tan(k l) = k (l - c) (pi^2/4 dead, pi^2 at the clamp)."""
    exact = p_critical(route)
    errors = []
    for n in (50, 100, 200):
        eq = solve(route, exact * 1.05, n)
        assert eq.converged and eq.stable and len(eq.bifurcations) == 1, eq.message
        errors.append(abs(eq.bifurcations[0].p_critical[0] - exact))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(rates - 2.0) < 0.1), (errors, rates)
    assert errors[-1] < 1e-3 * exact


def test_closed_form_of_the_middle_route():
    """The issue's number: p_cr = 18.2738 for the route through (0.5 l, 0)."""
    assert abs(p_critical(MIDDLE) - 18.2738) < 1e-4


IMPERFECT = (500.0, 5.0)    # the middle route moved 5 mm off the axis


@pytest.fixture(scope="module")
def imperfect_fold():
    """The imperfect arm (route 5 mm off the axis) on its complementary branch
    (tip on the side away from the imperfection), unloaded until the branch
    folds: the last converged state before the fold, by bisection."""
    disc = Discretisation.from_arm(on_axis_arm(IMPERFECT, 60))
    with EquilibriumSolver(disc) as solver:
        natural = solver.solve([25.0])
        assert natural.converged and not natural.bifurcations    # no crossing: imperfect
        u, _, reason = solver.newton(disc.consistent_state(-natural.theta), [25.0])
        assert newton_converged(reason)
        state = solver.solve([19.0], start=Equilibrium(disc, np.array([25.0]), u, True, "", 0, 0))
        assert state.converged and state.stable and state.tip[1] < 0
        lo, hi = 18.5, 19.0
        for _ in range(6):
            mid = 0.5 * (lo + hi)
            trial = solver.solve([mid], start=state)
            if trial.converged:
                hi, state = mid, trial
            else:
                lo = mid
    return disc, natural, state


def test_limit_point_is_not_a_bifurcation(imperfect_fold):
    """At a fold the critical mode has a component along dF/dp (measured 0.83);
    on the straight arm under an axial cable it has none (dF/dp = 0)."""
    disc, _, fold = imperfect_fold
    lam, v = critical_mode(disc, fold.u, fold.p)
    assert abs(lam) < 0.05                                    # near the fold: K near singular
    assert orthogonality(disc, fold.u, [1.0], v) > 0.1
    straight = Discretisation.from_arm(on_axis_arm(MIDDLE, 100))
    _, v = critical_mode(straight, straight.straight(), [18.0])
    assert orthogonality(straight, straight.straight(), [1.0], v) == 0.0


def test_imperfection_removes_the_bifurcation(imperfect_fold):
    """With the route 5 mm off the axis the loading path is smooth: no crossing
    is recorded, and the arm deflects to the imperfection's side."""
    _, natural, _ = imperfect_fold
    assert natural.stable and not natural.bifurcations and natural.tip[1] > 0
    assert natural.message == ""


def test_branch_that_ends_on_the_routing_point_is_reported():
    """A route 30 mm short of the tip: the buckled branches leave the straight
    arm upwards in p but the tip recedes onto the routing point before p
    grows by 2 %.  At 1.01 p_cr the buckled state exists (and matches the
    shooting solution); at 1.02 p_cr the solve says BIFURCATION and why (no
    stable state on either side), not a limit point."""
    route = (970.0, 0.0)
    pc = p_critical(route)
    below = solve(route, 1.01 * pc, 200)
    assert below.converged and below.stable and len(below.bifurcations) == 1
    assert 0.97 < below.tip[0] < 1.0
    tip, _ = shooting(route, 1.01 * pc, below.tip, below.curvature[0])
    np.testing.assert_allclose(below.tip, tip, atol=2e-4)       # O(h^2) at 200 elements
    beyond = solve(route, 1.02 * pc, 200)
    assert not beyond.converged and beyond.reason == BIFURCATION
    assert "not a limit point" in beyond.message
    assert beyond.message.count("onto its routing point") == 2, beyond.message
    assert abs(beyond.p[0] - pc) < 0.01 * pc


def test_bad_side_is_an_input_error():
    from elastica_petsc.core.errors import InputError

    with pytest.raises(InputError, match="side must be one of"):
        solve(MIDDLE, 18.6, 50, side="up")


# --- the must-show -----------------------------------------------------------------
def test_route_through_middle_buckles_to_both_sides():
    """solve --tensions 18.6 on the cable-through-(0.5 l, 0) arm at 400 elements:
    a stable buckled state with tip (0.9674 l, +-0.0689 l) within 1e-4 l (our
    shooting solution gives the reference), the left side by default (equal
    energies), the right one on request."""
    left = solve(MIDDLE, 18.6, 400)
    tip_ref, _ = shooting(MIDDLE, 18.6, left.tip, left.curvature[0])
    right = solve(MIDDLE, 18.6, 400, side="right")
    for eq, sign in ((left, 1.0), (right, -1.0)):
        assert eq.converged and eq.stable
        np.testing.assert_allclose(eq.tip, [tip_ref[0], sign * tip_ref[1]], atol=1e-4)
        np.testing.assert_allclose(eq.tip, [0.9674, sign * 0.0689], atol=1e-4)
    assert left.bifurcations[0].side == "left" and "same energy" in left.bifurcations[0].rule
    assert right.bifurcations[0].rule == "requested"
    assert "bifurcation" in left.message and "left branch" in left.message


# --- post-buckling against the shooting solution -------------------------------------------
@pytest.mark.parametrize("route, p", [(DEAD, 3.0), (DEAD, 5.0), (CLAMP, 12.0), (MIDDLE, 18.6)])
def test_post_buckled_tip_matches_shooting(route, p):
    """Stable buckled states at 100, 200 and 400 elements converge to the shooting
    solution at second order; Richardson extrapolation of the 200/400 pair
    matches it to 1e-6 l."""
    states = {n: solve(route, p, n) for n in (100, 200, 400)}
    tips = {n: eq.tip for n, eq in states.items()}
    ref, _ = shooting(route, p, tips[400], states[400].curvature[0])
    errors = [np.linalg.norm(tips[n] - ref) for n in (100, 200, 400)]
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(rates - 2.0) < 0.1), (errors, rates)
    richardson = (4.0 * tips[400] - tips[200]) / 3.0
    assert np.linalg.norm(richardson - ref) < 1e-6, (richardson, ref)
