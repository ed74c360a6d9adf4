"""Newton's method on the tip (two tendons) for the boundary-filled map
(docs/model.md, "Maps filled from the traced boundary").

With n = 2 tendons the tip map x_t(p) (Eq. (13)) is square, so a target x_d
inside W_0 is reached by Newton's method on x_t(p) = x_d:
p <- p + S^{-1} (x_d - x_t(p)), S = d x_t / d p (Eq. (13)), each step an
equilibrium solve (Eq. (9)) at fixed tensions from the Euler predictor
u + (du/dp) dp (Eq. (14)): about two Newton iterations of the equilibrium per
step and two steps per grid neighbour, against tip control's line searches.
A step is refused (the caller falls back to tip control) when it leaves
P_i >= 0 or the motor limit, jumps to another branch (an angle moves more
than ``jump_tol`` from its predictor), pulls a cable onto its routing point,
or meets a singular S (a fold of the tip map).  Stability is checked by the
caller (the smallest eigenvalue it records anyway).

:class:`Anchors`: warm starts for the first sample of a chunk, equilibria on
proportional loading rays p = s (cos a, sin a) by continuation from the
straight arm (a fixed function of the arm, so a map does not depend on how
its chunks are spread over ranks).
"""
from __future__ import annotations

import math

import numpy as np

from ...solvers.equilibrium import COLLAPSE_LENGTH, Equilibrium, newton_converged
from ...solvers.sensitivity import SensitivityError


class TipNewton:
    """Newton's method on x_t(p) = x_d for a two-tendon arm, borrowing the
    equilibrium and sensitivity solvers of a :class:`~elastica_petsc.solvers.control.TipController`.

    ``tol``: the tip tolerance in units of l, that of tip control's E < eps
    (|x_t - x_d| < sqrt(2 eps)); ``max_dp``: largest tension change of one step;
    ``max_steps``: Newton steps per target; ``homotopy_l``: largest distance (units
    of l) between consecutive targets of :meth:`reach`, ``halvings``: how often
    a refused step of it is halved before it gives up; ``path_tol``: the tip
    tolerance (units of l) at the homotopy's intermediate targets."""

    max_steps = 8
    max_dp = 4.0
    jump_tol = 0.5
    homotopy_l = 0.05
    path_tol = 1e-3
    halvings = 3

    def __init__(self, controller):
        self.solver, self.sens = controller.solver, controller.sens
        self.disc = controller.disc
        self.tol = math.sqrt(2.0 * controller.eps)
        self.upper = np.inf if controller.upper is None else float(controller.upper)
        self.iterations = 0               # equilibrium Newton iterations of the last reach

    def start(self, eq: Equilibrium):
        """(equilibrium, sensitivity) of a converged state, or None."""
        try:
            return eq, self.sens.compute(eq)
        except SensitivityError:
            return None

    def solve(self, target: np.ndarray, start, tol: float | None = None):
        """(equilibrium, sensitivity) with the tip within ``tol`` (default
        ``self.tol``) of ``target`` (units of l) by Newton steps from ``start`` =
        (equilibrium, sensitivity), or None where a step is refused (module doc).
        The sensitivity returned is that of the state where the last Newton step
        started (within one quadratically small step of the state returned): it
        serves only as the predictor of the next target, and saves one
        factorisation per target."""
        eq, sens = start
        tol = self.tol if tol is None else tol
        N = self.disc.n_elements
        for _ in range(self.max_steps):
            residual = np.asarray(target, float) - eq.tip
            if np.linalg.norm(residual) < tol:
                return eq, sens
            try:
                dp = np.linalg.solve(sens.tip_jacobian, residual)
            except np.linalg.LinAlgError:
                return None
            p = eq.p + dp
            if (not np.all(np.isfinite(dp)) or np.max(np.abs(dp)) > self.max_dp
                    or p.min() < 0.0 or p.max() > self.upper):
                return None
            u0 = eq.u + dp @ sens.state_derivative                  # Euler predictor, Eq. (14)
            u, its, reason = self.solver.newton(u0, p)
            self.iterations += its
            if not newton_converged(reason) or np.max(np.abs(u[:N] - u0[:N])) > self.jump_tol:
                return None
            eq = Equilibrium(self.disc, p, u, True, reason, its, 1)
            if np.min(eq.cable_lengths) < COLLAPSE_LENGTH:
                return None
            if np.linalg.norm(np.asarray(target, float) - eq.tip) < tol:
                return eq, sens            # S of the step before: a predictor for the next
            try:
                sens = self.sens.compute(eq)
            except SensitivityError:
                return None
        return None

    def reach(self, target: np.ndarray, start):
        """:meth:`solve` along the straight segment from ``start``'s tip to
        ``target`` (a homotopy in target space): steps of at most ``homotopy_l``,
        halved after a refused step and doubled after an accepted one; None
        once a step of ``homotopy_l / 2**halvings`` (or the last, shorter
        remainder) is refused."""
        self.iterations = 0
        tip, state = start[0].tip, start
        length = max(float(np.linalg.norm(target - tip)), 1e-300)
        ds_max = min(1.0, self.homotopy_l / length)
        ds_min, s, ds = ds_max / 2 ** self.halvings, 0.0, ds_max
        while s < 1.0:
            step = min(ds, 1.0 - s)
            last = step >= 1.0 - s
            found = self.solve(target if last else tip + (target - tip) * (s + step), state,
                               None if last else self.path_tol)
            if found is None:
                if step <= ds_min * (1.0 + 1e-12):
                    return None
                ds = 0.5 * step
                continue
            state, s = found, (1.0 if last else s + step)
            ds = min(2.0 * step, ds_max)
        return state


class Anchors:
    """Warm starts for a target with no reached neighbour: the nodes of the
    traced W_0 loop (:mod:`elastica_petsc.studies.boundary`) on the faces
    P_i = 0 of D (stable states; the fold and collapse curves are not: S or
    the tangent is singular there), with their sensitivities (built on first
    use; a fixed function of the arm's traced boundary)."""

    def __init__(self, newton: TipNewton, boundary):
        self.newton, self.boundary = newton, boundary
        self._states = None
        self._tips = None

    def _build(self) -> None:
        disc, states = self.newton.disc, []
        faces = {f"P{i + 1}=0" for i in range(disc.n_tendons)}
        for curve in self.boundary.regions["W0"].curves:
            if curve.constraint not in faces:
                continue
            for point in curve.points:
                w = np.asarray(point.w, float)
                p = np.maximum(w[-disc.n_tendons:], 0.0)
                eq = Equilibrium(disc, p, w[:-disc.n_tendons].copy(), True, "loop node", 0, 0)
                if np.min(eq.cable_lengths) < 5 * COLLAPSE_LENGTH:
                    continue
                state = self.newton.start(eq)
                if state is not None:
                    states.append(state)
        self._states = states
        self._tips = np.array([s[0].tip for s in states]).reshape(-1, 2)

    def nearest(self, target: np.ndarray, count: int = 2) -> list:
        """The ``count`` anchors whose tips lie nearest ``target`` (units of l)."""
        if self._states is None:
            self._build()
        if not self._states:
            return []
        order = np.argsort(np.linalg.norm(self._tips - target, axis=1), kind="stable")
        return [self._states[i] for i in order[:count]]
