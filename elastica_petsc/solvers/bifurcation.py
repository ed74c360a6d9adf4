"""Symmetric bifurcations of load-controlled equilibria and branch switching.

Along a loading path p(lam) = p_a + lam (p_b - p_a) a stable branch u(lam) of
F(u, p) = 0 (Eq. (9), bordered form of :mod:`elastica_petsc.core.fem`) loses
stability where the smallest eigenvalue of the tangent K crosses zero
(docs/model.md §2).  Let v be the critical mode (K v = 0) and
f = dF_theta/dp . (p_b - p_a) the load derivative of the residual.  Then

* v . f != 0: a limit point (fold).  The branch turns back; the arm snaps.
* v . f = 0: a bifurcation (for a symmetric problem, e.g. the straight arm
  under a cable on its axis, a symmetric pitchfork): the branch continues
  through the critical load, unstable, and two new branches leave it along
  +-v.  The classical test (e.g. Seydel, "Practical Bifurcation and
  Stability Analysis", Sec. 5.4) is the one used here, normalised:
  |v . f| <= :data:`BIFURCATION_TOL` |v| |f|, or f = 0 altogether.

Branch switching (Keller's amplitude parametrisation): from the critical
state u_c, the bifurcating branch is followed with the mode amplitude
a = h v . (theta - theta_c) as the parameter and lam as an unknown,

    F(u, p(lam)) = 0,     h v . (theta - theta_c) - a = 0,

one Newton solve per amplitude step on the bordered Jacobian
[[dF/du, dF/dp . (p_b - p_a)], [h v^T, 0]] (sparse LU in the natural order,
O(N): the extra row and column are one more border).  The amplitude grows
until lam reaches the end of the loading segment; a final Newton solve at
the end load is left to the caller.  If lam falls below the critical load
the bifurcation is subcritical: there is no stable post-critical state near
the branch, and the caller reports that.

Everything is non-dimensional (lengths / l, p = P l^2 / B).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..core.fem import Discretisation

# |v . f| / (|v| |f|) below this (or f = 0): the critical mode is orthogonal to
# the load derivative of the residual, a bifurcation rather than a limit point.
BIFURCATION_TOL = 1e-3


@dataclass(frozen=True)
class Bifurcation:
    """A bifurcation crossed along a loading path, and the branch taken.

    p_critical : tensions at the critical point (interpolated where the
        smallest eigenvalue of K crosses zero).
    side : "left" or "right": on which side of the arm's tangent at the tip
        the tip moved (left = counter-clockwise, +y for an arm along +x).
    rule : why that side ("requested", "lower energy", or "equal energies:
        left by convention", or "the only stable side").
    """

    p_critical: np.ndarray
    side: str
    rule: str

    def describe(self) -> str:
        return ("crossed a symmetric bifurcation at p = ("
                + ", ".join(f"{v:.6g}" for v in self.p_critical)
                + f") (the straight/previous branch loses stability there); took the "
                  f"{self.side} branch ({self.rule})")


def inverse_iteration(matrix: sp.spmatrix, n: int, h: float, iterations: int = 30,
                      seed: int = 0) -> tuple[float, np.ndarray, np.ndarray]:
    """Eigenpair (lambda, v) of S v = lambda h v with |lambda| smallest, S the
    Schur complement of a bordered ``matrix`` onto its first ``n`` unknowns
    (each solve is one sparse LU solve of the bordered matrix, O(N)).
    v is scaled to max |v| = 1; the third value is the whole last solution
    (v and the border unknowns that go with it), scaled alike."""
    lu = spla.splu(sp.csc_matrix(matrix))
    v = np.random.default_rng(seed).standard_normal(n)
    lam = 0.0
    rhs = np.zeros(matrix.shape[0])
    full = rhs
    for _ in range(iterations):
        rhs[:n] = h * v
        full = lu.solve(rhs)
        lam = float(np.dot(v, h * v) / np.dot(v, h * full[:n]))
        full = full / np.max(np.abs(full[:n]))
        v = full[:n]
    return lam, v, full


def jacobian(disc: Discretisation, u, p) -> sp.csr_matrix:
    """The bordered Jacobian dF/du as a scipy CSR matrix."""
    indptr, indices, _ = disc.pattern
    return sp.csr_matrix((disc.jacobian_values(u, p), indices, indptr),
                         shape=(disc.size, disc.size))


def critical_mode(disc: Discretisation, u, p) -> tuple[float, np.ndarray]:
    """The eigenpair of K v = lambda h v nearest zero at the state (u, p)
    (the buckling mode near a loss of stability), v the N free nodal angles."""
    return inverse_iteration(jacobian(disc, u, p), disc.n_elements, disc.h)[:2]


def orthogonality(disc: Discretisation, u, dp, v) -> float:
    """|v . f| / (|v| |f|) with f = dF_theta/dp . dp; 0 if f vanishes."""
    f = (np.asarray(dp, float) @ disc.load_derivative(u))[: disc.n_elements]
    norm = float(np.linalg.norm(f))
    if norm <= 1e-12 * max(1.0, float(np.max(np.abs(dp)))):
        return 0.0
    return abs(float(np.dot(v, f))) / (float(np.linalg.norm(v)) * norm)


def tip_side(disc: Discretisation, u_ref, u) -> str:
    """"left" if the tip of ``u`` lies to the left of the tip tangent of
    ``u_ref`` (counter-clockwise from it), else "right"."""
    theta_ref, theta = disc.split(u_ref)[0], disc.split(u)[0]
    t = np.array([np.cos(theta_ref[-1]), np.sin(theta_ref[-1])])
    delta = disc.node_positions(theta)[-1] - disc.node_positions(theta_ref)[-1]
    cross = t[0] * delta[1] - t[1] * delta[0]
    if abs(cross) <= 1e-12:                   # the tip did not move sideways
        cross = float(np.sum(theta[1:] - theta_ref[1:]))
    return "left" if cross > 0 else "right"


class AmplitudeContinuation:
    """Follows a bifurcating branch from the critical state ``u_c`` at
    ``p_a + lam_c (p_b - p_a)`` along +-v (module docstring)."""

    def __init__(self, disc: Discretisation, pa, pb, atol: float, max_it: int = 25):
        self.disc, self.atol, self.max_it = disc, atol, max_it
        self.pa, self.dp = np.asarray(pa, float), np.asarray(pb, float) - np.asarray(pa, float)

    def _newton(self, u, lam, theta_c, v, a):
        disc, N = self.disc, self.disc.n_elements
        hv = disc.h * v
        for _ in range(self.max_it):
            p = self.pa + lam * self.dp
            F = disc.residual(u, p)
            c = float(hv @ (u[:N] - theta_c[1:])) - a
            if not np.all(np.isfinite(F)):
                return None
            if np.max(np.abs(F)) <= self.atol and abs(c) <= self.atol:
                return u, lam
            col = (self.dp @ disc.load_derivative(u))[:, None]
            row = np.concatenate((hv, np.zeros(disc.size - N)))[None, :]
            A = sp.bmat([[jacobian(disc, u, p), sp.csr_matrix(col)],
                         [sp.csr_matrix(row), sp.csr_matrix((1, 1))]], format="csc")
            try:
                step = spla.splu(A).solve(-np.append(F, c))
            except RuntimeError:                      # singular: no branch here
                return None
            u, lam = u + step[:-1], lam + step[-1]
        return None

    def _jumped(self, guess, out, angle_tol: float = 0.2, load_tol: float = 0.05) -> bool:
        """A corrected state far from its predictor belongs to another branch."""
        N = self.disc.n_elements
        return (abs(out[1] - guess[1]) > load_tol
                or float(np.max(np.abs(out[0][:N] - guess[0][:N]))) > angle_tol)

    def branch(self, u_c, lam_c: float, v, sign: float, *, da0: float = 0.02,
               da_max: float = 0.05, max_steps: int = 400):
        """Follow the branch leaving u_c along ``sign`` v until lam >= 1.

        Returns (outcome, states): "reached" with the last two states (u, lam)
        (lam of the last >= 1); "subcritical" if lam falls below ``lam_c``;
        "collapse" if the branch pulls an attachment point through its routing
        point (the corrector then meets the mirror solution with negative
        tensions: same force, cable direction flipped); "lost" if it cannot be
        followed with the smallest amplitude step or within ``max_steps``."""
        disc = self.disc
        theta_c = disc.split(u_c)[0]
        prev, cur = None, (np.asarray(u_c, float), lam_c)
        a_prev, a, da = 0.0, 0.0, da0
        for _ in range(max_steps):
            a_new = a + sign * da
            if prev is None:
                theta = theta_c.copy()
                theta[1:] += a_new * v / float(disc.h * v @ v)
                guess = (disc.consistent_state(theta), lam_c)
            else:
                r = (a_new - a) / (a - a_prev)
                guess = (cur[0] + r * (cur[0] - prev[0]), cur[1] + r * (cur[1] - prev[1]))
            out = self._newton(guess[0], guess[1], theta_c, v, a_new)
            flipped = out is not None and bool(np.any(self.pa + out[1] * self.dp < 0.0))
            if out is None or flipped or self._jumped(guess, out):
                if da <= 1e-4:                       # Newton left the branch at any step
                    return ("collapse" if flipped else "lost"), (prev, cur)
                da *= 0.5
                continue
            a_prev, a, prev, cur = a, a_new, cur, out
            if cur[1] < lam_c - 1e-6:                # the branch bends back
                return "subcritical", (prev, cur)
            if cur[1] >= 1.0:
                return "reached", (prev, cur)
            da = min(1.5 * da, da_max)
        return "lost", (prev, cur)
