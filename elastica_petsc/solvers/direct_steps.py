"""Direct Gauss-Newton steps of tip control, before TAO (issue 25).

On a warm-started point of a path (the start's evaluation is known) the
BLMVM iteration of :mod:`.control` is, step after step, the full
Gauss-Newton/Levenberg-Marquardt step s of :meth:`TipProblem.gauss_newton`
(its initial Hessian is that metric, its history is off, its bounds are the
box between p and p + s) accepted at unit length by the More-Thuente line
search.  This module takes those steps itself,

    p <- P[p + s],   accepted when   E(p + s) <= E(p) + 1e-4 g.s          (Armijo)
                            and   |g(p + s).s| <= 0.1 |g.s|              (curvature)

(TAO's ``ftol`` and our ``LINE_SEARCH_GTOL``: the strong Wolfe conditions
More-Thuente checks first at the unit step), with the same stopping test
(:meth:`TipProblem.stop`) at every iterate, so a warm point costs no TAO
set-up, callbacks or PETSc matrix of the metric.  The first step that is not
accepted (or a failed equilibrium) hands the current iterate to TAO, which
then runs as before from there.
"""
from __future__ import annotations

import math

import numpy as np

from .reasons import TAO_REASONS
from .tip_problem import Evaluation, TipProblem

ARMIJO = 1e-4            # TAO's More-Thuente ftol
CURVATURE = 0.1          # control.LINE_SEARCH_GTOL


def gauss_newton_steps(problem: TipProblem, ev: Evaluation, max_steps: int,
                       correction: np.ndarray | None = None):
    """Up to ``max_steps`` accepted Gauss-Newton steps from the known
    evaluation ``ev``; ``correction`` (the path predictor of
    :class:`PathPredictor`) is added to the first.  Returns (evaluation,
    TAO-style reason or None, steps): a reason when :meth:`TipProblem.stop`
    ended the solve, None when TAO must continue from the evaluation
    returned (its iterate not yet recorded).  ``problem.first_step`` is the
    first Gauss-Newton step (without the correction)."""
    upper = problem.rule.upper
    problem.evaluations += 1                          # as TAO's first evaluation, cached
    p = ev.p
    r, E = problem.residual_E(ev)
    g = ev.sensitivity.tip @ r                        # Eq. (12)
    problem.E_max = max(problem.E_max, E)
    problem.last_good = ev
    its = 0
    while True:
        problem.history.append((p, ev.equilibrium.tip.copy(), E))
        step = problem.gauss_newton(ev)[1] if E >= problem.rule.eps else None
        corrected = its == 0 and correction is not None and step is not None
        if its == 0:
            problem.first_step = step
        if corrected:
            step = step + correction
        pg = problem.projected_gradient(p, g)
        pgnorm = math.sqrt(float(pg @ pg))
        stop = problem.stop(its, E, pgnorm, ev)
        if stop is not None:
            problem.reason = stop[0]
            return ev, TAO_REASONS[stop[1]], its
        if its >= max_steps:
            break
        p_new = np.minimum(np.maximum(p + step, 0.0), upper)
        d = p_new - p
        slope = float(g @ d)
        ev_new, E_new, g_new = problem.objective(p_new)
        if ev_new is not None:
            problem.E_max = max(problem.E_max, E_new)   # as TAO's penalised objective
        if ev_new is None or not (E_new <= E + ARMIJO * slope
                                  and abs(float(g_new @ d)) <= CURVATURE * abs(slope)):
            if not corrected:   # TAO's line search tries p_new first again (cached or
                problem.evaluations -= 1        # known to fail): counted there, not twice
                problem.failed -= ev_new is None
            break
        p, ev, E, g = ev_new.p, ev_new, E_new, g_new
        its += 1
    problem.history.pop()                 # TAO evaluates and records this iterate again
    problem.best_E.pop()
    problem.evaluations -= 1
    return ev, None, its


class PathPredictor:
    """The second-order defect of the previous point of a path, as a
    correction of the next point's first Gauss-Newton step.

    Along a path x_d^k with steps dx_k = x_d^k - x_t(p_{k-1}), the first
    Gauss-Newton step s_k = S_{k-1}^+ dx_k is exact to first order; the
    tensions actually needed differ by the quadratic term of p(x_d),
    q_k = (p_k^* - p_{k-1}) - s_k (p_k^*: p_k with its residual tip error
    removed, S_k^+ (x_t - x_d^k)).  When the next step is nearly the same
    vector (|dx_{k+1} - dx_k| <= ``SAME_STEP`` |dx_k|: straight lines and
    arcs of equally spaced points) the first step is s_{k+1} plus the
    defect extrapolated along the path, 2 q_k - q_{k-1}, and turned with the
    step: a change v of the first step changes the defect by -S^+ dS^T v to
    first order (dS = S_k - S_{k-1} ~ d^2 x_t / dp^2 [p_k - p_{k-1}, .];
    S^+ = S (S^T S)^{-1}), for the vertices of polygons and arcs.  So
    most points land within the tolerance in one step where the plain step
    needs two (docs/model.md §25).  The corrected step must still pass the
    line search's tests (:func:`gauss_newton_steps`), else TAO takes over."""

    SAME_STEP = 0.25

    def __init__(self):
        self.end = None                  # the equilibrium of the last point
        self.dx = self.defect = self.last = None

    def _turn(self, v: np.ndarray) -> np.ndarray:
        """-S^+ dS^T v: the change of the defect when the first step changes by v."""
        return -self.S_plus @ (self.dS.T @ v)

    def correction(self, start, target: np.ndarray) -> np.ndarray | None:
        """The defect to add to the first step of a solve from ``start``."""
        if start is None or start is not self.end:
            return None
        dx = target - start.tip
        if float(np.linalg.norm(dx - self.dx)) > self.SAME_STEP * float(np.linalg.norm(self.dx)):
            return None
        step = self.S_plus @ dx                          # the first step, to first order
        return self.defect + self._turn(step - self.first)

    def record(self, start, target: np.ndarray, known: Evaluation, problem: TipProblem,
               ev: Evaluation | None, reached: bool) -> None:
        """Remember the defect of a point reached from ``start`` (evaluation ``known``)."""
        chained = start is not None and start is self.end
        self.end = None
        if not reached or start is None or problem.first_step is None:
            return
        S = ev.sensitivity.tip                       # (n, 2): remove the residual error
        p0 = known.p
        step = ev.p - p0
        try:
            S_plus = S @ np.linalg.inv(S.T @ S)      # S^+ = S (S^T S)^{-1}
        except np.linalg.LinAlgError:                # S rank one (the straight arm)
            return
        fix = S_plus @ (ev.equilibrium.tip - target)
        if not (np.all(np.isfinite(fix)) and fix @ fix <= step @ step):
            return                                   # S nearly singular: no prediction
        defect = (ev.p - fix - p0) - problem.first_step
        first = problem.first_step
        self.S_plus, self.dS = S_plus, S - known.sensitivity.tip
        if chained and self.last is not None:        # the last defect turned to this step
            self.defect = 2.0 * defect - (self.last + self._turn(first - self.first))
        else:
            self.defect = defect
        self.end, self.dx, self.last, self.first = ev.equilibrium, target - start.tip, defect, first
