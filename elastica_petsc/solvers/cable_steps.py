"""The cables' complementarity inside each step (docs/model.md §16.6): event capturing.

A length-controlled cable i is a unilateral constraint: its gap
g_i = Lbar_i(t) - |r_i - x_i| >= 0, its tension p_i >= 0, g_i p_i = 0.  Instead of
locating the instants where a cable goes slack or taut (TSEvent on a tension that
unresolved mesh modes dominate after an impact, §16.3), every step of the alpha
method decides it, in the style of Moreau and Jean: the step's mean tension p (the
integrator's tension at the alpha point t_n + alpha_f dt; for rho_inf = 1 exactly
Delta Lambda / dt) and

    w = Lbar'(t_{n+1}) - grad L(theta_{n+1}) . theta'_{n+1} + max(g_n, 0) / dt

(the gap rate at the *end* of the step, plus the open gap at its start spread over
the step; a closed gap g_n < 0 enters as eps g_n / dt instead) satisfy 0 <= p  _|_  w >= 0.  A cable whose gap stays open, g_n + dt
gdot_{n+1} > 0, is slack (p = 0); one that closes in the step stops with the gap
closed at the step's end (a plastic impact, whose impulse is p dt); a taut one keeps
gdot = 0 at every step's end (Moreau's velocity-level law: the constraint acts on
the step-end velocities, so a persistent contact carries no velocity that alternates
from step to step).  A closed gap (g_n < 0: the length of a taut cable drifts, the
trapezoidal rule integrating its rate, by dt^3 Lbar'''/12 per step) is pulled back
slowly (eps = ``DRIFT_PULL``, in about 1 / eps steps): pulled back at once, the
velocity that undoes it is kinetic energy the scheme makes up at every impact (with
eps = 0.1 and contacts decided at the step's start the arm's vibration grew without
bound in a test run).

The complementarity is one semismooth row of the step's Newton system,

    phi = max(-w, -s p) = -min(w, s p),   s = dt W_ii   (W = C^T M^{-1} C),

whose active branch (taut: w <= s p, the row -w; slack: the row -s p) the PC of
:mod:`.dynamics` follows at every Newton iterate (a semismooth Newton method).  The
scale s makes the two branches comparable (a mean tension p over dt changes the gap
rate by about W p dt).  Step-end values come from the alpha point:
X_{n+1} = X_n + (X_{n+alpha_f} - X_n) / alpha_f.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# eps: a closed gap (a taut cable stretched by the O(dt^2) drift of its length) is
# pulled back at the rate eps g / dt, in about 1 / eps steps
DRIFT_PULL = 0.05
# a cable stretched by more than this (l) in one step: the step is taken again, shorter
PENETRATION_TOL = 1e-3


@dataclass(frozen=True)
class StepStart:
    """The state at t_n of the step under way."""

    t: float
    U: np.ndarray
    V: np.ndarray
    gap: np.ndarray          # g_n (l)


class CableComplementarity:
    """Per-step complementarity of the cables of a LengthDrive (module doc).

    ``geometry``: the DynamicsSolver (``N``, ``theta_of``, ``cable_lengths``,
    ``grad_lengths``); ``alpha_f``: of the alpha method; ``delassus``: the diagonal of
    W = C^T M^{-1} C at the start state (1 / effective mass of each cable's end).
    """

    def __init__(self, geometry, drive, alpha_f: float, delassus: np.ndarray):
        self.geo, self.drive, self.alpha_f = geometry, drive, alpha_f
        self.delassus = np.asarray(delassus, float)
        self.start: StepStart | None = None

    def begin(self, t: float, U: np.ndarray, V: np.ndarray) -> None:
        """The step from t starts at (U, V)."""
        gap = self.drive.lengths(t) - self.geo.cable_lengths(self.geo.theta_of(U))
        self.start = StepStart(t, U.copy(), V.copy(), gap)

    def rows(self, t_alpha, U, V, af: float, dt: float):
        """(phi, taut, s): the complementarity rows at the Newton iterate (U, V) at the
        alpha point t_alpha of a step dt with parameter ``af`` (alpha_f), which branch
        each follows (taut: -w) and the scales s."""
        N, s = self.geo.N, self.start
        U1, V1 = s.U + (U - s.U) / af, s.V + (V - s.V) / af       # step-end values
        w = (self.drive.rates(t_alpha + (1.0 - af) * dt)
             - self.geo.grad_lengths(self.geo.theta_of(U1)) @ V1[:N]
             + (np.maximum(s.gap, 0.0) + DRIFT_PULL * np.minimum(s.gap, 0.0)) / dt)
        scale = self.delassus * dt
        sp = scale * V[N:]
        taut = w <= sp
        return np.where(taut, -w, -sp), taut, scale

    def penetrated(self, t1: float, U1: np.ndarray) -> bool:
        """Whether a cable's gap at the step's end (t1, U1) fell below -PENETRATION_TOL
        and below its start's (module doc: the velocity-level law does not forbid a
        penetration within a step; steps longer than the vibration find them)."""
        gap = self.drive.lengths(t1) - self.geo.cable_lengths(self.geo.theta_of(U1))
        return bool(np.any((gap < -PENETRATION_TOL) & (gap < self.start.gap)))

    def mean_tensions(self, t1: float, U1: np.ndarray, V1: np.ndarray):
        """(p, taut) of the step that ended at (t1, U1, V1): its tensions at the alpha
        point, 0 exactly where the slack branch holds (the row -s p = 0)."""
        s, af = self.start, self.alpha_f
        U, V = s.U + af * (U1 - s.U), s.V + af * (V1 - s.V)
        _, taut, _ = self.rows(s.t + af * (t1 - s.t), U, V, af, t1 - s.t)
        return np.where(taut, V[self.geo.N:], 0.0), taut
