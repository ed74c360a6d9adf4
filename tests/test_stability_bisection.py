"""The smallest eigenvalue without SLEPc (StabilitySolver.smallest, solvers/lambda_min.py)
against SLEPc's shift-and-invert solve (StabilitySolver.solve): the same
lambda_min and raw_min to 1e-8 relative, on stable and unstable states, both
mass models; the bracket is exact (the inertia count of K - lambda M)."""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import Arm, Tendon, load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.lambda_min import SmallestEigenvalue
from elastica_petsc.solvers.stability import StabilitySolver

RTOL = 1e-8


@pytest.fixture(scope="module")
def states():
    """Equilibria of the paper's arm (N = 180): straight, the two Fig. 8 states at
    p = (25.2, 10.8), and states along a ray of growing tension."""
    disc = Discretisation.from_arm(load_config(), 180)
    found = [(disc.straight(), np.zeros(2))]
    with EquilibriumSolver(disc) as eq:
        for order in ((2, 1), (1, 2)):
            e = eq.solve((25.2, 10.8), order=order)
            assert e.converged, e.message
            found.append((e.u, e.p))
        for p in ((3.0, 0.0), (0.0, 8.0), (12.0, 30.0), (40.0, 5.0)):
            e = eq.solve(p)
            if e.converged:
                found.append((e.u, e.p))
    return disc, found


@pytest.mark.parametrize("mass", ["lumped", "paper"])
def test_bisection_matches_slepc(states, mass):
    disc, found = states
    signs = set()
    with StabilitySolver(disc, nev=1, mass=mass) as solver:
        for u, p in found:
            reference = solver.solve(u, p)
            lam, raw = solver.smallest(u, p)
            assert lam == pytest.approx(reference.lambda_min, rel=RTOL, abs=1e-12)
            assert raw == pytest.approx(reference.raw_min, rel=RTOL, abs=1e-14)
            signs.add(lam > 0)
    assert signs == {True}                  # the paper's states here are stable


@pytest.mark.parametrize("route_l, p", [((-1e6, 0.0), 0.9 * np.pi**2 / 4),   # dead tip load
                                         ((-1e6, 0.0), 1.2 * np.pi**2 / 4),   # one negative
                                         ((-1e6, 0.0), 1.2 * (1.5 * np.pi)**2),  # two
                                         ((0.0, 0.0), 1.3 * np.pi**2)])      # aimed at the clamp
def test_bisection_matches_slepc_beyond_buckling(route_l, p):
    """Straight arm under an axial tip load (docs/model.md §7): unstable states too."""
    arm = Arm(length_mm=1000.0, bending_stiffness_Nm2=1.0, elements=100,
              tendons=(Tendon(1000.0, (1000.0 * route_l[0], 1000.0 * route_l[1])),))
    disc = Discretisation.from_arm(arm)
    u = disc.straight()
    with StabilitySolver(disc, nev=1) as solver:
        reference = solver.solve(u, [p])
        lam, raw = solver.smallest(u, [p])
    assert lam == pytest.approx(reference.lambda_min, rel=RTOL, abs=1e-12)
    assert raw == pytest.approx(reference.raw_min, rel=RTOL, abs=1e-14)
    assert (lam < 0) == (p > np.pi**2 / 4 if route_l[0] < 0 else p > np.pi**2)


def test_bisection_bracket_is_the_inertia(states):
    """Just below lambda_min K - sigma M has no negative eigenvalue, just above one."""
    disc, found = states
    with StabilitySolver(disc, nev=1) as solver:
        for u, p in found:
            lam, _ = solver.smallest(u, p)
            values = disc.stability_values(u, p)
            slots = SmallestEigenvalue(disc).diagonal
            for sigma, expected in ((lam - 1e-6 * abs(lam), 0), (lam + 1e-6 * abs(lam), 1)):
                shifted = values.copy()
                shifted[slots] -= sigma * solver.m
                assert solver.inertia.count(shifted, disc.stability_border) == expected


def test_unloaded_arm_is_pi2_over_4():
    """The straight unloaded arm: lambda l^2/B -> pi^2/4 at O(h^2) (docs/model.md §3)."""
    disc = Discretisation.from_arm(load_config(), 180)
    with StabilitySolver(disc, nev=1) as solver:
        lam, raw = solver.smallest(disc.straight(), np.zeros(2))
    assert lam == pytest.approx(np.pi ** 2 / 4, rel=1e-4)
    assert raw == pytest.approx(np.pi ** 2 / 4 * disc.h, rel=2e-2)


def test_bisection_alone_when_inverse_iteration_fails(states, monkeypatch):
    """Without the inverse iteration (a singular factor, no settling), bisection
    alone gives the same values."""
    import elastica_petsc.solvers.lambda_min as lambda_min

    disc, found = states
    with StabilitySolver(disc, nev=1) as solver:
        expected = [solver.smallest(u, p) for u, p in found]
        monkeypatch.setattr(lambda_min, "inverse_iteration", lambda *args, **kw: None)
        for (u, p), (lam, raw) in zip(found, expected):
            assert solver.smallest(u, p) == pytest.approx((lam, raw), rel=1e-10)
