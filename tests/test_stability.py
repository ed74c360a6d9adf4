"""Stability indicator and eigenfrequencies (elastica_petsc.solvers.stability).

Closed-form checks (docs/model.md §7): buckling of the straight arm under a dead tip
load (p_cr = pi^2/4) and under a tip load aimed at the clamp (p_cr = pi^2);
the unloaded arm's lambda l^2/B -> pi^2/4 with the fitted order; the clamped-
free Euler-Bernoulli frequency.  Reference states: Fig. 8 at p = (25.2, 10.8).
Self-contained (own helpers) so that it does not depend on shared fixtures.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
from petsc4py import PETSc
from scipy.optimize import brentq

from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.inertia import InertiaCounter
from elastica_petsc.core.model import Arm, Tendon
from elastica_petsc.solvers.stability import (EB_BETA1, StabilitySolver, euler_bernoulli_f1_hz,
                                      frequency_scale_hz, kinetic_mass_apply,
                                      max_tracing_speed_mm_s, node_masses, schur_asymmetry)

P_FIG8 = (25.2, 10.8)


# --- helpers ---------------------------------------------------------------------
def tip_arm(route_l, n_elements: int) -> Arm:
    """1000 mm arm, B = 1, one tendon at the tip routed to ``route_l`` (units of l)."""
    return Arm(length_mm=1000.0, bending_stiffness_Nm2=1.0, elements=n_elements,
               tendons=(Tendon(1000.0, (1000.0 * route_l[0], 1000.0 * route_l[1])),),
               mass_per_length_kg_m=1.0)


def tip_disc(route_l, n_elements: int) -> Discretisation:
    return Discretisation.from_arm(tip_arm(route_l, n_elements))


def dense_tangent(disc, u, p) -> np.ndarray:
    """K = T - B C from the bordered SNES Jacobian, densely (small N only)."""
    indptr, indices, _ = disc.pattern
    J = sp.csr_matrix((disc.jacobian_values(u, p), indices, indptr),
                      shape=(disc.size, disc.size)).toarray()
    N = disc.n_elements
    return J[:N, :N] - J[:N, N:] @ np.linalg.solve(J[N:, N:], J[N:, :N])


def lumped_mass(disc) -> np.ndarray:
    m = np.full(disc.n_elements, disc.h)
    m[-1] *= 0.5
    return m


@pytest.fixture(scope="module")
def paper_arm() -> Arm:
    return load_config()


@pytest.fixture(scope="module")
def fig8_states(paper_arm):
    """The two load-controlled states of Fig. 8 at p = (25.2, 10.8), N = 180."""
    disc = Discretisation.from_arm(paper_arm, 180)
    with EquilibriumSolver(disc) as eq:
        states = {order: eq.solve(P_FIG8, order=order) for order in ((2, 1), (1, 2))}
    for e in states.values():
        assert e.converged, e.message
    return disc, states


# --- the bordered pencil ----------------------------------------------------------------
@pytest.mark.parametrize("operator", ["jacobian", "symmetric"])
@pytest.mark.parametrize("mass", ["lumped", "paper"])
def test_pencil_matches_dense_generalized_problem(paper_arm, operator, mass):
    """Finite eigenvalues of the bordered pencil are those of (K, M); the
    border's infinite eigenvalues never come back from shift-and-invert."""
    coarse = Discretisation.from_arm(paper_arm, 30)
    with EquilibriumSolver(coarse) as eq:
        e = eq.solve(P_FIG8, order=(2, 1))
    assert e.converged
    K = dense_tangent(coarse, e.u, e.p)
    m = lumped_mass(coarse) if mass == "lumped" else np.full(30, coarse.h)
    exact = np.sort(sla.eigh(0.5 * (K + K.T), np.diag(m), eigvals_only=True))
    with StabilitySolver(coarse, nev=6, mass=mass, operator=operator) as solver:
        r = solver.solve(e.u, e.p)
    assert r.converged >= 6 and len(r.eigenvalues) == 6
    assert np.all(np.isfinite(r.eigenvalues)) and r.max_imag == 0.0
    np.testing.assert_allclose(r.eigenvalues, exact[:6], rtol=1e-9)
    raw = np.linalg.eigvalsh(0.5 * (K + K.T))[0]
    assert r.raw_min == pytest.approx(raw, rel=1e-9)
    # modes: theta_0 = 0, unit max, and K v = lambda M v on the theta part
    v = r.modes[0][1:]
    assert r.modes[0][0] == 0.0 and np.max(np.abs(r.modes[0])) == pytest.approx(1.0)
    np.testing.assert_allclose(K @ v, r.eigenvalues[0] * m * v, atol=1e-8 * np.abs(K).max())


def test_operators_and_masses_agree_at_fig8(fig8_states):
    disc, states = fig8_states
    e = states[(2, 1)]
    with StabilitySolver(disc, operator="jacobian") as a, \
            StabilitySolver(disc, operator="symmetric") as b, \
            StabilitySolver(disc, mass="paper") as c:
        ra, rb, rc = a.solve(e.u, e.p), b.solve(e.u, e.p), c.solve(e.u, e.p)
    np.testing.assert_allclose(ra.eigenvalues, rb.eigenvalues, rtol=1e-10)
    # the raw indicator lambda_min(K) does not depend on the mass model
    assert ra.raw_min == pytest.approx(rc.raw_min, rel=1e-10)
    assert rc.raw_min == pytest.approx(disc.h * rc.eigenvalues[0], rel=1e-14)


# --- reference states of Fig. 8 --------------------------------------------------------
@pytest.mark.parametrize("order", [(2, 1), (1, 2)])
def test_fig8_states_stable_symmetric_and_consistent(fig8_states, order):
    disc, states = fig8_states
    e = states[order]
    with StabilitySolver(disc) as solver:
        r = solver.solve(e.u, e.p)
    assert r.stable and r.eigenvalues[0] > 0
    assert r.negative == r.inertia_negative == 0 and r.inertia_agrees
    assert r.asymmetry < 1e-10
    assert r.raw_min > 0 and r.reason.startswith("CONVERGED")
    assert np.all(np.diff(r.eigenvalues) >= 0)


def test_asymmetry_estimator_detects_asymmetry():
    """The probe estimate of ||K - K^T||_F / ||K||_F is the real thing."""
    rng = np.random.default_rng(7)
    N = 40
    T = sp.csr_matrix(np.diag(rng.uniform(2, 3, N)) + np.diag(rng.uniform(-1, 0, N - 1), 1)
                      + np.diag(rng.uniform(-1, 0, N - 1), -1))
    B, C = sp.csr_matrix(rng.standard_normal((N, 2))), sp.csr_matrix(rng.standard_normal((2, N)))
    K = (T - B @ C).toarray()
    exact = np.linalg.norm(K - K.T) / np.linalg.norm(K)
    assert exact > 0.1
    assert schur_asymmetry(T, B, C, rng, probes=400) == pytest.approx(exact, rel=0.15)
    Ts = sp.csr_matrix(0.5 * (T + T.T))
    assert schur_asymmetry(Ts, B, -B.T, rng) < 1e-15    # T + B B^T is symmetric


def test_unloaded_raw_value_matches_paper_scaling(paper_arm):
    """Raw lambda_min(K)/(B/l) at N = 180 ~ 2.4674 / 180 (docs/model.md §3)."""
    disc = Discretisation.from_arm(paper_arm, 180)
    with StabilitySolver(disc) as solver:
        r = solver.solve(disc.straight(), np.zeros(2))
    assert r.eigenvalues[0] == pytest.approx(math.pi**2 / 4, rel=1e-5)
    # K's own eigenvalue, no mass: the tip row sees a full mass h
    assert r.raw_min == pytest.approx(math.pi**2 / 4 / 180, rel=1e-2)


# --- mesh convergence of the unloaded arm -------------------------------------------------
@pytest.mark.parametrize("mass, order", [("lumped", 2.0), ("paper", 1.0)])
def test_unloaded_eigenvalue_converges(mass, order):
    hs, errors = [], []
    for N in (20, 40, 80, 160, 320):
        disc = tip_disc((2.0, 0.0), N)
        with StabilitySolver(disc, mass=mass, nev=1) as solver:
            r = solver.solve(disc.straight(), [0.0], raw=False)
        if mass == "lumped":   # exactly the finite-difference eigenvalue 4 N^2 sin^2(pi/(4N))
            assert r.eigenvalues[0] == pytest.approx(4 * N**2 * math.sin(math.pi / (4 * N))**2,
                                                     rel=1e-11)
        hs.append(disc.h)
        errors.append(abs(r.eigenvalues[0] - math.pi**2 / 4))
    rate = np.polyfit(np.log(hs), np.log(errors), 1)[0]
    assert abs(rate - order) < 0.1
    assert errors[-1] < (1e-4 if mass == "lumped" else 1e-2)


# --- buckling of the straight arm (docs/model.md §7) -------------------------------------------------
def critical_load(route_l, N: int, p_hi: float) -> float:
    """Tension at which lambda_min of K on the straight state crosses zero."""
    disc = tip_disc(route_l, N)
    u = disc.straight()          # an equilibrium for every p: the load is axial
    assert np.max(np.abs(disc.residual(u, [p_hi])[:N])) < 1e-12
    with StabilitySolver(disc, nev=1) as solver:
        return brentq(lambda p: solver.solve(u, [p], raw=False).eigenvalues[0], 0.1, p_hi,
                      xtol=1e-10)


@pytest.mark.parametrize("route, p_cr", [((-1e6, 0.0), math.pi**2 / 4), ((0.0, 0.0), math.pi**2)])
def test_buckling_load(route, p_cr):
    found = critical_load(route, 100, 1.5 * p_cr)
    assert found == pytest.approx(p_cr, rel=1e-2)
    assert found == pytest.approx(p_cr, rel=2e-3)      # in fact much closer at N = 100


def test_beyond_buckling_negative_modes_found_and_counted():
    """Dead tip load beyond the 1st and the 2nd critical loads: 1 and 2 negative
    eigenvalues, all found by SLEPc and matching the LDL^T inertia."""
    disc = tip_disc((-1e6, 0.0), 100)
    u = disc.straight()
    with StabilitySolver(disc, nev=2) as solver:
        for p, expected in ((0.9 * math.pi**2 / 4, 0), (1.2 * math.pi**2 / 4, 1),
                            (1.2 * (1.5 * math.pi)**2, 2)):
            r = solver.solve(u, [p])
            assert r.negative == r.inertia_negative == expected
            assert r.stable == (expected == 0)
            assert len(r.eigenvalues) >= expected + 1
            assert r.raw_min == pytest.approx(
                np.linalg.eigvalsh(dense_tangent(disc, u, [p]))[0], rel=1e-8, abs=1e-12)


def test_inertia_agrees_along_a_loading_path(paper_arm):
    disc = Discretisation.from_arm(paper_arm, 60)
    counter = InertiaCounter(disc)
    with EquilibriumSolver(disc) as eq, StabilitySolver(disc) as solver:
        for p in ((5.0, 0.0), (5.0, 5.0), (25.2, 10.8), (0.0, 20.0)):
            e = eq.solve(p)
            assert e.converged
            r = solver.solve(e.u, e.p)
            assert r.negative == counter.negative_eigenvalues(e.u, e.p) == e.unstable_modes
    counter.destroy()


# --- options --------------------------------------------------------------------------------
def test_command_line_options_under_prefix(paper_arm):
    disc = Discretisation.from_arm(paper_arm, 60)
    opts = PETSc.Options()
    opts["stabtest_eps_nev"] = 7
    try:
        with StabilitySolver(disc, options_prefix="stabtest_") as solver:
            assert solver.nev == 7
            assert solver.eps.getOptionsPrefix() == "stabtest_"
            r = solver.solve(disc.straight(), np.zeros(2))
        assert len(r.eigenvalues) == 7
    finally:
        opts.delValue("stabtest_eps_nev")


def test_bad_arguments(paper_arm):
    disc = Discretisation.from_arm(paper_arm, 30)
    with pytest.raises(ValueError, match="mass"):
        StabilitySolver(disc, mass="consistent")
    with pytest.raises(ValueError, match="operator"):
        StabilitySolver(disc, operator="dense")


# --- eigenfrequencies ---------------------------------------------------------------------------
def test_kinetic_mass_apply_matches_dense(paper_arm):
    disc = Discretisation.from_arm(paper_arm, 30)
    with EquilibriumSolver(disc) as eq:
        e = eq.solve(P_FIG8)
    theta = e.theta
    N = disc.n_elements
    # G = d x_nodes / d theta by central differences of the positions (Eq. (2))
    G = np.zeros((N, 2, N))
    for j in range(N):
        d = np.zeros(N + 1)
        d[j + 1] = 1e-6
        G[:, :, j] = (disc.node_positions(theta + d) - disc.node_positions(theta - d))[1:] / 2e-6
    w = node_masses(disc, tip_mass=0.3)
    M = np.einsum("kci,k,kcj->ij", G, w, G)
    v = np.random.default_rng(1).standard_normal(N)
    np.testing.assert_allclose(kinetic_mass_apply(disc, theta, v, w), M @ v, rtol=1e-7,
                               atol=1e-9 * np.abs(M @ v).max())


def test_unloaded_frequency_is_euler_bernoulli(paper_arm):
    disc = Discretisation.from_arm(paper_arm, 180)
    with StabilitySolver(disc) as solver:
        f = solver.frequencies(disc.straight(), np.zeros(2), paper_arm, nev=3)
    f_eb = euler_bernoulli_f1_hz(paper_arm)
    assert f_eb == pytest.approx(1.8319, rel=1e-4)        # B = 0.2, rho_A = 0.144, l = 0.6
    assert f.f1_hz == pytest.approx(f_eb, rel=1e-4)
    assert f.omega2[0] == pytest.approx(EB_BETA1**4, rel=1e-4)
    # second clamped-free mode, beta_2 l = 4.694091
    assert f.omega2[1] == pytest.approx(4.6940911329741745**4, rel=1e-3)
    assert f.hz[0] == pytest.approx(math.sqrt(f.omega2[0]) * frequency_scale_hz(paper_arm))


def test_frequency_converges_at_second_order():
    hs, errors = [], []
    for N in (20, 40, 80, 160):
        disc = tip_disc((2.0, 0.0), N)
        with StabilitySolver(disc) as solver:
            f = solver.frequencies(disc.straight(), [0.0], nev=1)
        hs.append(disc.h)
        errors.append(abs(f.omega2[0] - EB_BETA1**4))
    assert abs(np.polyfit(np.log(hs), np.log(errors), 1)[0] - 2.0) < 0.1


def test_length_control_interlaces_load_control(paper_arm, fig8_states):
    """Holding the n = 2 cable lengths constrains the motion: by interlacing
    Omega_k(load) <= Omega_k(length) <= Omega_{k+2}(load)."""
    disc, states = fig8_states
    e = states[(2, 1)]
    with StabilitySolver(disc) as solver:
        load = solver.frequencies(e.u, e.p, paper_arm, nev=5, control="load")
        length = solver.frequencies(e.u, e.p, paper_arm, nev=3, control="length")
    assert np.all(load.omega2 > 0) and np.all(length.omega2 > 0)
    for k in range(3):
        assert load.omega2[k] <= length.omega2[k] * (1 + 1e-9)
        assert length.omega2[k] <= load.omega2[k + 2] * (1 + 1e-9)
    # the rule of thumb of Sec. 4.5 (vi): v_max = 2 pi f_1 delta
    assert max_tracing_speed_mm_s(load.f1_hz, 1.0) == pytest.approx(2 * math.pi * load.f1_hz)
