"""Deflation operator for finding several distinct equilibria with Newton.

Farrell, Birkisson & Funke (2015), "Deflation techniques for finding
distinct solutions of nonlinear partial differential equations", SIAM J.
Sci. Comput. 37(4), A2026-A2045: once solutions z_1..z_K of F(z) = 0 are
known, Newton is applied to the deflated residual

    G(z) = M(z) F(z),      M(z) = prod_k ( 1 / ||z - z_k||^q + sigma ),

(their "shifted" deflation operator, Sec. 3; here q = 2, sigma = 1).  G has
the same zeros as F except the z_k, near which G stays away from zero
(M -> infinity), so Newton started anywhere cannot converge to them again.
Because M > 0, multiplying the equation rows of a complementarity problem by
M keeps their sign, so the same operator deflates the variational inequality
of length control (F_i >= 0 at a lower bound stays F_i >= 0).

The norm is over the shape only: ||z - z_k||^2 = h sum_j (theta_j - theta_kj)^2,
the discrete L2 norm of theta - theta_k on [0, l] (mesh independent).

Jacobian.  dG/dz = M J + F (grad M)^T: a rank-one update of M J, dense
(F has every row, grad M every theta column).  It is never formed.  Instead
the solvers in :mod:`elastica_petsc.solvers.lengths` carry mu = M(z) as one extra
unknown with the extra equation mu - M(z) = 0 and solve

    [ mu F(z)     ]                       [ mu J     F ]
    [ mu - M(z)   ] = 0,   with Jacobian  [ -grad M  1 ].

The Newton step of this system, (mu J + F grad M^T) dz = -M F after
eliminating d mu, is exactly the deflated Newton step of Farrell et al.
(at mu = M), and the extra row and column are one more border of the
bordered system: LU in the natural order still fills only the border, O(N).
"""
from __future__ import annotations

import math

import numpy as np

# exp of more than this overflows a double: M is then reported as +inf
_LOG_MAX = math.log(np.finfo(float).max) - 1.0
_TINY = np.finfo(float).tiny


class Deflation:
    """M(theta) = prod_k (||theta - theta_k||^-q + sigma) and its gradient.

    ``h`` is the element size (weights of the discrete L2 norm); states are
    the N free nodal angles theta_1..theta_N (radians).
    """

    def __init__(self, h: float, *, power: float = 2.0, shift: float = 1.0):
        if power <= 0 or shift <= 0:
            raise ValueError("deflation needs power > 0 and shift > 0")
        self.h = float(h)
        self.power = float(power)
        self.shift = float(shift)
        self.roots: list[np.ndarray] = []
        self._stack = None                      # the roots as one (K, N) array, built on use
        self._last = None                       # [theta's bytes, M, diff, s, grad] of the last call

    def add(self, theta: np.ndarray) -> None:
        """Deflate one more known solution (its free angles theta_1..theta_N)."""
        self.roots.append(np.array(theta, dtype=float, copy=True))
        self._stack = self._last = None

    def clear(self) -> None:
        self.roots.clear()
        self._stack = self._last = None

    def __len__(self) -> int:
        return len(self.roots)

    def _roots(self) -> np.ndarray:
        """The roots stacked (K, N); restacked only after :meth:`add` or :meth:`clear`."""
        if self._stack is None:
            self._stack = np.asarray(self.roots)
        return self._stack

    def distances(self, theta: np.ndarray) -> np.ndarray:
        """||theta - theta_k|| (discrete L2 on [0, l]) to every deflated root."""
        if not self.roots:
            return np.zeros(0)
        diff = theta[None, :] - self._roots()
        return np.sqrt(self.h * np.sum(diff * diff, axis=1))

    def factor(self, theta: np.ndarray) -> float:
        """M(theta) alone (a residual needs no gradient: the line search's trial
        points outnumber the Jacobians); its parts are kept, so that
        :meth:`factor_and_gradient` at the same point only adds the gradient."""
        if not self.roots:
            return 1.0
        return self._parts(theta)[1]

    def factor_and_gradient(self, theta: np.ndarray) -> tuple[float, np.ndarray]:
        """M(theta) and dM/dtheta; M = 1, grad = 0 when nothing is deflated.

        Evaluated through log M = sum_k log(s_k^(-q/2) + sigma), s_k = ||theta - theta_k||^2,
        so that no intermediate overflows: at (or within round-off of) a deflated
        root M is returned as +inf with a zero gradient, without a warning."""
        if not self.roots:
            return 1.0, np.zeros_like(theta)
        last = self._parts(theta)       # the SNES asks for the Jacobian where it just had F
        if last[4] is None:
            last[4] = self._gradient(theta, *last[1:4])
        return last[1], last[4]

    def _parts(self, theta: np.ndarray) -> list:
        """[key, M, diff, s, gradient or None] of theta, the last point's if it is theta."""
        key = np.asarray(theta, float).tobytes()
        if self._last is None or self._last[0] != key:
            self._last = [key, *self._factor(theta), None]
        return self._last

    def _factor(self, theta: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        q, sigma = self.power, self.shift
        diff = theta - self._roots()                               # (K, N)
        # ndarray.sum: the same reduction as np.sum without its Python wrapper
        s = np.maximum(self.h * (diff * diff).sum(axis=1), _TINY)
        # log(s^(-q/2) + sigma) = -(q/2) log s + log(1 + sigma s^(q/2))
        log_M = float((-(q / 2.0) * np.log(s) + np.log1p(sigma * s ** (q / 2.0))).sum())
        if log_M > _LOG_MAX:
            return math.inf, diff, s
        return math.exp(log_M), diff, s

    def _gradient(self, theta, M, diff, s) -> np.ndarray:
        if math.isinf(M):
            return np.zeros_like(theta)
        q, sigma = self.power, self.shift
        # d/dtheta log(s^(-q/2) + sigma) = -(q/2) / (s (1 + sigma s^(q/2))) * 2 h diff
        coeff = -(q / 2.0) / (s * (1.0 + sigma * s ** (q / 2.0)))
        return M * (coeff @ (2.0 * self.h * diff))
