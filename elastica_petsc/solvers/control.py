"""Tip control by load optimisation (Eqs. (10)-(12), Algorithm 1) with PETSc TAO.

Find tensions p >= 0 (and p <= p_crit of Eq. (22) when the arm has a motor
limit) that put the tip of the arm at a target x_d:

    minimise E(p) = |x_d - x_t(p)|^2 / 2                         (Eqs. (10)-(11))
    dE/dp_i = (x_t - x_d) . d x_t / d p_i                         (Eq. (12))

Each evaluation of E solves the equilibrium (Eq. (9)) warm-started from the
last good equilibrium of the current solve (:meth:`EquilibriumSolver.follow`
from that state: continuation in tension space, so the branch the arm is on
is followed) and the sensitivities d x_t / d p
(:mod:`elastica_petsc.solvers.sensitivity`: one LU, one solve per tendon).
Non-dimensional throughout (lengths / l, p = P l^2 / B);
:meth:`TipController.solve_mm` takes a target in mm.

The problem of one solve (objective, penalty of failed equilibria,
stopping test, Gauss-Newton metric) is :mod:`.tip_problem`; the paper's
gradient descent is :mod:`.descent`; the global strategies (homotopy,
seeds, verdicts) are :mod:`.reach`.  This module owns the PETSc objects.

Methods
-------
``blmvm`` (default)
    TAO BLMVM (projected limited-memory variable metric with a More-Thuente
    line search) whose initial Hessian H0 (``TaoLMVMSetH0``) is the
    Gauss-Newton matrix of :meth:`TipProblem.gauss_newton`, refreshed at
    every iterate (from the monitor, which TAO calls before each new
    direction).  The line search (More-Thuente, curvature parameter 0.1) is
    confined to the box of that step (TAO's bounds for that iteration), so
    it cannot extrapolate past it into a cable collapse.  With that metric
    the BFGS history only hurts (measured on Fig. 2: 9 iterations with the
    default 5 pairs, 5 with none), so it is off by default
    (``lmvm_history=0``, i.e. ``-ctl_tao_blmvm_mat_lmvm_hist_size 0``): the
    method is then a projected Gauss-Newton/Levenberg-Marquardt iteration
    run by BLMVM.  From a warm start (p0's evaluation known) the same steps
    are taken first without TAO, with a path predictor (:mod:`.direct_steps`);
    TAO continues where they stop undecided.  ``gauss_newton=False`` gives
    stock BLMVM (15 iterations on Fig. 2).
``gd``
    The paper's Algorithm 1 (:mod:`.descent`).  The ``ctl_`` options do not
    apply to it.

TAO's own reason is always checked and reported; a TAO line-search failure
ends the solve with that reason.
"""
from __future__ import annotations

import dataclasses
import math
from collections import OrderedDict

import numpy as np
from petsc4py import PETSc

from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.loading import Loading
from ..core.model import Arm
from .descent import gradient_descent
from .direct_steps import PathPredictor, gauss_newton_steps
from .equilibrium import COLLAPSE_LENGTH, Equilibrium, EquilibriumSolver, check_tensions
from .options import SolverOptions, check_comm
from .reasons import converged_reason
from .sensitivity import SensitivityError, SensitivitySolver
from .tip_problem import (CABLE_COLLAPSE, CABLE_FRACTION, COLLAPSE_STOP, LINE_SEARCH_FAILURE,
                          MAX_EVALUATIONS, MAX_ITERATIONS, STALLED, STATIONARY, TARGET_REACHED,
                          ControlResult, Evaluation, StopRule, TipProblem, default_eps)

__all__ = ["CABLE_COLLAPSE", "CABLE_FRACTION", "COLLAPSE_STOP", "LINE_SEARCH_FAILURE",
           "MAX_EVALUATIONS", "MAX_ITERATIONS", "METHODS", "STALLED", "STATIONARY",
           "TARGET_REACHED", "ControlResult", "Evaluation", "TipController", "default_eps"]

METHODS = ("blmvm", "gd", "brgn")

# More-Thuente curvature parameter with the Gauss-Newton metric: 0.1 instead of
# TAO's 0.9, so a step that overshoots a minimum along the line is refined
# (outside targets, large residual: the Gauss-Newton step overshoots by ~1.8x
# and the unit step was accepted; 47 iterations to the closest boundary point
# became 4).
LINE_SEARCH_GTOL = "0.1"


class StartFailed(RuntimeError):
    """No equilibrium could be computed at the initial tensions of a solve
    (e.g. a guess that pulls a cable onto its routing point): a failed start,
    which the global search answers by trying its next strategy."""
# TAO BRGN (method "brgn"): a proximal weight (E ~ 1e-16 at the target, so
# PETSc's 1e-4 dominates the Gauss-Newton matrix: 277 iterations on Fig. 2)
# and an Armijo line search in its BNLS subsolver (14 evaluations on Fig. 2
# instead of More-Thuente's 17); BENCHMARKS.md compares it with blmvm.
BRGN_DEFAULTS = {"tao_brgn_regularizer_weight": 1e-12, "tao_brgn_subsolver_tao_ls_type": "armijo"}


class TipController:
    """Tip control for one arm (Algorithm 1) with a reusable TAO solver.

    Parameters
    ----------
    arm : the arm; the tension bounds are 0 <= p_i <= ``arm.max_tension``
        (no upper bound when the motor has no limit).
    solver : an :class:`EquilibriumSolver` to use (borrowed: neither changed
        nor destroyed by us); by default one is created on ``arm`` with
        ``n_elements``.
    method : ``"blmvm"`` (default) or ``"gd"`` (Algorithm 1), see the module doc.
    tip_tol_mm, eps : stopping criterion E < eps, eps = (tip_tol_mm / l)^2 / 2
        unless ``eps`` is given (non-dimensional).
    max_it : iteration limit (default 200 for blmvm, 2000 for gd).
    max_evaluations : limit on objective evaluations.
    max_failures : failed equilibrium evaluations allowed per solve; beyond it
        every evaluation is penalised without solving (each failure costs a
        continuation to the collapse of a cable), so the line search ends
        quickly.  Reached targets need 0-3.
    stationary_rtol : stop as STATIONARY when the projected gradient norm is
        below ``stationary_rtol * |x_t - x_d| * |S|_2``.
    stall_its : stop as STALLED when E has not decreased by a relative
        ``stall_rtol`` over this many iterations.
    gauss_newton : BLMVM with the Gauss-Newton initial Hessian (default True).
    lmvm_history : BFGS pairs kept by BLMVM (default 0 with ``gauss_newton``,
        PETSc's default otherwise).
    trust_tension : Levenberg-Marquardt limit on the tension change of a
        Gauss-Newton step, max(trust_tension, max p); None: no limit.
    comm : one process (default ``PETSc.COMM_SELF``).
    options_prefix : options prefix of the TAO and its vectors
        (``-ctl_tao_monitor``, ``-ctl_tao_view``); an equilibrium solver made
        here has ``eq_``.
    petsc_options : PETSc options for the TAO without the prefix, e.g.
        ``{"tao_ls_type": "armijo"}`` or ``{"tao": {"ls_type": "armijo"}}``;
        command-line options win (:mod:`.options`); options given later (in
        the database under the prefix, or by ``self.options.update``) are
        applied at the next solve.  Refused (InputError) with ``gd``.
    """

    def __init__(self, arm: Arm, *, solver: EquilibriumSolver | None = None,
                 n_elements: int | None = None, method: str = "blmvm",
                 tip_tol_mm: float = 1e-5, eps: float | None = None,
                 max_it: int | None = None, max_evaluations: int = 20000,
                 max_failures: int = 25,
                 stationary_rtol: float = 1e-7, stall_its: int = 8, stall_rtol: float = 1e-9,
                 gauss_newton: bool = True, lmvm_history: int | None = None,
                 trust_tension: float | None = 10.0, comm=None, options_prefix: str = "ctl_",
                 petsc_options=None):
        if method not in METHODS:
            raise InputError(f"unknown tip-control method {method!r} (choose from {METHODS})")
        if method == "gd" and petsc_options:
            raise InputError("the gd method (Algorithm 1) is our own loop and runs no TAO: "
                             "petsc_options do not apply to it (use blmvm or brgn)")
        self.gauss_newton = gauss_newton and method == "blmvm"
        if lmvm_history is None:
            lmvm_history = 0 if self.gauss_newton else None
        defaults = {"tao_ls_gtol": LINE_SEARCH_GTOL} if self.gauss_newton else {}
        if method == "brgn":
            defaults = dict(BRGN_DEFAULTS)
        if lmvm_history is not None:
            defaults["tao_blmvm_mat_lmvm_hist_size"] = str(int(lmvm_history))
        self.options = SolverOptions(options_prefix, petsc_options, defaults)
        self.comm = check_comm(comm)          # one arm per process (parallelism is across arms)
        self.arm = arm
        self.method = method
        self._own_solver = solver is None
        if solver is None:
            solver = EquilibriumSolver(Discretisation.from_arm(arm, n_elements), comm=self.comm)
        self.solver = solver
        self.disc = solver.disc
        self.sens = SensitivitySolver(self.disc, comm=self.comm)
        self.n = self.disc.n_tendons
        self.length_mm = arm.length_mm
        self.eps = default_eps(arm.length_mm, tip_tol_mm) if eps is None else float(eps)
        if not self.eps > 0:
            raise InputError(f"eps must be positive, got {self.eps}")
        self.max_it = (200 if method == "blmvm" else 2000) if max_it is None else int(max_it)
        self.max_evaluations = int(max_evaluations)
        self.max_failures = int(max_failures)
        self.upper = arm.max_tension                     # None: unbounded above
        self.rule = StopRule(self.eps, self.max_evaluations, stationary_rtol, stall_its,
                             stall_rtol, np.inf if self.upper is None else self.upper,
                             trust_tension)
        self._cache: OrderedDict[bytes, Evaluation] = OrderedDict()
        self.predictor = PathPredictor()
        self.tao = self.H0 = None
        if method == "blmvm":
            self._create_tao()
        elif method == "brgn":
            self._create_brgn()

    def _create_tao(self) -> None:
        self.x = PETSc.Vec().createSeq(self.n, comm=self.comm)
        self.lb = self.x.duplicate()
        self.ub = self.x.duplicate()
        self.lb.set(0.0)
        self.ub.set(PETSc.INFINITY if self.upper is None else self.upper)
        tao = PETSc.TAO().create(self.comm)
        self.options.label(tao, self.x, self.lb, self.ub)
        tao.setType(PETSc.TAO.Type.BLMVM)
        tao.setSolution(self.x)
        # the callbacks find the solve's TipProblem in the TAO's application context
        tao.setObjectiveGradient(self._objective_gradient, None)
        tao.setVariableBounds(self.lb, self.ub)
        tao.setConvergenceTest(self._convergence_test)
        tao.setMonitor(self._monitor)
        tao.setMaximumIterations(self.max_it)
        tao.setMaximumFunctionEvaluations(self.max_evaluations)
        if self.gauss_newton:
            self.H0 = PETSc.Mat().createDense((self.n, self.n), comm=self.comm)
            self.H0.setOptionsPrefix(self.options.prefix)
            self.H0.setUp()
            self._set_H0(np.eye(self.n))
            tao.setLMVMH0(self.H0)
            ksp = tao.getLMVMH0KSP()
            ksp.setType(PETSc.KSP.Type.PREONLY)
            ksp.getPC().setType(PETSc.PC.Type.CHOLESKY)
        self.options.apply(tao)
        self.tao = tao

    def _create_brgn(self) -> None:
        """TAO BRGN on the residual r(p) = x_t(p) - x_d (Eq. (11)) and its
        Jacobian S^T (Eq. (13)), bounded; our stopping test and monitor on its
        Newton subsolver (BNLS), which runs the iterations."""
        self.x = PETSc.Vec().createSeq(self.n, comm=self.comm)
        self.lb, self.ub = self.x.duplicate(), self.x.duplicate()
        self.R = PETSc.Vec().createSeq(2, comm=self.comm)
        self.Jr = PETSc.Mat().createDense((2, self.n), comm=self.comm)
        self.Jr.setUp()
        self._true_bounds()
        tao = PETSc.TAO().create(self.comm)
        self.options.label(tao, self.x, self.lb, self.ub, self.R, self.Jr)
        tao.setType(PETSc.TAO.Type.BRGN)
        # PETSc 3.18 names the subsolver when BRGN is created, before any prefix
        tao.getBRGNSubsolver().setOptionsPrefix(self.options.prefix + "tao_brgn_subsolver_")
        tao.setSolution(self.x)
        tao.setResidual(self._residual, self.R)
        tao.setJacobianResidual(self._jacobian_residual, self.Jr, self.Jr)
        tao.setVariableBounds(self.lb, self.ub)
        self.options.apply(tao)
        sub = tao.getBRGNSubsolver()
        sub.setConvergenceTest(self._convergence_test)
        sub.setMonitor(self._monitor)
        sub.setMaximumIterations(self.max_it)
        sub.setMaximumFunctionEvaluations(self.max_evaluations)
        self.tao = tao

    def _residual(self, tao, X, F) -> None:
        problem = tao.getAppCtx()
        p = np.maximum(X.getArray(readonly=True).copy(), 0.0)
        E, g = problem.penalised(p)
        ev = self._cache.get(p.tobytes())
        F.setArray(ev.equilibrium.tip - problem.target if ev is not None
                   else [np.sqrt(2.0 * E), 0.0])              # penalty: |r|^2 / 2 = E_fail
        # after a failure, the Jacobian row whose J^T r is the penalty's secant gradient
        problem.penalty_row = None if ev is not None else g / np.sqrt(2.0 * E)

    def _jacobian_residual(self, tao, X, J, P) -> None:
        problem = tao.getAppCtx()
        p = np.maximum(X.getArray(readonly=True).copy(), 0.0)
        ev = self._cache.get(p.tobytes())
        if ev is not None:
            jac = ev.sensitivity.tip.T                          # d x_t / d p, (2, n)
        else:                                                   # a failure (_residual)
            row = problem.penalty_row
            jac = np.vstack((np.zeros(self.n) if row is None else row, np.zeros(self.n)))
        J.setValues(range(2), range(self.n), np.ascontiguousarray(jac).ravel())
        J.assemble()

    # --- evaluations ----------------------------------------------------------
    def _remember(self, ev: Evaluation) -> None:
        self._cache[ev.p.tobytes()] = ev
        while len(self._cache) > 32:
            self._cache.popitem(last=False)

    def evaluate(self, p, start: Equilibrium | None = None,
                 start_loading: Loading | None = None,
                 tangent: np.ndarray | None = None) -> Evaluation | None:
        """Equilibrium and sensitivities at tensions ``p`` (cached by p), outside
        a solve: continuation from ``start`` (``start_loading``: the path that
        reached it; ``tangent``: du/dp at ``start`` for the first predictor,
        Eq. (14)), by default proportional loading from the straight arm;
        None if it fails.  The evaluation records its loading path (None if
        unknown)."""
        return self._evaluate(check_tensions(p, self.n), None, start, start_loading, tangent)

    def _evaluate(self, p: np.ndarray, problem: TipProblem | None, start=None,
                  start_loading=None, tangent=None) -> Evaluation | None:
        """:meth:`evaluate` of checked tensions; within a solve (``problem``)
        continued from its last good state, then from its starting equilibrium."""
        cached = self._cache.get(p.tobytes())
        if cached is not None:
            return cached
        if problem is not None and (p.tobytes() in problem.failed_at
                                    or problem.failed >= problem.max_failures):
            return None                 # known to fail, or the failure budget is spent
        message = ""
        for origin, tangent, loading in self._origins(problem, start, start_loading, tangent):
            eq = self.solver.follow(p, start=origin, tangent=tangent)
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
        if problem is not None:
            problem.failure = message
            problem.failed_at.add(p.tobytes())
        return None

    def _origins(self, problem, start, start_loading, tangent=None) -> list:
        """(equilibrium, du/dp for the predictor, its loading path) to continue from."""
        starts = []
        if start is not None:
            starts.append((start, tangent, start_loading))
        elif problem is not None:
            if problem.last_good is not None:
                good = problem.last_good
                starts.append((good.equilibrium, good.sensitivity.state_derivative,
                               good.loading))
            if problem.anchor is not None and all(problem.anchor is not o for o, _, _ in starts):
                starts.append((problem.anchor, None, problem.anchor_loading))
        if not starts:
            starts.append((None, None, Loading.straight(self.n)))
        return starts

    def _lookup(self, p: np.ndarray, problem: TipProblem) -> Evaluation | None:
        p = np.maximum(p, 0.0)
        ev = self._cache.get(p.tobytes())
        return ev if ev is not None else self._evaluate(p, problem)

    # --- the emulated Gauss-Newton of BLMVM -------------------------------------
    def _true_bounds(self) -> None:
        """TAO's bounds back to 0 <= p <= upper (the step box of the last
        iteration otherwise stays, see :meth:`_monitor`)."""
        self.lb.set(0.0)
        self.ub.set(PETSc.INFINITY if self.upper is None else self.upper)

    def _set_H0(self, H: np.ndarray) -> None:
        idx = list(range(self.n))
        self.H0.setValues(idx, idx, np.ascontiguousarray(H, dtype=float).ravel())
        self.H0.assemble()

    def _gauss_newton_H0(self, problem: TipProblem, ev: Evaluation) -> None:
        """BLMVM's H0 := the Gauss-Newton metric of :meth:`TipProblem.gauss_newton`,
        and the box between p and p + s (intersected with the true bounds) as
        TAO's bounds for this iteration: the More-Thuente search cannot
        extrapolate past the Levenberg-Marquardt step, into a cable collapse
        or a snap of the arm.  The true bounds are used for every stopping
        test and restored at each solve."""
        H, step = problem.gauss_newton(ev)
        self._set_H0(H)
        upper = np.inf if self.upper is None else self.upper
        self.lb.setArray(np.maximum(ev.p - np.abs(step), 0.0))
        self.ub.setArray(np.minimum(ev.p + np.abs(step), upper))

    # --- TAO callbacks (the solve's TipProblem is the TAO's application context) --
    def _objective_gradient(self, tao, X, G) -> float:
        p = np.maximum(X.getArray(readonly=True).copy(), 0.0)   # round-off below 0
        E, g = tao.getAppCtx().penalised(p)
        G.setArray(g)
        return E

    def _monitor(self, tao) -> None:
        problem = tao.getAppCtx()
        p = tao.getSolution().getArray(readonly=True).copy()
        ev = self._lookup(p, problem)
        if ev is None:
            return
        problem.current = ev
        _, E = problem.residual_E(ev)
        problem.history.append((np.maximum(p, 0.0), ev.equilibrium.tip.copy(), E))
        if self.gauss_newton and E >= self.eps:        # next direction from a fresh GN H0
            self._gauss_newton_H0(problem, ev)
        elif self.method == "brgn" and E >= self.eps:
            problem.gauss_newton(ev)                   # only for CABLE_COLLAPSE

    def _convergence_test(self, tao) -> None:
        problem = tao.getAppCtx()
        its, f, gnorm, _, _, _ = tao.getSolutionStatus()
        p = np.maximum(tao.getSolution().getArray(readonly=True).copy(), 0.0)
        ev = self._cache.get(p.tobytes())
        E = f
        if ev is not None:
            r, E = problem.residual_E(ev)
            gnorm = float(np.linalg.norm(problem.projected_gradient(p, ev.sensitivity.tip @ r)))
        stop = problem.stop(its, E, gnorm, ev)
        problem.reason = None if stop is None else stop[0]
        tao.setConvergedReason(PETSc.TAO.Reason.CONTINUE_ITERATING if stop is None else stop[1])

    def _solve_tao(self, problem: TipProblem, p0: np.ndarray):
        """BLMVM from ``p0``: (final evaluation, TAO's reason, iterations)."""
        self.options.refresh(self.tao)
        self.x.setArray(p0)
        self._true_bounds()
        taos = [self.tao] + ([self.tao.getBRGNSubsolver()] if self.method == "brgn" else [])
        for tao in taos:
            tao.setAppCtx(problem)
        try:
            self.tao.solve(self.x)
        finally:
            for tao in taos:
                tao.setAppCtx(None)
            self._true_bounds()
        p = np.maximum(self.x.getArray(readonly=True).copy(), 0.0)
        ev = self._cache.get(p.tobytes()) or self._evaluate(p, problem)
        return ev, converged_reason(self.tao), self.tao.getIterationNumber()

    def _solve_blmvm(self, problem: TipProblem, p0: np.ndarray):
        """A warm start (p0's evaluation known) first takes the direct
        Gauss-Newton steps of :mod:`.direct_steps`; TAO runs from where they
        stop without a verdict (the iterations add up)."""
        known = self._cache.get(p0.tobytes()) if self.gauss_newton else None
        if known is None:
            return self._solve_tao(problem, p0)
        start = problem.anchor
        ev, tao_reason, steps = gauss_newton_steps(
            problem, known, problem.max_it, self.predictor.correction(start, problem.target))
        self.predictor.record(start, problem.target, known, problem, ev,
                              tao_reason is not None and problem.reason == TARGET_REACHED)
        if tao_reason is not None:
            return ev, tao_reason, steps
        problem.max_it -= steps
        ev, tao_reason, iterations = self._solve_tao(problem, ev.p)
        return ev, tao_reason, steps + iterations

    # --- public API --------------------------------------------------------------
    def solve(self, target, p0=None, start: Equilibrium | None = None,
              max_failures: int | None = None,
              start_loading: Loading | None = None, max_it: int | None = None,
              budget=None, stall: tuple[int, float] | None = None) -> ControlResult:
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
        budget : a :class:`~elastica_petsc.core.budget.TimeBudget`; once it is
            spent the solve stops after its current iteration with reason
            ``TIME_LIMIT`` (an undecided local end).
        stall : (iterations, relative decrease of E) of the STALLED test for
            this solve (default: the controller's ``stall_its``, ``stall_rtol``),
            e.g. a coarse one when only the closest tip is wanted.
        """
        target = np.asarray(target, dtype=float).ravel()
        if target.shape != (2,) or not np.all(np.isfinite(target)):
            raise InputError(f"target must be two finite numbers (x, y), got {target!r}")
        if p0 is None:
            p0 = np.zeros(self.n) if start is None else np.asarray(start.p, float)
        p0 = np.asarray(p0, dtype=float).ravel()
        if p0.size != self.n or not np.all(np.isfinite(p0)):
            raise InputError(f"expected {self.n} finite initial tensions, got {p0!r}")
        p0 = np.maximum(p0, 0.0) if self.upper is None else np.minimum(np.maximum(p0, 0.0),
                                                                          self.upper)
        if start is not None and not start.converged:
            raise InputError("start must be a converged equilibrium")
        rule = self.rule if stall is None else dataclasses.replace(
            self.rule, stall_its=int(stall[0]), stall_rtol=float(stall[1]))
        problem = TipProblem(
            target=target, rule=rule, evaluate=self._evaluate, anchor=start,
            anchor_loading=start_loading,
            max_failures=self.max_failures if max_failures is None else int(max_failures),
            max_it=self.max_it if max_it is None else min(int(max_it), self.max_it),
            budget=budget)
        self._keep_start(start, start_loading, p0)
        if self.tao is None:
            ev, tao_reason, iterations = gradient_descent(problem, p0)
        else:
            ev, tao_reason, iterations = self._solve_blmvm(problem, p0)
        if ev is None:
            ev = problem.last_good
        if ev is None:
            raise StartFailed(
                "tip control could not compute any equilibrium from the initial tensions "
                f"{p0}: {problem.failure}")
        return self._result(problem, ev, tao_reason, iterations)

    def _keep_start(self, start, start_loading, p0) -> None:
        """Evaluations are valid within one solve (the branch depends on the
        start): keep only the one of ``start`` (the previous path point: its
        sensitivities)."""
        keep = [ev for ev in self._cache.values() if start is not None and ev.equilibrium is start]
        self._cache.clear()
        if keep:
            ev0 = keep[0]
            if start_loading is not None and ev0.loading is not start_loading:
                ev0 = dataclasses.replace(ev0, loading=start_loading)
            self._remember(ev0)
        elif start is not None and np.array_equal(np.asarray(start.p, float), p0):
            self._remember(Evaluation(p0.copy(), start, self.sens.compute(start), start_loading))

    def solve_mm(self, target_mm, p0=None, start: Equilibrium | None = None,
                 max_failures: int | None = None,
                 start_loading: Loading | None = None) -> ControlResult:
        """:meth:`solve` with the target in mm."""
        return self.solve(np.asarray(target_mm, float) / self.length_mm, p0=p0, start=start,
                          max_failures=max_failures, start_loading=start_loading)

    def _on_bound(self, ev: Evaluation, g: np.ndarray) -> tuple:
        """(tendon number, "lower"/"upper") of the tensions held on a bound."""
        upper = np.inf if self.upper is None else self.upper
        tol = 1e-10 * max(1.0, float(np.max(ev.p)) if len(ev.p) else 1.0)
        on_bound = []
        for i, (pi, gi) in enumerate(zip(ev.p, g), start=1):
            if pi <= tol and gi > 0:
                on_bound.append((i, "lower"))
            elif pi >= upper - tol and gi < 0:
                on_bound.append((i, "upper"))
        return tuple(on_bound)

    def _result(self, problem: TipProblem, ev: Evaluation, tao_reason: str,
                iterations: int) -> ControlResult:
        eq = ev.equilibrium
        r, E = problem.residual_E(ev)
        converged = E < self.eps
        reason = problem.reason
        if reason is None:                       # TAO stopped on its own (line search failure)
            reason = tao_reason
        if converged:
            reason = TARGET_REACHED
        on_bound = self._on_bound(ev, ev.sensitivity.tip @ r)
        reachable = True if converged else None   # a local end proves nothing
        mm = self.length_mm
        tip_error = math.sqrt(float(r @ r))
        if converged:
            message = f"tip within {tip_error * mm:.2e} mm of the target"
        else:
            bound_txt = ", ".join(f"p_{i} on its {kind} bound" for i, kind in on_bound)
            message = (f"stopped ({reason}, TAO {tao_reason}) with the tip "
                       f"{tip_error * mm:.4g} mm from the target"
                       + (f"; {bound_txt}" if bound_txt else "")
                       + (f"; tendon {problem.collapsing + 1}'s cable is "
                          f"{eq.cable_lengths[problem.collapsing] * mm:.2f} mm long and the next "
                          "step would pull its attachment point onto its routing point (a local "
                          "end: other initial tensions may still reach the target)"
                          if reason == CABLE_COLLAPSE else "")
                       + (f"; last equilibrium failure: {problem.failure}"
                          if problem.failure else ""))
        hist = problem.history or [(ev.p, eq.tip, E)]
        return ControlResult(
            converged=converged, reachable=reachable, reason=reason, tao_reason=tao_reason,
            message=message, method=self.method, iterations=iterations,
            evaluations=problem.evaluations, failed_evaluations=problem.failed,
            target=problem.target.copy(), p=ev.p.copy(), tip=eq.tip.copy(),
            tip_error=tip_error, E=E, eps=self.eps, equilibrium=eq,
            sensitivity=ev.sensitivity, cable_lengths=eq.cable_lengths.copy(),
            history_p=np.array([h[0] for h in hist]), history_tip=np.array([h[1] for h in hist]),
            history_E=np.array([h[2] for h in hist]), on_bound=on_bound,
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
            for obj in (self.tao, self.x, self.lb, self.ub, self.H0, getattr(self, "R", None),
                        getattr(self, "Jr", None)):
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
