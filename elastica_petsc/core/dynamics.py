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
The O(N) loops are compiled (core/fem_dynamics.c, docs/model.md §30).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from . import fem_kernels
from .fem import Discretisation

# beta_1 l of the clamped-free Euler-Bernoulli beam: cos(bl) cosh(bl) = -1
EB_BETA1 = 1.8751040687119611


def node_masses(disc: Discretisation, tip_mass: float = 0.0) -> np.ndarray:
    """Trapezoidal nodal masses of nodes 1..N in units of rho_A l (tip: h/2 + tip_mass)."""
    m = np.full(disc.n_elements, disc.h)
    m[-1] = 0.5 * disc.h + tip_mass
    return m


def mass_apply(disc: Discretisation, theta: np.ndarray, v: np.ndarray,
               weights: np.ndarray) -> np.ndarray:
    """G^T D G v (translational kinetic mass times v) in O(N) (compiled)."""
    zero = np.zeros((disc.n_elements, 3))
    return _inertial_force(theta, np.zeros(disc.n_elements), v, weights, zero, zero, 0.0, 0.0)


def _inertial_force(theta, v, a, weights, rotary, elastic, viscous, kelvin_voigt):
    """G^T D (G a' + c) + M_rot a' + kelvin_voigt L v with a' = a + viscous v and c the
    centripetal node accelerations (compiled, core/fem_dynamics.c)."""
    out = np.empty(len(weights))
    dense = np.ascontiguousarray
    fem_kernels.inertial_force(dense(theta, dtype=float), dense(v, dtype=float),
                               dense(a, dtype=float), weights, rotary, elastic, float(viscous),
                               float(kelvin_voigt), out)
    return out


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


def straight_cables(disc: Discretisation) -> tuple[Discretisation, np.ndarray]:
    """The paper's cable kernel of an arm whose cables run straight to the centreline
    and the weight beyond each element's midpoint G_e (N, 2) (docs/model.md §11.5; zero
    without weight): the dynamics' preconditioner adds G_e to the cables' forces in T
    (§16.4).  ValueError for cables through guides or with offset ends."""
    if type(disc) is Discretisation:
        return disc, np.zeros((disc.n_elements, 2))
    if disc.point_nodes != tuple(disc.attach_nodes) or np.any(disc.point_offsets != 0.0):
        raise ValueError("cables through guides or with offset ends")
    return Discretisation(disc.n_elements, disc.attach_nodes, disc.routes), disc.element_weight


def weight_potential(disc: Discretisation, theta: np.ndarray) -> float:
    """Potential of the arm's weight and tip mass, -sum_k w_k q . x_k - q_t . x_N
    (docs/model.md §11.5), units B/l; 0 without weight."""
    if type(disc) is Discretisation:
        return 0.0
    return disc.potential(theta, np.zeros(disc.n_tendons)) - disc.strain_energy(theta)


@dataclass(frozen=True)
class Inertia:
    """Mass and damping data of one discretised arm (non-dimensional)."""

    disc: Discretisation
    weights: np.ndarray        # nodal masses m_1..m_N, units rho_A l
    rotary: np.ndarray         # (N, 3) band of M_rot
    viscous: float             # a: viscous damping a M theta'
    kelvin_voigt: float        # b: Kelvin-Voigt damping b L theta'
    elastic: np.ndarray        # (N, 3) band of L (elastic_band)

    @classmethod
    def build(cls, disc: Discretisation, *, tip_mass: float = 0.0, rotary: float = 0.0,
              damping_ratio: float = 0.0, kelvin_voigt_fraction: float = 0.5,
              omega1: float = EB_BETA1**2) -> "Inertia":
        """Rayleigh damping with damping ratio ``damping_ratio`` at the circular
        frequency ``omega1`` (units 1/tau): zeta(omega) = a/(2 omega) + b omega/2,
        a share ``kelvin_voigt_fraction`` of zeta_1 from b (docs/model.md §16)."""
        zeta, f = float(damping_ratio), float(kelvin_voigt_fraction)
        return cls(disc, node_masses(disc, tip_mass), rotary_band(disc, rotary),
                   2.0 * zeta * (1.0 - f) * omega1, 2.0 * zeta * f / omega1,
                   elastic_band(disc))

    def mass(self, theta, v) -> np.ndarray:
        """M(theta) v = G^T D G v + M_rot v."""
        return _inertial_force(theta, np.zeros(len(v)), v, self.weights, self.rotary,
                               self.elastic, 0.0, 0.0)

    def force(self, theta, v, a) -> np.ndarray:
        """Inertial plus damping force M a + c(theta, v) + a M v + b L v."""
        return _inertial_force(theta, v, a, self.weights, self.rotary, self.elastic,
                               self.viscous, self.kelvin_voigt)

    def residual(self, theta, v, a, p) -> np.ndarray:
        """The angle rows of the equations of motion (docs/model.md §16.1): ``force``
        plus the static residual R(theta, p) of §8 with the cables ending at the nodes
        x_{m_i}(theta), in one compiled call, plus the weight's angle rows (§11.5); an arm
        with guides or offsets (core/guided.py) adds its own residual to ``force``."""
        if self._cables is None:                   # guides or offset ends
            disc = self.disc
            u = disc.consistent_state(theta)
            return self.force(theta, v, a) + disc.residual(u, p)[: disc.n_elements]
        disc, weight = self._cables
        out = np.empty(disc.n_elements)
        dense = np.ascontiguousarray
        fem_kernels.motion_residual(dense(theta, dtype=float), dense(v, dtype=float),
                                    dense(a, dtype=float), dense(p, dtype=float),
                                    dense(disc.routes, dtype=float), disc.attach_index,
                                    self.weights, self.rotary, self.elastic,
                                    float(self.viscous), float(self.kelvin_voigt), out)
        if weight.any():        # the weight's -(h/2) n_e . G_e on both nodes of e (§11.5)
            c, s = disc.trig(theta)
            q = 0.5 * disc.h * (c * weight[:, 1] - s * weight[:, 0])
            out -= q
            out[:-1] -= q[1:]
        return out

    @cached_property
    def _cables(self):
        """:func:`straight_cables` of the arm, None with guides or offset ends."""
        try:
            return straight_cables(self.disc)
        except ValueError:
            return None

    def kinetic_energy(self, theta, v) -> float:
        """(1/2) v . M(theta) v = (1/2) sum m_k |x_k'|^2 + (1/2) v M_rot v, units B/l."""
        return float(0.5 * np.dot(v, self.mass(theta, v)))


class BandedInverse:
    """Exact O(N) solve of (sigma G^T D G + T) x = r for a tridiagonal T (compiled,
    core/fem_dynamics.c).

    Unknowns per element j = 0..N-1, interleaved (base 5j): the angle
    increment x_{j+1}, the node displacement X_{j+1} = sum_{e<=j} (h/2) n_e
    (x_e + x_{e+1}) and the tail force F_j = sum_{k>j} m_k X_k, so that
    G^T D G x at node k is sum_{e in {k-1,k}} (h/2) n_e . F_e.  Every row couples
    unknowns at most 7 below and 9 above its own: a banded LU with partial
    pivoting (LAPACK's dgbtf2/dgbtrs in C), O(N) to factor and to solve.
    """

    KL, KU = 7, 9

    def __init__(self, disc: Discretisation, theta: np.ndarray, weights: np.ndarray,
                 sigma: float, band: np.ndarray):
        N = disc.n_elements
        self.ab = np.empty((2 * self.KL + self.KU + 1) * 5 * N)
        self.piv = np.empty(5 * N, np.int32)
        theta, weights, band = (np.ascontiguousarray(x, dtype=float)
                                 for x in (theta, weights, band))
        info = fem_kernels.principal_factor(theta, weights, float(sigma), band, self.ab, self.piv)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded LU: singular pivot {info}")
        self.N = N

    def solve(self, r: np.ndarray) -> np.ndarray:
        """x for one right-hand side (N,) or several (N, k)."""
        r = np.ascontiguousarray(r, dtype=float)
        out = np.empty_like(r)
        fem_kernels.principal_solve(self.ab, self.piv, r, out)
        return out

