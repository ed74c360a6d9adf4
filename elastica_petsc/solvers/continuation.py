"""Pseudo-arclength continuation of curves on the equilibrium manifold.

For an arm with n tendons the equilibria form an n-dimensional manifold
M = {(u, p) : F(u, p) = 0} (F: the bordered residual of Eq. (9),
:mod:`elastica_petsc.core.fem`).  With two tendons, one more scalar
equation c(u, p) = 0 cuts a curve out of M: a face of the tension domain
(c = p_i, or c = p_i - p_crit, Eq. (22)), a cable about to collapse onto its
routing point (c = L_i - eps), a level curve of a restriction (Eqs. (19),
(21)) or the fold of M over tension space, where the tangent K is singular
and stability under load control is lost (Eq. (20); c = sigma, the
minimally extended system below).

Predictor-corrector (Keller's pseudo-arclength), unknowns w = (u, p):

    predictor   w* = w_k + ds t_k
    corrector   G(w) = [F(u, p); c(w); t_k . D (w - w*)] = 0    (SNES, Newton)
    tangent     [dF/dw; dc/dw; t_k^T D] t_{k+1} = [0; 0; 1],  normalised in D

D = diag(h for the angles, 1 for the attachment unknowns, 1/p_ref^2 for the
tensions) weighs the angles by the mesh size, so steps do not depend on N.
The corrector's Jacobian is the bordered Jacobian of fem with n dense
columns (dF/dp, Eq. (14)) and two dense rows, factored by a sparse LU with
partial pivoting (:func:`use_pivoting_lu`: J is singular on the fold).
Debian's PETSc 3.18 has no SNESNEWTONAL, so the extended system is set up
here on a plain SNES (Newton with line search, options prefix ``cont_``).

Step control: the step doubles after a corrector of at most 3 Newton
iterations and halves on failure, on a corrector that moved any angle by
more than ``jump_tol`` from the predictor (a jump to another branch) or on a
tip step longer than ``max_tip_step``.  Before the corrector the step is
capped so that the predicted tip step is 0.8 ``max_tip_step``
(:meth:`CurveTracer.step_limit`) and, on the boundary tracer's walks, so that
the predictor at most halves a cable that shortens (past its routing point
the cable direction of Eq. (3) flips and no corrector converges;
``studies/boundary/walker.py``, ``Walker._collapse_limit``).  Within a corrector,
once the residual is below ``lag_below`` the factored Jacobian of the
previous iterate is kept (a chord step; the stopping tests are unchanged).

Test functions along a curve (evaluated at every accepted point):
stability (negative eigenvalues of K by Sylvester inertia: a change is a
limit point of M, a *fold*); the sign of det [dG/dw] with the tangent row
(a change without a fold is a *branch point* of the curve); and the sign of
det S, S = d x_t / d p the 2 x 2 tip Jacobian (Eq. (13)), whose change marks
a fold of the tip map (where an interior fold curve of the workspace meets
this curve).

The fold constraint (minimally extended system, Griewank-Reddien): with
bordering vectors b, c (approximate right and left null vectors of J),

    [J  b] [v]   [0]          [J^T c] [psi]   [0]
    [c^T 0] [s] = [1],         [b^T 0] [ s ] = [1],     sigma(w) = s,

sigma vanishes exactly where J (hence K, its Schur complement) is singular,
and d sigma/dw = -psi^T (dJ/dw) v.  The last term is a directional second
derivative of F; it is computed as the central difference, in the direction
v, of the gradient of psi^T F (one Jacobian evaluation on each side: error
O(eps^2) ~ 1e-10 relative).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from ..core import interrupt
from ..core.errors import SolverError
from ..core.fem import Discretisation
from .inertia import InertiaCounter
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm
from .reasons import converged_reason

# LU with partial pivoting for the extended systems: their leading block J is
# singular on the fold and their last rows have no diagonal entry, so the
# natural-order LU without pivoting of linalg.use_bordered_lu would break down.
PIVOTING_LU = ("klu", "umfpack", "superlu", "mumps")


def use_pivoting_lu(ksp: PETSc.KSP) -> PETSc.KSP:
    """KSP preonly with a sparse LU that pivots (first available package)."""
    use_bordered_lu(ksp)
    pc = ksp.getPC()
    for package in PIVOTING_LU:
        try:
            pc.setFactorSolverType(package)
            return ksp
        except PETSc.Error:
            continue
    raise ContinuationError("no pivoting sparse LU (UMFPACK, SuperLU or MUMPS) in this PETSc")


class ContinuationError(SolverError):
    """The curve could not be followed (step too small, singular system)."""


class BorderedPattern:
    """CSR structure of [[A, C], [R]]: the sparse pattern A (size x size) of
    fem's Jacobian bordered by k dense columns C and k dense rows R."""

    def __init__(self, indptr, indices, size: int, k: int):
        nnz_rows = np.diff(indptr)
        counts = np.concatenate((nnz_rows + k, np.full(k, size + k)))
        new_ptr = np.concatenate(([0], np.cumsum(counts))).astype(np.int32)
        row_of = np.repeat(np.arange(size), nnz_rows)
        self.base_pos = new_ptr[row_of] + (np.arange(len(indices)) - indptr[row_of])
        self.col_pos = (new_ptr[:size] + nnz_rows)[:, None] + np.arange(k)
        self.row_pos = new_ptr[size:size + k][:, None] + np.arange(size + k)
        new_idx = np.empty(new_ptr[-1], np.int32)
        new_idx[self.base_pos] = indices
        new_idx[self.col_pos] = size + np.arange(k)
        new_idx[self.row_pos] = np.arange(size + k)
        self.csr = (new_ptr, new_idx)
        self.n = size + k
        self._transpose = None

    def values(self, base_values, columns, rows) -> np.ndarray:
        out = np.empty(self.csr[0][-1])
        out[self.base_pos] = base_values
        out[self.col_pos] = columns
        out[self.row_pos] = rows
        return out

    @staticmethod
    def determinant_sign(lu) -> float:
        """Sign of det B from the SuperLU factors of B^T (:meth:`lu_of_transpose`):
        P_r B^T P_c = L U with L unit lower triangular, so
        sign det B = sign(P_r) sign(P_c) prod sign(U_kk) (no dense LU needed)."""
        sign = float(np.prod(np.sign(lu.U.diagonal())))
        for perm in (lu.perm_r, lu.perm_c):         # perm_c: the identity in natural order
            if np.any(perm != np.arange(len(perm))):
                sign *= permutation_sign(perm)
        return sign

    def lu_of_transpose(self, values):
        """SuperLU (scipy, partial pivoting) of B^T, B the CSR matrix with these
        values (its CSR arrays are the CSC arrays of B^T): B x = b is
        ``lu.solve(b, trans="T")``, B^T y = c is ``lu.solve(c)``."""
        from scipy.sparse.linalg import splu
        if self._transpose is None:            # built (and checked) once, values reset
            self._transpose = sp.csc_matrix((values, self.csr[1], self.csr[0]),
                                            shape=(self.n, self.n))
        self._transpose.data[:] = values
        # natural order: the dense border is last, so its fill stays in the border
        return splu(self._transpose, permc_spec="NATURAL")


def permutation_sign(perm: np.ndarray) -> float:
    """Sign (+1 or -1) of a permutation, (-1)^(n - number of cycles): each
    element's cycle is labelled by its smallest member by pointer doubling
    (log2 n rounds of indexing, no Python loop over the elements)."""
    perm = np.asarray(perm)
    label, step = np.minimum(np.arange(len(perm)), perm), perm
    for _ in range(max(int(np.ceil(np.log2(max(len(perm), 2)))), 1)):
        label = np.minimum(label, label[step])
        step = step[step]
    cycles = np.count_nonzero(label == np.arange(len(perm)))
    return -1.0 if (len(perm) - cycles) % 2 else 1.0


class BorderedAIJ:
    """A PETSc AIJ matrix [[A, C], [R]]: the sparse pattern A (size x size) of
    fem's Jacobian bordered by k dense columns C and k dense rows R
    (k x (size + k)); the pattern is fixed, values are reset in one call."""

    def __init__(self, indptr, indices, size: int, k: int):
        self.pattern = BorderedPattern(indptr, indices, size, k)
        self.csr, self.size, self.k = self.pattern.csr, size, k
        self.values = np.zeros(self.csr[0][-1])
        self.mat = PETSc.Mat().createAIJ(size=(size + k, size + k), csr=(*self.csr,
                                         self.values), comm=PETSc.COMM_SELF)

    def fill(self, base_values, columns, rows, mat: PETSc.Mat | None = None) -> None:
        self.values[:] = self.pattern.values(base_values, columns, rows)
        target = self.mat if mat is None else mat
        target.setValuesCSR(*self.csr, self.values)
        target.assemble()

    def destroy(self) -> None:
        self.mat.destroy()


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
        cols = N + 2 * i + np.arange(2)
        out[:N] = -self.jacobian(w)[:N][:, cols].toarray()
        return out

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


# --- constraints c(w) = 0 cutting curves out of M ----------------------------------
class Constraint:
    """A scalar c(w); the admissible side is ``side * c >= 0``."""

    name = "constraint"
    side = 1.0

    def value(self, w: np.ndarray) -> float:
        raise NotImplementedError

    def gradient(self, w: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def margin(self, w: np.ndarray) -> float:
        """side * c: >= 0 on the admissible side."""
        return self.side * self.value(w)

    def route_gradient(self, w: np.ndarray, i: int) -> np.ndarray:
        """dc/dr_i at fixed w, (2,): zero unless c involves the routing points."""
        return np.zeros(2)


class TensionBound(Constraint):
    """Face of the tension domain: p_i = bound (0 below, p_crit above, Eq. (22))."""

    def __init__(self, manifold: Manifold, i: int, bound: float, upper: bool = False):
        self.mf, self.i, self.bound = manifold, i, float(bound)
        self.side = -1.0 if upper else 1.0
        self.name = f"P{i + 1}=P_crit" if upper else f"P{i + 1}=0"

    def value(self, w):
        return float(w[self.mf.size + self.i] - self.bound)

    def gradient(self, w):
        g = np.zeros(self.mf.m)
        g[self.mf.size + self.i] = 1.0
        return g


class TensionRay(Constraint):
    """The ray p = s (cos a, sin a), s >= 0, of the tension plane: c = n . p with
    n = (-sin a, cos a) (proportional loading in a fixed ratio; a scan line)."""

    def __init__(self, manifold: Manifold, angle: float):
        self.mf = manifold
        self.normal = np.array([-np.sin(angle), np.cos(angle)])
        self.direction = np.array([np.cos(angle), np.sin(angle)])
        self.name = f"ray {np.degrees(angle):.0f} deg"

    def value(self, w):
        return float(self.normal @ w[self.mf.size:])

    def gradient(self, w):
        g = np.zeros(self.mf.m)
        g[self.mf.size:] = self.normal
        return g


class CableCollapse(Constraint):
    """L_i = eps: the attachment point of tendon i within eps (units of l) of its
    routing point; beyond it the cable direction of Eq. (3) is undefined.  For a
    cable through guides (docs/model.md §11): its shortest segment, between
    point a and its predecessor (the routing point for the first)."""

    def __init__(self, manifold: Manifold, i: int, eps: float):
        self.mf, self.i, self.eps = manifold, i, float(eps)
        self.name = f"L{i + 1}=0"

    def _offset(self) -> int:
        return self.mf.disc.n_elements + 2 * self.i

    def _segment(self, w):
        """(length, unit vector, index) of the cable's shortest chord z_a."""
        disc = self.mf.disc
        lengths, e = disc.segments(disc.split(self.mf.split(w)[0])[1])
        first, last = disc.path_starts[self.i], disc.path_starts[self.i + 1]
        a = first + int(np.argmin(lengths[first:last]))
        return lengths[a], e[a], a

    def value(self, w):
        if self.mf.disc.has_paths:
            return float(self._segment(w)[0] - self.eps)
        y = w[self._offset():self._offset() + 2]
        return float(np.linalg.norm(self.mf.disc.routes[self.i] - y) - self.eps)

    def gradient(self, w):
        g = np.zeros(self.mf.m)
        if self.mf.disc.has_paths:                     # d|z_a|/dz_a = e_a
            _, e, a = self._segment(w)
            N = self.mf.disc.n_elements
            g[N + 2 * a:N + 2 * a + 2] = e
            return g
        y = w[self._offset():self._offset() + 2]
        chord = self.mf.disc.routes[self.i] - y
        g[self._offset():self._offset() + 2] = -chord / np.linalg.norm(chord)
        return g

    def route_gradient(self, w, i):
        if i != self.i:
            return np.zeros(2)
        if self.mf.disc.has_paths:          # |z_a| does not involve r_i (F does)
            return np.zeros(2)
        y = w[self._offset():self._offset() + 2]
        chord = self.mf.disc.routes[self.i] - y
        return chord / np.linalg.norm(chord)                      # d|r_i - y_i|/dr_i


class StateLevel(Constraint):
    """A level curve limit - f(theta) >= 0 of a function of the angles only:
    l*kappa_max (Eq. (19)) or the strain energy in units of SE_0 (Eq. (21))."""

    def __init__(self, manifold: Manifold, kind: str, limit: float):
        if kind not in ("kappa", "energy"):
            raise ValueError(kind)
        self.mf, self.kind, self.limit = manifold, kind, float(limit)
        self.name = "l*kappa_max=limit" if kind == "kappa" else "SE=SE_max"

    def _theta(self, w):
        return self.mf.disc.split(self.mf.split(w)[0])[0]

    def value(self, w):
        theta, disc = self._theta(w), self.mf.disc
        if self.kind == "kappa":
            return float(self.limit - np.max(np.abs(disc.curvature(theta))))
        return float(self.limit - 2.0 * disc.strain_energy(theta))

    def gradient(self, w):
        theta, disc = self._theta(w), self.mf.disc
        jump = np.diff(theta)
        dtheta = np.zeros(len(theta))
        if self.kind == "kappa":                       # the element of largest |theta'|
            e = int(np.argmax(np.abs(jump)))
            sign = np.sign(jump[e]) / disc.h
            dtheta[e + 1] -= sign
            dtheta[e] += sign
        else:                                          # d(2 sum jump^2/(2h))/dtheta
            dtheta[1:] -= 2.0 * jump / disc.h
            dtheta[:-1] += 2.0 * jump / disc.h
        g = np.zeros(self.mf.m)
        g[: disc.n_elements] = dtheta[1:]
        return g


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
        """d sigma/dr_i = -psi^T (d^2 F/du dr_i) v: the central difference in the
        direction v of psi^T dF/dr_i (as for d sigma/dw)."""
        system, mf = self.sys, self.sys.mf
        v, _ = system._solve(w, False)
        psi, _ = system._solve(w, True)
        eps = 1e-6 / max(np.linalg.norm(v), 1e-300)
        u, p = mf.split(w)
        shifted = [np.concatenate((u + sign * eps * v, p)) for sign in (1.0, -1.0)]
        a, b = (psi @ mf.route_derivative(ws, i) for ws in shifted)
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


@dataclass
class CurvePoint:
    """An accepted point on a curve: state, tangent and test functions."""

    w: np.ndarray
    t: np.ndarray
    tip: np.ndarray
    tip_velocity: np.ndarray          # d x_t / ds along t
    unstable_modes: int
    det_sign: float                   # sign of det [dG/dw; t^T] (branch points)
    iterations: int
    tip_det: float = np.nan           # intrinsic tip-map test (CurveTracer.tangent)
    tip_inward: np.ndarray = field(default_factory=lambda: np.full(2, np.nan))
    #                                   tip motion into the admissible side


@dataclass
class Curve:
    """Points of one traced curve and why it ended."""

    constraint: str
    points: list = field(default_factory=list)
    end: str = ""
    end_constraint: str | None = None
    active: object = field(default=None, repr=False)        # the Constraint followed
    hit: object = field(default=None, repr=False)           # the one met at the end corner


class CurveTracer:
    """Pseudo-arclength continuation on M with one active constraint and SNES
    as the corrector.  ``solves`` counts the corrector solves (each one
    nonlinear solve of the extended system), ``rejected`` the steps among
    them that were not accepted.  The contract of :mod:`.options`: ``comm``
    (one process), ``options_prefix`` (default ``cont_``; the tangent solves
    ``<prefix>tangent_``), ``petsc_options``."""

    def __init__(self, disc: Discretisation, *, jump_tol: float = 0.5,
                 max_tip_step: float = 0.2, ds_max: float = 4.0, comm=None,
                 options_prefix: str = "cont_", petsc_options=None):
        # full Newton steps by default: the predictor is close, and a corrector
        # that would need damping is a step to halve (one residual per iteration)
        self.options = SolverOptions(options_prefix, petsc_options,
                                     {"snes_linesearch_type": "basic"})
        self.comm = comm = check_comm(comm)
        self.mf = Manifold(disc)
        mf = self.mf
        self.jump_tol, self.max_tip_step, self.ds_max = jump_tol, max_tip_step, ds_max
        self.step_max_it = 6
        self.A = BorderedAIJ(*mf.csr, mf.size, mf.n)
        self.x = PETSc.Vec().createSeq(mf.m, comm=comm)
        self.f = self.x.duplicate()
        snes = PETSc.SNES().create(comm)
        self.options.label(snes, self.A.mat, self.x, self.f)
        snes.setType(PETSc.SNES.Type.NEWTONLS)
        snes.setFunction(self._form_function, self.f)
        snes.setJacobian(self._form_jacobian, self.A.mat, self.A.mat)
        atol = max(1e-10, 1e-14 * disc.n_elements ** 1.5)
        snes.setTolerances(rtol=1e-10, atol=atol, stol=1e-14, max_it=12)
        use_pivoting_lu(snes.getKSP())
        self.options.apply(snes)
        self.rtol, self.atol, self.stol, _ = snes.getTolerances()
        self.contraction = 0.5
        self.lag_below = 1e-7          # residual norm below which the Jacobian is kept
        self._fnorms = []
        snes.setConvergenceTest(self._converged)
        self.snes = snes
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setOptionsPrefix(self.options.name("tangent_"))
        use_pivoting_lu(self.ksp)
        self.options.apply(self.ksp)
        self.inertia = InertiaCounter(disc, comm=comm,
                                      options_prefix=self.options.name("inertia_"))
        self.solves = 0
        self.rejected = 0            # steps whose corrector failed or was rejected (halved)
        self._rows = None            # the two scalar equations: callables (value, gradient)

    # --- the extended system G(w) = [F; r_1; r_2] -----------------------------
    def _form_function(self, snes, X, Fv) -> None:
        w = X.getArray(readonly=True)
        Fv.setArray(np.concatenate((self.mf.residual(w), [value(w) for value, _ in self._rows])))

    def _fill(self, w, rows) -> None:
        self.A.fill(self.mf.jacobian_values(w), self.mf.load_columns(w), rows)

    def _form_jacobian(self, snes, X, J, P) -> None:
        """The extended Jacobian at the iterate, except once Newton is within
        ``lag_below`` of the root: then the previous iterate's (already
        factored) matrix is kept (PETSc does not refactor an unchanged
        operator), a chord step from an O(|dx|)-accurate Jacobian; the stopping
        tests on the residual are unchanged."""
        if snes.getIterationNumber() > 0 and self._fnorms and self._fnorms[-1] < self.lag_below:
            return
        w = X.getArray(readonly=True)
        self._fill(w, np.array([gradient(w) for _, gradient in self._rows]))

    def _solve(self, w0: np.ndarray, rows, max_it: int = 12) -> tuple[np.ndarray, bool, int]:
        self.options.refresh(self.snes, self.ksp)
        self._rows = rows
        self.x.setArray(w0)
        self.snes.setTolerances(max_it=max_it)
        self.snes.solve(None, self.x)
        self.solves += 1
        reason = self.snes.getConvergedReason()
        ok = reason > 0 and np.all(np.isfinite(self.x.getArray(readonly=True)))
        return self.x.getArray().copy(), bool(ok), self.snes.getIterationNumber()

    def reason(self) -> str:
        return converged_reason(self.snes)

    def _converged(self, snes, it, norms):
        """PETSc's tests (atol, rtol, stol, max_it) plus one for Newton from a
        close predictor: from the second iteration on, a residual that does not
        shrink by ``contraction`` per iteration is not converging quadratically
        (the step is too long or the curve jumped): stop, the step is halved."""
        xnorm, snorm, fnorm = norms
        R = PETSc.SNES.ConvergedReason
        self._fnorms = [fnorm] if it == 0 else self._fnorms + [fnorm]
        if not np.isfinite(fnorm):
            return R.DIVERGED_FNORM_NAN
        if fnorm < self.atol:
            return R.CONVERGED_FNORM_ABS
        if it > 0 and fnorm < self.rtol * self._fnorms[0]:
            return R.CONVERGED_FNORM_RELATIVE
        if it > 0 and snorm < self.stol * xnorm:
            return R.CONVERGED_SNORM_RELATIVE
        if it >= snes.getTolerances()[3]:
            return R.DIVERGED_MAX_IT
        if it >= 2 and fnorm > self.contraction * self._fnorms[-2]:
            return R.DIVERGED_DTOL
        return R.ITERATING

    @staticmethod
    def _row(constraint: Constraint):
        return constraint.value, constraint.gradient

    def _arclength_row(self, t: np.ndarray, w_pred: np.ndarray):
        dt = self.mf.metric * t
        return (lambda w: float(dt @ (w - w_pred))), (lambda w: dt)

    # --- tangents and test functions --------------------------------------------
    def tangent(self, w: np.ndarray, constraint: Constraint, orient: np.ndarray) -> tuple:
        """Unit tangent (metric D) of the curve {F = 0, c = 0} at w, oriented so
        that t . D orient > 0; the sign of det B of the bordered matrix
        B = [dF/dw; dc/dw; orient^T D]; and the intrinsic tip-map test

            tip_det = sign(det B) det [T tau, T t],   B tau = e_(m-1),

        (tau: the direction in M leaving the curve with dc = 1), which does not
        depend on the two bordering rows (changing them scales det [T tau, T t]
        and det B by reciprocal factors).  In the stable region, with the rows
        picking p, it is det S det J: its sign changes exactly across a fold of
        the tip map (det S = 0), and it stays finite across the fold of M.
        Also sets ``last_inward`` = side * T tau, the tip's motion as the
        state leaves the curve into the constraint's admissible side.
        One sparse LU (scipy SuperLU, partial pivoting) gives all three."""
        mf = self.mf
        values = self.A.pattern.values(mf.jacobian_values(w), mf.load_columns(w),
                                       np.array([constraint.gradient(w), mf.metric * orient]))
        lu = self.A.pattern.lu_of_transpose(values)                    # of B^T
        rhs = np.zeros((mf.m, 2))
        rhs[-1, 0] = rhs[-2, 1] = 1.0
        sol = lu.solve(rhs, trans="T")
        sign = self.A.pattern.determinant_sign(lu)
        scale = mf.norm(sol[:, 0])
        t, tau = sol[:, 0] / scale, sol[:, 1]
        T = mf.tip_gradient(w)
        n = mf.size
        tip_det = sign * float(np.linalg.det(np.column_stack((T @ tau[:n], T @ t[:n]))))
        self.last_inward = constraint.side * (T @ tau[:n])
        return t, sign, tip_det

    def point(self, w, t, det_sign, iterations, tip_det: float = np.nan,
              tip_inward=None) -> CurvePoint:
        u, p = self.mf.split(w)
        return CurvePoint(w=w.copy(), t=t.copy(), tip=self.mf.tip(w),
                          tip_velocity=self.mf.tip_velocity(w, t),
                          # on a face p_i = 0 a round-off -1e-17 must not reach sqrt(p)
                          unstable_modes=self.inertia.negative_eigenvalues(u, np.maximum(p, 0)),
                          det_sign=det_sign, iterations=iterations, tip_det=tip_det,
                          tip_inward=(np.full(2, np.nan) if tip_inward is None
                                      else np.array(tip_inward, float)))

    def correct(self, w_guess: np.ndarray, constraints) -> tuple[np.ndarray, bool]:
        """Solve F = 0 with two scalar constraints (a corner of two curves)."""
        w, ok, _ = self._solve(w_guess, [self._row(c) for c in constraints])
        return w, ok

    def route_velocity(self, w: np.ndarray, rows, i: int) -> np.ndarray:
        """dw/dr_i, (m, 2), of a point of M held by two scalar equations ``rows``
        (constraints, or a constraint and a fixed linear row given as a vector
        g with g . dw = 0): differentiate [F; c_a; c_b](w, r) = 0,

            [dF/dw; dc_a/dw; dc_b/dw] dw/dr_i = -[dF/dr_i; dc_a/dr_i; dc_b/dr_i].

        At a corner both rows are constraints; inside a curve the second row
        fixes how the point slides along the curve (the normal component of
        the tip's motion does not depend on it)."""
        grads, rhs = [], [self.mf.route_derivative(w, i)]
        for row in rows:
            if isinstance(row, np.ndarray):
                grads.append(row)
                rhs.append(np.zeros((1, 2)))
            else:
                grads.append(row.gradient(w))
                rhs.append(row.route_gradient(w, i)[None, :])
        self._fill(w, np.array(grads))
        self.ksp.setOperators(self.A.mat)
        b = -np.vstack(rhs)
        out = np.empty((self.mf.m, 2))
        rv, sol = self.x.duplicate(), self.x.duplicate()
        for k in range(2):
            rv.setArray(b[:, k])
            self.ksp.solve(rv, sol)
            out[:, k] = sol.getArray(readonly=True)
        rv.destroy(); sol.destroy()
        return out

    def step_limit(self, pt: CurvePoint) -> float:
        """The step length whose predicted tip step is 0.8 max_tip_step (a
        longer one would be rejected after its corrector)."""
        speed = float(np.linalg.norm(pt.tip_velocity))
        return 0.8 * self.max_tip_step / speed if speed > 0 else self.ds_max

    def step(self, pt: CurvePoint, constraint: Constraint, ds: float):
        """One predictor-corrector step of length ds: (point | None, iterations).
        The corrector gets ``step_max_it`` Newton iterations: from the tangent
        predictor a step that needs more is too long (it is halved)."""
        interrupt.check()                         # a run's stop, inside long work
        w_pred = pt.w + ds * pt.t
        w, ok, its = self._solve(w_pred, [self._row(constraint), self._arclength_row(pt.t, w_pred)],
                                 max_it=self.step_max_it)
        n_angles = self.mf.disc.n_elements
        if (not ok or np.max(np.abs(w[:n_angles] - w_pred[:n_angles])) > self.jump_tol
                or np.linalg.norm(self.mf.tip(w) - pt.tip) > self.max_tip_step):
            self.rejected += 1
            return None, its
        t, det_sign, tip_det = self.tangent(w, constraint, pt.t)
        return self.point(w, t, det_sign, its, tip_det, self.last_inward), its

    def destroy(self) -> None:
        self.inertia.destroy()
        for obj in (self.snes, self.ksp, self.A, self.x, self.f):
            obj.destroy()

    def __enter__(self) -> "CurveTracer":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()
