"""Length control (docs/model.md §4.7; paper Sec. 4.1, 4.6, Figs. 7-8, Eq. (23)).

Every converged state is checked independently of PETSc's own test by the
numpy kernels (bordered residual, complementarity) inside the solver, and
here against load-controlled solves, closed forms and dense linear algebra.
Lengths in the paper's mm (arm length 600 mm) where named ``*_mm``, else in
units of l; tensions p = P l^2 / B.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

from elastica_petsc.studies.buckling import aligned_family, critical_configuration, segment_geometry
from elastica_petsc.core.model import load_config
from elastica_petsc.core.deflation import Deflation
from elastica_petsc.solvers.equilibrium import EquilibriumSolver, newton_converged
from elastica_petsc.core.errors import InputError
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.lengths import (AugmentedSystem, LengthInertia, LengthSolver,
                                            constrained_mode)
from elastica_petsc.studies.replay import replay
from elastica_petsc.studies.search import equilibria, length_equilibria, tension_starts
from elastica_petsc.core.model import Arm, Tendon

L_MM = 600.0
P_FIG8 = np.array([25.2, 10.8])
L_FIG8_MM = np.array([147.1, 472.5])


# --- fixtures ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def arm():
    return load_config()


@pytest.fixture(scope="module")
def eqs(arm):
    solver = EquilibriumSolver(Discretisation.from_arm(arm))
    yield solver
    solver.destroy()


@pytest.fixture(scope="module")
def ls(arm):
    solver = LengthSolver.from_arm(arm)
    yield solver
    solver.destroy()


@pytest.fixture(scope="module")
def starts(eqs):
    return tension_starts(eqs)


def assert_length_equilibrium(s, L, tol=1e-8):
    """Bordered residual of Eq. (9) and the complementarity of Eq. (23)."""
    assert s.converged, s.message
    assert np.max(np.abs(s.disc.residual(s.u, s.p))) <= tol
    slack = np.asarray(L) - s.cable_lengths
    assert np.all(s.p >= 0.0)
    assert np.all(slack >= -1e-9)
    assert np.all(np.abs(s.p * slack) <= 1e-9)


def dp_dL(solver, state, h_mm=0.01):
    """(dp_i / dL_j) per mm by central differences of length-controlled solves."""
    L = state.lengths_requested
    cols = []
    for j in range(len(L)):
        e = np.zeros(len(L))
        e[j] = h_mm / L_MM
        a, b = solver.solve(L + e, start=state), solver.solve(L - e, start=state)
        assert a.converged and b.converged
        cols.append((a.p - b.p) / (2 * h_mm))
    return np.array(cols).T


# --- the augmented system: Jacobian and deflation -------------------------------------
def test_deflation_gradient_matches_finite_differences():
    rng = np.random.default_rng(1)
    d = Deflation(1 / 40)
    for _ in range(2):
        d.add(rng.standard_normal(40) * 0.3)
    theta = rng.standard_normal(40) * 0.3
    M, g = d.factor_and_gradient(theta)
    eps = 1e-6
    fd = np.array([(d.factor_and_gradient(theta + eps * e)[0]
                    - d.factor_and_gradient(theta - eps * e)[0]) / (2 * eps) for e in np.eye(40)])
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=1e-9 * M)
    # far from every root M -> sigma^K = 1; at a root it blows up
    assert d.factor_and_gradient(theta + 1e6)[0] == pytest.approx(1.0, abs=1e-9)
    assert d.factor_and_gradient(d.roots[0] + 1e-7)[0] > 1e10


@pytest.mark.parametrize("mode", ["length", "load"])
def test_augmented_jacobian_is_consistent(arm, mode):
    """The assembled Jacobian of (mu F, mu g, mu - M) equals central finite
    differences of the residual, with two deflated roots (the rank-one term
    F grad M^T is carried by the mu row and column)."""
    disc = Discretisation.from_arm(arm, 30)
    system = AugmentedSystem(disc, mode, f"test_{mode}_")
    try:
        rng = np.random.default_rng(2)
        s = np.linspace(0, 1, 31)
        theta = 0.4 * np.sin(2.0 * s) - 0.3 * s ** 2
        u = disc.consistent_state(theta)
        u[-4:] += 1e-3 * rng.standard_normal(4)            # y off X(theta): general point
        for k in range(2):
            system.deflation.add(theta[1:] + 0.1 * (k + 1) * rng.standard_normal(30))
        system.target = np.array([0.3, 0.9]) if mode == "length" else np.array([3.0, 2.0])
        z = system.augment(u, np.array([3.0, 2.0]))
        z[system.imu] *= 1.3                               # mu != M(z)
        J = system.scipy_jacobian(z).toarray()
        eps = 1e-7
        fd = np.empty_like(J)
        for j in range(system.size):
            e = np.zeros(system.size)
            e[j] = eps
            fd[:, j] = (system.residual(z + e) - system.residual(z - e)) / (2 * eps)
        scale = np.max(np.abs(J))
        assert np.max(np.abs(J - fd)) <= 2e-6 * scale
    finally:
        system.destroy()


# --- consistency with load control, slack cables --------------------------------------
def test_length_control_returns_the_load_controlled_state(eqs, ls):
    """A load-controlled equilibrium, held at its own cable lengths and
    started from a disturbed shape and wrong tensions, comes back with the
    same tensions and shape."""
    eq = eqs.solve([12.0, 6.0])
    assert eq.converged
    theta = eq.theta + 0.02 * np.sin(np.pi * np.linspace(0, 1, eq.theta.size))
    theta[0] = 0.0
    start = (ls.disc.consistent_state(theta), np.array([9.0, 8.0]))
    s = ls.solve(eq.cable_lengths, start)
    assert_length_equilibrium(s, eq.cable_lengths)
    np.testing.assert_allclose(s.p, eq.p, rtol=0, atol=1e-8)
    assert np.max(np.abs(s.theta - eq.theta)) <= 1e-9
    assert s.taut.all() and s.unstable_modes == 0 and s.length_unstable_modes == 0


def test_slack_cable_has_no_tension(eqs, ls):
    """Cable 2 given 5 mm more than it spans: it goes slack (p_2 = 0, slack
    5 mm) and the arm is the equilibrium under tendon 1 alone."""
    eq = eqs.solve([15.0, 0.0])
    L = eq.cable_lengths + np.array([0.0, 5.0 / L_MM])
    s = ls.solve(L, (eq.u, np.array([10.0, 5.0])))
    assert_length_equilibrium(s, L)
    assert s.p[1] == 0.0 and s.taut.tolist() == [True, False]
    np.testing.assert_allclose(s.slack_mm, [0.0, 5.0], atol=1e-7)
    assert s.p[0] == pytest.approx(15.0, abs=1e-8)
    assert np.max(np.abs(s.theta - eq.theta)) <= 1e-9


def test_both_cables_slack_gives_the_straight_arm(ls):
    L = ls.lengths_of(ls.disc.straight()) + 0.01
    s = ls.solve(L, (ls.disc.straight(), np.array([1.0, 1.0])))
    assert_length_equilibrium(s, L)
    assert np.all(s.p == 0.0) and np.max(np.abs(s.theta)) < 1e-12


def test_bad_lengths_are_input_errors(ls):
    with pytest.raises(InputError, match="expected 2 cable lengths"):
        ls.solve([0.3])
    with pytest.raises(InputError, match="positive"):
        ls.solve([0.3, -0.1])
    with pytest.raises(InputError, match="shape"):
        replay(ls, [[147.0, 472.0]], [[1.0, 2.0], [3.0, 4.0]])


# --- Fig. 8 ------------------------------------------------------------------------------
@pytest.mark.slow
def test_fig8_length_control_finds_states_1_and_2(eqs, ls, starts):
    """Fig. 8: L = (147.1, 472.5) mm has (at least) two equilibria, with
    p = (25.2, 10.8) (state 1) and p = (9.7, 12.6) (state 2).

    Tolerance, per tension: the paper rounds p to 0.1 (+-0.05) and L to
    0.1 mm (+-0.05 mm); its discretisation also differs from ours: at state
    1 its p = (25.2, 10.8) gives L = (147.1, 472.5) mm, ours
    (147.21, 472.48) mm, i.e. up to dL_model = (0.11, 0.02) mm.  So
    tol_i = 0.05 + sum_j |dp_i/dL_j| (0.05 + dL_model_j), with the
    sensitivities dp/dL measured at each state (at state 2 they give
    tol ~ (0.10, 0.06)).  Measured: (25.245, 10.803) and (9.620, 12.580).
    dp/dL is symmetric (p_i = -dU/dL_i: tensions are the gradient of the
    constrained strain energy), which is checked as well."""
    L = L_FIG8_MM / L_MM
    res = length_equilibria(ls, L, starts, p_max=load_config().max_tension)
    # issue 12: the reference (scripts/studies/equilibria_reference.py) finds six states with
    # 0 <= p_i <= P_crit l^2/B = 203.22, four of them unstable; the default search finds
    # all six, first by the curve search (studies.preimage)
    assert len(res) == 6, res.summary()
    assert [f.state.stable_under_length_control for f in res.states].count(True) == 2
    assert all(f.state.length_unstable_modes >= 0 and f.state.unstable_modes >= 0
               for f in res.states)
    methods = res.methods()
    assert methods["curve continuation"][1] == 6, methods
    assert res.curves["p_max"] == pytest.approx(203.22, abs=0.01)
    assert 0 < res.last_new_attempt <= res.attempts
    eq1 = eqs.solve(P_FIG8, order=(2, 1))
    dL_model = np.abs(eq1.cable_lengths * L_MM - L_FIG8_MM)        # (0.11, 0.02) mm
    assert np.all(dL_model < 0.15)
    for p_paper in ([25.2, 10.8], [9.7, 12.6]):
        found = res.closest(p=p_paper).state
        assert_length_equilibrium(found, L)
        S = dp_dL(ls, found)
        np.testing.assert_allclose(S, S.T, rtol=0, atol=1e-3 * np.max(np.abs(S)))
        tol = 0.05 + np.abs(S) @ (0.05 + dL_model)
        assert np.all(np.abs(found.p - p_paper) <= tol), (found.p, p_paper, tol)
        assert found.length_unstable_modes == 0
    s1, s2 = res.closest(p=[25.2, 10.8]).state, res.closest(p=[9.7, 12.6]).state
    assert np.linalg.norm(s1.tip - s2.tip) * L_MM > 300.0           # far apart (Fig. 8)
    # the paper's remark: x_1 barely moves between states 1 and 2
    assert np.linalg.norm(s1.attachments[0] - s2.attachments[0]) * L_MM < 10.0


@pytest.mark.slow
def test_fig8_load_control_finds_states_1_and_3(eqs, starts):
    """Fig. 8: p = (25.2, 10.8) has states with L = (147.1, 472.5) mm (state 1)
    and L = (96.2, 454.3) mm (state 3); both stable.  The search may find
    more (here also an unstable one)."""
    res = equilibria(eqs, P_FIG8, starts, length_mm=L_MM)
    lengths = [f.state.cable_lengths * L_MM for f in res.states]
    for expected in ([147.1, 472.5], [96.2, 454.3]):
        err = [np.max(np.abs(Lk - expected)) for Lk in lengths]
        k = int(np.argmin(err))
        assert err[k] <= 0.5, res.summary()
        assert res.states[k].state.unstable_modes == 0
    for f in res.states:
        assert np.max(np.abs(f.state.disc.residual(f.state.u, P_FIG8))) <= 1e-8
        np.testing.assert_array_equal(f.state.p, P_FIG8)


# --- stability under length control ------------------------------------------------------
def _dense_constrained_negatives(disc, u, p, taut):
    J = sp.csr_matrix((disc.jacobian_values(u, p), disc.pattern[1], disc.pattern[0]),
                      shape=(disc.size, disc.size)).toarray()
    N = disc.n_elements
    K = J[:N, :N] - J[:N, N:] @ np.linalg.solve(J[N:, N:], J[N:, :N])
    K = 0.5 * (K + K.T)
    C = disc.load_derivative(u)[taut, :N].T
    Z = sla.null_space(C.T) if C.shape[1] else np.eye(N)
    return int(np.sum(np.linalg.eigvalsh(Z.T @ K @ Z) < 0)), int(np.sum(np.linalg.eigvalsh(K) < 0))


def test_constrained_inertia_matches_dense_projection(arm):
    """In([[T, W, C], [W^T, -I, 0], [C^T, 0, 0]]) - (m, n + m, 0) counts the
    negative eigenvalues of K on null(C^T) (Haynsworth + the saddle-point
    inertia theorem).  Checked against the eigenvalues of Z^T K Z (Z an
    orthonormal basis of null(C^T)) on a 30-element mesh, for shapes and
    tensions that make K indefinite, with taut and slack cables."""
    disc = Discretisation.from_arm(arm, 30)
    counter = LengthInertia(disc)
    try:
        s = np.linspace(0, 1, 31)
        cases = []
        for amp in (0.0, 0.5, 1.5):
            theta = amp * np.sin(1.5 * np.pi * s) - 0.4 * amp * s
            for p in ([0.0, 0.0], [40.0, 0.0], [0.0, 30.0], [25.0, 10.8], [80.0, 60.0],
                      [200.0, 5.0]):
                cases.append((disc.consistent_state(theta), np.array(p)))
        seen = set()
        for u, p in cases:
            expected, unconstrained = _dense_constrained_negatives(disc, u, p, p > 0)
            assert counter.negative_eigenvalues(u, p) == expected
            assert expected <= unconstrained                 # constraints only remove modes
            seen.add((expected, unconstrained))
        assert any(e < k for e, k in seen) and any(e > 0 for e, _ in seen), seen
    finally:
        counter.destroy()


def pinned_elastica(chord: float) -> tuple[float, float]:
    """Euler's pinned-pinned elastica of unit length with end-to-end distance
    ``chord``: chord = 2 E(m)/K(m) - 1, p = P l^2/B = 4 K(m)^2, end slopes
    +-alpha with m = sin^2(alpha/2).  Returns (p, total turning 2 alpha)."""
    m = brentq(lambda m: 2 * ellipe(m) / ellipk(m) - 1 - chord, 1e-12, 0.99)
    return 4 * ellipk(m) ** 2, 4 * math.asin(math.sqrt(m))


@pytest.mark.parametrize("chord", [0.95, 0.7])
def test_tendon_routed_at_the_clamp_is_a_pinned_column(chord):
    """Hand check of length control.  One tip tendon routed at the clamp:
    its force always passes through the clamp, so the moment there vanishes
    and the arm is Euler's pinned-pinned column of length l (rotated so that
    theta(0) = 0).  Under load control the straight arm buckles at
    p = pi^2 (docs/model.md §7).  Under length control the cable fixes the chord
    |x_tip| = L.  At L = l (straight) the constraint is degenerate: grad L = 0,
    any p >= 0 balances the straight arm, so the tension is indeterminate
    (the bordered saddle matrix is singular there; not tested).  For L < l
    the state is the buckled elastica with p = 4 K(m)^2 and
    L = l (2E(m)/K(m) - 1) (closed form), and it is stable under length
    control (and, first mode, under load control: dL/dp < 0).  Checked at
    two meshes: error O(h^2)."""
    p_exact, turn_exact = pinned_elastica(chord)
    errors = []
    for n in (60, 120):
        disc = Discretisation.from_arm(Arm(length_mm=1000.0, bending_stiffness_Nm2=1.0,
                                           elements=n, tendons=(Tendon(1000.0, (0.0, 0.0)),)))
        with LengthSolver(disc) as solver:
            s = np.linspace(0, 1, n + 1)
            u0 = disc.consistent_state(-0.8 * s)             # a bent guess: picks a side
            st = solver.solve([chord], (u0, np.array([12.0])))
            assert_length_equilibrium(st, [chord])
            assert st.taut[0]
            assert st.length_unstable_modes == 0 and st.unstable_modes == 0
            assert abs(st.theta[-1]) == pytest.approx(turn_exact, rel=1e-2)
            errors.append(abs(st.p[0] - p_exact) / p_exact)
    assert errors[1] < 1e-3
    assert 3.0 < errors[0] / errors[1] < 5.0                 # second order


# --- Fig. 7: buckling of the straight segment under length control ------------------------
def _column(disc, u, s_index):
    """(alignment, signed max deviation) of the segment beyond attachment 1:
    alignment = t x (r_2 - x_1) with t the chord direction x_1 -> tip (0 when
    the line of the segment passes through r_2); deviation = the largest
    distance of the segment from that chord (units of l, signed)."""
    return segment_geometry(disc, u, s_index)


@pytest.fixture(scope="module")
def fig7(eqs, ls):
    """The Fig. 7 scenario on the paper's arm (:mod:`elastica_petsc.studies.buckling`).
    With p_2 = 0 the arm beyond x_1 is straight (no moment there); at p_1*
    the line of that segment passes through r_2 (found by root finding):
    tendon 2 is just taut and aligned with the segment (the paper's critical
    configuration).  Then L_2 is shortened.  Keeping the segment exactly
    straight ("perfect column") needs L_1 to be let out at the same time:
    the aligned family is traced by a secant iteration on L_1 for each L_2
    (length control)."""
    p1s, e0 = critical_configuration(eqs)
    aligned = aligned_family(eqs, ls, (0.5, 1.0, 1.5, 2.0), critical=(p1s, e0))
    return dict(p1s=p1s, e0=e0, L0=e0.cable_lengths.copy(), aligned=aligned,
                m1=eqs.disc.attach_nodes[0])


def test_fig7_length_path_buckles_the_straight_segment(eqs, ls, fig7):
    """Fig. 7 (Sec. 4.6).  Along the aligned family the smallest eigenvalue
    of K on null(C^T) (both cables taut) falls linearly with the shortening
    dL_2 and crosses zero: a symmetric bifurcation.  The continuation in
    the cable lengths (VI solver, warm starts, inertia after every step)
    detects the loss of constrained stability there, within 0.02 mm, and
    jumps to a buckled state; perturbing along +- the buckling mode gives
    two stable post-buckling states with the segment bent to either side
    (not mirror images: the first segment is curved, so nothing makes the
    bifurcation symmetric; the paper's "one of two states").

    Critical values (measured): dL_2 = 1.61 mm, p_2 = 10.96.  Estimate: the
    segment beyond x_1 (length a = 2l/3) as a column clamped at x_1 with
    its tip load aimed at r_2, a distance c = L_2 from the tip on the
    column's axis (c > a: r_2 lies behind x_1).  Linearised, w'' + k^2 w =
    k^2 w_t (1 - (a - xi)/c) with w(0) = w'(0) = 0, w(a) = w_t gives
    tan(ka) = -k (c - a): k a = 2.283, p_cr = 11.73.  The real base x_1 is
    not a clamp (the first segment bends), so the measured load is lower,
    0.93 of the clamped estimate."""
    disc = eqs.disc
    aligned, m1 = fig7["aligned"], fig7["m1"]
    dls = sorted(aligned)
    lam = {}
    for dl in dls:
        st = aligned[dl]
        assert abs(_column(disc, st.u, m1)[1]) * L_MM < 1e-6          # straight segment
        lam[dl] = constrained_mode(ls.system, ls.system.augment(st.u, st.p, 1.0))[0]
    # stable (constrained) before, unstable after; K alone loses definiteness earlier
    assert [aligned[d].length_unstable_modes for d in dls] == [0, 0, 0, 0, 1]
    assert aligned[1.5].unstable_modes == 1 and aligned[1.0].unstable_modes == 0
    # linear interpolation of the eigenvalue between 1.5 and 2.0 mm
    dl_cr = 1.5 + 0.5 * lam[1.5] / (lam[1.5] - lam[2.0])
    w = (dl_cr - 1.5) / 0.5
    L_cr = (1 - w) * aligned[1.5].lengths_requested + w * aligned[2.0].lengths_requested
    p2_cr = (1 - w) * aligned[1.5].p[1] + w * aligned[2.0].p[1]
    assert 1.5 < dl_cr < 1.7 and 10.5 < p2_cr < 11.5

    a, c = 2.0 / 3.0, L_cr[1]
    ka = brentq(lambda x: math.tan(x) + (c - a) / a * x, math.pi / 2 + 1e-9, math.pi - 1e-9)
    p_clamped = (ka / a) ** 2
    assert p_clamped == pytest.approx(11.73, abs=0.01)
    assert 0.85 * p_clamped < p2_cr < p_clamped

    # the continuation along the aligned lengths detects the event
    path = ls.path([aligned[d].lengths_requested for d in dls[1:]], aligned[0.0])
    assert all(s.converged for s in path), path[-1].message
    assert [len(s.instabilities) for s in path] == [0, 0, 0, 1]
    L_event = path[-1].instabilities[0]
    assert abs((fig7["L0"][1] - L_event[1]) * L_MM - dl_cr) < 0.02
    assert np.max(np.abs(L_event - L_cr)) * L_MM < 0.05
    assert len(path[-1].jumps) == 1
    assert path[-1].instability_kinds == ("bifurcation",)      # buckling, not a fold
    assert path[-1].length_unstable_modes == 0
    assert abs(_column(disc, path[-1].u, m1)[1]) * L_MM > 1.0           # buckled

    # both post-buckling states, 0.3 mm of L_2 beyond the aligned state at 1.5 mm
    L_post = aligned[1.5].lengths_requested + \
        (aligned[2.0].lengths_requested - aligned[1.5].lengths_requested) * 0.6
    straight = ls.solve(L_post, aligned[2.0])
    assert abs(_column(disc, straight.u, m1)[1]) * L_MM < 0.01   # interpolated lengths: ~1e-3
    assert straight.length_unstable_modes == 1
    states = ls.branches(aligned[1.5].u, aligned[1.5].p, L_post)
    devs = sorted(_column(disc, s.u, m1)[1] * L_MM for s in states)
    # measured: -1.21 mm (p_2 = 11.28) and +3.72 mm (p_2 = 9.80); straight p_2 = 12.24
    assert len(states) == 2 and devs[0] < -0.5 and devs[1] > 0.5, devs
    for s in states:
        assert_length_equilibrium(s, L_post)
        assert s.length_unstable_modes == 0 and s.taut.all()
        assert s.p[1] < straight.p[1]                  # the buckled column carries less


def test_fig7_paper_experiment_holds_L1(eqs, ls, fig7):
    """The paper's experiment keeps L_1 and shortens L_2 by a few mm.  That
    path leaves the aligned family at once (an imperfect column): the
    segment bows continuously to one side, p_2 levels off below the perfect
    column's 10.96, and the state stays stable under length control
    although K alone becomes indefinite (it would be unstable under load
    control): length control stabilises it (Sec. 4.6)."""
    disc, m1, L0 = eqs.disc, fig7["m1"], fig7["L0"]
    schedule = [L0 - np.array([0.0, d / L_MM]) for d in (0.5, 1.0, 2.0, 3.0, 6.0)]
    path = ls.path(schedule, fig7["e0"])
    assert all(s.converged and not s.jumps and not s.instabilities for s in path)
    dev = [abs(_column(disc, s.u, m1)[1]) * L_MM for s in path]
    p2 = [s.p[1] for s in path]
    assert np.all(np.diff(dev) > 0) and dev[0] > 0.3 and dev[-1] > 10.0
    assert np.all(np.diff(p2) > 0) and p2[-1] < 10.96
    assert all(s.length_unstable_modes == 0 for s in path)
    assert path[-1].unstable_modes == 1


def test_fold_relation_between_load_and_length_stability(eqs, ls, fig7):
    """For taut cables, by the Schur complement of [[K, C], [C^T, 0]] and
    dL/dp = -C^T K^{-1} C along a load-controlled branch (Maddocks 1987):
    neg_length = neg_load - pos(dL/dp).  dL/dp is measured here by central
    differences of plain load-controlled Newton solves, independently of
    the bordered inertia; states with (neg_load, neg_length) = (0, 0),
    (1, 0) and (1, 1) are all covered."""
    disc = eqs.disc
    seen = set()
    for dl in (0.5, 1.5, 2.0):
        st = fig7["aligned"][dl]
        S = np.empty((2, 2))
        for j in range(2):
            e = np.zeros(2)
            e[j] = 1e-5
            ua, _, reason_a = eqs.newton(st.u, st.p + e)
            ub, _, reason_b = eqs.newton(st.u, st.p - e)
            assert newton_converged(reason_a) and newton_converged(reason_b)
            S[:, j] = (ls.lengths_of(ua) - ls.lengths_of(ub)) / 2e-5
        pos = int(np.sum(np.linalg.eigvalsh(0.5 * (S + S.T)) > 0))
        assert st.length_unstable_modes == st.unstable_modes - pos
        seen.add((st.unstable_modes, st.length_unstable_modes))
    assert seen == {(0, 0), (1, 0), (1, 1)}


# --- replay of a traced schedule ---------------------------------------------------------
@pytest.fixture(scope="module")
def planned(eqs):
    """A short traced path built from forward solves: tensions along a line,
    each state warm-started from the previous one (the planned branch)."""
    P = np.linspace([20.0, 8.0], [23.0, 10.0], 7)
    states, prev = [], None
    for p in P:
        prev = eqs.solve(p, start=prev)
        assert prev.converged
        states.append(prev)
    return dict(P=P, lengths_mm=np.array([s.cable_lengths * L_MM for s in states]),
                tips_mm=np.array([s.tip * L_MM for s in states]),
                thetas=np.array([s.theta for s in states]))


def test_replay_reproduces_a_planned_path(ls, eqs, planned):
    """Under length control the planned cable lengths give back the planned
    tips (1e-5 mm, the paper's tip tolerance) and shapes, with tensions
    equal to the planned ones, stable, without jumps."""
    r = replay(ls, planned["lengths_mm"], planned["tips_mm"], planned["P"], planned["thetas"],
               eq_solver=eqs)
    assert r.completed and r.all_on_branch, r.summary()
    assert r.max_tip_error_mm < 1e-5
    assert r.first_departure is None and not r.jumps
    for q, p in zip(r.points, planned["P"]):
        np.testing.assert_allclose(q.state.p, p, atol=1e-7)
        assert q.stable and q.shape_error < 1e-8
    assert "load-controlled state at the planned tensions" in r.start_method
    # without planned tensions: first point by length continuation from the straight arm
    r2 = replay(ls, planned["lengths_mm"], planned["tips_mm"])
    assert r2.all_on_branch and r2.max_tip_error_mm < 1e-5, r2.summary()


def test_replay_reports_where_the_arm_buckles(ls, fig7):
    """Replaying the aligned (straight-segment) schedule of Fig. 7: the
    points before the critical shortening are reproduced; the last one is
    reached only after a buckling jump, off the planned branch."""
    aligned = fig7["aligned"]
    dls = sorted(aligned)
    r = replay(ls, [aligned[d].lengths_requested * L_MM for d in dls],
               [aligned[d].tip * L_MM for d in dls],
               planned_thetas=[aligned[d].theta for d in dls])
    assert r.completed, r.summary()
    assert [q.on_branch for q in r.points] == [True] * 4 + [False]
    assert r.first_departure == 4
    assert [q.jumped for q in r.points] == [False] * 4 + [True]
    (k, L_mm), = r.jumps
    (k_event, _, kind), = r.instabilities
    assert k_event == 4 and kind == "bifurcation"
    assert "a bifurcation (buckling" in r.summary()
    assert k == 4 and abs(fig7["L0"][1] * L_MM - L_mm[1] - 1.61) < 0.05
    assert r.points[-1].tip_error_mm > 1.0 and r.points[-1].stable
