"""Redundant tendons (n >= 3): choose how tension is shared among the tension
sets that put the tip on the target.

With n tendons the tensions reaching a tip x_d form (locally) an
(n - 2)-dimensional family.  :class:`TensionSharer` picks one:

    minimise f(p)  subject to  x_t(p) = x_d  (2 equations, Eq. (11) at E = 0)
                               p_i >= p_min  (a pretension floor: every cable taut)

with ``share``

* ``min-norm``:   f = |p|^2 / 2,                 grad f = p;
* ``min-energy``: f = U(p) / (B/l), the strain energy (Eq. (21)) of the
  equilibrium, grad f = -(dL/dp) p: at equilibrium dU/dtheta = -sum_j p_j
  dL_j/dtheta (the stationarity of Pi = U + sum_j p_j L_j, docs/model.md §2),
  so dU/dp_i = -sum_j p_j dL_j/dp_i (one more use of the sensitivities of
  :mod:`sensitivity`, no extra solve).

Solved with PETSc TAO ALMM (augmented Lagrangian; equality constraint x_t - x_d
with Jacobian S^T, S[i] = d x_t / d p_i (Eq. (13)); bounds p >= p_min), started
from a state that already reaches the target (:mod:`reach`), every equilibrium
continued from the last one computed (the branch is followed) and its loading
path recorded.  The first-order optimality (KKT) conditions are checked by
:func:`kkt_residual`.  Non-dimensional throughout.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from petsc4py import PETSc

from .options import set_from_options
from ..core.errors import InputError
from .control import ControlResult, Evaluation, TipController

SHARES = ("min-norm", "min-energy")
CONSTRAINT_SCALE = 1e-3      # tip error unit inside the ALMM solve, units of l
GATOL = 1e-7                 # ALMM gradient tolerance of the scaled problem (f / f_0)


def objective(share: str, ev: Evaluation) -> tuple[float, np.ndarray]:
    """(f, grad f) of the sharing rule at an evaluated state (module doc)."""
    p = ev.p
    if share == "min-norm":
        return 0.5 * float(p @ p), p.copy()
    dL = ev.sensitivity.cable_lengths                  # [i, j] = d L_j / d p_i
    return 0.5 * ev.equilibrium.strain_energy, -(dL @ p)


def kkt_residual(share: str, ev: Evaluation, p_min: float = 0.0, tol: float = 1e-9) -> float:
    """Relative first-order optimality residual at a state on the target:
    grad f = S lam + mu with mu_i >= 0 only where p_i = p_min (else 0).
    Least-squares multipliers over the free tensions; returns
    max(|projected residual|, -min(mu)) / |grad f|."""
    _, g = objective(share, ev)
    S = ev.sensitivity.tip                              # (n, 2)
    bound = ev.p <= p_min + tol
    free = ~bound
    lam = np.linalg.lstsq(S[free], g[free], rcond=None)[0] if np.any(free) else np.zeros(2)
    r = g - S @ lam
    mu = r[bound]
    scale = max(float(np.linalg.norm(g)), 1e-300)
    return max(float(np.linalg.norm(r[free])), float(-mu.min()) if mu.size else 0.0) / scale


class TensionSharer:
    """The sharing rule on one controller (its equilibrium solver and sensitivities).

    share : ``min-norm`` or ``min-energy``.
    min_tension : the floor p_min (non-dimensional; P_min = p_min B / l^2).
    """

    def __init__(self, controller: TipController, share: str = "min-norm",
                 min_tension: float = 0.0, max_it: int = 50):
        if share not in SHARES:
            raise InputError(f"unknown tension sharing {share!r} (choose from {SHARES})")
        if not (np.isfinite(min_tension) and min_tension >= 0):
            raise InputError(f"the minimum tension must be >= 0, got {min_tension}")
        upper = controller.upper
        if upper is not None and min_tension >= upper:
            raise InputError(f"the minimum tension {min_tension:g} is not below the motor "
                             f"limit {upper:g} (P l^2/B)")
        self.controller, self.share, self.min_tension = controller, share, float(min_tension)
        self.max_it = max_it
        self._current: Evaluation | None = None

    def _eval(self, p: np.ndarray) -> Evaluation | None:
        cur = self._current
        if cur is not None and np.array_equal(cur.p, p):
            return cur
        ev = self.controller.evaluate(np.maximum(p, 0.0), start=cur.equilibrium,
                                      start_loading=cur.loading)
        if ev is not None:
            self._current = ev
        return ev

    def solve(self, reached: ControlResult) -> ControlResult:
        """The shared tensions at ``reached.target``, from the reached state."""
        ctl = self.controller
        n = ctl.n
        self._current = Evaluation(reached.p.copy(), reached.equilibrium, reached.sensitivity,
                                   reached.loading)
        target = reached.target
        tao, vecs = self._create(n, target)
        try:
            vecs[0].setArray(np.maximum(reached.p, self.min_tension))
            tao.solve(vecs[0])
            reason = tao.getConvergedReason()
            p = np.maximum(vecs[0].getArray(readonly=True).copy(), self.min_tension)
        finally:
            for obj in (tao, *vecs):
                obj.destroy()
        ev = self._eval(p) or self._current
        res = ctl.solve(target, p0=ev.p, start=ev.equilibrium, start_loading=ev.loading)
        if not res.converged or np.min(res.p) < self.min_tension - 1e-9:
            return dataclasses.replace(
                res, converged=False, reachable=None, reason="SHARE_FAILED",
                message=f"tension sharing ({self.share}, TAO ALMM reason {reason}) did not "
                        f"end on the target with p >= {self.min_tension:g}: {res.message}")
        return dataclasses.replace(res, strategy=f"{reached.strategy}; shared {self.share}")

    def _create(self, n: int, target: np.ndarray):
        x = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        lb, ub = x.duplicate(), x.duplicate()
        lb.set(self.min_tension)
        ub.set(PETSc.INFINITY if self.controller.upper is None else self.controller.upper)
        ce = PETSc.Vec().createSeq(2, comm=PETSc.COMM_SELF)
        J = PETSc.Mat().createDense((2, n), comm=PETSc.COMM_SELF)
        J.setUp()

        # scaling: f / f_0 (f_0 at the reached state) and the tip error in units of
        # CONSTRAINT_SCALE (1e-3 l), so that multipliers and penalties are O(1)
        f_scale = max(abs(objective(self.share, self._current)[0]), 1e-12)
        c_scale = CONSTRAINT_SCALE

        def fg(tao, X, G):
            ev = self._eval(X.getArray(readonly=True).copy())
            if ev is None:                    # no equilibrium: steer back
                G.setArray(X.getArray(readonly=True) - self._current.p)
                return 1e6
            f, g = objective(self.share, ev)
            G.setArray(g / f_scale)
            return f / f_scale

        def con(tao, X, C):
            ev = self._eval(X.getArray(readonly=True).copy()) or self._current
            C.setArray((ev.equilibrium.tip - target) / c_scale)

        def jac(tao, X, A, P):
            ev = self._eval(X.getArray(readonly=True).copy()) or self._current
            A.setValues(range(2), range(n), ev.sensitivity.tip.T.ravel() / c_scale)
            A.assemble()

        tao = PETSc.TAO().create(PETSc.COMM_SELF)
        tao.setOptionsPrefix("share_")
        tao.setType(PETSc.TAO.Type.ALMM)
        tao.setSolution(x)
        tao.setObjectiveGradient(fg, None)
        tao.setVariableBounds(lb, ub)
        tao.setEqualityConstraints(con, ce)
        tao.setJacobianEquality(jac, J, J)
        tao.setTolerances(gatol=GATOL)
        tao.setConstraintTolerances(catol=1e-9 / c_scale)
        tao.setMaximumIterations(self.max_it)
        # the subsolver (BQNLS) otherwise stalls at a gradient ~1e-8 of the scaled
        # problem for thousands of iterations (measured on a traced circle)
        set_from_options(tao, "share_", {"tao_almm_subsolver_tao_max_it": "100"})
        return tao, (x, lb, ub, ce, J)
