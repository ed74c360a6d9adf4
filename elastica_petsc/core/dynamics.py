"""Pure-numpy kernels of the arm in motion (docs/model.md §16).

Non-dimensional: lengths in l, time in tau = sqrt(rho_A l^4 / B), masses in
rho_A l, forces in B / l^2, energies in B / l.  The unknowns are the nodal
angles theta_1..theta_N of docs/model.md §8; the nodes move as

    x_k = h sum_{e<k} t_e,  x_k'' = h sum_{e<k} (n_e phi_e'' - t_e phi_e'^2)   (Eq. (2))

with phi_e = (theta_e + theta_{e+1}) / 2.  The equations of motion are
Lagrange's, with nodal masses m_k (trapezoidal, plus a tip mass):

    G^T D x'' + M_rot theta'' + c_d (a M + b L) theta' + R(theta, p) = 0,

G = dx/dtheta (a cumulative sum), D = diag(m_k), R the static residual of
docs/model.md §8 (the gradient of Pi_h), M = G^T D G + M_rot the kinetic mass,
L the elastic (Kelvin-Voigt) stiffness.  Every product with G or G^T is a
cumulative sum: O(N).  :class:`BandedInverse` solves the Newton systems
(sigma M + T) x = r exactly in O(N) as one banded system in the angles, the
node displacements X = G x and the tail forces F_e = sum_{k>e} m_k X_k.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import lapack

from .fem import Discretisation

# beta_1 l of the clamped-free Euler-Bernoulli beam: cos(bl) cosh(bl) = -1
EB_BETA1 = 1.8751040687119611


def node_masses(disc: Discretisation, tip_mass: float = 0.0) -> np.ndarray:
    """Trapezoidal nodal masses of nodes 1..N in units of rho_A l (tip: h/2 + tip_mass)."""
    m = np.full(disc.n_elements, disc.h)
    m[-1] = 0.5 * disc.h + tip_mass
    return m


def _normals(disc: Discretisation, theta: np.ndarray) -> np.ndarray:
    """h n_e of each element, (N, 2)."""
    phi = disc.element_angles(theta)
    return disc.h * np.column_stack((-np.sin(phi), np.cos(phi)))


def node_velocities(disc: Discretisation, theta: np.ndarray, v: np.ndarray) -> np.ndarray:
    """x_k' of nodes 1..N, (N, 2): G v (the midpoint rule of Eq. (2) differentiated)."""
    vt = np.concatenate(([0.0], v))
    return np.cumsum(_normals(disc, theta) * disc.element_angles(vt)[:, None], axis=0)


def transpose_apply(disc: Discretisation, theta: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """G^T f for nodal vectors f (N, 2) of nodes 1..N: the generalized force
    sum_k f_k . dx_k/dtheta_j, by a reverse cumulative sum (tail forces)."""
    tail = np.cumsum(forces[::-1], axis=0)[::-1]          # tail[e] = sum over nodes k > e
    g = np.einsum("ec,ec->e", _normals(disc, theta), tail)
    return 0.5 * (g + np.append(g[1:], 0.0))


def mass_apply(disc: Discretisation, theta: np.ndarray, v: np.ndarray,
               weights: np.ndarray) -> np.ndarray:
    """G^T D G v (translational kinetic mass times v) in O(N)."""
    return transpose_apply(disc, theta, weights[:, None] * node_velocities(disc, theta, v))


def rotary_band(disc: Discretisation, inertia: float) -> np.ndarray:
    """Tridiagonal (N, 3) of M_rot: sum_e inertia h (dphi_e/dtheta)(dphi_e/dtheta)^T,
    inertia = I / (A l^2) (0: no rotary inertia)."""
    N, w = disc.n_elements, 0.25 * inertia * disc.h
    band = np.zeros((N, 3))
    band[:, 1] = 2.0 * w
    band[-1, 1] = w
    band[1:, 0] = w
    band[:-1, 2] = w
    return band


def elastic_band(disc: Discretisation) -> np.ndarray:
    """Tridiagonal (N, 3) of the elastic stiffness L: (1/h)(-1, 2, -1), last diagonal 1/h."""
    h = disc.h
    band = np.empty((disc.n_elements, 3))
    band[:, 0], band[:, 1], band[:, 2] = -1.0 / h, 2.0 / h, -1.0 / h
    band[-1, 1] = 1.0 / h
    band[0, 0] = band[-1, 2] = 0.0
    return band


def band_apply(band: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Tridiagonal (lower, diag, upper) times v."""
    out = band[:, 1] * v
    out[1:] += band[1:, 0] * v[:-1]
    out[:-1] += band[:-1, 2] * v[1:]
    return out


@dataclass(frozen=True)
class Inertia:
    """Mass and damping data of one discretised arm (non-dimensional)."""

    disc: Discretisation
    weights: np.ndarray        # nodal masses m_1..m_N, units rho_A l
    rotary: np.ndarray         # (N, 3) band of M_rot
    viscous: float             # a: viscous damping a M theta'
    kelvin_voigt: float        # b: Kelvin-Voigt damping b L theta'

    @classmethod
    def build(cls, disc: Discretisation, *, tip_mass: float = 0.0, rotary: float = 0.0,
              damping_ratio: float = 0.0, kelvin_voigt_fraction: float = 0.5,
              omega1: float = EB_BETA1**2) -> "Inertia":
        """Rayleigh damping with damping ratio ``damping_ratio`` at the circular
        frequency ``omega1`` (units 1/tau): zeta(omega) = a/(2 omega) + b omega/2,
        a share ``kelvin_voigt_fraction`` of zeta_1 from b (docs/model.md §16)."""
        zeta, f = float(damping_ratio), float(kelvin_voigt_fraction)
        return cls(disc, node_masses(disc, tip_mass), rotary_band(disc, rotary),
                   2.0 * zeta * (1.0 - f) * omega1, 2.0 * zeta * f / omega1)

    def mass(self, theta, v) -> np.ndarray:
        """M(theta) v = G^T D G v + M_rot v."""
        return mass_apply(self.disc, theta, v, self.weights) + band_apply(self.rotary, v)

    def force(self, theta, v, a) -> np.ndarray:
        """Inertial plus damping force M a + c(theta, v) + a M v + b L v."""
        disc = self.disc
        phi_v = disc.element_angles(np.concatenate(([0.0], v)))
        phi = disc.element_angles(theta)
        centripetal = -disc.h * np.column_stack((np.cos(phi), np.sin(phi))) * phi_v[:, None] ** 2
        acc = node_velocities(disc, theta, a + self.viscous * v) + np.cumsum(centripetal, axis=0)
        out = transpose_apply(disc, theta, self.weights[:, None] * acc)
        out += band_apply(self.rotary, a + self.viscous * v)
        if self.kelvin_voigt:
            out += self.kelvin_voigt * band_apply(elastic_band(disc), v)
        return out

    def kinetic_energy(self, theta, v) -> float:
        """(1/2) sum m_k |x_k'|^2 + (1/2) v M_rot v, units B/l."""
        xdot = node_velocities(self.disc, theta, v)
        return float(0.5 * np.sum(self.weights * np.sum(xdot**2, axis=1))
                     + 0.5 * v @ band_apply(self.rotary, v))


class BandedInverse:
    """Exact O(N) solve of (sigma G^T D G + T) x = r for a tridiagonal T.

    Unknowns per element j = 0..N-1, interleaved (base 5j): the angle
    increment x_{j+1}, the node displacement X_{j+1} = sum_{e<=j} (h/2) n_e
    (x_e + x_{e+1}) and the tail force F_j = sum_{k>j} m_k X_k, so that
    G^T D G x at node k is sum_{e in {k-1,k}} (h/2) n_e . F_e.  Every row couples
    unknowns at most 7 below and 9 above its own: LAPACK's banded LU with
    partial pivoting (dgbtrf), O(N) to factor and to solve.
    """

    KL, KU = 7, 9

    def __init__(self, disc: Discretisation, theta: np.ndarray, weights: np.ndarray,
                 sigma: float, band: np.ndarray):
        N = disc.n_elements
        n = 5 * N
        kl, ku = self.KL, self.KU
        ab = np.zeros((2 * kl + ku + 1, n))
        half_n = 0.5 * _normals(disc, theta)                 # (h/2) n_e, (N, 2)
        j = np.arange(N)

        def put(rows, cols, vals):
            ab[kl + ku + rows - cols, cols] = vals

        r = 5 * j                                            # angle rows, node k = j + 1
        for c in (0, 1):
            put(r, r + 3 + c, sigma * half_n[:, c])          # F_j (element k-1)
            put(r[:-1], r[:-1] + 8 + c, sigma * half_n[1:, c])   # F_{j+1} (element k)
        put(r, r, band[:, 1])
        put(r[1:], r[1:] - 5, band[1:, 0])
        put(r[:-1], r[:-1] + 5, band[:-1, 2])
        for c in (0, 1):                                     # X_{j+1} definitions
            rx = 5 * j + 1 + c
            put(rx, rx, np.ones(N))
            put(rx[1:], rx[1:] - 5, -np.ones(N - 1))
            put(rx, 5 * j, -half_n[:, c])                    # x_{j+1}
            put(rx[1:], 5 * j[1:] - 5, -half_n[1:, c])       # x_j
            rf = 5 * j + 3 + c                               # F_j definitions
            put(rf, rf, np.ones(N))
            put(rf[:-1], rf[:-1] + 5, -np.ones(N - 1))
            put(rf, 5 * j + 1 + c, -weights)
        self.lu, self.piv, info = lapack.dgbtrf(ab, kl, ku)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded LU: singular pivot {info}")
        self.N = N

    def solve(self, r: np.ndarray) -> np.ndarray:
        """x for one right-hand side (N,) or several (N, k)."""
        r = np.asarray(r, float)
        cols = 1 if r.ndim == 1 else r.shape[1]
        rhs = np.zeros((5 * self.N, cols))
        rhs[0::5] = r.reshape(self.N, cols)
        x, info = lapack.dgbtrs(self.lu, self.KL, self.KU, rhs, self.piv)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded solve: illegal argument {-info}")
        out = x[0::5]
        return out[:, 0] if r.ndim == 1 else out

