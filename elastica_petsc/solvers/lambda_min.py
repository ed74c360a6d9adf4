"""The smallest eigenvalue of the pencil (K, M) without an eigen solver
(docs/model.md §25): what a workspace map records per sample.

K = T + W^T W (tridiagonal T, :meth:`Discretisation.band`; n rows of W,
:meth:`Discretisation.stiffness_border`), M = diag(weights) > 0.

1. Bracket: Gershgorin(T, M) <= lambda_min (Weyl: W^T W >= 0) <= the Rayleigh
   quotients of the unit vectors and of the unloaded arm's first mode.
2. Inertia bisection: K - sigma M has a negative eigenvalue iff sigma >
   lambda_min; its inertia is that of H(sigma) = [[T - sigma M, W^T], [W, -I]]
   less (0, n, 0) (Haynsworth), counted in O(N) by the compiled natural-order
   LDL^T (:func:`~elastica_petsc.core.fem.ldlt_negatives`).  Stable states
   (most) are halved from 0; the bracket is narrowed to ``coarse_rtol``.
3. Inverse iteration shifted at the bracket's lower end (Woodbury, LAPACK's
   tridiagonal LU): its Rayleigh quotient rho >= lambda_min.
4. Certificate: one count at rho (1 - ``rtol``) proves lambda_min there or
   above; otherwise (or if step 3 failed) bisection alone to ``rtol``.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

from ..core.fem import Discretisation, ldlt_negatives


def _tridiagonal_apply(band: np.ndarray, x: np.ndarray) -> np.ndarray:
    """T x for the band (N, 3) = (lower, diag, upper) of :meth:`Discretisation.band`."""
    y = band[:, 1] * x
    y[1:] += band[1:, 0] * x[:-1]
    y[:-1] += band[:-1, 2] * x[1:]
    return y


def rayleigh(band, W, weights, x) -> float:
    """x^T K x / x^T M x for K = T + W^T W, M = diag(weights): >= lambda_min."""
    return float(x @ (_tridiagonal_apply(band, x) + W.T @ (W @ x)) / (x @ (weights * x)))


def inverse_iteration(band, W, weights, sigma: float, x: np.ndarray, rtol: float,
                      max_steps: int = 12) -> float | None:
    """The Rayleigh quotient of inverse iteration x <- (K - sigma M)^{-1} M x for
    K = T + W^T W (Woodbury: (T - sigma M) by LAPACK's pivoted tridiagonal LU,
    then the n x n capacitance I + W (T - sigma M)^{-1} W^T), once it changes
    by less than ``rtol``; None if a factor is singular or it does not settle.
    With sigma below lambda_min it converges to lambda_min (the caller checks)."""
    dl, d, du, du2, ipiv, info = lapack.dgttrf(band[1:, 0], band[:, 1] - sigma * weights,
                                                band[:-1, 2])
    if info != 0:
        return None
    Y, info = lapack.dgttrs(dl, d, du, du2, ipiv, np.ascontiguousarray(W.T))
    if info != 0:
        return None
    try:                               # Y (I + W Y)^{-1}: the capacitance inverted once
        YC = Y @ np.linalg.inv(np.eye(W.shape[0]) + W @ Y)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(YC)):
        return None
    rho = None
    for _ in range(max_steps):
        y, info = lapack.dgttrs(dl, d, du, du2, ipiv, weights * x)
        x = y - YC @ (W @ y)
        x /= np.max(np.abs(x))
        previous, rho = rho, rayleigh(band, W, weights, x)
        if not np.isfinite(rho):
            return None
        if previous is not None and abs(rho - previous) <= rtol * abs(rho):
            return rho
    return None


class SmallestEigenvalue:
    """lambda_min of (K(u, p), diag(weights)) for one discretised arm (module doc).

    ``rtol``: relative accuracy (the counts' rounding is ~eps ||K||);
    ``coarse_rtol``: the bisection bracket handed to inverse iteration;
    ``rayleigh_rtol``: when the Rayleigh quotient has settled (its own rounding
    is ~eps ||K|| / lambda_min, about 1e-12 at 180 elements)."""

    rtol = 1e-11
    coarse_rtol = 0.1
    rayleigh_rtol = 1e-10

    def __init__(self, disc: Discretisation):
        self.disc = disc
        indptr, indices, _ = disc.stability_pattern
        N = disc.n_elements
        self.diagonal = np.asarray(indptr[:N], np.int64)    # T's diagonal among H's values
        if not np.array_equal(indices[self.diagonal], np.arange(N)):
            raise ValueError("the stability pattern's rows do not start at the diagonal")
        self.csr = (np.ascontiguousarray(indptr, np.int32), np.ascontiguousarray(indices, np.int32))
        self.mode = np.sin(0.5 * np.pi * np.arange(1, N + 1) / N)   # the unloaded first mode
        self._state = None

    def _operators(self, u, p):
        """(T's band, W, H's values) at (u, p), kept for the last state."""
        u, p = np.asarray(u, float), np.asarray(p, float)
        if self._state is None or not (np.array_equal(self._state[0], u)
                                       and np.array_equal(self._state[1], p)):
            disc = self.disc
            theta, y = disc.split(u)
            band = disc.band(theta, disc.cables(y)[1], p)
            self._state = (u.copy(), p.copy(), band, disc.stiffness_border(theta, y, p),
                           disc.stability_values(u, p))
        return self._state[2:]

    def counter(self, values: np.ndarray, weights: np.ndarray):
        """below(sigma): whether lambda_min < sigma (or = : H(sigma) singular)."""
        N, border = self.disc.n_elements, self.disc.stability_border
        shifted = np.array(values, float)
        on_diagonal = shifted[self.diagonal].copy()

        def below(sigma: float) -> bool:
            shifted[self.diagonal] = on_diagonal - sigma * weights
            negative = ldlt_negatives(self.csr, shifted, N)
            return negative is None or negative > border
        return below

    def of(self, u, p, weights: np.ndarray) -> float:
        """lambda_min of (K(u, p), diag(weights)) within ``rtol`` (module doc)."""
        band, W, values = self._operators(u, p)
        s = 1.0 / np.sqrt(weights)
        radius = np.append(0.0, np.abs(band[1:, 0]) * s[1:] * s[:-1]) + \
            np.append(np.abs(band[:-1, 2]) * s[:-1] * s[1:], 0.0)
        scaled_diagonal = band[:, 1] * s * s
        scale = float(np.max(np.abs(scaled_diagonal) + radius) + np.sum(W * W) / weights.min())
        lower = float(np.min(scaled_diagonal - radius)) - 1e-12 * scale
        upper = min(float(np.min((band[:, 1] + np.sum(W * W, axis=0)) / weights)),
                    rayleigh(band, W, weights, self.mode)) + 1e-12 * scale
        below = self.counter(values, weights)

        def bisect(lower, upper, rtol):
            while upper - lower > rtol * max(abs(lower), abs(upper)) + 1e-16 * scale:
                sigma = 0.5 * (lower + upper)
                lower, upper = (lower, sigma) if below(sigma) else (sigma, upper)
            return lower, upper

        if lower < 0.0 < upper:            # most states are stable: halve from 0
            lower, upper = (lower, 0.0) if below(0.0) else (0.0, upper)
        lower, upper = bisect(lower, upper, self.coarse_rtol)
        rho = inverse_iteration(band, W, weights, lower, self.mode, self.rayleigh_rtol)
        if rho is not None and lower <= rho <= upper and \
                not below(rho - self.rtol * abs(rho) - 1e-16 * scale):
            return rho
        lower, upper = bisect(lower, upper, self.rtol)
        return 0.5 * (lower + upper)
