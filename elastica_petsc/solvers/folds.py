"""The two fold constraints of the continuation (solvers/continuation.py):
the fold of M over tension space (minimally extended system, sigma = 0,
Eq. (20)) and the fold of the tip map (det S = 0, Eq. (13)); the module
docstring of :mod:`.continuation` derives both."""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from .bordered import BorderedAIJ, BorderedPattern, use_pivoting_lu
from .constraints import Constraint
from .manifold import Manifold
from .options import SolverOptions, check_comm

class FoldSystem:
    """The minimally extended system of the module docstring: sigma(w) and its
    gradient, with LU solves (PETSc KSP) of J bordered by b and c."""

    def __init__(self, manifold: Manifold, *, comm=None, options_prefix: str = "fold_",
                 petsc_options=None):
        self.options = SolverOptions(options_prefix, petsc_options)
        self.comm = comm = check_comm(comm)
        self.mf = manifold
        self.mat = BorderedAIJ(*manifold.csr, manifold.size, 1)
        self.rhs = PETSc.Vec().createSeq(manifold.size + 1, comm=comm)
        self.sol = self.rhs.duplicate()
        self.ksp = PETSc.KSP().create(comm)
        self.options.label(self.ksp, self.mat.mat, self.rhs, self.sol)
        self.ksp.setOperators(self.mat.mat)
        use_pivoting_lu(self.ksp)
        self.options.apply(self.ksp)
        self.b = self.c = None
        self._cache = {}

    def set_vectors(self, v: np.ndarray) -> None:
        """Bordering vectors from an approximate null vector of J."""
        v = v / np.linalg.norm(v)
        self.b, self.c = v.copy(), v.copy()
        self._cache = {}

    def null_vector(self, w: np.ndarray, guess: np.ndarray | None = None, its: int = 3):
        """Approximate null vector of J(w) by inverse iteration (J near singular)."""
        J = self.mf.jacobian(w).tocsc()
        from scipy.sparse.linalg import splu
        lu = splu(J, permc_spec="NATURAL")
        v = np.ones(self.mf.size) if guess is None else guess.copy()
        for _ in range(its):
            v = lu.solve(v)
            v /= np.linalg.norm(v)
        return v

    def _solve(self, w, transpose: bool) -> tuple[np.ndarray, float]:
        """Solution of the bordered system (or its transpose) at w; the matrix is
        filled (and factored) once per w and bordering, results are cached."""
        key = w.tobytes()
        if self._cache.get("w") != key:
            self.mat.fill(self.mf.jacobian_values(w), self.b[:, None],
                          np.append(self.c, 0.0)[None, :])
            self.ksp.setOperators(self.mat.mat)
            self._cache = {"w": key}
        if transpose not in self._cache:
            rhs = np.zeros(self.mf.size + 1)
            rhs[-1] = 1.0
            self.rhs.setArray(rhs)
            (self.ksp.solveTranspose if transpose else self.ksp.solve)(self.rhs, self.sol)
            x = self.sol.getArray(readonly=True).copy()
            self._cache[transpose] = (x[:-1], float(x[-1]))
        return self._cache[transpose]

    def sigma(self, w) -> float:
        return self._solve(w, False)[1]

    def sigma_gradient(self, w) -> tuple[float, np.ndarray, np.ndarray]:
        """sigma, d sigma / dw and the null vector v (normalised)."""
        v, s = self._solve(w, False)
        # transpose of [J b; c^T 0] is [J^T c; b^T 0]: its solution is (psi, s)
        psi, _ = self._solve(w, True)
        eps = 1e-6 / max(np.linalg.norm(v), 1e-300)
        step = np.concatenate((eps * v, np.zeros(self.mf.n)))
        # central difference in the direction v of grad_w (psi . F): the design
        # gradients (route_velocity) need it accurate, and consistent with
        # Fold.route_gradient
        dJv = (self.mf.residual_gradient(w + step, psi)
               - self.mf.residual_gradient(w - step, psi)) / (2 * eps)
        return s, -dJv, v / np.linalg.norm(v)

    def destroy(self) -> None:
        for obj in (self.ksp, self.mat, self.rhs, self.sol):
            obj.destroy()


class Fold(Constraint):
    """The fold of M over tension space (det K = 0, Eq. (20)): sigma(w) = 0.
    ``side`` is set so that the stable side is admissible."""

    name = "fold"

    def __init__(self, system: FoldSystem):
        self.sys = system

    def value(self, w):
        return self.sys.sigma(w)

    def gradient(self, w):
        return self.sys.sigma_gradient(w)[1]

    def update(self, w) -> None:
        """New bordering vectors at an accepted point (kept fixed within a solve)."""
        if self.sys.b is None:
            self.sys.set_vectors(self.sys.null_vector(w))
        self.sys.set_vectors(self.sys.sigma_gradient(w)[2])

    def route_gradient(self, w, i):
        """d sigma/dr_i (:meth:`parameter_gradient` of dF/dr_i)."""
        return self.parameter_gradient(w, lambda ws: self.sys.mf.route_derivative(ws, i), 2)

    def parameter_gradient(self, w, residual, k):
        """d sigma/dq = -psi^T (d^2 F/du dq) v: the central difference in the
        direction v of psi^T dF/dq (as for d sigma/dw); ``residual(w)`` = dF/dq."""
        system, mf = self.sys, self.sys.mf
        v, _ = system._solve(w, False)
        psi, _ = system._solve(w, True)
        eps = 1e-6 / max(np.linalg.norm(v), 1e-300)
        u, p = mf.split(w)
        shifted = [np.concatenate((u + sign * eps * v, p)) for sign in (1.0, -1.0)]
        a, b = (psi @ residual(ws) for ws in shifted)
        return -(a - b) / (2 * eps)


class TipFold(Constraint):
    """A fold of the tip map on M: rank [d x_t along M] < 2, Eq. (13).

    With R (2 x m) rows transverse to the tangent plane of M, the bordered
    matrix B = [dF/dw; R] and tau = B^-1 [0; I] (two vectors spanning the
    tangent plane), c = det (T tau), T = d x_t/du.  Its zero set does not
    depend on R (another R multiplies c by a nonzero factor), and with
    R = [0 I] (the tension rows) it is det S = 0, S = d x_t/dp; a frame R
    from the tangent plane itself keeps B regular across the fold of M (where
    det S is unbounded).  The frame is fixed within a corrector solve and
    moved to the current tangent plane at accepted points (:meth:`update`).
    Gradient, with A = adj(T tau), a_j its rows, mu_j = B^-T [T^T a_j; 0]:

        dc = sum_j a_j . (dT tau_j) - mu_j . (dG tau_j),   G = dF/dw,

    the last term as the forward difference, in the direction tau_j, of
    grad_w (mu_j . F) = (J^T mu_j, (dF/dp)^T mu_j)."""

    name = "tip fold"

    def __init__(self, manifold: Manifold):
        self.mf = manifold
        self.R = None
        self._cache = (None, None)
        self.pattern = BorderedPattern(*manifold.csr, manifold.size, manifold.n)

    def reset(self, w) -> None:
        """Frame R = [0 I] (tension rows: regular where K is), then moved to w."""
        self.R = np.zeros((self.mf.n, self.mf.m))
        self.R[:, self.mf.size:] = np.eye(self.mf.n)
        self._cache = (None, None)
        self.update(w)

    def update(self, w) -> None:
        """Frame from the tangent plane at w (D-orthonormalised, orientation kept)."""
        tau = self._data(w)[1]
        metric = self.mf.metric
        q = tau / np.sqrt(np.sum(metric[:, None] * tau * tau, axis=0))[None]
        second = q[:, 1] - (metric * q[:, 0]) @ q[:, 1] * q[:, 0]
        q[:, 1] = second / self.mf.norm(second)
        self.R = (metric[:, None] * q).T
        self._cache = (None, None)

    def _data(self, w):
        key = w.tobytes()
        if self._cache[0] != key:
            mf = self.mf
            values = self.pattern.values(mf.jacobian_values(w), mf.load_columns(w), self.R)
            lu = self.pattern.lu_of_transpose(values)                  # of B^T
            rhs = np.zeros((mf.m, mf.n))
            rhs[mf.size:] = np.eye(mf.n)
            tau = lu.solve(rhs, trans="T")
            T = mf.tip_gradient(w)
            self._cache = (key, (T @ tau[: mf.size], tau, lu, T))
        return self._cache[1]

    def value(self, w):
        return float(np.linalg.det(self._data(w)[0]))

    def gradient(self, w):
        mf = self.mf
        S, tau, lu, T = self._data(w)
        adj = np.array([[S[1, 1], -S[0, 1]], [-S[1, 0], S[0, 0]]])

        out = np.zeros(mf.m)
        for j in range(mf.n):
            out += mf.tip_curvature_term(w, adj[j], tau[: mf.size, j])
            rhs = np.zeros(mf.m)
            rhs[: mf.size] = T.T @ adj[j]
            mu = lu.solve(rhs)[: mf.size]                              # B^T mu = rhs
            d = tau[:, j]
            eps = 1e-7 / max(mf.norm(d), 1e-300)
            out -= (mf.residual_gradient(w + eps * d, mu) - mf.residual_gradient(w, mu)) / eps
        return out
