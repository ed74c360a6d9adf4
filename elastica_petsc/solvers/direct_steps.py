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


def gauss_newton_steps(problem: TipProblem, ev: Evaluation, max_steps: int):
    """Up to ``max_steps`` accepted Gauss-Newton steps from the known
    evaluation ``ev``.  Returns (evaluation, TAO-style reason or None, steps):
    a reason when :meth:`TipProblem.stop` ended the solve, None when TAO must
    continue from the evaluation returned (its iterate not yet recorded)."""
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
        if ev_new is None or not (E_new <= E + ARMIJO * slope
                                  and abs(float(g_new @ d)) <= CURVATURE * abs(slope)):
            break                         # TAO's line search takes over from p
        problem.E_max = max(problem.E_max, E_new)
        p, ev, E, g = ev_new.p, ev_new, E_new, g_new
        its += 1
    problem.history.pop()                 # TAO records this iterate again
    problem.best_E.pop()
    return ev, None, its
