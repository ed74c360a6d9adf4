"""Tip control by load optimisation (Eqs. (10)-(12), Algorithm 1) with PETSc TAO.

Find tensions p >= 0 (and p <= p_crit of Eq. (22) when the arm has a motor
limit) that put the tip of the arm at a target x_d:

    minimise E(p) = |x_d - x_t(p)|^2 / 2                         (Eqs. (10)-(11))
    dE/dp_i = (x_t - x_d) . d x_t / d p_i                         (Eq. (12))

Each evaluation of E solves the equilibrium (Eq. (9)) warm-started from the
last good equilibrium of the current solve (:meth:`EquilibriumSolver.solve`
with ``start``: continuation in tension space from that state, so the branch
the arm is on is followed) and the sensitivities d x_t / d p
(:mod:`elastica_petsc.solvers.sensitivity`: one LU, one solve per tendon).
Non-dimensional throughout (lengths / l, p = P l^2 / B);
:meth:`TipController.solve_mm` takes a target in mm.

Methods
-------
``blmvm`` (default)
    TAO BLMVM (projected limited-memory variable metric with a More-Thuente
    line search) whose initial Hessian H0 (``TaoLMVMSetH0``) is the
    Gauss-Newton matrix S S^T of this least-squares problem
    (S[i] = d x_t / d p_i), refreshed at every iterate (from the monitor,
    which TAO calls before each new direction), with the tensions held on a
    bound decoupled, and a Levenberg-Marquardt shift mu I (mu >= 1e-10 tr,
    since S is rank one on the straight arm; larger when the step would
    change a tension by more than ``max(trust_tension, max p)`` or shorten a
    cable by more than half its length).  The line search (More-Thuente,
    curvature parameter 0.1) is confined to the box of that step, so it
    cannot extrapolate past it into a cable collapse.  With that
    metric the BFGS history only hurts (measured on Fig. 2: 9 iterations with
    the default 5 pairs, 5 with none), so it is off by default
    (``lmvm_history=0``, i.e. ``-ctl_tao_blmvm_mat_lmvm_hist_size 0``): the
    method is then a projected Gauss-Newton/Levenberg-Marquardt iteration
    run by BLMVM.  ``gauss_newton=False`` gives stock BLMVM (15 iterations
    on Fig. 2).
``gd``
    The paper's Algorithm 1: p <- P[p - gamma grad E] (P: projection on the
    bounds) with an adaptive step gamma: the Barzilai-Borwein step
    s.y / y.y of the last two iterates, capped so that the linearised tip
    motion stays below 2 |x_t - x_d|, halved until E decreases (Armijo), so
    E decreases monotonically as in Fig. 2c.  Our own loop, not TAO: TAO's
    steepest descent (BNCG, ``-tao_bncg_type gd``, More-Thuente step) did
    not reach the target of Fig. 2 within 5000 iterations (tip still
    0.009 mm off), whereas this loop needs 17 iterations ("over a dozen",
    Sec. 3).  The ``ctl_`` options do not apply to it.

Stopping is exactly the paper's criterion E < eps (a custom TAO convergence
test; default eps = (1e-5 mm / l)^2 / 2: the tip within 1e-5 mm), plus: the
iteration limit; a stationary point with E >= eps (projected gradient below
``stationary_rtol`` |x_t - x_d| |S|: the target cannot be reached from here,
typically because a tension sits on a bound); and a stall (E not decreased
over ``stall_its`` iterations); and CABLE_COLLAPSE (blmvm): a cable is
shorter than ``COLLAPSE_STOP * COLLAPSE_LENGTH`` and the Gauss-Newton step
would pull it onto its routing point, i.e. the optimiser is heading for the
collapse corner of the tension domain (the tip at a routing point), a local
end: the target may still be reachable from another start.  (Before this
test and the step box, such targets, in the band y < 50 mm of the paper's
workspace, ended in line-search failures after ~20 failed equilibria each,
0.33 s per target.)  TAO's own reason is always checked and
reported; a TAO line-search failure ends the solve with that reason.

Failed equilibria: when the optimiser proposes tensions whose equilibrium
cannot be reached by continuation from the last good state (a cable pulled
onto its routing point, a snap with nowhere stable to go, SNES failure), a
second continuation from the starting equilibrium of this solve is tried
(an equilibrium whose cable is shorter than ``COLLAPSE_LENGTH``, its
attachment point on the routing point, counts as failed: the cable
direction, hence the load, is undefined there);
if that fails too, the objective returns the penalty E_fail = 10 (E_max + 1)
(E_max: the largest E evaluated in this solve) with the secant gradient
(E_fail - E_good) dp / |dp|^2 towards the last good tensions, so the line
search backtracks.  Failures are counted (``failed_evaluations``) and not
retried within a solve.  Each costs a full continuation in
:class:`EquilibriumSolver` (up to 0.3 s at 180 elements); at most
``max_failures`` are solved per tip-control solve.
"""
from __future__ import annotations

import dataclasses
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
from petsc4py import PETSc

from ..core.results import Result
from .options import set_from_options
from .equilibrium import COLLAPSE_LENGTH, Equilibrium, EquilibriumSolver, check_tensions
from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.loading import Loading
from ..core.model import Arm
from .sensitivity import Sensitivity, SensitivityError, SensitivitySolver

TAO_REASONS = {v: k for k, v in vars(PETSc.TAO.Reason).items() if not k.startswith("_")}
TAO_REASONS[0] = "CONTINUE_ITERATING"

METHODS = ("blmvm", "gd")
LINE_SEARCH_FAILURE = "LINE_SEARCH_FAILURE"   # gd: no decrease along the step

# Our stopping reasons (ControlResult.reason) and the TAO reason we set for them.
TARGET_REACHED = "TARGET_REACHED"        # E < eps            -> CONVERGED_USER
STATIONARY = "STATIONARY"                # projected grad ~ 0 -> CONVERGED_GATOL
STALLED = "STALLED"                      # no progress        -> CONVERGED_STEPTOL
MAX_ITERATIONS = "MAX_ITERATIONS"        #                    -> DIVERGED_MAXITS
MAX_EVALUATIONS = "MAX_EVALUATIONS"      #                    -> DIVERGED_MAXFCN
CABLE_COLLAPSE = "CABLE_COLLAPSE"        # step would collapse a cable -> DIVERGED_USER

# Gauss-Newton steps may shorten a cable by at most this fraction of its length
# (linearised: L_j + dL_j/dp . s >= (1 - CABLE_FRACTION) L_j), so the iterates
# approach a collapse geometrically instead of jumping past it.
CABLE_FRACTION = 0.5
# Stop (CABLE_COLLAPSE) when a cable is shorter than this many COLLAPSE_LENGTH
# and the Gauss-Newton step would still pull it onto its routing point.
COLLAPSE_STOP = 5.0
# More-Thuente curvature parameter with the Gauss-Newton metric: 0.1 instead of
# TAO's 0.9, so a step that overshoots a minimum along the line is refined
# (outside targets, large residual: the Gauss-Newton step overshoots by ~1.8x
# and the unit step was accepted; 47 iterations to the closest boundary point
# became 4, and the workspace's outside targets cost 13.5 s instead of 28.7 s).
LINE_SEARCH_GTOL = "0.1"


def default_eps(length_mm: float, tip_tol_mm: float = 1e-5) -> float:
    """E tolerance (non-dimensional) for a tip within ``tip_tol_mm``: (tol / l)^2 / 2.

    The paper's eps = 1e-10 mm^2 (Sec. 4.5 (iv)) is this with tol = 1e-5 mm
    up to its factor 1/2 convention; ours guarantees |x_t - x_d| < tol."""
    return 0.5 * (tip_tol_mm / length_mm) ** 2



class StartFailed(RuntimeError):
    """No equilibrium could be computed at the initial tensions of a solve
    (e.g. a guess that pulls a cable onto its routing point): a failed start,
    which the global search answers by trying its next strategy."""

@dataclass(frozen=True)
class Evaluation:
    """One objective evaluation: equilibrium and sensitivities at tensions p."""

    p: np.ndarray
    equilibrium: Equilibrium
    sensitivity: Sensitivity
    loading: Loading | None = None      # how the equilibrium was reached (None: unknown)


@dataclass(frozen=True, repr=False)
class ControlResult(Result):
    """Outcome of one tip-control solve.  Non-dimensional: lengths in units of
    l (``length_mm``), tensions p = P l^2 / B (``force_scale_N`` = B / l^2)."""

    converged: bool                 # E < eps: the tip is on the target
    reachable: bool | None          # True: reached; False: proven outside W_0 (see
    #                                 ``evidence``, set by :mod:`.reach` only); None:
    #                                 not reached and not proven unreachable
    reason: str                     # TARGET_REACHED, STATIONARY, STALLED, MAX_ITERATIONS, ...
    tao_reason: str                 # TAO's converged reason, checked
    message: str
    method: str
    iterations: int                 # TAO iterations
    evaluations: int                # objective evaluations (equilibrium solves incl. cached)
    failed_evaluations: int         # evaluations whose equilibrium failed (penalised)
    target: np.ndarray              # x_d
    p: np.ndarray                   # tensions reached
    tip: np.ndarray                 # x_t(p)
    tip_error: float                # |x_t - x_d|
    E: float
    eps: float
    equilibrium: Equilibrium
    sensitivity: Sensitivity
    cable_lengths: np.ndarray       # L_i = |r_i - x_i|
    history_p: np.ndarray           # (k+1, n) tensions at iterations 0..k
    history_tip: np.ndarray         # (k+1, 2)
    history_E: np.ndarray           # (k+1,)
    on_bound: tuple[tuple[int, str], ...] = ()   # (tendon number 1.., "lower"/"upper")
    length_mm: float = 1.0
    force_scale_N: float = 1.0
    loading: Loading | None = None  # loading path from the straight arm (None: unknown)
    evidence: str = ""              # why reachable is False (or what the search tried)
    strategy: str = "local"         # what reached the target: local, homotopy, seed, ...
    local_reason: str = ""          # with SEARCH_EXHAUSTED: how the closest local solve ended

    @property
    def gradient(self) -> np.ndarray:
        """dE/dp at the solution (Eq. (12))."""
        return self.sensitivity.tip @ (self.tip - self.target)

    @property
    def tip_mm(self) -> np.ndarray:
        return self.tip * self.length_mm

    @property
    def target_mm(self) -> np.ndarray:
        return self.target * self.length_mm

    @property
    def tip_error_mm(self) -> float:
        return self.tip_error * self.length_mm

    @property
    def tensions_N(self) -> np.ndarray:
        return self.p * self.force_scale_N

    @property
    def cable_lengths_mm(self) -> np.ndarray:
        return self.cable_lengths * self.length_mm


@dataclass
class _SolveState:
    """Mutable bookkeeping of one TipController.solve call."""

    target: np.ndarray
    anchor: Equilibrium | None
    max_failures: int
    anchor_loading: Loading | None = None
    max_it: int = 200
    last_good: Evaluation | None = None
    evaluations: int = 0
    failed: int = 0
    current: Evaluation | None = None
    E_max: float = 0.0
    reason: str | None = None
    history: list = field(default_factory=list)
    best_E: list = field(default_factory=list)
    failure: str = ""
    failed_at: set = field(default_factory=set)   # tensions whose equilibrium failed
    collapsing: int | None = None                  # cable (0-based) the GN step would collapse


class TipController:
    """Tip control for one arm (Algorithm 1) with a reusable TAO solver.

    Parameters
    ----------
    arm : the arm; the tension bounds are 0 <= p_i <= ``arm.max_tension``
        (no upper bound when the motor has no limit).
    solver : an :class:`EquilibriumSolver` to use (not destroyed by us; its
        SNES is switched to ``setForceIteration(True)``, see ``__init__``); by
        default one is created on ``arm`` with ``n_elements``.
    method : ``"blmvm"`` (default) or ``"gd"`` (Algorithm 1), see the module doc.
    tip_tol_mm, eps : stopping criterion E < eps, eps = (tip_tol_mm / l)^2 / 2
        unless ``eps`` is given (non-dimensional).
    max_it : iteration limit (default 200 for blmvm, 2000 for gd).
    max_evaluations : limit on objective evaluations.
    max_failures : failed equilibrium evaluations allowed per solve; beyond it
        every evaluation is penalised without solving (each failure costs a
        continuation to the collapse of a cable, up to ~0.1 s), so the line
        search ends quickly (targets in the band y < 50 mm of the paper's arm
        otherwise spent up to 13 s each).  Reached targets need 0-3.
    stationary_rtol : stop as STATIONARY when the projected gradient norm is
        below ``stationary_rtol * |x_t - x_d| * |S|_2``.
    stall_its : stop as STALLED when E has not decreased by a relative
        ``stall_rtol`` over this many iterations.
    gauss_newton : BLMVM with the Gauss-Newton initial Hessian (default True).
    lmvm_history : BFGS pairs kept by BLMVM (default 0 with ``gauss_newton``,
        PETSc's default otherwise).
    trust_tension : Levenberg-Marquardt limit on the tension change of a
        Gauss-Newton step, max(trust_tension, max p); None: no limit.
    options : extra PETSc options for the TAO, without prefix, e.g.
        ``{"tao_ls_type": "armijo"}``; pushed only while the TAO is configured,
        command-line options (``-ctl_...``) take precedence.
    prefix : options prefix (``-ctl_tao_monitor``, ``-ctl_tao_view``).
    """

    def __init__(self, arm: Arm, *, solver: EquilibriumSolver | None = None,
                 n_elements: int | None = None, method: str = "blmvm",
                 tip_tol_mm: float = 1e-5, eps: float | None = None,
                 max_it: int | None = None, max_evaluations: int = 20000,
                 max_failures: int = 25,
                 stationary_rtol: float = 1e-7, stall_its: int = 8, stall_rtol: float = 1e-9,
                 gauss_newton: bool = True, lmvm_history: int | None = None,
                 trust_tension: float | None = 10.0, options: dict | None = None,
                 prefix: str = "ctl_"):
        if method not in METHODS:
            raise InputError(f"unknown tip-control method {method!r} (choose from {METHODS})")
        self.arm = arm
        self.method = method
        self.comm = PETSc.COMM_SELF       # one arm per process (parallelism is across arms)
        self._own_solver = solver is None
        if solver is None:
            solver = EquilibriumSolver(Discretisation.from_arm(arm, n_elements))
        self.solver = solver
        # At least one Newton step per solve: with a warm start whose residual is
        # already below the SNES atol (tension changes below ~1e-8), SNES would
        # return the start unchanged and x_t(p) would be piecewise constant at the
        # scale the last iterations of the gradient method need (measured: 54 of
        # 1350 path points stalled at E ~ 2-5 eps without this).
        solver.snes.setForceIteration(True)
        self.disc = solver.disc
        self.sens = SensitivitySolver(self.disc)
        self.n = self.disc.n_tendons
        self.length_mm = arm.length_mm
        self.eps = default_eps(arm.length_mm, tip_tol_mm) if eps is None else float(eps)
        if not self.eps > 0:
            raise InputError(f"eps must be positive, got {self.eps}")
        self.max_it = (200 if method == "blmvm" else 2000) if max_it is None else int(max_it)
        self.max_evaluations = int(max_evaluations)
        self.max_failures = int(max_failures)
        self.stationary_rtol = stationary_rtol
        self.stall_its = stall_its
        self.stall_rtol = stall_rtol
        self.gauss_newton = gauss_newton and method == "blmvm"
        self.trust_tension = trust_tension
        if lmvm_history is None:
            lmvm_history = 0 if self.gauss_newton else None
        self.lmvm_history = lmvm_history
        self.upper = arm.max_tension                     # None: unbounded above
        self._cache: OrderedDict[bytes, Evaluation] = OrderedDict()
        self._state: _SolveState | None = None

        self.tao = None
        self.H0 = None
        if method == "blmvm":
            self._create_tao(prefix, options or {})

    def _create_tao(self, prefix: str, options: dict) -> None:
        self.x = PETSc.Vec().createSeq(self.n, comm=self.comm)
        self.lb = self.x.duplicate()
        self.ub = self.x.duplicate()
        self.lb.set(0.0)
        self.ub.set(PETSc.INFINITY if self.upper is None else self.upper)
        tao = PETSc.TAO().create(self.comm)
        tao.setOptionsPrefix(prefix)
        tao.setType(PETSc.TAO.Type.BLMVM)
        tao.setSolution(self.x)
        tao.setObjectiveGradient(self._objective_gradient, None)
        tao.setVariableBounds(self.lb, self.ub)
        tao.setConvergenceTest(self._convergence_test)
        tao.setMonitor(self._monitor)
        tao.setMaximumIterations(self.max_it)
        tao.setMaximumFunctionEvaluations(self.max_evaluations)
        if self.gauss_newton:
            self.H0 = PETSc.Mat().createDense((self.n, self.n), comm=self.comm)
            self.H0.setUp()
            self._set_H0(np.eye(self.n))
            tao.setLMVMH0(self.H0)
            ksp = tao.getLMVMH0KSP()
            ksp.setType(PETSc.KSP.Type.PREONLY)
            ksp.getPC().setType(PETSc.PC.Type.CHOLESKY)
        defaults = {}
        if self.gauss_newton:
            defaults["tao_ls_gtol"] = LINE_SEARCH_GTOL
        if self.lmvm_history is not None:
            defaults["tao_blmvm_mat_lmvm_hist_size"] = str(int(self.lmvm_history))
        defaults.update(options)
        set_from_options(tao, prefix, defaults)
        self.tao = tao

    # --- evaluations ----------------------------------------------------------
    def _remember(self, ev: Evaluation) -> None:
        self._cache[ev.p.tobytes()] = ev
        while len(self._cache) > 32:
            self._cache.popitem(last=False)

    def evaluate(self, p, start: Equilibrium | None = None,
                 start_loading: Loading | None = None,
                 tangent: np.ndarray | None = None) -> Evaluation | None:
        """Equilibrium and sensitivities at tensions ``p`` (cached by p).

        Continuation from ``start`` (default: the last good state of the
        current solve), then from the solve's starting equilibrium; None if
        both fail.  Outside a solve and without ``start``: proportional
        loading from the straight arm.  The evaluation records its loading
        path (:class:`~elastica_petsc.core.loading.Loading`): the origin's
        path continued to ``p`` (``start_loading`` for ``start``; None if unknown).
        ``tangent``: du/dp at ``start`` for the first predictor (Eq. (14))."""
        p = check_tensions(p, self.n)
        cached = self._cache.get(p.tobytes())
        if cached is not None:
            return cached
        st = self._state
        if st is not None and (p.tobytes() in st.failed_at or st.failed >= st.max_failures):
            return None                 # known to fail, or the failure budget is spent
        starts = self._origins(start, start_loading, tangent)
        message = ""
        for origin, tangent, loading in starts:
            eq = self.solver.solve(p, start=origin, tangent=tangent)
            if not eq.converged:
                message = eq.message
                continue
            if np.min(eq.cable_lengths) < COLLAPSE_LENGTH:
                i = int(np.argmin(eq.cable_lengths))
                message = (f"tendon {i + 1} has pulled its attachment point onto its routing "
                           f"point (cable length {eq.cable_lengths[i]:.1e} l)")
                break
            try:
                sens = self.sens.compute(eq)
            except SensitivityError as err:
                message = str(err)
                continue
            ev = Evaluation(p.copy(), eq, sens, None if loading is None else loading.then(p))
            self._remember(ev)
            return ev
        if st is not None:
            st.failure = message
            st.failed_at.add(p.tobytes())
        return None

    def _origins(self, start, start_loading, tangent=None) -> list:
        """(equilibrium, du/dp for the predictor, its loading path) to continue from."""
        st = self._state
        starts = []
        if start is not None:
            starts.append((start, tangent, start_loading))
        elif st is not None:
            if st.last_good is not None:
                good = st.last_good
                starts.append((good.equilibrium, good.sensitivity.state_derivative,
                               good.loading))
            if st.anchor is not None and all(st.anchor is not o for o, _, _ in starts):
                starts.append((st.anchor, None, st.anchor_loading))
        if not starts:
            starts.append((None, None, Loading.straight(self.n)))
        return starts

    def _true_bounds(self) -> None:
        """TAO's bounds back to 0 <= p <= upper (the step box of the last
        iteration otherwise stays, see :meth:`_gauss_newton_H0`)."""
        self.lb.set(0.0)
        self.ub.set(PETSc.INFINITY if self.upper is None else self.upper)

    def _set_H0(self, H: np.ndarray) -> None:
        idx = list(range(self.n))
        self.H0.setValues(idx, idx, np.ascontiguousarray(H, dtype=float).ravel())
        self.H0.assemble()

    def _active(self, p: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Tensions on a bound with the gradient pushing through it."""
        upper = np.inf if self.upper is None else self.upper
        return ((p <= 0.0) & (g > 0)) | ((p >= upper) & (g < 0))

    def _gauss_newton_H0(self, ev: Evaluation, target: np.ndarray) -> None:
        """H0 = S^T S + mu I (S = d x_t / d p), the Gauss-Newton Hessian of E,
        with the tensions held on a bound decoupled (reduced-space Newton),
        and the box of the step it gives as TAO's bounds for this iteration.

        mu = 1e-10 tr(S^T S) at least (S is rank one on the straight arm);
        larger (Levenberg-Marquardt) when the step s = -H0^{-1} g would change
        a tension by more than max(trust_tension, max p) or shorten a cable by
        more than CABLE_FRACTION of its length (linearised with
        dL/dp of :mod:`sensitivity`).  The line search is then confined to the
        box between p and p + s (intersected with the true bounds): the
        More-Thuente search cannot extrapolate past the Levenberg-Marquardt
        step, into a cable collapse or a snap of the arm.  The true bounds are
        used for every stopping test and restored at each solve."""
        S = ev.sensitivity.tip                         # (n, 2), rows d x_t / d p_i
        g = S @ (ev.equilibrium.tip - target)
        H = S @ S.T
        scale = max(float(np.trace(H)), 1e-300)
        active = self._active(ev.p, g)
        if np.any(active):
            diag = np.diag(H).copy()
            H[active, :] = 0.0
            H[:, active] = 0.0
            H[active, active] = diag[active]
        eye = np.eye(self.n)
        L = ev.equilibrium.cable_lengths
        dL = ev.sensitivity.cable_lengths               # [i, j] = d L_j / d p_i
        mu = 1e-10 * scale
        step = -np.linalg.solve(H + mu * eye, g)        # the Gauss-Newton step
        doomed = (L + step @ dL < COLLAPSE_LENGTH) & (L < COLLAPSE_STOP * COLLAPSE_LENGTH)
        self._state.collapsing = int(np.argmax(doomed)) if np.any(doomed) else None
        radius = np.inf if self.trust_tension is None else max(self.trust_tension,
                                                               float(np.max(ev.p)))
        for _ in range(60):
            if np.max(np.abs(step)) <= radius and np.all(step @ dL >= -CABLE_FRACTION * L):
                break
            mu *= 4.0
            step = -np.linalg.solve(H + mu * eye, g)
        self._set_H0(H + mu * eye)
        upper = np.inf if self.upper is None else self.upper
        self.lb.setArray(np.maximum(ev.p - np.abs(step), 0.0))
        self.ub.setArray(np.minimum(ev.p + np.abs(step), upper))

    # --- TAO callbacks ---------------------------------------------------------
    def _objective_gradient(self, tao, X, G) -> float:
        st = self._state
        p = np.maximum(X.getArray(readonly=True).copy(), 0.0)   # round-off below 0
        st.evaluations += 1
        ev = self.evaluate(p)
        if ev is None:                                 # line-search friendly penalty
            st.failed += 1
            good = st.last_good
            E_fail = 10.0 * (st.E_max + 1.0)
            if good is None:
                G.set(0.0)
                return E_fail
            E_good = 0.5 * float(np.sum((good.equilibrium.tip - st.target) ** 2))
            dp = p - good.p
            G.setArray((E_fail - E_good) * dp / max(float(dp @ dp), 1e-300))
            return E_fail
        st.last_good = ev
        r = ev.equilibrium.tip - st.target
        E = 0.5 * float(r @ r)
        st.E_max = max(st.E_max, E)
        G.setArray(ev.sensitivity.tip @ r)             # Eq. (12)
        return E

    def _lookup(self, p: np.ndarray) -> Evaluation | None:
        p = np.maximum(p, 0.0)
        ev = self._cache.get(p.tobytes())
        return ev if ev is not None else self.evaluate(p)

    def _monitor(self, tao) -> None:
        st = self._state
        p = tao.getSolution().getArray(readonly=True).copy()
        ev = self._lookup(p)
        if ev is None:
            return
        st.current = ev
        r = ev.equilibrium.tip - st.target
        E = 0.5 * float(r @ r)
        st.history.append((np.maximum(p, 0.0), ev.equilibrium.tip.copy(), E))
        if self.gauss_newton and E >= self.eps:        # next direction from a fresh GN H0
            self._gauss_newton_H0(ev, st.target)

    def _stop(self, its: int, E: float, pgnorm: float, ev: Evaluation | None):
        """The stopping test shared by TAO and the gd loop: (reason, TAO reason) or None."""
        Reason = PETSc.TAO.Reason
        st = self._state
        st.best_E.append(E)
        if ev is not None and E < self.eps:                     # Algorithm 1, line 8
            return TARGET_REACHED, Reason.CONVERGED_USER
        if st.collapsing is not None:
            return CABLE_COLLAPSE, Reason.DIVERGED_USER
        if its >= st.max_it:
            return MAX_ITERATIONS, Reason.DIVERGED_MAXITS
        if st.evaluations >= self.max_evaluations:
            return MAX_EVALUATIONS, Reason.DIVERGED_MAXFCN
        if ev is not None and pgnorm <= self.stationary_rtol * np.sqrt(2 * E) * max(
                np.linalg.norm(ev.sensitivity.tip, 2), 1e-300):
            return STATIONARY, Reason.CONVERGED_GATOL
        if (len(st.best_E) > self.stall_its
                and st.best_E[-1] >= (1.0 - self.stall_rtol) * st.best_E[-1 - self.stall_its]):
            return STALLED, Reason.CONVERGED_STEPTOL
        return None

    def _convergence_test(self, tao) -> None:
        st = self._state
        its, f, gnorm, _, _, _ = tao.getSolutionStatus()
        p = np.maximum(tao.getSolution().getArray(readonly=True).copy(), 0.0)
        ev = self._cache.get(p.tobytes())
        E = f
        if ev is not None:
            r = ev.equilibrium.tip - st.target
            E = 0.5 * float(r @ r)
            gnorm = float(np.linalg.norm(self._projected_gradient(p, ev.sensitivity.tip @ r)))
        stop = self._stop(its, E, gnorm, ev)
        if stop is None:
            st.reason = None
            tao.setConvergedReason(PETSc.TAO.Reason.CONTINUE_ITERATING)
        else:
            st.reason = stop[0]
            tao.setConvergedReason(stop[1])

    # --- the paper's gradient descent (Algorithm 1) ------------------------------
    def _projected_gradient(self, p: np.ndarray, g: np.ndarray) -> np.ndarray:
        """g with the components that push through an active bound removed."""
        return np.where(self._active(p, g), 0.0, g)

    def _solve_gd(self, p0: np.ndarray) -> tuple[Evaluation | None, str, int]:
        """Algorithm 1: p <- P[p - gamma grad E] with an adaptive step gamma.

        gamma is the Barzilai-Borwein step s.y / y.y of the last two iterates
        (the first: the step whose linearised tip motion is |x_t - x_d|),
        limited so that the linearised tip motion stays below 2 |x_t - x_d| and
        no tension changes by more than max(trust_tension, max p); the step
        is halved until E decreases (Armijo, 1e-4; cut by 10 after a failed
        equilibrium), so E decreases monotonically as in Fig. 2c.  P projects
        onto the tension bounds.
        Returns (final evaluation, TAO-style reason name, iterations)."""
        st = self._state
        upper = np.inf if self.upper is None else self.upper
        Reason = PETSc.TAO.Reason

        def objective(p):
            st.evaluations += 1
            ev = self.evaluate(p)
            if ev is None:
                st.failed += 1
                return None, np.inf, None
            st.last_good = ev
            r = ev.equilibrium.tip - st.target
            return ev, 0.5 * float(r @ r), ev.sensitivity.tip @ r

        p = np.clip(p0, 0.0, upper)
        ev, E, g = objective(p)
        if ev is None:
            return None, "EQUILIBRIUM_FAILURE", 0
        its = 0
        gamma = None
        while True:
            st.history.append((p.copy(), ev.equilibrium.tip.copy(), E))
            stop = self._stop(its, E, float(np.linalg.norm(self._projected_gradient(p, g))), ev)
            if stop is not None:
                st.reason = stop[0]
                return ev, TAO_REASONS[stop[1]], its
            tip_rate = np.linalg.norm(ev.sensitivity.tip.T @ g)      # |d x_t / d gamma|
            cap = 2.0 * np.sqrt(2.0 * E) / max(tip_rate, 1e-300)
            if self.trust_tension is not None:
                radius = max(self.trust_tension, float(np.max(p)))
                cap = min(cap, radius / max(float(np.max(np.abs(g))), 1e-300))
            gamma = cap / 2.0 if gamma is None else min(gamma, cap)
            d = np.clip(p - gamma * g, 0.0, upper) - p
            lam, slope = 1.0, float(g @ d)
            while True:
                p_new = p + lam * d
                ev_new, E_new, g_new = objective(p_new)
                if E_new <= E + 1e-4 * lam * slope:
                    break
                lam *= 0.5 if ev_new is not None else 0.1    # failed equilibria are costly
                if lam < 1e-8 or st.evaluations >= self.max_evaluations:
                    st.reason = LINE_SEARCH_FAILURE
                    return ev, TAO_REASONS[Reason.DIVERGED_LS_FAILURE], its
            s, y = p_new - p, g_new - g
            sy = float(s @ y)
            gamma = sy / float(y @ y) if sy > 0 else None            # BB2 step
            p, ev, E, g = p_new, ev_new, E_new, g_new
            its += 1

    # --- public API --------------------------------------------------------------
    def solve(self, target, p0=None, start: Equilibrium | None = None,
              max_failures: int | None = None,
              start_loading: Loading | None = None, max_it: int | None = None) -> ControlResult:
        """Tensions putting the tip at ``target`` (units of l), Algorithm 1.

        One local run (a stationary point away from the target is reported
        with ``reachable`` None: for the global search and its verdicts see
        :func:`elastica_petsc.solvers.reach.reach`).

        p0 : initial tensions (default: ``start.p`` if ``start`` is given, else 0).
        start : an equilibrium to warm-start the equilibrium solves from (e.g.
            the previous point of a path); default the straight arm, loaded
            proportionally to p0.
        max_failures : failure budget of this solve (default: the controller's).
        start_loading : the loading path that reached ``start`` (e.g. the
            ``loading`` of the previous result), so that the result's
            ``loading`` is known; without it a result started from ``start``
            has ``loading`` None.
        max_it : iteration limit of this solve (default: the controller's).
        """
        target = np.asarray(target, dtype=float).ravel()
        if target.shape != (2,) or not np.all(np.isfinite(target)):
            raise InputError(f"target must be two finite numbers (x, y), got {target!r}")
        if p0 is None:
            p0 = np.zeros(self.n) if start is None else np.asarray(start.p, float)
        p0 = np.asarray(p0, dtype=float).ravel()
        if p0.size != self.n or not np.all(np.isfinite(p0)):
            raise InputError(f"expected {self.n} finite initial tensions, got {p0!r}")
        p0 = np.clip(p0, 0.0, np.inf if self.upper is None else self.upper)
        if start is not None and not start.converged:
            raise InputError("start must be a converged equilibrium")
        self._state = st = _SolveState(
            target=target, anchor=start, anchor_loading=start_loading,
            max_failures=self.max_failures if max_failures is None else int(max_failures),
            max_it=self.max_it if max_it is None else min(int(max_it), self.max_it))
        # evaluations are valid within one solve (the branch depends on the start);
        # keep only the one of ``start`` (the previous path point: its sensitivities)
        keep = [ev for ev in self._cache.values() if start is not None and ev.equilibrium is start]
        self._cache.clear()
        if keep:
            ev0 = keep[0]
            if start_loading is not None and ev0.loading is not start_loading:
                ev0 = dataclasses.replace(ev0, loading=start_loading)
            self._remember(ev0)
        elif start is not None and np.array_equal(np.asarray(start.p, float), p0):
            self._remember(Evaluation(p0.copy(), start, self.sens.compute(start), start_loading))
        try:
            if self.tao is None:
                ev, tao_reason, iterations = self._solve_gd(p0)
            else:
                self.x.setArray(p0)
                self._true_bounds()
                try:
                    self.tao.solve(self.x)
                finally:
                    self._true_bounds()
                tao_reason = TAO_REASONS.get(self.tao.getConvergedReason(), "UNKNOWN")
                iterations = self.tao.getIterationNumber()
                p = np.maximum(self.x.getArray(readonly=True).copy(), 0.0)
                ev = self._cache.get(p.tobytes()) or self.evaluate(p)
            if ev is None:
                ev = st.last_good
            if ev is None:
                raise StartFailed(
                    "tip control could not compute any equilibrium from the initial tensions "
                    f"{p0}: {st.failure}")
            return self._result(st, ev, tao_reason, iterations)
        finally:
            self._state = None

    def solve_mm(self, target_mm, p0=None, start: Equilibrium | None = None,
                 max_failures: int | None = None,
                 start_loading: Loading | None = None) -> ControlResult:
        """:meth:`solve` with the target in mm."""
        return self.solve(np.asarray(target_mm, float) / self.length_mm, p0=p0, start=start,
                          max_failures=max_failures, start_loading=start_loading)

    def _result(self, st: _SolveState, ev: Evaluation, tao_reason: str,
                iterations: int) -> ControlResult:
        eq = ev.equilibrium
        r = eq.tip - st.target
        E = 0.5 * float(r @ r)
        converged = E < self.eps
        reason = st.reason
        if reason is None:                       # TAO stopped on its own (line search failure)
            reason = tao_reason
        if converged:
            reason = TARGET_REACHED
        g = ev.sensitivity.tip @ r
        upper = np.inf if self.upper is None else self.upper
        tol = 1e-10 * max(1.0, float(np.max(ev.p)) if len(ev.p) else 1.0)
        on_bound = []
        for i, (pi, gi) in enumerate(zip(ev.p, g), start=1):
            if pi <= tol and gi > 0:
                on_bound.append((i, "lower"))
            elif pi >= upper - tol and gi < 0:
                on_bound.append((i, "upper"))
        reachable = True if converged else None   # a local end proves nothing
        mm = self.length_mm
        if converged:
            message = f"tip within {np.linalg.norm(r) * mm:.2e} mm of the target"
        else:
            bound_txt = ", ".join(f"p_{i} on its {kind} bound" for i, kind in on_bound)
            message = (f"stopped ({reason}, TAO {tao_reason}) with the tip "
                       f"{np.linalg.norm(r) * mm:.4g} mm from the target"
                       + (f"; {bound_txt}" if bound_txt else "")
                       + (f"; tendon {st.collapsing + 1}'s cable is "
                          f"{eq.cable_lengths[st.collapsing] * mm:.2f} mm long and the next step "
                          "would pull its attachment point onto its routing point (a local "
                          "end: other initial tensions may still reach the target)"
                          if reason == CABLE_COLLAPSE else "")
                       + (f"; last equilibrium failure: {st.failure}" if st.failure else ""))
        hist = st.history or [(ev.p, eq.tip, E)]
        return ControlResult(
            converged=converged, reachable=reachable, reason=reason, tao_reason=tao_reason,
            message=message, method=self.method, iterations=iterations,
            evaluations=st.evaluations, failed_evaluations=st.failed, target=st.target.copy(),
            p=ev.p.copy(), tip=eq.tip.copy(), tip_error=float(np.linalg.norm(r)), E=E,
            eps=self.eps, equilibrium=eq, sensitivity=ev.sensitivity,
            cable_lengths=eq.cable_lengths.copy(),
            history_p=np.array([h[0] for h in hist]), history_tip=np.array([h[1] for h in hist]),
            history_E=np.array([h[2] for h in hist]), on_bound=tuple(on_bound),
            length_mm=mm, force_scale_N=self.arm.force_scale_N, loading=ev.loading)

    def forget(self) -> None:
        """Drop the cached evaluations (they are keyed by tensions alone, and the
        branch depends on the start): before evaluations from an unrelated state."""
        self._cache.clear()

    def forward(self, p, start: Equilibrium | None = None) -> Equilibrium:
        """The equilibrium at tensions ``p`` (load stepping from ``start`` or the
        straight arm); convenience for known-answer checks."""
        return self.solver.solve(p, start=start)

    # --- lifetime ----------------------------------------------------------------
    def destroy(self) -> None:
        self._cache.clear()
        if self.tao is not None:
            for obj in (self.tao, self.x, self.lb, self.ub, self.H0):
                if obj is not None:
                    obj.destroy()
            self.tao = None
        self.sens.destroy()
        if self._own_solver:
            self.solver.destroy()

    def __enter__(self) -> "TipController":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()
