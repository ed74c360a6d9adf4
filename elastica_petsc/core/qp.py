"""A small dense quadratic programme with equality constraints and a box, solved
exactly by active-set enumeration (numpy only; for the few tensions of one arm).

    minimise    g.d + d.W.d / 2
    subject to  A^T d = -c            (m equality constraints, A: (n, m))
                lo <= d <= hi

W must be symmetric positive definite, so the QP is strictly convex and its KKT
point, if the constraints are feasible, is unique.  Every assignment of each
variable to {free, on lo, on hi} is tried, nearest to a guessed assignment
first (the previous step's, so a warm start usually needs one linear solve);
the first that satisfies all KKT conditions is the solution:

    W d + g = A lam + mu,   mu_i >= 0 on lo,  mu_i <= 0 on hi,  mu_i = 0 free,
    lo <= d <= hi,          A^T d = -c.

3^n assignments at most (n <= MAX_VARIABLES): no iteration that could cycle or
hang.  When none satisfies them, the linearised constraints cannot be met in
the box and :func:`solve_box_qp` returns None (see :func:`closest_in_box`).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .errors import InputError

MAX_VARIABLES = 8          # 3^8 = 6561 assignments in the worst case
FREE, LOWER, UPPER = 0, -1, 1


@dataclass(frozen=True)
class QPSolution:
    d: np.ndarray           # the step
    lam: np.ndarray         # multipliers of A^T d = -c
    mu: np.ndarray          # multipliers of the box (> 0 on lo, < 0 on hi, 0 free)
    active: np.ndarray      # per variable FREE, LOWER or UPPER


def _assignments(n: int, guess: np.ndarray, finite_hi: np.ndarray):
    """All assignments, the fewest changes from ``guess`` first."""
    choices = [(FREE, LOWER, UPPER) if finite_hi[i] else (FREE, LOWER) for i in range(n)]
    combos = [np.array(a) for a in itertools.product(*choices)]
    combos.sort(key=lambda a: int(np.sum(a != guess)))
    return combos


def _solve_assignment(W, g, A, c, lo, hi, act, tol):
    """The equality-constrained QP with the assigned variables fixed; None if it
    is singular or violates a KKT condition."""
    n, m = A.shape
    d = np.where(act == LOWER, lo, np.where(act == UPPER, hi, 0.0))
    F = act == FREE
    k = int(F.sum())
    if k < m:
        return None
    K = np.zeros((k + m, k + m))
    K[:k, :k] = W[np.ix_(F, F)]
    K[:k, k:] = -A[F]
    K[k:, :k] = A[F].T
    rhs = np.concatenate((-g[F] - W[np.ix_(F, ~F)] @ d[~F], -c - A[~F].T @ d[~F]))
    try:
        sol = np.linalg.solve(K, rhs)
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(sol)) or np.linalg.norm(K @ sol - rhs) > 1e-8 * (
            1.0 + np.linalg.norm(rhs)):
        return None                       # (near-)singular: A_F has rank < m
    d[F] = sol[:k]
    lam = sol[k:]
    mu = W @ d + g - A @ lam
    mu[F] = 0.0
    scale = tol * (1.0 + float(np.max(np.abs(g))) + float(np.max(np.abs(A @ lam), initial=0.0)))
    box = tol * (1.0 + np.abs(lo) + np.abs(np.where(np.isfinite(hi), hi, 0.0)))
    if np.any(d[F] < lo[F] - box[F]) or np.any(d[F] > hi[F] + box[F]):
        return None
    if np.any(mu[act == LOWER] < -scale) or np.any(mu[act == UPPER] > scale):
        return None
    return QPSolution(d, lam, mu, act)


def solve_box_qp(W, g, A, c, lo, hi, guess=None, tol: float = 1e-10) -> QPSolution | None:
    """The KKT point of the QP of the module doc, or None if its constraints
    are infeasible.  ``guess``: a previous ``active`` array (default all free)."""
    W, g, A = np.asarray(W, float), np.asarray(g, float), np.asarray(A, float)
    c, lo, hi = np.asarray(c, float), np.asarray(lo, float), np.asarray(hi, float)
    n = len(g)
    if n > MAX_VARIABLES:
        raise InputError(f"at most {MAX_VARIABLES} tendons are supported by the tension "
                         f"sharing QP, got {n}")
    guess = np.zeros(n, int) if guess is None else np.asarray(guess, int)
    for act in _assignments(n, guess, np.isfinite(hi)):
        if np.any((act == LOWER) & ~np.isfinite(lo)):
            continue
        sol = _solve_assignment(W, g, A, c, lo, hi, act, tol)
        if sol is not None:
            return sol
    return None


def closest_in_box(A, c, lo, hi) -> tuple[np.ndarray, float]:
    """The step in the box that best meets the linearised constraints:
    argmin |A^T d + c| over lo <= d <= hi (bounded least squares, scipy),
    and the residual |A^T d + c| it leaves."""
    from scipy.optimize import lsq_linear      # here: scipy.optimize costs ~0.1 s to import

    A, c = np.asarray(A, float), np.asarray(c, float)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    d = lo.copy()
    free = hi - lo > 1e-14 * (1.0 + np.abs(lo))      # scipy needs lo < hi: fix the others
    if np.any(free):
        rhs = -c - A[~free].T @ d[~free]
        res = lsq_linear(A[free].T, rhs, bounds=(lo[free], hi[free]), method="bvls")
        d[free] = np.clip(res.x, lo[free], hi[free])
    return d, float(np.linalg.norm(A.T @ d + c))
