"""Redundant tendons (n >= 3): choose how tension is shared among the tension
sets that put the tip on the target.

With n tendons the tensions reaching a tip x_d form (locally) an
(n - 2)-dimensional family.  :class:`TensionSharer` picks one:

    minimise f(p)  subject to  x_t(p) = x_d  (2 equations, Eq. (11) at E = 0)
                               p_min <= p_i (<= p_crit, Eq. (22))

with ``share``

* ``min-norm``:   f = |p|^2 / 2,                 grad f = p;
* ``min-energy``: f = U(p) / (B/l), the strain energy (Eq. (21)) of the
  equilibrium, grad f = -(dL/dp) p: at equilibrium dU/dtheta = -sum_j p_j
  dL_j/dtheta (the stationarity of Pi = U + sum_j p_j L_j, docs/model.md §2),
  so dU/dp_i = -sum_j p_j dL_j/dp_i (one more use of the sensitivities of
  :mod:`sensitivity`, no extra solve);

and p_min a pretension floor (every cable taut).  Non-dimensional throughout.

Two methods (measured in BENCHMARKS.md, "Tension sharing along a trace"):

``newton`` (default)
    Sequential quadratic programming on the KKT system: at tensions p with
    tip error c = x_t - x_d, tip Jacobian S (S[i] = d x_t / d p_i, Eq. (13)),
    gradient g = grad f, the step d solves the convex QP
    min g.d + d.W.d/2 s.t. S^T d = -c, p_min - p <= d <= p_crit - p, |d_i| <= R
    exactly (:func:`elastica_petsc.core.qp.solve_box_qp`, active sets
    enumerated: no inner iteration), W a damped-BFGS approximation of the
    Hessian of the Lagrangian f - lam.(x_t - x_d), started from the Hessian of
    f (I for min-norm; -(dL/dp), positive definite at a stable state, for
    min-energy).  The step is globalised by an l1 merit f + nu |c|_1 with a
    second-order correction and backtracking.  Along a path (:meth:`follow`)
    the previous point's tensions, multipliers, active set and W warm-start
    the next point: the constraint linearisation moves the tip to the new
    target while the Lagrangian keeps the sharing optimal, typically 2-3
    equilibrium solves per point.
``almm``
    PETSc TAO ALMM (augmented Lagrangian; equality constraint x_t - x_d with
    Jacobian S^T, bounds), started from a state that already reaches the
    target (the first implementation; kept for the comparison).

Stopping reasons (``ControlResult.reason``): TARGET_REACHED (tip within
tolerance, p >= p_min, KKT residual below ``kkt_tol``), SHARE_INFEASIBLE (the
linearised tip constraint cannot be met with p >= p_min and the bounded
least-squares step no longer brings the tip closer: a *local* finding, the
target may still be reachable with p >= p_min elsewhere, so ``reachable`` is
None), SHARE_MAX_ITERATIONS, SHARE_LINE_SEARCH_FAILURE (no step decreases the
merit), SHARE_FAILED (ALMM did not end on the target).  Every loop is capped
(``max_it`` iterations, ``MAX_BACKTRACKS`` per line search, the QP by
enumeration): nothing here can hang.

The first-order optimality (KKT) conditions are checked by
:func:`kkt_residual`, independently of the solver's own multipliers.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from petsc4py import PETSc

from .options import SolverOptions, check_comm
from .reasons import converged_reason
from ..core.errors import InputError
from ..core.qp import FREE, closest_in_box, solve_box_qp
from .control import TARGET_REACHED, ControlResult, Evaluation, TipController

SHARES = ("min-norm", "min-energy")
METHODS = ("newton", "almm")
SHARE_INFEASIBLE = "SHARE_INFEASIBLE"
SHARE_MAX_ITERATIONS = "SHARE_MAX_ITERATIONS"
SHARE_LINE_SEARCH_FAILURE = "SHARE_LINE_SEARCH_FAILURE"
SHARE_STALLED = "SHARE_STALLED"
SHARE_FAILED = "SHARE_FAILED"
CONSTRAINT_SCALE = 1e-3      # ALMM: tip error unit inside the solve, units of l
GATOL = 1e-7                 # ALMM gradient tolerance of the scaled problem (f / f_0)
KKT_TOL = 1e-9               # newton: relative KKT residual at convergence
MAX_BACKTRACKS = 12          # newton: merit line-search halvings per iteration
INFEASIBLE_GAIN = 1e-3       # newton: relative tip-error gain below which it is SHARE_INFEASIBLE
TIP_NOISE = 16 * np.finfo(float).eps   # round-off of a tip coordinate (units of l, |x| ~ 1)
STALL_ITS, STALL_GAIN = 5, 0.1   # newton: SHARE_STALLED if the tip error (still > 10x the
#                                  tolerance) has not dropped by 10 % over 5 iterations


def share_rule(share: str | None, min_tension_N: float = 0.0) -> str:
    """The sharing rule a user asked for: ``share`` ('min-norm', 'min-energy' or
    'none'); None means 'min-norm' with a floor (``min_tension_N`` > 0, newtons)
    and 'none' without.  :class:`InputError` for an unknown rule, a floor that is
    not a finite number >= 0, or a floor with 'none'."""
    if not (np.isfinite(min_tension_N) and min_tension_N >= 0):
        raise InputError(f"the minimum tension (--min-tension-N) must be a number of newtons "
                         f">= 0, got {min_tension_N}")
    if share is None:
        return "min-norm" if min_tension_N > 0 else "none"
    if share not in SHARES + ("none",):
        raise InputError(f"unknown tension sharing {share!r} (choose from {SHARES + ('none',)})")
    if share == "none" and min_tension_N > 0:
        raise InputError("a pretension floor (--min-tension-N) needs a sharing rule: "
                         "drop --share none")
    return share


def objective(share: str, ev: Evaluation) -> tuple[float, np.ndarray]:
    """(f, grad f) of the sharing rule at an evaluated state (module doc)."""
    p = ev.p
    if share == "min-norm":
        return 0.5 * float(p @ p), p.copy()
    dL = ev.sensitivity.cable_lengths                  # [i, j] = d L_j / d p_i
    return 0.5 * ev.equilibrium.strain_energy, -(dL @ p)


def kkt_residual(share: str, ev: Evaluation, p_min: float = 0.0, tol: float = 1e-9,
                 upper: float | None = None) -> float:
    """Relative first-order optimality residual at a state on the target:
    grad f = S lam + mu with mu_i >= 0 only where p_i = p_min, mu_i <= 0 only
    where p_i = ``upper`` (else 0).  Least-squares multipliers over the free
    tensions; returns max(|projected residual|, sign violations of mu) / |grad f|."""
    _, g = objective(share, ev)
    S = ev.sensitivity.tip                              # (n, 2)
    low = ev.p <= p_min + tol
    high = np.zeros_like(low) if upper is None else ev.p >= upper - tol
    free = ~(low | high)
    lam = np.linalg.lstsq(S[free], g[free], rcond=None)[0] if np.any(free) else np.zeros(2)
    r = g - S @ lam
    wrong = np.concatenate((-r[low], r[high]))
    scale = max(float(np.linalg.norm(g)), 1e-300)
    return max(float(np.linalg.norm(r[free])), float(wrong.max()) if wrong.size else 0.0) / scale


def _hessian_f(share: str, ev: Evaluation) -> np.ndarray:
    """The Hessian of f without its second-derivative terms: I (min-norm),
    -(dL/dp) symmetrised (min-energy; positive definite at a stable state)."""
    n = len(ev.p)
    if share == "min-norm":
        return np.eye(n)
    H = -ev.sensitivity.cable_lengths
    H = 0.5 * (H + H.T)
    w = np.linalg.eigvalsh(H)
    floor = 1e-6 * max(float(w.max()), 1e-12)
    return H + max(floor - float(w.min()), 0.0) * np.eye(n)


def _bfgs(W: np.ndarray, s: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Powell-damped BFGS update of W (stays positive definite)."""
    Ws = W @ s
    sWs = float(s @ Ws)
    if not sWs > 1e-300:
        return W
    sy = float(s @ y)
    if sy < 0.2 * sWs:
        theta = 0.8 * sWs / (sWs - sy)
        y = theta * y + (1.0 - theta) * Ws
        sy = float(s @ y)
    return W - np.outer(Ws, Ws) / sWs + np.outer(y, y) / sy


@dataclasses.dataclass
class WarmStart:
    """What the SQP hands from one point of a path to the next (module doc,
    ``newton``): the quasi-Newton matrix W, the multipliers and the active
    set.  One per path (:func:`elastica_petsc.studies.trace.trace` makes it),
    never kept on the sharer; None fields: a cold start."""

    W: np.ndarray | None = None
    lam: np.ndarray | None = None
    active: np.ndarray | None = None

    def clear(self) -> None:
        self.W = self.lam = self.active = None


@dataclasses.dataclass
class _Call:
    """One sharing solve's own state: its target (units of l) and floor, the
    equilibrium solves so far and (ALMM) the last state evaluated."""

    target: np.ndarray
    floor: float
    evals: int = 0
    current: Evaluation | None = None


@dataclasses.dataclass
class _Point:
    """One SQP iterate: the evaluation, f, grad f, tip error c, |c|."""

    ev: Evaluation
    f: float
    g: np.ndarray
    c: np.ndarray

    @property
    def S(self) -> np.ndarray:
        return self.ev.sensitivity.tip

    def merit(self, nu: float) -> float:
        return self.f + nu * float(np.abs(self.c).sum())


class TensionSharer:
    """The sharing rule on one controller (its equilibrium solver and sensitivities).

    share : ``min-norm`` or ``min-energy``.
    min_tension : the floor p_min (non-dimensional; P_min = p_min B / l^2).
    method : ``newton`` (SQP on the KKT system, default) or ``almm`` (TAO), module doc.
    max_it : iteration cap per target (both methods).
    max_evaluations : newton: cap on equilibrium solves per target (each can be a
        long continuation when the tensions change much).
    trust : newton: a step changes no tension by more than max(trust, max p).
    kkt_tol : newton: relative KKT residual (:func:`kkt_residual`) at convergence.
    """

    def __init__(self, controller: TipController, share: str = "min-norm",
                 min_tension: float = 0.0, *, method: str = "newton", max_it: int = 30,
                 max_evaluations: int = 60, trust: float = 10.0, kkt_tol: float = KKT_TOL,
                 comm=None, options_prefix: str = "share_", petsc_options=None):
        # almm: the subsolver (BQNLS) otherwise stalls at a gradient ~1e-8 of the
        # scaled problem for thousands of iterations (measured on a traced circle)
        self.options = SolverOptions(options_prefix, petsc_options,
                                     {"tao_almm_subsolver_tao_max_it": "100"})
        self.comm = check_comm(comm)
        if share not in SHARES:
            raise InputError(f"unknown tension sharing {share!r} (choose from {SHARES})")
        if method not in METHODS:
            raise InputError(f"unknown tension sharing method {method!r} (choose from {METHODS})")
        if not (np.isfinite(min_tension) and min_tension >= 0):
            raise InputError(f"the minimum tension must be >= 0, got {min_tension}")
        upper = controller.upper
        if upper is not None and min_tension >= upper:
            raise InputError(f"the minimum tension {min_tension:g} is not below the motor "
                             f"limit {upper:g} (P l^2/B)")
        self.controller, self.share, self.min_tension = controller, share, float(min_tension)
        self.method, self.max_it, self.trust, self.kkt_tol = method, int(max_it), trust, kkt_tol
        self.max_evaluations = int(max_evaluations)

    # --- public --------------------------------------------------------------------
    def solve(self, reached: ControlResult, floor: float | None = None,
              warm: WarmStart | None = None) -> ControlResult:
        """The shared tensions at ``reached.target``, from a state on it (``control``),
        from a cold start; ``warm`` (a path's) is cleared, then filled by this solve."""
        if self.method == "almm":
            return self._almm(reached)
        if warm is not None:
            warm.clear()
        start = Evaluation(reached.p.copy(), reached.equilibrium, reached.sensitivity,
                           reached.loading)
        res = self.track(reached.target, start, floor, warm)
        return dataclasses.replace(res, strategy=f"{reached.strategy}; shared {self.share}")

    def follow(self, target, previous: Evaluation | None, reacher, *, p0=None, start=None,
               start_loading=None, floor: float | None = None,
               global_search: bool = True, warm: WarmStart | None = None) -> ControlResult:
        """One point of a path (units of l): from the previous point's shared state
        (``previous``) and the path's ``warm`` start, :meth:`track` to ``target``; if that fails, or with no
        previous point (then from ``p0``/``start``), reach the target first
        (``reacher``: :class:`~elastica_petsc.solvers.reach.Reacher`) and share from there."""
        target = np.asarray(target, float)
        if previous is not None:
            if self.method == "newton":
                res = self.track(target, previous, floor, warm)
                if res.converged:
                    return res
            p0, start, start_loading = previous.p, previous.equilibrium, previous.loading
        # the reacher's seed library grows like n! levels^n equilibrium solves (about
        # 31,000 for n = 4, measured: minutes): its global search only up to 3 tendons
        reached = reacher.reach(target, p0=p0, start=start, start_loading=start_loading,
                                global_search=global_search and self.controller.n <= 3)
        if not reached.converged:
            return reached
        return self.solve(reached, floor, warm)

    def track(self, target, start: Evaluation, floor: float | None = None,
              warm: WarmStart | None = None) -> ControlResult:
        """SQP (module doc) from ``start`` to the shared tensions at ``target``
        (units of l), warm-started by ``warm`` (the previous point's W,
        multipliers and active set, updated here; None: a cold start)."""
        ctl = self.controller
        call = _Call(np.asarray(target, float),
                     self.min_tension if floor is None else float(floor))
        warm = WarmStart() if warm is None else warm
        floor = call.floor
        upper = np.inf if ctl.upper is None else ctl.upper
        tol_c = 0.1 * np.sqrt(2.0 * ctl.eps)
        cur = self._point(start, call.target)
        if np.any(start.p < floor):                # onto the floor first (the tip moves)
            raised = self._eval(np.maximum(start.p, floor), cur, call)
            if raised is None:
                return self._result(call, cur, SHARE_STALLED, 0, [cur], np.inf)
            cur = raised
        W = warm.W if warm.W is not None else _hessian_f(self.share, start)
        lam = np.zeros(2) if warm.lam is None else warm.lam
        guess, nu, reason, hist, kkt = warm.active, 0.0, SHARE_MAX_ITERATIONS, [cur], np.inf
        for it in range(self.max_it + 1):
            kkt = kkt_residual(self.share, cur.ev, floor, upper=ctl.upper)
            if (np.linalg.norm(cur.c) <= tol_c and np.min(cur.ev.p) >= floor - 1e-12
                    and kkt <= self.kkt_tol):
                reason = TARGET_REACHED
                break
            if it == self.max_it or call.evals >= self.max_evaluations:
                break
            errors = [float(np.linalg.norm(h.c)) for h in hist[-STALL_ITS - 1:]]
            if (len(errors) > STALL_ITS and errors[-1] > 10.0 * tol_c
                    and errors[-1] > (1.0 - STALL_GAIN) * errors[0]):
                reason = SHARE_STALLED
                break
            radius = max(self.trust, float(np.max(cur.ev.p)))
            lo = np.maximum(floor - cur.ev.p, -radius)
            hi = np.maximum(np.minimum(upper - cur.ev.p, radius), lo)
            qp = solve_box_qp(W, cur.g, cur.S, cur.c, lo, hi, guess)
            if qp is None:                          # restoration: bring the tip closer
                new, reason = self._restore(cur, lo, hi, call)
            else:
                lam, guess = qp.lam, qp.active
                nu = max(nu, 2.0 * float(np.max(np.abs(lam))))
                new, reason = self._merit_search(cur, qp, nu, call), reason
            if new is None:
                reason = SHARE_LINE_SEARCH_FAILURE if qp is not None else reason
                break
            y = (new.g - new.S @ lam) - (cur.g - cur.S @ lam)
            W = _bfgs(W, new.ev.p - cur.ev.p, y)
            cur = new
            hist.append(cur)
        warm.W, warm.lam, warm.active = W, lam, guess
        if reason != TARGET_REACHED:                  # report the closest tip found
            cur = min(hist, key=lambda h: float(np.linalg.norm(h.c)))
        return self._result(call, cur, reason, len(hist) - 1, hist, kkt)

    # --- newton internals ---------------------------------------------------------
    def _point(self, ev: Evaluation, target: np.ndarray) -> _Point:
        f, g = objective(self.share, ev)
        return _Point(ev, f, g, ev.equilibrium.tip - target)

    def _eval(self, p: np.ndarray, origin: _Point, call: _Call) -> _Point | None:
        call.evals += 1
        ev = self.controller.evaluate(np.maximum(p, 0.0), start=origin.ev.equilibrium,
                                      start_loading=origin.ev.loading,
                                      tangent=origin.ev.sensitivity.state_derivative)
        return None if ev is None else self._point(ev, call.target)

    def _clip(self, cur: _Point, p: np.ndarray, floor: float) -> np.ndarray:
        upper = np.inf if self.controller.upper is None else self.controller.upper
        return np.clip(p, np.minimum(floor, cur.ev.p), np.maximum(upper, cur.ev.p))

    def _merit_search(self, cur: _Point, qp, nu: float, call: _Call) -> _Point | None:
        """Backtracking on f + nu |c|_1 along the QP step, with a second-order
        correction of the tip error after a rejected full step (Maratos).  The
        tip error's round-off (TIP_NOISE per coordinate, times nu) is allowed: at
        a tip error of ~1e-15 l the last steps' f decrease is of that size too."""
        d = qp.d
        slope = float(cur.g @ d) - nu * float(np.abs(cur.c).sum())
        m0 = cur.merit(nu) + nu * TIP_NOISE * len(cur.c)
        alpha = 1.0
        for k in range(MAX_BACKTRACKS):
            new = self._eval(self._clip(cur, cur.ev.p + alpha * d, call.floor), cur, call)
            if new is not None and new.merit(nu) <= m0 + 1e-4 * alpha * slope:
                return new
            if k == 0 and new is not None:
                free = qp.active == FREE
                e = np.zeros_like(d)
                S = cur.S[free]
                e[free] = -S @ np.linalg.lstsq(S.T @ S, new.c, rcond=None)[0]
                soc = self._eval(self._clip(cur, cur.ev.p + d + e, call.floor), cur, call)
                if soc is not None and soc.merit(nu) <= m0 + 1e-4 * slope:
                    return soc
            alpha *= 0.5 if new is not None else 0.1
        return None

    def _restore(self, cur: _Point, lo, hi, call: _Call):
        """The QP is infeasible: a bounded least-squares step towards the target
        (:func:`closest_in_box`); (None, SHARE_INFEASIBLE) when it no longer
        brings the tip closer."""
        d, resid = closest_in_box(cur.S, cur.c, lo, hi)
        c0 = float(np.linalg.norm(cur.c))
        if c0 - resid <= INFEASIBLE_GAIN * c0:
            return None, SHARE_INFEASIBLE
        alpha = 1.0
        for _ in range(MAX_BACKTRACKS):
            new = self._eval(self._clip(cur, cur.ev.p + alpha * d, call.floor), cur, call)
            if new is not None and np.linalg.norm(new.c) <= c0 - 1e-4 * alpha * (c0 - resid):
                return new, SHARE_MAX_ITERATIONS
            alpha *= 0.5 if new is not None else 0.1
        return None, SHARE_LINE_SEARCH_FAILURE

    def _result(self, call: _Call, cur: _Point, reason: str, its: int, hist: list,
                kkt: float) -> ControlResult:
        """A ControlResult of the shared state (``converged``: reached and shared)."""
        ctl, target, floor = self.controller, call.target, call.floor
        ev, mm = cur.ev, ctl.length_mm
        E = 0.5 * float(cur.c @ cur.c)
        err_mm = float(np.linalg.norm(cur.c)) * mm
        taut = bool(np.min(ev.p) >= floor - 1e-9)
        floor_N = floor * ctl.arm.force_scale_N
        if reason == TARGET_REACHED:
            message = (f"tip within {err_mm:.2e} mm of the target; tensions shared "
                       f"{self.share} (KKT residual {kkt:.1e}, {its} SQP iterations)")
        elif reason in (SHARE_INFEASIBLE, SHARE_STALLED):
            why = ("the linearised tip constraint cannot be met within the bounds and the "
                   "closest step gains nothing" if reason == SHARE_INFEASIBLE else
                   "the tip error stopped decreasing (or no equilibrium at the raised tensions)")
            message = (f"no tension set with every P >= {floor_N:g} N was found that puts the tip "
                       f"on the target ({reason}): from this state {why} (tip {err_mm:.4g} mm "
                       f"away after {its} iterations). A local finding, not a proof: the target "
                       f"may be reachable with P >= {floor_N:g} N on another branch")
        else:
            message = (f"tension sharing ({self.share}) stopped ({reason}) after {its} "
                       f"iterations and {call.evals} equilibrium solves with the tip "
                       f"{err_mm:.3g} mm from the target and KKT residual {kkt:.1e}")
        tol = 1e-9
        upper = np.inf if ctl.upper is None else ctl.upper
        on_bound = tuple((i + 1, "lower") for i in np.flatnonzero(ev.p <= floor + tol)) + tuple(
            (i + 1, "upper") for i in np.flatnonzero(ev.p >= upper - tol))
        return ControlResult(
            converged=reason == TARGET_REACHED and E < ctl.eps, reachable=True if (
                E < ctl.eps and taut) else None, reason=reason, tao_reason="none (SQP)",
            message=message, method=f"share {self.share} ({self.method})", iterations=its,
            evaluations=call.evals, failed_evaluations=0, target=np.asarray(target).copy(),
            p=ev.p.copy(), tip=ev.equilibrium.tip.copy(), tip_error=err_mm / mm, E=E,
            eps=ctl.eps, equilibrium=ev.equilibrium, sensitivity=ev.sensitivity,
            cable_lengths=ev.equilibrium.cable_lengths.copy(),
            history_p=np.array([h.ev.p for h in hist]),
            history_tip=np.array([h.ev.equilibrium.tip for h in hist]),
            history_E=np.array([0.5 * float(h.c @ h.c) for h in hist]), on_bound=on_bound,
            length_mm=mm, force_scale_N=ctl.arm.force_scale_N, loading=ev.loading,
            strategy=f"shared {self.share}")

    # --- almm ----------------------------------------------------------------------
    def _almm_eval(self, p: np.ndarray, call: _Call) -> Evaluation | None:
        cur = call.current
        if np.array_equal(cur.p, p):
            return cur
        call.evals += 1
        ev = self.controller.evaluate(np.maximum(p, 0.0), start=cur.equilibrium,
                                      start_loading=cur.loading)
        if ev is not None:
            call.current = ev
        return ev

    def _almm(self, reached: ControlResult) -> ControlResult:
        """TAO ALMM from the reached state, then a tip-control polish (module doc)."""
        ctl, target = self.controller, reached.target
        call = _Call(target, self.min_tension, current=Evaluation(
            reached.p.copy(), reached.equilibrium, reached.sensitivity, reached.loading))
        tao, vecs = self._create(ctl.n, call)
        try:
            vecs[0].setArray(np.maximum(reached.p, self.min_tension))
            tao.solve(vecs[0])
            reason = converged_reason(tao)
            its = tao.getIterationNumber()
            p = np.maximum(vecs[0].getArray(readonly=True).copy(), self.min_tension)
        finally:
            for obj in (tao, *vecs):
                obj.destroy()
        ev = self._almm_eval(p, call) or call.current
        res = ctl.solve(target, p0=ev.p, start=ev.equilibrium, start_loading=ev.loading)
        res = dataclasses.replace(res, iterations=its + res.iterations,
                                  evaluations=call.evals + res.evaluations)
        if not res.converged or np.min(res.p) < self.min_tension - 1e-9:
            return dataclasses.replace(
                res, converged=False, reachable=None, reason=SHARE_FAILED,
                message=f"tension sharing ({self.share}, TAO ALMM reason {reason}) did not "
                        f"end on the target with p >= {self.min_tension:g}: {res.message}")
        return dataclasses.replace(res, strategy=f"{reached.strategy}; shared {self.share}")

    def _create(self, n: int, call: _Call):
        x = PETSc.Vec().createSeq(n, comm=self.comm)
        lb, ub = x.duplicate(), x.duplicate()
        lb.set(self.min_tension)
        ub.set(PETSc.INFINITY if self.controller.upper is None else self.controller.upper)
        ce = PETSc.Vec().createSeq(2, comm=self.comm)
        J = PETSc.Mat().createDense((2, n), comm=self.comm)
        J.setUp()

        # scaling: f / f_0 (f_0 at the reached state) and the tip error in units of
        # CONSTRAINT_SCALE (1e-3 l), so that multipliers and penalties are O(1)
        f_scale = max(abs(objective(self.share, call.current)[0]), 1e-12)
        c_scale, target = CONSTRAINT_SCALE, call.target

        def fg(tao, X, G):
            ev = self._almm_eval(X.getArray(readonly=True).copy(), call)
            if ev is None:                    # no equilibrium: steer back
                G.setArray(X.getArray(readonly=True) - call.current.p)
                return 1e6
            f, g = objective(self.share, ev)
            G.setArray(g / f_scale)
            return f / f_scale

        def con(tao, X, C):
            ev = self._almm_eval(X.getArray(readonly=True).copy(), call) or call.current
            C.setArray((ev.equilibrium.tip - target) / c_scale)

        def jac(tao, X, A, P):
            ev = self._almm_eval(X.getArray(readonly=True).copy(), call) or call.current
            A.setValues(range(2), range(n), ev.sensitivity.tip.T.ravel() / c_scale)
            A.assemble()

        tao = PETSc.TAO().create(self.comm)
        self.options.label(tao, x, lb, ub, ce, J)
        tao.setType(PETSc.TAO.Type.ALMM)
        tao.setSolution(x)
        tao.setObjectiveGradient(fg, None)
        tao.setVariableBounds(lb, ub)
        tao.setEqualityConstraints(con, ce)
        tao.setJacobianEquality(jac, J, J)
        tao.setTolerances(gatol=GATOL)
        tao.setConstraintTolerances(catol=1e-9 / c_scale)
        tao.setMaximumIterations(self.max_it)
        self.options.apply(tao)
        return tao, (x, lb, ub, ce, J)


def family(controller: TipController, ev: Evaluation, target, j: int, values,
           tol: float = 1e-12) -> list[Evaluation]:
    """An independent check of the sharing (n = 3): the tension sets on the
    target with p_j fixed at each of ``values`` (in order), by Newton on the
    other two tensions (the 2 x 2 block of the tip Jacobian, Eq. (13)), each
    continued from the last; stops at the first value it cannot reach.
    Returns the states found (tip within ``tol`` l of the target)."""
    target = np.asarray(target, float)
    others = [i for i in range(len(ev.p)) if i != j]
    if len(others) != 2:
        raise InputError(f"the family check needs 3 tendons, got {len(ev.p)}")
    found = []
    for t in values:
        for _ in range(30):
            r = ev.equilibrium.tip - target
            if np.linalg.norm(r) < tol and ev.p[j] == t:
                break
            S, p = ev.sensitivity.tip, ev.p.copy()
            p[others] += np.linalg.solve(S[others].T, -r - S[j] * (t - p[j]))
            p[j] = t
            ev = controller.evaluate(np.maximum(p, 0.0), start=ev.equilibrium)
            if ev is None:
                return found
        if np.linalg.norm(ev.equilibrium.tip - target) < 10 * tol:
            found.append(ev)
    return found
