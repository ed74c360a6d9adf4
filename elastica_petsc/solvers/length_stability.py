"""Stability under length control (Sec. 4.6; docs/model.md §4.7; split from
:mod:`.lengths`).

Stability under length control (Sec. 4.6)
-----------------------------------------
With the cables rigid, the potential is the strain energy alone,
constrained by L_i(theta) = L_i for the taut cables; the tensions are the
Lagrange multipliers and the Hessian of the Lagrangian is the same tangent
K as under load control (docs/model.md §2).  A taut state is stable iff K is
positive definite on null(C^T), C = [grad_theta L_i] of the taut cables
(N x m, full rank).  Counted with inertia, still O(N):

    H_c = [[T, W, C], [W^T, -I_n, 0], [C^T, 0, 0]],
    In(H_c) = (0, n, 0) + In([[K, C], [C^T, 0]])
            = (0, n, 0) + (m, m, 0) + In(K restricted to null C^T)

(Haynsworth on the -I block, then the saddle-point inertia theorem).  A
slack cable gets a zero column and a corner entry +1 (one positive
eigenvalue), so the matrix keeps its size.  A cable with p_i = 0 that is
just taut (g_i = 0) counts as slack: with a zero multiplier the one-sided
constraint |r_i - x_i| <= L_i leaves a half-space of admissible
variations, on which the quadratic form v^T K v is positive iff it is
positive on the whole space (it is even in v).  LDL^T in the natural order
(zero block last; PETSc's own SBAIJ Cholesky accepts the negative pivots);
if it meets a zero pivot the state is counted as marginal.

Full rank of C fails where a cable's length is stationary, e.g. the
straight arm with a cable along its axis (grad L = 0): the tension is then
indeterminate under length control and the saddle matrix singular (zero
pivot, reported as marginal); such states are limits of well-posed ones.

Being stable under load control (K > 0) implies stability under length
control (constraints only remove variations).  The two are tied by the
folds of the load path (Maddocks 1987): along a load-controlled branch
dL/dp = -C^T K^{-1} C (m x m), and the Schur complement of [[K, C],
[C^T, 0]] gives neg_length = neg_load - pos(dL/dp) (tested): a state that
is unstable under load control is stable under length control where the
cable lengths grow with the tensions along the branch.
"""
from __future__ import annotations

import math

import numpy as np

from ..core.fem import Discretisation
from .bifurcation import inverse_iteration
from .inertia import BorderedInertia
from .length_system import TAUT_TOL, AugmentedSystem

# |q . dL| / (|(v, q)| |dL|) below this: a loss of stability under length control is a
# bifurcation, not a limit point (instability_kind; calibrated on Fig. 7 only, 0.005).
LENGTH_BIFURCATION_TOL = 0.05


class LengthInertia(BorderedInertia):
    """Negative eigenvalues of K restricted to null(C^T) of the taut cables
    (module docstring), by the LDL^T inertia of the bordered H_c, O(N)."""

    def __init__(self, disc: Discretisation, taut_tol: float = TAUT_TOL, **contract):
        self.disc, self.taut_tol = disc, taut_tol
        w_supports = disc.stability_pattern_supports
        supports = np.concatenate((w_supports, disc.length_supports))        # W cols, C cols
        starts = np.concatenate((disc.stability_pattern_starts, np.zeros(disc.n_tendons, int)))
        pattern = disc.bordered_pattern(supports, upper=True, starts=starts)
        self._src = pattern[2]
        super().__init__(pattern, disc.n_elements + len(supports),
                         self.values(disc.straight(), np.zeros(disc.n_tendons))[0], **contract)

    def values(self, u, p) -> tuple[np.ndarray, int]:
        """Upper-triangle entries of H_c and the number m of taut cables."""
        disc = self.disc
        p = np.asarray(p, float)
        theta, y = disc.split(u)
        w = disc.stiffness_border(theta, y, p)                              # (n, N)
        taut = p > self.taut_tol
        C = disc.load_derivative(u)[:, : disc.n_elements] * taut[:, None]  # grad L_i (n, N)
        border = np.vstack((w, C))                                          # (2n, N)
        corner = np.concatenate((-np.ones(disc.stability_border), np.where(taut, 0.0, 1.0)))
        source = np.concatenate((disc.band(theta, disc.cables(y)[1], p).ravel(),
                                 border.T.ravel(), border.ravel(), corner))
        return source[self._src], int(np.count_nonzero(taut))

    def negative_eigenvalues(self, u, p) -> int:
        """Negative (or zero) eigenvalues of K on null(C_taut^T); 0: stable
        under length control."""
        vals, m = self.values(u, p)
        return self.count(vals, self.disc.stability_border + m)


def constrained_mode(system: AugmentedSystem, z, iterations: int = 30,
                     full: bool = False) -> tuple:
    """Eigenpair of K v = lambda h v on null(C_taut^T) with the smallest
    |lambda| (the buckling mode near a loss of stability), by inverse
    iteration with the length-control Jacobian [[J, dF/dp], [dg/du, 0]]
    (sparse LU, O(N), :func:`~elastica_petsc.solvers.bifurcation.inverse_iteration`).
    Returns (lambda, v) with v the N nodal angle increments, max |v| = 1;
    with ``full`` also the tension increments q (n) that go with v (zero for
    slack cables, which have no constraint)."""
    disc = system.disc
    z = np.array(z, float)
    z[system.imu] = 1.0
    A = system.scipy_jacobian(z).tolil()
    p = z[system.ip:system.imu]
    for i in np.flatnonzero(p <= TAUT_TOL):       # slack: p_i stays 0, no constraint row
        r = system.ip + i
        A[r, :] = 0.0
        A[:, r] = 0.0
        A[r, r] = 1.0
    lam, v, w = inverse_iteration(A, disc.n_elements, disc.h, iterations)
    return (lam, v, w[system.ip:system.imu]) if full else (lam, v)


def instability_kind(system: AugmentedSystem, z, dL) -> str:
    """"bifurcation" or "limit point" for a loss of stability under length
    control at the state z, the lengths moving along ``dL``: the
    constrained critical mode (v, q) (:func:`constrained_mode`) is the null
    vector of the symmetric length-control Jacobian, and the path derivative
    of the residual is -dL in the cable rows, so the test of
    :mod:`~elastica_petsc.solvers.bifurcation` reads |q . dL| <=
    LENGTH_BIFURCATION_TOL |(v, q)| |dL| (v weighted by h).  The tolerance
    is looser than under load control: a path of straight segments in the
    lengths only approximates a perfect column (Fig. 7's aligned path:
    measured 0.005 one step before the crossing)."""
    _, v, q = constrained_mode(system, z, full=True)
    dL = np.asarray(dL, float)
    scale = math.sqrt(system.disc.h * float(v @ v) + float(q @ q)) * float(np.linalg.norm(dL))
    return "bifurcation" if abs(float(q @ dL)) <= LENGTH_BIFURCATION_TOL * scale \
        else "limit point"
