"""The compiled kernels of the arm in motion (core/fem_dynamics.c, docs/model.md §26)
against independent computations: node velocities by finite differences of the node
positions, the dense matrix of the banded system, and the tension history by np.interp."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import elastica_petsc as ep_configs

from elastica_petsc.core import fem_kernels
from elastica_petsc.core.drive import TensionDrive
from elastica_petsc.core.dynamics import BandedInverse, Inertia, elastic_band
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import Arm, load_config

N = 30


@pytest.fixture(scope="module")
def disc():
    return Discretisation.from_arm(Arm.paper(), N)


def _state(seed):
    rng = np.random.default_rng(seed)
    return np.concatenate(([0.0], 0.6 * rng.standard_normal(N))), rng.standard_normal(N)


def test_kinetic_energy_from_node_velocities(disc):
    """(1/2) v.M v = (1/2) sum m_k |x_k'|^2 with x_k' = d/dt x_k(theta + t v) by central
    differences of the node positions (Eq. (2)); the rotary term adds (1/2) v.M_rot v."""
    theta, v = _state(3)
    inert = Inertia.build(disc, tip_mass=0.3)
    eps = 1e-6
    pad = np.concatenate(([0.0], v))
    xdot = (disc.node_positions(theta + eps * pad) - disc.node_positions(theta - eps * pad))[1:]
    expected = 0.5 * np.sum(inert.weights * np.sum((xdot / (2 * eps)) ** 2, axis=1))
    assert abs(inert.kinetic_energy(theta, v) - expected) < 1e-8 * expected
    spinning = Inertia.build(disc, tip_mass=0.3, rotary=0.02)
    rotary = 0.5 * np.sum(0.02 * disc.h * disc.element_angles(pad) ** 2)
    extra = spinning.kinetic_energy(theta, v) - inert.kinetic_energy(theta, v)
    assert abs(extra - rotary) < 1e-12 * expected


def test_mass_is_symmetric_positive(disc):
    theta, _ = _state(4)
    inert = Inertia.build(disc, tip_mass=0.1, rotary=0.01)
    M = np.column_stack([inert.mass(theta, e) for e in np.eye(N)])
    assert np.max(np.abs(M - M.T)) < 1e-14 * np.max(np.abs(M))
    assert np.linalg.eigvalsh(M).min() > 0


@pytest.mark.parametrize("sigma", [1e-6, 1.0, 1e8])
def test_banded_solve_pivots_on_indefinite_band(disc, sigma):
    """A band T far from positive (negative and zero diagonals, as a buckled state's
    tangent can be) needs the row exchanges of the LU; the solve is exact against the
    dense matrix sigma M + T for several right-hand sides at once."""
    theta, _ = _state(5)
    inert = Inertia.build(disc, tip_mass=0.2)
    rng = np.random.default_rng(6)
    band = elastic_band(disc) + rng.standard_normal((N, 3)) * 40.0
    band[::7, 1] = 0.0
    band[1:, 0] = band[:-1, 2]                   # T symmetric, as the tangent is
    T = np.diag(band[:, 1]) + np.diag(band[1:, 0], -1) + np.diag(band[:-1, 2], 1)
    M = np.column_stack([inert.mass(theta, e) for e in np.eye(N)])
    A = sigma * M + T
    R = rng.standard_normal((N, 3))
    inverse = BandedInverse(disc, theta, inert.weights, sigma, band)
    assert np.any(inverse.piv != np.arange(5 * N))           # rows were exchanged
    X, exact = inverse.solve(R), np.linalg.solve(A, R)
    assert np.linalg.norm(X - exact) < 1e-14 * np.linalg.cond(A) * np.linalg.norm(exact)


def test_singular_system_is_reported(disc):
    theta, _ = _state(7)
    with pytest.raises(np.linalg.LinAlgError, match="singular pivot"):
        BandedInverse(disc, theta, np.zeros(N), 1.0, np.zeros((N, 3)))


def test_kernels_check_sizes(disc):
    theta, v = _state(8)
    out = np.empty(N)
    with pytest.raises(ValueError, match="rotary"):
        fem_kernels.inertial_force(theta, v, v, np.ones(N), np.zeros((N, 2)), np.zeros((N, 3)),
                                   0.0, 0.0, out)
    with pytest.raises(ValueError, match="ab"):
        fem_kernels.principal_factor(theta, np.ones(N), 1.0, np.zeros((N, 3)), np.empty(10),
                                     np.empty(5 * N, np.int32))


def test_tension_history_is_piecewise_linear():
    drive = TensionDrive(np.array([0.0, 1.0, 3.0]), np.array([[0.0, 1.0], [2.0, 3.0], [4.0, -1.0]]))
    for t in (-1.0, 0.0, 0.25, 1.0, 2.2, 3.0, 7.0):
        expected = [np.interp(t, drive.times, drive.values[:, i]) for i in range(2)]
        np.testing.assert_allclose(drive.tensions(t), expected, rtol=1e-15, atol=1e-15)
    np.testing.assert_array_equal(TensionDrive.constant([1.5, 2.0]).tensions(9.0), [1.5, 2.0])


def test_motion_residual_is_force_plus_static_residual(disc):
    """The fused kernel (one call per residual of the integrator) equals the inertial
    force plus the static residual at the consistent state, with damping and tip mass;
    an arm with weight (core/guided.py) adds the weight's rows, gravity included."""
    theta, v = _state(9)
    a = np.random.default_rng(10).standard_normal(N)
    p = np.array([2.0, 5.0])
    inert = Inertia.build(disc, tip_mass=0.2, rotary=0.01, damping_ratio=0.1)
    expected = inert.force(theta, v, a) + disc.residual(disc.consistent_state(theta), p)[:N]
    np.testing.assert_allclose(inert.residual(theta, v, a, p), expected, rtol=1e-13,
                               atol=1e-13 * np.abs(expected).max())
    vertical = load_config(Path(ep_configs.__file__).parent / "configs" / "paper_vertical.toml")
    heavy = Discretisation.from_arm(vertical, N)           # gravity: core/guided.py's kernel
    straight, zero = np.zeros(N + 1), np.zeros(N)
    weight = Inertia.build(heavy).residual(straight, zero, zero, np.zeros(2))
    np.testing.assert_allclose(weight, heavy.residual(heavy.consistent_state(straight),
                                                      np.zeros(2))[:N], rtol=1e-14)
    assert np.abs(weight).max() > 1e-3           # the weight bends the straight arm
