"""The paper's gradient descent for tip control (Algorithm 1, Fig. 2c).

    p <- P[p - gamma grad E]          (P: projection on the tension bounds)

with an adaptive step gamma: the Barzilai-Borwein step s.y / y.y of the
last two iterates, capped so that the linearised tip motion stays below
2 |x_t - x_d|, halved until E decreases (Armijo), so E decreases
monotonically as in Fig. 2c.  Our own loop, not TAO: TAO's steepest
descent (BNCG, ``-tao_bncg_type gd``, More-Thuente step) did not reach the
target of Fig. 2 within 5000 iterations (tip still 0.009 mm off), whereas
this loop needs 17 iterations ("over a dozen", Sec. 3).  PETSc options do
not apply to it.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from .reasons import TAO_REASONS
from .tip_problem import LINE_SEARCH_FAILURE, Evaluation, TipProblem


def _step_length(problem: TipProblem, p, E: float, g, ev: Evaluation, gamma):
    """gamma: the previous BB step (None: the step whose linearised tip motion
    is |x_t - x_d|), capped so the linearised tip motion stays below
    2 |x_t - x_d| and no tension changes by more than max(trust_tension, max p)."""
    tip_rate = np.linalg.norm(ev.sensitivity.tip.T @ g)      # |d x_t / d gamma|
    cap = 2.0 * np.sqrt(2.0 * E) / max(tip_rate, 1e-300)
    trust = problem.rule.trust_tension
    if trust is not None:
        radius = max(trust, float(np.max(p)))
        cap = min(cap, radius / max(float(np.max(np.abs(g))), 1e-300))
    return cap / 2.0 if gamma is None else min(gamma, cap)


def gradient_descent(problem: TipProblem, p0: np.ndarray) -> tuple[Evaluation | None, str, int]:
    """Algorithm 1 from ``p0`` on ``problem``: the step is halved until E
    decreases (Armijo, 1e-4; cut by 10 after a failed equilibrium).
    Returns (final evaluation, TAO-style reason name, iterations)."""
    upper = problem.rule.upper
    Reason = PETSc.TAO.Reason
    p = np.clip(p0, 0.0, upper)
    ev, E, g = problem.objective(p)
    if ev is None:
        return None, "EQUILIBRIUM_FAILURE", 0
    its = 0
    gamma = None
    while True:
        problem.history.append((p.copy(), ev.equilibrium.tip.copy(), E))
        stop = problem.stop(its, E, float(np.linalg.norm(problem.projected_gradient(p, g))), ev)
        if stop is not None:
            problem.reason = stop[0]
            return ev, TAO_REASONS[stop[1]], its
        gamma = _step_length(problem, p, E, g, ev, gamma)
        d = np.clip(p - gamma * g, 0.0, upper) - p
        lam, slope = 1.0, float(g @ d)
        while True:
            p_new = p + lam * d
            ev_new, E_new, g_new = problem.objective(p_new)
            if E_new <= E + 1e-4 * lam * slope:
                break
            lam *= 0.5 if ev_new is not None else 0.1    # failed equilibria are costly
            if lam < 1e-8 or problem.evaluations >= problem.rule.max_evaluations:
                problem.reason = LINE_SEARCH_FAILURE
                return ev, TAO_REASONS[Reason.DIVERGED_LS_FAILURE], its
        s, y = p_new - p, g_new - g
        sy = float(s @ y)
        gamma = sy / float(y @ y) if sy > 0 else None            # BB2 step
        p, ev, E, g = p_new, ev_new, E_new, g_new
        its += 1
