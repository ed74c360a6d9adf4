"""The equilibrium manifold M = {(u, p): F(u, p) = 0} of one discretised arm
as functions of w = (u, p) (solvers/continuation.py): residual, Jacobian and
load columns (cached per state), the tip, its derivatives and the metric D."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..core.fem import Discretisation

def _remember(cache: dict, key, value, size: int = 4) -> None:
    """Keep ``value`` under ``key`` in a small cache (the oldest entry goes)."""
    if key not in cache and len(cache) >= size:
        cache.pop(next(iter(cache)))
    cache[key] = value


class Manifold:
    """F(u, p) = 0 of one discretised arm as functions of w = (u, p)."""

    def __init__(self, disc: Discretisation, p_ref: float = 10.0):
        self.disc = disc
        self.size = disc.size
        self.n = disc.n_tendons
        self.m = self.size + self.n
        indptr, indices, _ = disc.pattern
        self.csr = (indptr, indices)
        weights = np.ones(self.m)
        weights[: disc.n_elements] = disc.h
        weights[self.size:] = 1.0 / p_ref**2
        self.metric = weights                      # D of the module docstring
        self._jac_cache, self._load_cache = {}, {}
        self._rows_of_entries = np.repeat(np.arange(self.size), np.diff(indptr))
        self._route_cache = {}

    def split(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return w[: self.size], w[self.size:]

    def residual(self, w: np.ndarray) -> np.ndarray:
        """F at w; J and dF/dp at w are computed in the same pass
        (:meth:`Discretisation.linearisation`) and cached: Newton, the tangent
        and the test functions ask for them at the iterates it evaluates."""
        u, p = self.split(w)
        F, J, L = self.disc.linearisation(u, p)
        _remember(self._jac_cache, w.tobytes(), J)
        _remember(self._load_cache, u.tobytes(), L.T)
        return F

    def jacobian_values(self, w: np.ndarray) -> np.ndarray:
        """Entries of J = dF/du at w (pattern ``csr``); the last few w are cached
        (the corrector, the tangent and the fold test functions ask at the same w)."""
        key = w.tobytes()
        if key not in self._jac_cache:
            self._linearise(w)
        return self._jac_cache[key]

    def _linearise(self, w: np.ndarray) -> None:
        """Cache J and dF/dp at w, computed together (shared kernels)."""
        u, p = self.split(w)
        J, L = self.disc.linearisation(u, p, residual=False)
        _remember(self._jac_cache, w.tobytes(), J)
        _remember(self._load_cache, u.tobytes(), L.T)

    def jacobian(self, w: np.ndarray) -> sp.csr_matrix:
        return sp.csr_matrix((self.jacobian_values(w), self.csr[1], self.csr[0]),
                             shape=(self.size, self.size))

    def residual_gradient(self, w: np.ndarray, v: np.ndarray) -> np.ndarray:
        """grad_w (v . F) = (J^T v, (dF/dp)^T v), (m,), without building a matrix."""
        rows = self._rows_of_entries
        jt_v = np.bincount(self.csr[1], weights=self.jacobian_values(w) * v[rows],
                           minlength=self.size)
        return np.concatenate((jt_v, self.load_columns(w).T @ v))

    def load_columns(self, w: np.ndarray) -> np.ndarray:
        """dF/dp, (size, n): the tensions' columns (Eq. (14)); F is linear in p.
        Depends on u only; the last few are cached like :meth:`jacobian_values`."""
        key = self.split(w)[0].tobytes()
        if key not in self._load_cache:
            self._linearise(w)
        return self._load_cache[key]

    def route_derivative(self, w: np.ndarray, i: int) -> np.ndarray:
        """dF/dr_i, (size, 2), at fixed u and p: F_theta depends on r_i only through
        d_i = (r_i - y_i)/|r_i - y_i| (Eqs. (3)-(4), (9)), so dF/dr_i = -dF/dy_i on the
        angle rows (the border columns of tendon i of the Jacobian) and 0 on the
        attachment rows (y - X(theta) does not involve r_i)."""
        N = self.disc.n_elements
        if self.disc.has_paths:          # the first chord's equation (docs/model.md §11.7)
            return self.disc.route_derivative(*self.split(w), i)
        out = np.zeros((self.size, 2))
        rows, cols, entries = self._route_entries(i)
        out[rows, cols] = -self.jacobian_values(w)[entries]
        return out

    def _route_entries(self, i: int):
        """(rows, columns 0/1, entry indices) of the Jacobian's entries in the
        angle rows and the two attachment columns of tendon i (the pattern is
        fixed: found once)."""
        if i not in self._route_cache:
            N = self.disc.n_elements
            col = self.csr[1] - (N + 2 * i)
            entries = np.flatnonzero((self._rows_of_entries < N) & (col >= 0) & (col < 2))
            self._route_cache[i] = (self._rows_of_entries[entries], col[entries], entries)
        return self._route_cache[i]

    def tip(self, w: np.ndarray) -> np.ndarray:
        theta = self.disc.split(self.split(w)[0])[0]
        return self.disc.node_positions(theta)[-1]

    def tip_velocity(self, w: np.ndarray, t: np.ndarray) -> np.ndarray:
        """d x_t along the direction t of w (Eq. (13) with the midpoint rule)."""
        disc = self.disc
        theta = disc.split(self.split(w)[0])[0]
        dtheta = disc.split(self.split(t)[0])[0]
        phi = disc.element_angles(theta)
        dphi = disc.element_angles(dtheta)
        return disc.h * np.array([np.sum(-np.sin(phi) * dphi), np.sum(np.cos(phi) * dphi)])

    def norm(self, t: np.ndarray) -> float:
        return float(np.sqrt(np.sum(self.metric * t * t)))

    def tip_gradient(self, w: np.ndarray) -> np.ndarray:
        """T = d x_t/du, (2, size): x_t = h sum_e (cos phi_e, sin phi_e) with the
        element midpoint angles phi_e = (theta_e + theta_e+1)/2 (Eq. (2)), so
        d x_t/d theta_k = (g_k-1 + g_k)/2, g_e = h (-sin phi_e, cos phi_e), g_N = 0."""
        disc = self.disc
        phi = disc.element_angles(disc.split(self.split(w)[0])[0])
        g = disc.h * np.vstack((-np.sin(phi), np.cos(phi)))            # (2, N)
        out = np.zeros((2, self.size))
        out[:, : disc.n_elements] = 0.5 * g
        out[:, : disc.n_elements - 1] += 0.5 * g[:, 1:]
        return out

    def tip_curvature_term(self, w: np.ndarray, a: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        """grad_u (a . T(u) alpha) at fixed a (2,) and alpha (size,), padded to (m,):
        the second derivative of the tip (Eq. (2)) contracted with a and alpha."""
        disc = self.disc
        N = disc.n_elements
        phi = disc.element_angles(disc.split(self.split(w)[0])[0])
        dphi = disc.element_angles(np.concatenate(([0.0], alpha[:N])))
        q = disc.h * (-a[0] * np.cos(phi) - a[1] * np.sin(phi)) * dphi   # d/dphi_e
        out = np.zeros(self.m)
        out[:N] = 0.5 * q
        out[:N - 1] += 0.5 * q[1:]
        return out

    def tip_jacobian(self, w: np.ndarray, lu=None) -> tuple[np.ndarray, np.ndarray, object]:
        """S = d x_t/dp on M at w (Eq. (13)), alpha = du/dp (size, n) from
        J alpha = -dF/dp (Eq. (14)) and the LU of J (scipy), for reuse."""
        from scipy.sparse.linalg import splu
        lu = splu(self.jacobian(w).tocsc()) if lu is None else lu
        alpha = -lu.solve(self.load_columns(w))
        return self.tip_gradient(w) @ alpha, alpha, lu
