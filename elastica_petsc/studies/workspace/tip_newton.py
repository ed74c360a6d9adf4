"""Newton's method on the tip (two tendons) for the boundary-filled map
(docs/model.md, "Maps filled from the traced boundary").

With n = 2 tendons the tip map x_t(p) (Eq. (13)) is square, so a target x_d
inside W_0 is reached by Newton's method on x_t(p) = x_d, S = d x_t / d p
(Eq. (13)), with the equilibrium F(u, p) = 0 (Eq. (9)) solved together with
it: Newton's method on the unknowns (u, p) from the Euler predictor
p + S^{-1} (x_d - x_t), u + (du/dp) dp (Eq. (14)), one factorisation of
dF/du per iteration (:meth:`TipNewton.solve`; about 2.5 per grid neighbour,
against about 6.5 when each step on p was an equilibrium solve followed by
a sensitivity solve), against tip control's line searches.
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
from dataclasses import dataclass

import numpy as np

from ...solvers.equilibrium import COLLAPSE_LENGTH, Equilibrium
from ...solvers.sensitivity import SensitivityError


def solve2(S: np.ndarray, r: np.ndarray) -> np.ndarray:
    """S^{-1} r for the 2 x 2 tip Jacobian (n = 2) in closed form;
    LinAlgError if S is singular (a fold of the tip map) or not finite."""
    (a, b), (c, d) = S.tolist()
    det = a * d - b * c
    if det == 0.0 or not math.isfinite(det):
        raise np.linalg.LinAlgError("singular tip Jacobian")
    r0, r1 = r.tolist()
    return np.array(((d * r0 - b * r1) / det, (a * r1 - c * r0) / det))


@dataclass(frozen=True)
class Linearisation:
    """What a Newton step on the tip needs of a state: du/dp_i (rows, Eq. (14))
    and S = d x_t / d p (Eq. (13)), as :class:`Sensitivity` has them."""

    state_derivative: np.ndarray      # (n, size)
    tip_jacobian: np.ndarray          # (2, n)


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
        self.iterations = 0               # Newton iterations (factorisations) of the last reach

    def start(self, eq: Equilibrium):
        """(equilibrium, sensitivity) of a converged state, or None."""
        try:
            return eq, self.sens.compute(eq)
        except SensitivityError:
            return None

    def solve(self, target: np.ndarray, start, tol: float | None = None):
        """(equilibrium, linearisation) with the tip within ``tol`` (default
        ``self.tol``) of ``target`` (units of l), from ``start`` = (equilibrium,
        linearisation: a :class:`Sensitivity` or :class:`Linearisation`), or
        None where a step is refused (module doc).

        Newton's method on the equilibrium and the tip together (module doc):
        unknowns (u, p), equations F(u, p) = 0 (Eq. (9)) and x_t(u) = x_d.  Each
        iteration factors J = dF/du once and solves J [z, Z] = -[F, dF/dp]; the
        tip's linearisation x_t + G z + G Z dp = x_d (G = dx_t/du, Eq. (13):
        G Z = S) gives dp, then du = z + Z dp.  The first iterate is the
        predictor of the start: dp = S^{-1} (x_d - x_t), u + (du/dp) dp
        (Eq. (14)).  Converged when |F| <= the equilibrium solver's absolute
        tolerance (its SNES test) and |x_t - x_d| < tol.  The linearisation
        returned is that of the last iterate before (one quadratically small
        step away): it serves only as the predictor of the next target."""
        eq, lin = start
        target = np.asarray(target, float)
        tol = self.tol if tol is None else tol
        if math.hypot(*(target - eq.tip)) < tol:
            return eq, lin
        disc, N = self.disc, self.disc.n_elements
        try:
            dp = solve2(lin.tip_jacobian, target - eq.tip)
        except np.linalg.LinAlgError:
            return None
        p, u = eq.p + dp, eq.u + dp @ lin.state_derivative          # Euler predictor, Eq. (14)
        if not self._admissible(dp, p):
            return None
        predicted = u[:N].copy()
        for its in range(self.max_steps + 1):
            F = disc.residual(u, p)
            theta = disc.split(u)[0]
            miss = target - disc.node_positions(theta)[-1]
            if math.sqrt(F @ F) <= self.solver.atol and math.hypot(*miss) < tol:
                if its > 0:                # the factorisation of the iterate before is at hand
                    p, u = self._polish(p, u, F, theta, miss, lin)
                return self._accept(p, u, predicted, its, lin)
            if its == self.max_steps:
                return None
            try:
                rows = self.sens.tangent_solves(u, p, -np.vstack((F, disc.load_derivative(u))))
                moved = disc.position_derivative(theta, rows, [N])[:, 0]     # (1 + n, 2)
                lin = Linearisation(rows[1:], moved[1:].T)
                dp = solve2(lin.tip_jacobian, miss - moved[0])
            except (SensitivityError, np.linalg.LinAlgError):
                return None
            p, u = p + dp, u + rows[0] + dp @ rows[1:]
            if not self._admissible(dp, p):
                return None
        return None

    def _polish(self, p, u, F, theta, miss, lin) -> tuple:
        """(p, u) after one more Newton step with the last factorisation (a
        chord step, no new one): the converged iterate's residual, at most the
        SNES tolerance, falls to round-off, as after the equilibrium solver's
        quadratically converging last iteration."""
        try:
            z = self.sens.solve_again(-F[None])
            dz = self.disc.position_derivative(theta, z, [self.disc.n_elements])[0, 0]
            dp = solve2(lin.tip_jacobian, miss - dz)
        except (SensitivityError, np.linalg.LinAlgError):
            return p, u
        return (p + dp, u + z[0] + dp @ lin.state_derivative) if self._admissible(dp, p + dp) \
            else (p, u)

    def _admissible(self, dp: np.ndarray, p: np.ndarray) -> bool:
        """A finite step within ``max_dp`` that keeps 0 <= P_i <= the motor limit
        (the comparisons are False for NaN)."""
        return (all(abs(x) <= self.max_dp for x in dp.tolist())
                and all(0.0 <= x <= self.upper for x in p.tolist()))

    def _accept(self, p, u, predicted, its: int, lin):
        """The converged (equilibrium, linearisation), or None after a jump to
        another branch (an angle ``jump_tol`` from the predictor) or onto a
        cable collapse."""
        self.iterations += its
        if np.max(np.abs(u[:self.disc.n_elements] - predicted)) > self.jump_tol:
            return None
        eq = Equilibrium(self.disc, p, u, True, "CONVERGED_FNORM_ABS", its, 1)
        if np.min(eq.cable_lengths) < COLLAPSE_LENGTH:
            return None
        return eq, lin

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
