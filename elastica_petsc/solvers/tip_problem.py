"""The tip-control problem of one solve (Eqs. (10)-(12)): objective, stopping
test and Gauss-Newton metric, whatever optimiser runs it, and its result
(:class:`ControlResult`).

    minimise E(p) = |x_d - x_t(p)|^2 / 2          over 0 <= p <= p_max   (Eqs. (10)-(11))
    dE/dp_i = (x_t - x_d) . d x_t / d p_i                                (Eq. (12))

A :class:`TipProblem` is made for every solve of
:class:`~elastica_petsc.solvers.control.TipController` and holds all that
solve learns (iterates, the last good evaluation, failures, the stopping
reason): nothing of it stays on the controller.

Stopping (:meth:`TipProblem.stop`) is exactly the paper's criterion E < eps
(default eps = (1e-5 mm / l)^2 / 2: the tip within 1e-5 mm), plus: the
iteration limit; a stationary point with E >= eps (projected gradient below
``stationary_rtol`` |x_t - x_d| |S|: the target cannot be reached from
here, typically because a tension sits on a bound); a stall (E not
decreased over ``stall_its`` iterations); and CABLE_COLLAPSE: a cable is
shorter than ``COLLAPSE_STOP * COLLAPSE_LENGTH`` and the Gauss-Newton step
would pull it onto its routing point, i.e. the optimiser is heading for the
collapse corner of the tension domain (the tip at a routing point), a local
end: the target may still be reachable from another start.  (Before this
test and the step box, such targets, in the band y < 50 mm of the paper's
workspace, ended in line-search failures after ~20 failed equilibria each.)

Failed equilibria: when the optimiser proposes tensions whose equilibrium
cannot be reached by continuation from the last good state (a cable pulled
onto its routing point, a snap with nowhere stable to go, SNES failure), a
second continuation from the starting equilibrium of this solve is tried
(an equilibrium whose cable is shorter than ``COLLAPSE_LENGTH``, its
attachment point on the routing point, counts as failed: the cable
direction, hence the load, is undefined there); if that fails too, the
objective returns the penalty E_fail = 10 (E_max + 1) (E_max: the largest E
evaluated in this solve) with the secant gradient (E_fail - E_good) dp /
|dp|^2 towards the last good tensions, so the line search backtracks.
Failures are counted (``failed_evaluations``) and not retried within a
solve; at most ``max_failures`` are solved per solve.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from petsc4py import PETSc

from ..core.budget import TIME_LIMIT        # the solve's TimeBudget is spent -> DIVERGED_USER
from ..core.loading import Loading
from ..core.model import Arm
from ..core.results import Result
from .equilibrium import COLLAPSE_LENGTH, Equilibrium
from .sensitivity import Sensitivity

# Our stopping reasons (ControlResult.reason) and the TAO reason we set for them.
TARGET_REACHED = "TARGET_REACHED"        # E < eps            -> CONVERGED_USER
STATIONARY = "STATIONARY"                # projected grad ~ 0 -> CONVERGED_GATOL
STALLED = "STALLED"                      # no progress        -> CONVERGED_STEPTOL
MAX_ITERATIONS = "MAX_ITERATIONS"        #                    -> DIVERGED_MAXITS
MAX_EVALUATIONS = "MAX_EVALUATIONS"      #                    -> DIVERGED_MAXFCN
CABLE_COLLAPSE = "CABLE_COLLAPSE"        # step would collapse a cable -> DIVERGED_USER
LINE_SEARCH_FAILURE = "LINE_SEARCH_FAILURE"   # gd: no decrease along the step

# Gauss-Newton steps may shorten a cable by at most this fraction of its length
# (linearised: L_j + dL_j/dp . s >= (1 - CABLE_FRACTION) L_j), so the iterates
# approach a collapse geometrically instead of jumping past it.
CABLE_FRACTION = 0.5
# Stop (CABLE_COLLAPSE) when a cable is shorter than this many COLLAPSE_LENGTH
# and the Gauss-Newton step would still pull it onto its routing point.
COLLAPSE_STOP = 5.0


def default_eps(length_mm: float, tip_tol_mm: float = 1e-5) -> float:
    """E tolerance (non-dimensional) for a tip within ``tip_tol_mm``: (tol / l)^2 / 2.

    The paper's eps = 1e-10 mm^2 (Sec. 4.5 (iv)) is this with tol = 1e-5 mm
    up to its factor 1/2 convention; ours guarantees |x_t - x_d| < tol."""
    return 0.5 * (tip_tol_mm / length_mm) ** 2


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
    arm: Arm | None = None          # the arm (ep.control's results; saved as provenance)

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

    def to_vtk(self, directory) -> list:
        """The state reached as ParaView files in ``directory``, as ``control --vtk``
        writes them (``control.vtu``: arm and cables, mm, N); needs ``arm``."""
        import elastica_petsc             # the public State (io sits above this layer)

        return elastica_petsc.State(needs_arm(self), self.equilibrium).to_vtk(
            directory, name="control")


def needs_arm(result) -> Arm:
    """``result.arm``, or InputError for a result made without one."""
    if result.arm is None:
        from ..core.errors import InputError
        raise InputError(f"this {type(result).__name__} has no arm: results of ep.control "
                         "and ep.trace carry one")
    return result.arm


def spectral_norm(S: np.ndarray) -> float:
    """|S|_2 of an (n, 2) matrix: the square root of the largest eigenvalue
    of the 2x2 Gram matrix S^T S = [[a, b], [b, c]], in closed form."""
    a, b, c = float(S[:, 0] @ S[:, 0]), float(S[:, 0] @ S[:, 1]), float(S[:, 1] @ S[:, 1])
    return math.sqrt(0.5 * (a + c) + math.hypot(0.5 * (a - c), b))


@dataclass(frozen=True)
class StopRule:
    """The settings of :meth:`TipProblem.stop` and of the step limits."""

    eps: float                      # E < eps: the tip is on the target
    max_evaluations: int
    stationary_rtol: float
    stall_its: int
    stall_rtol: float
    upper: float                    # upper tension bound (inf: none)
    trust_tension: float | None     # Levenberg-Marquardt limit of a step's tension change


@dataclass
class TipProblem:
    """One tip-control solve: target, start, settings, and all it learns.

    ``evaluate(p, problem)`` (the controller's) gives the :class:`Evaluation`
    at tensions p continued from this solve's states, or None if it failed."""

    target: np.ndarray
    rule: StopRule
    evaluate: object                # callable (p, problem) -> Evaluation | None
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
    penalty_row: np.ndarray | None = None          # BRGN: residual Jacobian row of a failure
    budget: object = None                          # core.budget.TimeBudget or None
    first_step: np.ndarray | None = None           # the first Gauss-Newton step (direct_steps)

    # --- the objective -----------------------------------------------------------
    def residual_E(self, ev: Evaluation) -> tuple[np.ndarray, float]:
        """r = x_t - x_d and E = |r|^2 / 2 (Eq. (11)) at an evaluation."""
        r = ev.equilibrium.tip - self.target
        return r, 0.5 * float(r @ r)

    def objective(self, p: np.ndarray):
        """(evaluation, E, dE/dp) at p, counted; (None, inf, None) if the
        equilibrium failed (the gradient descent's line search backs off)."""
        self.evaluations += 1
        ev = self.evaluate(p, self)
        if ev is None:
            self.failed += 1
            return None, np.inf, None
        self.last_good = ev
        r, E = self.residual_E(ev)
        return ev, E, ev.sensitivity.tip @ r                       # Eq. (12)

    def penalised(self, p: np.ndarray) -> tuple[float, np.ndarray]:
        """(E, dE/dp) at p for a line search: a failed equilibrium gives the
        penalty of the module doc, with its secant gradient."""
        self.evaluations += 1
        ev = self.evaluate(p, self)
        if ev is None:                                 # line-search friendly penalty
            self.failed += 1
            good = self.last_good
            E_fail = 10.0 * (self.E_max + 1.0)
            if good is None:
                return E_fail, np.zeros_like(p)
            E_good = 0.5 * float(np.sum((good.equilibrium.tip - self.target) ** 2))
            dp = p - good.p
            return E_fail, (E_fail - E_good) * dp / max(float(dp @ dp), 1e-300)
        self.last_good = ev
        r, E = self.residual_E(ev)
        self.E_max = max(self.E_max, E)
        return E, ev.sensitivity.tip @ r               # Eq. (12)

    # --- bounds and stopping -------------------------------------------------------
    def active(self, p: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Tensions on a bound with the gradient pushing through it."""
        if p.min() > 0.0 and p.max() < self.rule.upper:
            return np.zeros(p.shape, bool)                      # the common case, cheaper
        return ((p <= 0.0) & (g > 0)) | ((p >= self.rule.upper) & (g < 0))

    def projected_gradient(self, p: np.ndarray, g: np.ndarray) -> np.ndarray:
        """g with the components that push through an active bound removed."""
        return np.where(self.active(p, g), 0.0, g)

    def stop(self, its: int, E: float, pgnorm: float, ev: Evaluation | None):
        """The stopping test of every optimiser: (reason, TAO reason) or None."""
        Reason = PETSc.TAO.Reason
        rule = self.rule
        self.best_E.append(E)
        if ev is not None and E < rule.eps:                     # Algorithm 1, line 8
            return TARGET_REACHED, Reason.CONVERGED_USER
        if self.collapsing is not None:
            return CABLE_COLLAPSE, Reason.DIVERGED_USER
        if self.budget is not None and self.budget.expired():
            return TIME_LIMIT, Reason.DIVERGED_USER
        if its >= self.max_it:
            return MAX_ITERATIONS, Reason.DIVERGED_MAXITS
        if self.evaluations >= rule.max_evaluations:
            return MAX_EVALUATIONS, Reason.DIVERGED_MAXFCN
        if ev is not None and pgnorm <= rule.stationary_rtol * np.sqrt(2 * E) * max(
                spectral_norm(ev.sensitivity.tip), 1e-300):
            return STATIONARY, Reason.CONVERGED_GATOL
        if (len(self.best_E) > rule.stall_its
                and self.best_E[-1] >= (1.0 - rule.stall_rtol) * self.best_E[-1 - rule.stall_its]):
            return STALLED, Reason.CONVERGED_STEPTOL
        return None

    # --- the Gauss-Newton metric ------------------------------------------------------
    def gauss_newton(self, ev: Evaluation) -> tuple[np.ndarray, np.ndarray]:
        """(H0, s): H0 = S^T S + mu I (S = d x_t / d p), the Gauss-Newton
        Hessian of E with the tensions held on a bound decoupled (reduced-space
        Newton), and its step s = -H0^{-1} g.

        mu = 1e-10 tr(S^T S) at least (S is rank one on the straight arm);
        larger (Levenberg-Marquardt) when the step would change a tension by
        more than max(trust_tension, max p) or shorten a cable by more than
        CABLE_FRACTION of its length (linearised with dL/dp of
        :mod:`.sensitivity`).  Sets ``collapsing`` when the step would pull a
        cable shorter than COLLAPSE_STOP * COLLAPSE_LENGTH onto its routing
        point (:meth:`stop`: CABLE_COLLAPSE)."""
        n = ev.p.size
        S = ev.sensitivity.tip                         # (n, 2), rows d x_t / d p_i
        g = S @ (ev.equilibrium.tip - self.target)
        H = S @ S.T
        scale = max(float(H.trace()), 1e-300)
        active = self.active(ev.p, g)
        if active.any():
            diag = np.diag(H).copy()
            H[active, :] = 0.0
            H[:, active] = 0.0
            H[active, active] = diag[active]
        eye = np.eye(n)
        L = ev.equilibrium.cable_lengths
        dL = ev.sensitivity.cable_lengths               # [i, j] = d L_j / d p_i
        mu = 1e-10 * scale
        A = H + mu * eye
        step = -np.linalg.solve(A, g)                   # the Gauss-Newton step
        short = L < COLLAPSE_STOP * COLLAPSE_LENGTH
        doomed = (L + step @ dL < COLLAPSE_LENGTH) & short if short.any() else short
        self.collapsing = int(doomed.argmax()) if doomed.any() else None
        trust = self.rule.trust_tension
        radius = np.inf if trust is None else max(trust, float(ev.p.max()))
        floor = -CABLE_FRACTION * L
        for _ in range(60):
            if abs(step).max() <= radius and (step @ dL >= floor).all():
                break
            mu *= 4.0
            A = H + mu * eye
            step = -np.linalg.solve(A, g)
        return A, step
