"""The augmented length-control system on one SNES VI (docs/model.md §4.7;
split from :mod:`.lengths`).

Length control as a complementarity problem
-------------------------------------------
The experiments prescribe the cable lengths L_i, not the tensions.  The
unknowns are z = (theta_1..theta_N, y_1..y_n, p_1..p_n): the bordered state
of :mod:`elastica_petsc.core.fem` plus the tensions.  The equations are the
bordered equilibrium residual F(u, p) = 0 (Eq. (9) and y_i = X_i(theta)) and,
per tendon, the complementarity conditions of a cable that cannot push or
stretch (Eq. (23)):

    p_i >= 0,   g_i = L_i - |r_i - y_i| >= 0,   p_i g_i = 0.

This is a mixed complementarity problem solved by PETSc's semismooth
reduced-space Newton for variational inequalities (SNES ``vinewtonrsls``),
options prefix ``len_``.  PETSc's convention: at a variable's lower bound
its function must be >= 0, between the bounds it must vanish.  So the row of
p_i is g_i = L_i - |r_i - y_i| (prescribed minus actual chord): a slack
cable has p_i = 0 and g_i > 0; a taut one p_i >= 0 and g_i = 0.  Angles and
attachment unknowns are unbounded.  The consistent Jacobian is the bordered
Jacobian, the columns dF/dp_i (:meth:`Discretisation.load_derivative`), and
the rows dg_i/dy_i = d_i^T; its CSR pattern extends ``disc.pattern`` once
and its values are written in place (``createAIJWithArrays``).  Natural-order LU fills only the
border: O(N) per Newton step.

Deflation
---------
:mod:`elastica_petsc.core.deflation`: the equation rows are multiplied by
M(z) = prod_k (1/||theta - theta_k||^2 + 1), with mu = M(z) carried as one
extra unknown (so every system here has the unknowns (u, p, mu) and the
extra row mu - M(z); without deflated roots M = 1 and mu stays 1).  M > 0,
so the complementarity signs are unchanged.  Load control uses the same
system with the p rows p_i - p_i* = 0.  Deflated solves use their own SNES
(prefixes ``len_defl_`` and ``defl_``) with the l2 line search, which
leaves the start's basin far more often than backtracking.  The searches
built on this live in :mod:`elastica_petsc.studies.search`.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from ..core.deflation import Deflation
from ..core.fem import Discretisation
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm
from .reasons import SNES_REASONS, reason_name

# A tension below this (non-dimensional, p = P l^2/B) counts as zero: the
# cable is slack or just taut and constrains nothing (:mod:`.length_stability`).
TAUT_TOL = 1e-8


# --- the augmented system (u, p, mu) on one SNES VI --------------------------------------
class DivergenceStop:
    """The convergence test PETSc applies to this VI solver (absolute, relative
    and step tolerances, function-evaluation count; checked: the same
    iterations and reasons for all 555 deflated solves of the four searches
    below), plus one test for deflated solves: from iteration 3 on,
    a residual norm above ``factor`` times the smallest one since iteration 1
    is DIVERGED_DTOL.  The first deflated step typically raises the norm
    10-35-fold (the deflation factor moves off its start); afterwards a solve
    that converges keeps within 14 times its best (measured: every one of 31
    converged deflated solves of four searches, Fig. 8's lengths and
    tensions, L = (96.2, 454.3) and (130, 480) mm), while the 524 that did not
    converge wandered to 25 iterations.  With ``factor`` = 50 those four
    searches find the same states with 26 % fewer deflated Newton iterations
    (BENCHMARKS.md)."""

    def __init__(self, factor: float):
        self.factor = float(factor)
        self.ttol = 0.0
        self.best = math.inf

    def __call__(self, snes, it, norms):
        xnorm, snorm, fnorm = norms
        Reason = PETSc.SNES.ConvergedReason
        rtol, atol, stol, _ = snes.getTolerances()
        if it == 0:
            self.ttol, self.best = fnorm * rtol, math.inf
        if fnorm != fnorm:
            return Reason.DIVERGED_FNORM_NAN
        if fnorm < atol:
            return Reason.CONVERGED_FNORM_ABS
        max_funcs = snes.getMaxFunctionEvaluations()
        if 0 <= max_funcs <= snes.getFunctionEvaluations():
            return Reason.DIVERGED_FUNCTION_COUNT
        if it:
            if fnorm <= self.ttol:
                return Reason.CONVERGED_FNORM_RELATIVE
            if snorm < stol * xnorm:
                return Reason.CONVERGED_SNORM_RELATIVE
            if it >= 3 and fnorm > self.factor * self.best:
                return Reason.DIVERGED_DTOL
            self.best = min(self.best, fnorm)
        return Reason.CONVERGED_ITERATING


class AugmentedSystem:
    """SNES ``vinewtonrsls`` on z = (theta, y, p, mu) (module docstring).

    ``mode="length"``: p rows g_i = L_i - |r_i - y_i| with p_i >= 0.
    ``mode="load"``: p rows p_i - p_i* (p fixed), no bounds on p.
    Rows of F and g are multiplied by mu, and mu - M(theta) = 0 (deflation).
    The contract of :mod:`.options`: ``options_prefix`` (of the SNES, its
    Jacobian and vectors), ``petsc_options``, ``comm`` (one process).
    ``divergence_factor``: stop a solve as DIVERGED_DTOL once its residual
    norm exceeds this factor times the smallest it reached
    (:class:`DivergenceStop`); None: PETSc's own convergence test.
    """

    def __init__(self, disc: Discretisation, mode: str, options_prefix: str,
                 deflation: Deflation | None = None, max_it: int = 50,
                 petsc_options=None, comm=None, divergence_factor: float | None = None):
        if mode not in ("length", "load"):
            raise ValueError(f"mode must be 'length' or 'load', got {mode!r}")
        self.options = SolverOptions(options_prefix, petsc_options)
        self.comm = comm = check_comm(comm)
        self.disc, self.mode = disc, mode
        N, n = disc.n_elements, disc.n_tendons
        self.nu, self.n = disc.size, n
        self.ip, self.imu = disc.size, disc.size + n
        self.size = disc.size + n + 1
        self.deflation = deflation if deflation is not None else Deflation(disc.h)
        self.target = np.zeros(n)
        self._last_equations = None          # (key, (F, g)) of the last evaluation
        # the pattern's fixed parts, asked once (not per Jacobian)
        self._supports = list(enumerate(np.asarray(disc.length_supports)))
        self._columns = [disc.length_columns(i) for i in range(n)]
        self._build_pattern()
        z0 = self.augment(disc.straight(), np.zeros(n))
        # J keeps this array (no copy): the Jacobian callback writes its entries in
        # place and assembles (as EquilibriumSolver), with no MatSetValuesCSR
        self._values = self.jacobian_values(z0)
        self.J = PETSc.Mat().createAIJWithArrays((self.size, self.size),
                                                 (self.indptr, self.indices, self._values),
                                                 comm=comm)
        self.x = PETSc.Vec().createSeq(self.size, comm=comm)
        self.f = self.x.duplicate()
        self.xl, self.xu = self.x.duplicate(), self.x.duplicate()
        lower = np.full(self.size, PETSc.NINFINITY)
        if mode == "length":
            lower[self.ip:self.imu] = 0.0                   # a cable cannot push
        lower[self.imu] = 0.5                # mu = M >= shift^K at a solution (see newton)
        self.xl.setArray(lower)
        self.xu.set(PETSc.INFINITY)
        snes = PETSc.SNES().create(comm)
        self.options.label(snes, self.J, self.x, self.f, self.xl, self.xu)
        snes.setType("vinewtonrsls")
        snes.setFunction(self._form_function, self.f)
        snes.setJacobian(self._form_jacobian, self.J, self.J)
        snes.setVariableBounds(self.xl, self.xu)
        # residual round-off grows like N^(3/2) (see EquilibriumSolver)
        self.atol = max(1e-10, 1e-14 * N ** 1.5)
        snes.setTolerances(rtol=1e-10, atol=self.atol, stol=1e-14, max_it=max_it)
        use_bordered_lu(snes.getKSP())
        self.options.apply(snes)
        if divergence_factor is not None:
            snes.setConvergenceTest(DivergenceStop(divergence_factor))
        self.snes = snes

    # --- layout ----------------------------------------------------------------------
    def augment(self, u, p, mu: float | None = None) -> np.ndarray:
        z = np.empty(self.size)
        z[: self.nu], z[self.ip:self.imu] = u, p
        z[self.imu] = self.deflation.factor(np.asarray(u)[: self.disc.n_elements]) \
            if mu is None else mu
        return z

    def parts(self, z):
        return z[: self.nu], z[self.ip:self.imu], z[self.imu]

    def _build_pattern(self) -> None:
        disc = self.disc
        N, n, nu, ip, imu = disc.n_elements, self.n, self.nu, self.ip, self.imu
        indptr, indices, _ = disc.pattern
        rows = [np.repeat(np.arange(nu), np.diff(indptr)), ]
        cols = [np.asarray(indices)]
        for i, m in enumerate(disc.length_supports):        # dF_theta/dp_i (rows < m_i)
            rows.append(np.arange(m)); cols.append(np.full(m, ip + i))
        for i in range(n):                                  # dg_i/dy (its cable's points)
            c = disc.length_columns(i)
            rows.append(np.full(len(c), ip + i)); cols.append(N + c)
        rows.append(ip + np.arange(n)); cols.append(ip + np.arange(n))   # p diagonal
        rows.append(np.arange(imu)); cols.append(np.full(imu, imu))      # d/dmu = F, g
        rows.append(np.full(N, imu)); cols.append(np.arange(N))          # -grad M
        rows.append(np.array([imu])); cols.append(np.array([imu]))
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        order = np.lexsort((cols, rows))
        self._order = order
        self.indptr = np.searchsorted(rows[order], np.arange(self.size + 1)).astype(np.int32)
        self.indices = cols[order].astype(np.int32)

    # --- residual and Jacobian ---------------------------------------------------------
    def equations(self, z) -> tuple[np.ndarray, np.ndarray]:
        """Unscaled residuals: F(u, p) (bordered) and the p rows.  The last
        evaluation is kept: SNES asks for the Jacobian at the point whose
        residual it has just computed, which then costs no second residual."""
        key = (np.asarray(z, float).tobytes(), self.target.tobytes())
        if self._last_equations is not None and self._last_equations[0] == key:
            return self._last_equations[1]
        u, p, _ = self.parts(z)
        F = self.disc.residual(u, p)
        if self.mode == "length":
            g = self.target - self.disc.cables(self.disc.split(u)[1])[0]
        else:
            g = p - self.target
        self._last_equations = (key, (F, g))
        return F, g

    def residual(self, z) -> np.ndarray:
        F, g = self.equations(z)
        mu = z[self.imu]
        M = self.deflation.factor(z[: self.disc.n_elements])
        out = np.empty(self.size)
        np.multiply(mu, F, out=out[: self.ip])
        if self.mode == "length":
            np.multiply(mu, g, out=out[self.ip:self.imu])
        else:
            out[self.ip:self.imu] = g
        out[self.imu] = mu - M
        return out

    def jacobian_values(self, z) -> np.ndarray:
        disc = self.disc
        u, p, mu = self.parts(z)
        F, g = self.equations(z)
        _, gradM = self.deflation.factor_and_gradient(u[: disc.n_elements])
        dFdp = disc.load_derivative(u)
        blocks = [mu * disc.jacobian_values(u, p)]
        blocks += [mu * dFdp[i, :m] for i, m in self._supports]
        columns = self._columns
        if self.mode == "length":
            dLdy = disc.length_gradients(disc.split(u)[1])           # dg/dy = -dL/dy
            blocks += [-mu * dLdy[i, c] for i, c in enumerate(columns)]
            blocks += [np.zeros(self.n), F, g]
        else:
            blocks += [np.zeros(sum(len(c) for c in columns)), np.ones(self.n), F,
                       np.zeros(self.n)]
        blocks += [-gradM, [1.0]]
        return np.concatenate(blocks)[self._order]

    def _form_function(self, snes, X, Fv) -> None:
        Fv.setArray(self.residual(X.getArray(readonly=True)))

    def _form_jacobian(self, snes, X, J, P) -> None:
        self._values[:] = self.jacobian_values(X.getArray(readonly=True))
        P.assemble()                    # P is self.J: its entries are self._values

    def scipy_jacobian(self, z) -> sp.csr_matrix:
        return sp.csr_matrix((self.jacobian_values(z), self.indices, self.indptr),
                             shape=(self.size, self.size))

    # --- one solve ---------------------------------------------------------------------
    def newton(self, z0, target, max_it: int | None = None) -> tuple[np.ndarray, int, str, bool]:
        """One VI Newton solve from z0: (z, iterations, reason, converged);
        ``max_it`` caps the Newton iterations of this solve only."""
        self.options.refresh(self.snes)
        self.target = np.asarray(target, float)
        z0 = np.array(z0, float)
        if self.mode == "length":
            z0[self.ip:self.imu] = np.maximum(z0[self.ip:self.imu], 0.0)
        M = self.deflation.factor(z0[: self.disc.n_elements])
        z0[self.imu] = M
        if not np.isfinite(M) or M > 1e12:       # the start sits on a deflated root
            return z0, 0, "START_ON_DEFLATED_ROOT", False
        # mu > 0 keeps the complementarity signs; M >= shift^K, so this bound never binds
        floor = 0.5 * min(1.0, self.deflation.shift ** len(self.deflation))
        self.xl.setValue(self.imu, floor)
        self.xl.assemble()
        self.x.setArray(z0)
        default_max_it = self.snes.getTolerances()[3]
        if max_it is not None:
            self.snes.setTolerances(max_it=max_it)
        try:
            self.snes.solve(None, self.x)
        except PETSc.Error:                      # e.g. a zero pivot in the LU
            return z0, self.snes.getIterationNumber(), "PETSC_ERROR", False
        finally:
            self.snes.setTolerances(max_it=default_max_it)
        reason = self.snes.getConvergedReason()
        z = self.x.getArray().copy()
        return z, self.snes.getIterationNumber(), reason_name(SNES_REASONS, reason), \
            reason > 0 and self.verified(z)

    def verified(self, z) -> bool:
        """Independent check of a converged state with the numpy kernels."""
        F, g = self.equations(z)
        if not (np.all(np.isfinite(F)) and np.all(np.isfinite(g))):
            return False
        tol = 1e-8 * max(1.0, (self.disc.n_elements / 180.0) ** 1.5)
        if np.max(np.abs(F)) > tol:
            return False
        if self.mode == "length":
            p = z[self.ip:self.imu]
            gtol = 1e-9
            if np.any(g < -gtol) or np.any(np.abs(g[p > TAUT_TOL]) > gtol):
                return False
        else:
            if np.max(np.abs(g)) > 1e-12 * max(1.0, np.max(np.abs(self.target))):
                return False
        lengths = self.disc.cables(self.disc.split(z[: self.nu])[1])[0]
        return bool(np.all(lengths > 1e-6))

    def destroy(self) -> None:
        for obj in (self.snes, self.J, self.x, self.f, self.xl, self.xu):
            obj.destroy()
