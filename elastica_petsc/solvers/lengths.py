"""Length-controlled equilibria and their stability (Sec. 4.1, 4.6, Figs. 7-8;
docs/model.md §4.7).

Everything is non-dimensional (docs/model.md §3): lengths in units of l, tensions
p = P l^2 / B; ``*_mm`` helpers convert with the arm length.

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
and is filled with ``setValuesCSR``.  Natural-order LU fills only the
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

from dataclasses import dataclass
import math

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from ..core.deflation import Deflation
from .equilibrium import Equilibrium
from ..core.errors import InputError
from ..core.fem import Discretisation
from .bifurcation import inverse_iteration
from .inertia import BorderedInertia, InertiaCounter
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm
from .reasons import SNES_REASONS, reason_name

# A tension below this (non-dimensional, p = P l^2/B) counts as zero: the
# cable is slack or just taut and constrains nothing (module docstring).
TAUT_TOL = 1e-8
# |q . dL| / (|(v, q)| |dL|) below this: a loss of stability under length control is a
# bifurcation, not a limit point (instability_kind; calibrated on Fig. 7 only, 0.005).
LENGTH_BIFURCATION_TOL = 0.05
# Global searches for a state to snap to (``post_critical`` of LengthSolver.follow) per path.
MAX_SNAP_SEARCHES = 3
# Two states are the same equilibrium if no nodal angle differs by more (rad).
SAME_SHAPE_TOL = 1e-4
# PETSc options (under the solver's prefix) for deflated solves, unless the
# user sets them: the secant ("l2") line search explores beyond the start's basin.
DEFLATION_OPTIONS = {"snes_linesearch_type": "l2"}


# --- results -----------------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class LengthEquilibrium(Equilibrium):
    """An equilibrium found under length control (or a load-controlled one
    re-examined under length control).

    Inherited fields keep their meaning: ``p`` the tensions found,
    ``unstable_modes`` the negative eigenvalues of K (stability under *load*
    control, ``stable``).  Added:

    lengths_requested : prescribed cable lengths L_i / l.
    length_unstable_modes : negative eigenvalues of K on null(C^T) of the
        taut cables (0: stable under length control); -1 if not computed.
    length_mm : the arm length, for the ``*_mm`` properties (None: unknown).
    jumps : cable lengths (units of l) at which a continuation path jumped
        to a distant state (snap or buckling); empty for a smooth path.
    instabilities : cable lengths at which the continued branch ended: it
        lost stability under length control or Newton could not continue it
        at any step size.
    instability_kinds : for each of ``instabilities``, "bifurcation" (the
        critical mode does not change the path's lengths: buckling, two
        branches) or "limit point" (a fold: the arm snaps), by
        :func:`instability_kind`.
    label : where the state came from (start and method), for searches.
    """

    lengths_requested: np.ndarray | None = None
    length_unstable_modes: int = -1
    length_mm: float | None = None
    jumps: tuple = ()
    instabilities: tuple = ()
    instability_kinds: tuple = ()
    label: str = ""

    @property
    def slack(self) -> np.ndarray:
        """L_i - |r_i - x_i| in units of l (>= 0; > 0 only for a slack cable)."""
        return self.lengths_requested - self.cable_lengths

    @property
    def taut(self) -> np.ndarray:
        """True for every cable that carries tension (p_i > TAUT_TOL)."""
        return np.asarray(self.p) > TAUT_TOL

    @property
    def stable_under_length_control(self) -> bool:
        return self.length_unstable_modes == 0

    def _mm(self, values):
        if self.length_mm is None:
            raise ValueError("the arm length is unknown: build the solver with from_arm()")
        return np.asarray(values) * self.length_mm

    @property
    def slack_mm(self) -> np.ndarray:
        return self._mm(self.slack)

    @property
    def cable_lengths_mm(self) -> np.ndarray:
        return self._mm(self.cable_lengths)

    @property
    def tip_mm(self) -> np.ndarray:
        return self._mm(self.tip)



def check_lengths(lengths, n_tendons: int) -> np.ndarray:
    """Positive, finite, one per tendon (units of l)."""
    L = np.asarray(lengths, dtype=float).ravel()
    if L.size != n_tendons:
        raise InputError(f"expected {n_tendons} cable lengths (one per tendon), got {L.size}")
    if not np.all(np.isfinite(L)) or np.any(L <= 0):
        raise InputError("cable lengths must be positive finite numbers")
    return L


def same_shape(a: Equilibrium, b: Equilibrium, tol: float = SAME_SHAPE_TOL) -> bool:
    return float(np.max(np.abs(a.theta - b.theta))) <= tol


# --- the augmented system (u, p, mu) on one SNES VI --------------------------------------
class AugmentedSystem:
    """SNES ``vinewtonrsls`` on z = (theta, y, p, mu) (module docstring).

    ``mode="length"``: p rows g_i = L_i - |r_i - y_i| with p_i >= 0.
    ``mode="load"``: p rows p_i - p_i* (p fixed), no bounds on p.
    Rows of F and g are multiplied by mu, and mu - M(theta) = 0 (deflation).
    The contract of :mod:`.options`: ``options_prefix`` (of the SNES, its
    Jacobian and vectors), ``petsc_options``, ``comm`` (one process).
    """

    def __init__(self, disc: Discretisation, mode: str, options_prefix: str,
                 deflation: Deflation | None = None, max_it: int = 50,
                 petsc_options=None, comm=None):
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
        self._build_pattern()
        z0 = self.augment(disc.straight(), np.zeros(n))
        self.J = PETSc.Mat().createAIJ(size=(self.size, self.size), comm=comm,
                                       csr=(self.indptr, self.indices, self.jacobian_values(z0)))
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
        self.snes = snes

    # --- layout ----------------------------------------------------------------------
    def augment(self, u, p, mu: float | None = None) -> np.ndarray:
        z = np.empty(self.size)
        z[: self.nu], z[self.ip:self.imu] = u, p
        z[self.imu] = self.deflation.factor_and_gradient(np.asarray(u)[: self.disc.n_elements])[0] \
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
        """Unscaled residuals: F(u, p) (bordered) and the p rows."""
        u, p, _ = self.parts(z)
        F = self.disc.residual(u, p)
        if self.mode == "length":
            g = self.target - self.disc.cables(self.disc.split(u)[1])[0]
        else:
            g = p - self.target
        return F, g

    def residual(self, z) -> np.ndarray:
        F, g = self.equations(z)
        mu = z[self.imu]
        M, _ = self.deflation.factor_and_gradient(z[: self.disc.n_elements])
        return np.concatenate((mu * F, mu * g if self.mode == "length" else g, [mu - M]))

    def jacobian_values(self, z) -> np.ndarray:
        disc = self.disc
        u, p, mu = self.parts(z)
        F, g = self.equations(z)
        _, gradM = self.deflation.factor_and_gradient(u[: disc.n_elements])
        dFdp = disc.load_derivative(u)
        blocks = [mu * disc.jacobian_values(u, p)]
        blocks += [mu * dFdp[i, :m] for i, m in enumerate(disc.length_supports)]
        columns = [disc.length_columns(i) for i in range(self.n)]
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
        P.setValuesCSR(self.indptr, self.indices, self.jacobian_values(X.getArray(readonly=True)))
        P.assemble()

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
        M, _ = self.deflation.factor_and_gradient(z0[: self.disc.n_elements])
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


# --- stability under length control ------------------------------------------------------
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


# --- the length-control solver ----------------------------------------------------------
class LengthSolver:
    """Length-controlled equilibria of one discretised arm (SNES VI, prefix ``len_``).

    Parameters
    ----------
    disc : the discretised arm.
    length_mm : arm length for the ``*_mm`` helpers (set by :meth:`from_arm`).
    jump_tol : largest change of any nodal angle [rad] between the predictor
        and the converged state of one continuation step before the step is
        halved (a larger change is a jump to another branch).
    max_step : largest change of any cable length (units of l) per
        continuation step.
    comm : one process (default ``PETSc.COMM_SELF``).
    options_prefix : PETSc options prefix, e.g. ``-len_snes_monitor``,
        ``-len_snes_vi_monitor``; the deflated solves use ``<prefix>defl_``.
    petsc_options : options without the prefix (``{"defl": {...}}`` for the
        deflated solves), :mod:`.options`.
    """

    def __init__(self, disc: Discretisation, *, length_mm: float | None = None,
                 jump_tol: float = 0.5, max_step: float = 0.02, comm=None,
                 options_prefix: str = "len_", petsc_options=None):
        self.disc = disc
        self.length_mm = length_mm
        self.jump_tol = jump_tol
        self.max_step = max_step
        given = SolverOptions(options_prefix, petsc_options)
        deflated = given.part("defl_")
        plain = {k: v for k, v in given.options.items() if not k.startswith("defl_")}
        self.system = AugmentedSystem(disc, "length", options_prefix, petsc_options=plain,
                                      comm=comm)
        self.prefix, self.comm = self.system.options.prefix, self.system.comm
        # deflated solves explore: the l2 (secant) line search leaves the basin
        # of the start far more often than backtracking (measured on Fig. 8)
        self.deflated_system = AugmentedSystem(disc, "length", self.prefix + "defl_",
                                               petsc_options={**DEFLATION_OPTIONS, **deflated},
                                               comm=comm)
        self.inertia = LengthInertia(disc, comm=comm, options_prefix=self.prefix + "inertia_")
        self.load_inertia = InertiaCounter(disc, comm=comm,
                                           options_prefix=self.prefix + "load_inertia_")

    @classmethod
    def from_arm(cls, arm, n_elements: int | None = None, **kw) -> "LengthSolver":
        return cls(Discretisation.from_arm(arm, n_elements), length_mm=arm.length_mm, **kw)

    # --- helpers -----------------------------------------------------------------------
    def _start(self, start) -> tuple[np.ndarray, np.ndarray]:
        if start is None:
            return self.disc.straight(), np.zeros(self.disc.n_tendons)
        if isinstance(start, Equilibrium):
            return np.asarray(start.u, float), np.asarray(start.p, float)
        u, p = start
        return np.asarray(u, float), np.asarray(p, float)

    def lengths_of(self, u) -> np.ndarray:
        """Cable chords |r_i - y_i| of a bordered state (units of l)."""
        return self.disc.cables(self.disc.split(u)[1])[0]

    def to_l(self, lengths_mm) -> np.ndarray:
        if self.length_mm is None:
            raise InputError("the arm length is unknown: build the solver with from_arm()")
        return np.asarray(lengths_mm, float) / self.length_mm

    def stability(self, u, p) -> tuple[int, int]:
        """(negative eigenvalues of K, of K on null(C_taut^T)): load and length control."""
        return (self.load_inertia.negative_eigenvalues(u, p),
                self.inertia.negative_eigenvalues(u, p))

    def _result(self, z, lengths, its, reason, ok, *, steps=1, message="", jumps=(),
                instabilities=(), kinds=(), label="") -> LengthEquilibrium:
        u, p, _ = self.system.parts(z)
        p = np.where(p <= 0.0, 0.0, p)
        modes = self.stability(u, p) if ok else (-1, -1)
        return LengthEquilibrium(
            self.disc, p.copy(), u.copy(), ok, reason, its, steps, message=message,
            unstable_modes=modes[0], lengths_requested=np.asarray(lengths, float).copy(),
            length_unstable_modes=modes[1], length_mm=self.length_mm, jumps=tuple(jumps),
            instabilities=tuple(instabilities), instability_kinds=tuple(kinds), label=label)

    # --- one VI Newton solve ------------------------------------------------------------
    def solve(self, lengths, start=None, *, deflate=None, label: str = "",
              max_it: int | None = None) -> LengthEquilibrium:
        """Equilibrium with cable lengths ``lengths`` (units of l) by one VI
        Newton solve from ``start`` (an Equilibrium, a pair (u, p), or None:
        the straight arm with p = 0).  ``deflate``: a :class:`Deflation`
        holding states Newton must not converge to again; ``max_it``: at most
        this many Newton iterations (default: the SNES's, 50)."""
        L = check_lengths(lengths, self.disc.n_tendons)
        u0, p0 = self._start(start)
        if deflate is None:
            sys = self.system
            sys.deflation = Deflation(self.disc.h)
            z, its, reason, ok = sys.newton(sys.augment(u0, p0), L, max_it)
        else:
            sys = self.deflated_system
            sys.deflation = deflate
            try:
                z, its, reason, ok = sys.newton(sys.augment(u0, p0), L, max_it)
            finally:
                sys.deflation = Deflation(self.disc.h)
        msg = "" if ok else (f"no length-controlled equilibrium reached from the start "
                             f"(PETSc SNES reason {reason})")
        return self._result(z, L, its, reason, ok, message=msg, label=label)

    def solve_mm(self, lengths_mm, start=None, **kw) -> LengthEquilibrium:
        return self.solve(self.to_l(lengths_mm), start, **kw)

    # --- continuation in the cable lengths -------------------------------------------------
    def follow(self, lengths, start=None, *, keep_stable: bool = True,
               min_fraction: float = 1e-4, label: str = "",
               post_critical=None) -> LengthEquilibrium:
        """Continuation from ``start`` (an equilibrium; its own cable chords are
        the initial lengths, or for a slack cable of a LengthEquilibrium its
        prescribed length) to ``lengths`` (units of l) along the straight
        segment in length space, warm-started with a secant predictor and an
        adaptive step (at most ``max_step`` change of any length per step).

        A step is halved when Newton fails, when its result is far from the
        predictor (``jump_tol``: another branch) or, with ``keep_stable`` and
        a stable path, when the result is unstable under length control.
        When the step cannot shrink below ``min_fraction`` of the first one,
        the path has reached a limit point or a bifurcation at the current
        lengths: they are recorded in ``instabilities``, and the path jumps to
        a stable state found by perturbing the last state along +- its
        constrained buckling mode (:meth:`branches`), or to the distant state
        Newton found if that one is stable; the lengths are recorded in
        ``jumps``.  If the mode finds none and ``post_critical`` is given,
        ``post_critical(lengths, u, p)`` (a global search at the critical
        lengths, e.g. :func:`elastica_petsc.studies.search.snap_targets`)
        returns stable states (u, p) there, nearest shape first, and the path
        jumps to the first that differs from the critical state by more than
        ``jump_tol`` (at most :data:`MAX_SNAP_SEARCHES` searches per path).  If no stable state is found the result has
        ``converged=False`` and a message that says it was not found (not that
        none exists).  Without ``keep_stable`` unstable states are followed
        like stable ones (used by searches).
        """
        L_end = check_lengths(lengths, self.disc.n_tendons)
        u, p = self._start(start)
        sys = self.system
        sys.deflation = Deflation(self.disc.h)
        L_start = self.lengths_of(u)
        if isinstance(start, LengthEquilibrium) and start.lengths_requested is not None:
            L_start = np.where(np.asarray(start.p) > TAUT_TOL, L_start,
                               np.maximum(L_start, start.lengths_requested))
        z = sys.augment(u, p, 1.0)
        span = float(np.max(np.abs(L_end - L_start)))
        full = 1.0 if span <= self.max_step else self.max_step / span
        keep = keep_stable and self.inertia.negative_eigenvalues(u, p) == 0
        lam, dlam, its_total, steps = 0.0, full, 0, 0
        z_prev = dlam_prev = None
        jumps, instabilities, kinds = [], [], []
        searches = 0
        reason = "CONVERGED_ITERATING"
        n_ang = self.disc.n_elements

        def where(t):
            return L_start + t * (L_end - L_start)

        while lam < 1.0:
            step = min(dlam, 1.0 - lam)
            pred = z if z_prev is None else z + (z - z_prev) * (step / dlam_prev)
            pred[sys.ip:sys.imu] = np.maximum(pred[sys.ip:sys.imu], 0.0)
            L_t = where(lam + step)
            z_new, its, reason, ok = sys.newton(pred, L_t)
            its_total += its
            jumped = lost = False
            if ok:
                jumped = np.max(np.abs(z_new[:n_ang] - pred[:n_ang])) > self.jump_tol
                lost = keep and self.inertia.negative_eigenvalues(
                    z_new[: sys.nu], z_new[sys.ip:sys.imu]) > 0
                if not (jumped or lost):
                    z_prev, dlam_prev = z, step
                    z, lam, steps = z_new, lam + step, steps + 1
                    if its <= 4:
                        dlam = min(2.0 * dlam, full)
                    continue
            if step > min_fraction * full:
                dlam = 0.5 * step
                continue
            # a limit point or bifurcation at L_t: the branch cannot be followed
            if lost or not ok:
                instabilities.append(L_t.copy())
                kinds.append(instability_kind(sys, z, L_end - L_start))
            candidates = self._post_critical(z_new if ok else z, where, lam, step, full)
            if not candidates and post_critical is not None and searches < MAX_SNAP_SEARCHES:
                searches += 1           # a distant state only: never back onto this branch
                candidates = [(lam, sys.augment(u, q, 1.0)) for u, q in post_critical(
                    where(lam), z[: sys.nu], z[sys.ip:sys.imu])
                    if np.max(np.abs(u[:n_ang] - z[:n_ang])) > self.jump_tol][:1]
            if ok and jumped and (not lost or not keep):
                candidates.append((lam + step, z_new))
            if candidates:
                t_best, z_best = min(candidates, key=lambda c: (c[0], self.disc.strain_energy(
                    self.disc.split(c[1][: sys.nu])[0])))
                jumps.append(where(t_best))
                z, z_prev, lam, dlam, steps = z_best, None, t_best, full, steps + 1
                continue
            kind = f" at a {kinds[-1]}" if kinds else ""
            msg = (("lost stability under length control" + kind if lost else
                    f"length continuation stopped{kind} (PETSc SNES reason {reason})")
                   + " at L/l = (" + ", ".join(f"{v:.6g}" for v in where(lam))
                   + ") on the way to (" + ", ".join(f"{v:.6g}" for v in L_end)
                   + "), and no stable state to jump to was found")
            return self._result(z, where(lam), its_total, "UNSTABLE_STATE" if lost else reason,
                                False, steps=steps, message=msg, jumps=jumps,
                                instabilities=instabilities, kinds=kinds, label=label)
        return self._result(z, L_end, its_total, reason, True, steps=steps, jumps=jumps,
                            instabilities=instabilities, kinds=kinds, label=label)

    def _post_critical(self, base, where, lam: float, step: float, full: float) -> list:
        """Stable states past a critical point of a continuation: the state
        ``base`` perturbed along +- its buckling mode (:meth:`branches`) at the
        path parameter lam + step, or a little further along the path if the
        critical point is too close; as (parameter, augmented state) pairs."""
        sys = self.system
        for t in sorted({lam + step, min(1.0, lam + 0.1 * full), min(1.0, lam + 0.5 * full)}):
            found = self.branches(base[: sys.nu], base[sys.ip:sys.imu], where(t))
            if found:
                return [(t, sys.augment(b.u, b.p, 1.0)) for b in found]
        return []

    def _tension_guess(self, u) -> np.ndarray:
        """Least-squares tensions for a shape: min_p |F(u, p)| (F is linear in p)."""
        F0 = self.disc.residual(u, np.zeros(self.disc.n_tendons))
        A = self.disc.load_derivative(u).T
        p, *_ = np.linalg.lstsq(A, -F0, rcond=None)
        return np.maximum(p, 0.0)

    def branches(self, u, p, lengths, amplitudes=(0.05, 0.2)) -> list[LengthEquilibrium]:
        """Stable states at ``lengths`` near the state (u, p): the state is
        perturbed along +- its constrained buckling mode (the eigenvector of
        K on null(C_taut^T) with the eigenvalue nearest zero,
        :func:`constrained_mode`) by each amplitude (max nodal angle, rad)
        and re-solved.  Distinct, converged, stable (length control) states
        are returned; for a symmetric bifurcation these are the two
        post-buckling states."""
        L = check_lengths(lengths, self.disc.n_tendons)
        sys = self.system
        sys.deflation = Deflation(self.disc.h)
        z_c = sys.augment(np.asarray(u, float), np.asarray(p, float), 1.0)
        try:
            _, v = constrained_mode(sys, z_c)
        except RuntimeError:                 # singular saddle matrix: fall back to no mode
            return []
        found: list[LengthEquilibrium] = []
        theta_c = self.disc.split(z_c[: sys.nu])[0]
        for sign in (1.0, -1.0):
            for a in amplitudes:
                theta = theta_c.copy()
                theta[1:] += sign * a * v
                u0 = self.disc.consistent_state(theta)
                z0 = sys.augment(u0, self._tension_guess(u0), 1.0)
                z, its, reason, ok = sys.newton(z0, L)
                if not ok:
                    continue
                state = self._result(z, L, its, reason, True,
                                     label=f"mode {'+' if sign > 0 else '-'}{a:g}")
                if state.length_unstable_modes != 0:
                    continue
                if not any(same_shape(state, f) for f in found):
                    found.append(state)
                break
        return found

    def path(self, schedule, start=None, *, keep_stable: bool = True) -> list[LengthEquilibrium]:
        """Step through a schedule of cable lengths (K, n) (units of l), each
        point reached by :meth:`follow` from the previous one (the first from
        ``start``, default the straight arm).  Stops after a point that could
        not be reached (its ``converged`` is False)."""
        schedule = np.atleast_2d(np.asarray(schedule, float))
        out, state = [], start
        for k, L in enumerate(schedule):
            state = self.follow(L, state, keep_stable=keep_stable, label=f"point {k}")
            out.append(state)
            if not state.converged:
                break
        return out

    def follow_mm(self, lengths_mm, start=None, **kw) -> LengthEquilibrium:
        return self.follow(self.to_l(lengths_mm), start, **kw)

    def destroy(self) -> None:
        self.system.destroy()
        self.deflated_system.destroy()
        self.inertia.destroy()
        self.load_inertia.destroy()

    def __enter__(self) -> "LengthSolver":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()

