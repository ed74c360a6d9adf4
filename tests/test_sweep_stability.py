"""SLEPc along a sweep (elastica_petsc.solvers.sweep_stability): the workspace
maps' lambda_min and raw lambda_min agree with StabilitySolver.solve and with
the dense generalized problem, stable or not, warm-started or not."""
from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import Arm, Tendon, load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.stability import StabilitySolver
from elastica_petsc.solvers.sweep_stability import SweepStability


def dense_pair(disc, u, p) -> tuple[float, float]:
    """(lambda_min of (K, lumped M), lambda_min of K) from the dense Schur complement."""
    indptr, indices, _ = disc.pattern
    J = sp.csr_matrix((disc.jacobian_values(u, p), indices, indptr),
                      shape=(disc.size, disc.size)).toarray()
    N = disc.n_elements
    K = J[:N, :N] - J[:N, N:] @ np.linalg.solve(J[N:, N:], J[N:, :N])
    K = 0.5 * (K + K.T)
    m = np.full(N, disc.h)
    m[-1] *= 0.5
    return float(sla.eigh(K, np.diag(m), eigvals_only=True)[0]), float(np.linalg.eigvalsh(K)[0])


@pytest.fixture(scope="module")
def sweep_states():
    """A row of neighbouring equilibria of the paper's arm (N = 60), as a map's chunk."""
    disc = Discretisation.from_arm(load_config(), 60)
    states, previous = [], None
    with EquilibriumSolver(disc) as solver:
        for t in np.linspace(1.0, 24.0, 12):
            previous = solver.solve((t, 0.5 * t), start=previous)
            assert previous.converged
            states.append(previous)
    return disc, states


def test_sweep_agrees_with_stability_solver_and_dense(sweep_states):
    disc, states = sweep_states
    with SweepStability(disc) as sweep, StabilitySolver(disc, nev=1) as full:
        for e in states:
            lam, raw = sweep.solve(e.u, e.p)
            ref = full.solve(e.u, e.p)
            assert lam == pytest.approx(ref.lambda_min, rel=1e-9)
            assert raw == pytest.approx(ref.raw_min, rel=1e-9)
            dense_lam, dense_raw = dense_pair(disc, e.u, e.p)
            assert lam == pytest.approx(dense_lam, rel=1e-8)
            assert raw == pytest.approx(dense_raw, rel=1e-8)


def test_restart_gives_the_cold_result_bit_for_bit(sweep_states):
    """After ``restart`` a solve equals a fresh solver's (a map's chunk does not
    depend on the chunks solved before it on the same rank)."""
    disc, states = sweep_states
    with SweepStability(disc) as fresh:
        cold = [fresh.solve(e.u, e.p) for e in states[:4]]
    with SweepStability(disc) as used:
        for e in states[6:]:
            used.solve(e.u, e.p)
        used.restart()
        assert [used.solve(e.u, e.p) for e in states[:4]] == cold


def test_negative_eigenvalues_found_below_buckling():
    """Dead tip load beyond the first and second critical loads (pi^2/4, (3 pi/2)^2):
    the smallest eigenvalue is negative and equals the dense one; below, positive."""
    arm = Arm(length_mm=1000.0, bending_stiffness_Nm2=1.0, elements=100,
              tendons=(Tendon(1000.0, (-1e9, 0.0)),), mass_per_length_kg_m=1.0)
    disc = Discretisation.from_arm(arm)
    u = disc.straight()
    with SweepStability(disc) as sweep:
        for p, sign in ((0.9 * math.pi**2 / 4, 1), (1.2 * math.pi**2 / 4, -1),
                        (1.2 * (1.5 * math.pi)**2, -1), (0.5, 1)):
            lam, raw = sweep.solve(u, [p])
            dense_lam, dense_raw = dense_pair(disc, u, [p])
            assert np.sign(lam) == np.sign(raw) == sign
            assert lam == pytest.approx(dense_lam, rel=1e-8)
            assert raw == pytest.approx(dense_raw, rel=1e-8)
