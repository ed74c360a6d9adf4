"""The arm in motion on PETSc TS (docs/model.md §16).

The unknowns are U = (theta_1..theta_N, Lambda_1..Lambda_n): the nodal angles
and the tension impulses, whose rates are the tensions, p = Lambda' (a
tension is then a velocity of the integrator, determined at the end of each
step like every velocity, and the displacement-like Lambda is smooth enough
for the alpha method's recursions).  The second-order residual (TSALPHA2,
``setI2Function``) is

    F_theta = M(theta) theta'' + c(theta, theta') + (a M + b L) theta' + R(theta, p)
    F_p_i   = p_i - pbar_i(t)                (force control)
            = max(-w_i, -s_i p_i)            (length control, :mod:`.cable_steps`)

with the kernels of :mod:`elastica_petsc.core.dynamics` and R the static
residual of docs/model.md §8 (so every load the static model has is in the
dynamics).  Under length control the cables' complementarity (slack or taut,
impacts) is decided inside every step by a semismooth row on the step's mean
tension and step-end gap rate (:mod:`.cable_steps`, docs/model.md §16.6).
Time integration: generalized-alpha for second-order systems (TSALPHA2) in
PETSc's parametrisation by the spectral radius rho_inf at infinite step
(``radius``; 1, the default: the implicit midpoint member, no numerical
dissipation), its start-up acceleration corrected (:mod:`.alpha2_start`).  Fixed
equal steps by default, or (``adaptive``) TSAdapt ``basic`` on the alpha
method's local error estimate of the angles (the tension impulses are
left out of the norm).  Newton: SNES with KSP ``preonly`` and a PC that
solves the principal part of the Jacobian exactly in O(N):

    J ~ [[sigma M + shift_V b L + K(theta, p),  shift_V C],   C = [grad L_i]
         [(shift_V / alpha_f) C_taut^T or diagonal rows   ]]

(sigma = shift_A + a shift_V; K = T + W diag(p/L) W^T the static tangent of
§2; the derivatives of M(theta) theta'' and of the velocity terms with respect
to theta, O(dt^2) and O(dt) relative, are left out, so Newton converges
linearly at that rate: a modified Newton).  T and sigma M are one banded
system (:class:`~elastica_petsc.core.dynamics.BandedInverse`), the tendon
terms a Woodbury correction of rank n, the taut cables an n x n Schur
complement: O(n N) per factorisation and per solve.

Under length control each cable's row follows its branch at every Newton
iterate (taut rows in the Schur complement, slack rows diagonal): a
semismooth Newton method.  Options prefix ``sim_`` (``-sim_ts_monitor``, ``-sim_snes_monitor``,
``-sim_ts_adapt_monitor``, ...).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from petsc4py import PETSc

from ..core.drive import LengthDrive, TensionDrive
from ..core.dynamics import (BandedInverse, Inertia, elastic_band, straight_cables,
                             weight_potential)
from ..core.fem import Discretisation
from .alpha2_start import START_UP, Alpha2Params
from .cable_steps import CableComplementarity
from .options import SolverOptions, check_comm
from .reasons import TS_REASONS, reason_name

FORCE, TAUT, SLACK = 0, 1, 2
MODE_NAMES = {FORCE: "force", TAUT: "taut", SLACK: "slack"}
EXCLUDED = 1e30            # atol of the tension unknowns: out of the error norm
TAUT_TENSION = 1e-9        # a step's mean tension above this (B/l^2): the cable was taut


@dataclass
class Trajectory:
    """Accepted steps of a run (non-dimensional; time in tau)."""

    time: list = field(default_factory=list)
    theta: list = field(default_factory=list)       # (N+1,) each, theta_0 = 0
    omega: list = field(default_factory=list)       # (N,) angular velocities
    p: list = field(default_factory=list)           # (n,) tensions
    lengths: list = field(default_factory=list)     # (n,) |r_i - x_i|
    kinetic: list = field(default_factory=list)     # B/l
    strain: list = field(default_factory=list)      # B/l
    gravity: list = field(default_factory=list)     # potential of the weight, B/l (§11.5)
    work: list = field(default_factory=list)        # work of the tensions on the arm, B/l
    events: list = field(default_factory=list)      # (time, tendon from 1, "slack"|"taut")
    steps: int = 0
    rejected: int = 0
    snes_failures: int = 0
    reason: str = ""
    completed: bool = False


class _Principal:
    """Python PC: the exact O(N) solve of the principal Jacobian (module docstring)."""

    def __init__(self, sim: "DynamicsSolver"):
        self.sim = sim
        self.apply_fn = None

    def setUp(self, pc):
        pass

    def apply(self, pc, x, y):
        y.setArray(self.apply_fn(x.getArray(readonly=True)))


class _Operator:
    """Shell Mat context: never multiplied (KSP preonly)."""

    def mult(self, mat, x, y):                   # pragma: no cover - preonly
        raise RuntimeError("the dynamics Jacobian is applied through its PC only")


class DynamicsSolver:
    """Integrates the arm of ``disc`` with masses and damping ``inertia``.

    ``adaptive``: TSAdapt ``basic`` with tolerances ``rtol``/``atol`` on the
    angles (rad) and angular velocities, first step ``dt0``; otherwise fixed
    steps ``dt0`` (tau).  ``radius``: rho_inf of the alpha method;
    ``lag_jacobian``: the PC (principal Jacobian and its banded LU) is
    refreshed every this many Newton iterations, across steps
    (``-snes_lag_jacobian_persists``), with fixed steps and force control only
    (adaptive steps and length control refresh it every iteration);
    ``max_steps``: cap on accepted steps.  ``comm``, ``options_prefix``
    (``sim_``), ``petsc_options``: the contract of :mod:`.options`.
    """

    def __init__(self, disc: Discretisation, inertia: Inertia, *, rtol: float = 1e-6,
                 atol: float = 1e-8, radius: float = 1.0, dt0: float = 1e-3,
                 adaptive: bool = True, max_steps: int = 10**7,
                 lag_jacobian: int = 10,
                 comm=None, options_prefix: str = "sim_", petsc_options=None):
        self.options = SolverOptions(options_prefix, petsc_options, {
            "ts_alpha_radius": radius, "ts_adapt_type": "basic" if adaptive else "none",
            "snes_linesearch_type": "basic", "snes_lag_jacobian": lag_jacobian,
            "snes_lag_jacobian_persists": True})
        self.comm = check_comm(comm)
        self.adaptive = adaptive
        self.disc, self.inertia = disc, inertia
        # the cables' kernel and the weight G_e of an arm with weight (docs/model.md §16.4)
        self.cable_disc, self.weight = straight_cables(disc)
        self.rtol, self.atol, self.radius, self.dt0 = rtol, atol, radius, dt0
        self.prefix, self.max_steps = self.options.prefix, max_steps
        self.N, self.n = disc.n_elements, disc.n_tendons
        self.L_band = elastic_band(disc)
        self.attach = list(disc.attach_nodes)
        self.modes = np.full(self.n, FORCE)
        self.drive, self.cables = None, None
        self._alpha2 = Alpha2Params()
        self.stage = (0.5, dt0)          # alpha_f and step of the stage under way

    # --- model pieces -------------------------------------------------------------
    def theta_of(self, U: np.ndarray) -> np.ndarray:
        return np.concatenate(([0.0], U[: self.N]))

    def cable_lengths(self, theta: np.ndarray) -> np.ndarray:
        x = self.cable_disc.node_positions(theta)[self.attach]
        return np.linalg.norm(self.cable_disc.routes - x, axis=1)

    def grad_lengths(self, theta) -> np.ndarray:
        """grad_theta L_i, (n, N)."""
        disc = self.cable_disc
        return disc.load_derivative(disc.consistent_state(theta))[:, : self.N]

    def residual(self, t, U, V, A) -> np.ndarray:
        N = self.N
        theta, p = self.theta_of(U), V[N:]
        out = np.empty(N + self.n)
        out[:N] = self.inertia.residual(theta, V[:N], A[:N], p)
        if self.cables is not None:          # length control: the complementarity rows
            out[N:] = self.cables.rows(t, U, V, *self.stage)[0]
        else:
            out[N:] = p - self.drive.tensions(t)
        return out

    def _factor(self, U, V, shift_v, shift_a, t=None):
        """Set the PC to the exact inverse of the principal Jacobian at (U, V)
        (d p / d Lambda = shift_v); under length control each cable's row follows
        the branch of its complementarity function at this iterate (:mod:`.cable_steps`)."""
        disc, inert, N = self.cable_disc, self.inertia, self.N
        theta, p = self.theta_of(U), V[N:]
        u = disc.consistent_state(theta)
        t_ = disc.terms(u, p)
        g = disc.attachment_gradients(theta, (t_.c, t_.s))
        sigma = shift_a + inert.viscous * shift_v
        # the weight is a dead load: its stiffness (h/4) t_e . G_e is T's (§11.5)
        weighted = t_._replace(force=t_.force + self.weight)
        band = disc.band(theta, t_.d, p, weighted) + shift_v * inert.kelvin_voigt * self.L_band \
            + sigma * inert.rotary
        inv = BandedInverse(disc, theta, inert.weights, sigma, band)
        Ut = disc.transverse_gradients(g, t_.d).T           # (N, n)
        c = p / t_.lengths
        C = -(g[..., 0] * t_.d[:, :1] + g[..., 1] * t_.d[:, 1:]).T   # grad L_i, (N, n)
        Z = inv.solve(np.column_stack((Ut, C)))
        Zu, Zc = Z[:, : self.n], Z[:, self.n:]
        woodbury = np.linalg.solve(np.eye(self.n) + c[:, None] * (Ut.T @ Zu),
                                   c[:, None] * Ut.T)       # cap^-1 diag(c) Ut^T, (n, N)

        def inverse(r2):           # (A + Ut diag(c) Ut^T)^{-1} r2 by Woodbury
            return r2 - Zu @ (woodbury @ r2)

        Y = inverse(Zc)                                      # A'^{-1} C
        gain, taut, row_scale = np.ones(self.n), np.zeros(self.n, bool), 1.0
        if self.cables is not None:
            # slack branch -s p: dp = -r / s; taut branch -w, d w / d x = -(shift_v /
            # alpha_f) C^T x (step-end velocities from the alpha point)
            _, taut, s = self.cables.rows(t, U, V, *self.stage)
            gain, row_scale = -1.0 / s, self.stage[0]
        taut, known = np.flatnonzero(taut), np.flatnonzero(~taut)
        S = C[:, taut].T @ Y[:, taut]

        def apply(r):
            dp = np.zeros(self.n)
            dp[known] = gain[known] * r[N:][known]
            x = inverse(inv.solve(r[:N] - C[:, known] @ dp[known])[:, None])[:, 0]
            if len(taut):
                dp[taut] = np.linalg.solve(S, C[:, taut].T @ x
                                           - row_scale * r[N:][taut] / shift_v)
                x = x - Y[:, taut] @ dp[taut]
            return np.concatenate((x, dp / shift_v))

        self.pc_ctx.apply_fn = apply

    def _delassus(self, theta) -> np.ndarray:
        """diag(C^T M^{-1} C), C = [grad L_i]: 1 / the effective mass of each cable's end."""
        C = self.grad_lengths(theta).T
        inv = BandedInverse(self.cable_disc, theta, self.inertia.weights, 1.0,
                            self.inertia.rotary)
        return np.einsum("ki,ki->i", C, inv.solve(C).reshape(C.shape))

    @property
    def alpha_f(self) -> float:
        """alpha_f = 1 / (1 + rho_inf) of PETSc's alpha2 (the radius in force at the solve)."""
        radius = PETSc.Options(self.prefix).getReal(
            "ts_alpha_radius", float(self.options.options["ts_alpha_radius"]))
        return 1.0 / (1.0 + radius)

    def _set_stage(self, ts) -> float:
        """The stage under way: its alpha_f and step for the cables' rows; returns the
        factor of the acceleration (2 in TSALPHA2's start-up, :mod:`.alpha2_start`)."""
        params = self._alpha2.params(ts)
        alpha_f = self.alpha_f if params is None else params[1]
        self.stage = (alpha_f, ts.getTimeStep())
        return 1.0 if params is None or params != START_UP else 2.0

    # --- the TS ----------------------------------------------------------------------
    def _make_ts(self, t0, t_end, U0, V0, record):
        comm = self.comm
        size = self.N + self.n
        ts = PETSc.TS().create(comm)
        ts.setOptionsPrefix(self.prefix)
        ts.setType(PETSc.TS.Type.ALPHA2)
        self.pc_ctx = _Principal(self)
        F = PETSc.Vec().createSeq(size, comm=comm)

        def i2function(ts_, t, U, V, A, Fv):
            factor = self._set_stage(ts_)
            Fv.setArray(self.residual(t, U.getArray(readonly=True), V.getArray(readonly=True),
                                      factor * A.getArray(readonly=True)))

        def i2jacobian(ts_, t, U, V, A, shift_v, shift_a, J, P):
            factor = self._set_stage(ts_)
            self._factor(U.getArray(readonly=True), V.getArray(readonly=True), shift_v,
                         factor * shift_a, t)

        J = PETSc.Mat().createPython([size, size], _Operator(), comm=comm)
        J.setUp()
        ts.setI2Function(i2function, F)
        ts.setI2Jacobian(i2jacobian, J, J)
        U, V = PETSc.Vec().createSeq(size, comm=comm), PETSc.Vec().createSeq(size, comm=comm)
        U.setArray(U0)
        V.setArray(V0)
        ts.setSolution2(U, V)
        ts.setTime(t0)
        if self.adaptive:
            ts.setMaxTime(t_end)
            ts.setTimeStep(self.dt0)
            ts.setMaxSteps(self.max_steps)
            ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
        elif self.cables is None:      # equal steps ending on t_end (no sliver)
            count = max(1, math.ceil((t_end - t0) / self.dt0 - 1e-9))
            ts.setTimeStep((t_end - t0) / count)
            ts.setMaxTime(t_end + 0.5 * (t_end - t0) / count)
            ts.setMaxSteps(count)
            ts.setExactFinalTime(PETSc.TS.ExactFinalTime.STEPOVER)
        else:      # equal steps (a failed Newton solve may shorten one: then MATCHSTEP)
            ts.setTimeStep((t_end - t0) / max(1, math.ceil((t_end - t0) / self.dt0 - 1e-9)))
            ts.setMaxTime(t_end)
            ts.setMaxSteps(self.max_steps)
            ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
        ts.setMaxSNESFailures(-1)
        ts.setMaxStepRejections(-1)
        atol, rtol = U.duplicate(), U.duplicate()
        atol.setArray(np.concatenate((np.full(self.N, self.atol), np.full(self.n, EXCLUDED))))
        rtol.setArray(np.concatenate((np.full(self.N, self.rtol), np.zeros(self.n))))
        ts.setTolerances(rtol=rtol, atol=atol)
        snes = ts.getSNES()
        snes.setType("newtonls")
        ksp = snes.getKSP()
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("python")
        pc.setPythonContext(self.pc_ctx)
        snes.setTolerances(rtol=1e-12, atol=1e-14, stol=1e-14, max_it=30)
        ts.setMonitor(record)
        if self.cables is not None:
            ts.setPreStep(self._begin_step(ts, t_end))
            ts.setPostStep(self._check_step)
        self.options.label(F, J, U, V)
        self.options.apply(ts)
        return ts, (U, V, F, J, atol, rtol)

    def _begin_step(self, ts, t_end):
        """TS pre-step: the state the step starts from (:mod:`.cable_steps`); a step that
        a failed Newton solve shortened is followed by full ones again."""
        step = ts.getTimeStep()

        def prestep(ts_):
            t, dt = ts_.getTime(), ts_.getTimeStep()
            if dt < step and not self.adaptive:
                dt = min(step, t_end - t)
                ts_.setTimeStep(dt)
            U, V = (v.getArray(readonly=True) for v in ts_.getSolution2())
            self.cables.begin(t, U, V)
        return prestep

    def _check_step(self, ts):
        """TS post-step: a step whose end has a cable stretched past
        ``PENETRATION_TOL`` beyond its start is taken again with a quarter of the
        step (:mod:`.cable_steps`: a spurious solution of a step too long for the
        vibration); counted as a rejection."""
        U = ts.getSolution2()[0].getArray(readonly=True)
        if self.cables.penetrated(ts.getTime(), U):
            dt = ts.getTime() - self.cables.start.t
            ts.rollBack()
            ts.setTimeStep(0.25 * dt)
            self._rollbacks += 1

    def run(self, theta0, omega0, p0, drive, modes, t_end: float, *,
            on_step=None, trajectory: Trajectory | None = None) -> Trajectory:
        """Integrate from (theta0 (N+1,), omega0 (N,), p0 (n,)) at t = 0 to ``t_end``.

        ``drive``: a TensionDrive (every cable force-controlled) or a
        LengthDrive; ``modes``: TAUT/SLACK of each cable at the start under a
        LengthDrive (the first step decides; a change is recorded as an event).
        ``on_step(t)`` after every accepted step.  The trajectory (also when
        interrupted) holds every accepted step.
        """
        self.drive = drive
        self.cables = None
        self.modes = np.full(self.n, FORCE)
        U0 = np.concatenate((np.asarray(theta0, float)[1:], np.zeros(self.n)))
        V0 = np.concatenate((np.asarray(omega0, float), p0))
        if isinstance(drive, LengthDrive):
            self.modes = np.asarray(modes, int).copy()
            self.cables = CableComplementarity(self, drive, self.alpha_f,
                                               self._delassus(self.theta_of(U0)))
        if self.adaptive or self.cables is not None:
            # the step changes (TSAdapt) or the active set does: a PC kept for another
            # step's shift or branch stalls Newton, so it is refreshed at every iteration
            self.options.update({"snes_lag_jacobian": 1})
        traj = trajectory if trajectory is not None else Trajectory()
        self._rollbacks = 0
        # t = 0: the drive's tensions under force control (a release acts from t = 0),
        # the start state's under length control
        self._record(traj, 0.0, U0, V0, None if self.cables is None else np.asarray(p0, float))
        ts, objs = self._make_ts(0.0, t_end, U0, V0, self._monitor(traj, on_step))
        try:
            try:
                with np.errstate(all="ignore"):     # a diverged step is reported below
                    ts.solve(objs[0])
                reason = ts.getConvergedReason()
            except (np.linalg.LinAlgError, PETSc.Error) as err:   # a singular step
                traj.completed, traj.reason = False, f"DIVERGED: {str(err).splitlines()[0]}"
                traj.steps += ts.getStepNumber()
                return traj
            traj.steps += ts.getStepNumber()
            traj.rejected += ts.getStepRejections() + self._rollbacks
            traj.snes_failures += ts.getSNESFailures()
            t = ts.getTime()
        finally:
            ts.destroy()
            for obj in objs:
                obj.destroy()
        traj.completed = bool(reason > 0 and t >= t_end * (1 - 1e-12))
        traj.reason = _reason(reason)
        return traj

    def _monitor(self, traj, on_step):
        def monitor(ts, step, t, U):
            if step == 0 or (traj.time and t <= traj.time[-1]):
                return
            u, v = (x.getArray(readonly=True).copy() for x in ts.getSolution2())
            p = None
            if self.cables is not None:
                p, taut = self.cables.mean_tensions(t, u, v)
                self._note_switches(traj, taut & (p > TAUT_TENSION))
            self._record(traj, t, u, v, p)
            if on_step is not None:
                on_step(t)
        return monitor

    def _note_switches(self, traj, taut):
        """The modes in the step just taken (taut: a positive mean tension); a change
        is an event at the step's start (its time known to within the step)."""
        new = np.where(taut, TAUT, SLACK)
        for i in np.flatnonzero(new != self.modes):
            traj.events.append((self.cables.start.t, int(i) + 1, MODE_NAMES[new[i]]))
        self.modes = new

    def _record(self, traj, t, U, V, p=None):
        """Append the state at t; ``p``: the tensions of the step that ended at t
        (length control: its mean tensions, whose work on the step is p . Delta L)."""
        theta = self.theta_of(U)
        mean = p is not None
        if p is None:
            p = self.drive.tensions(t)
        lengths = self.cable_lengths(theta)
        work = 0.0
        if traj.time:
            p_step = p if mean else 0.5 * (traj.p[-1] + p)
            work = traj.work[-1] - float(p_step @ (lengths - traj.lengths[-1]))
        traj.time.append(float(t))
        traj.theta.append(theta)
        traj.omega.append(V[: self.N].copy())
        traj.p.append(p)
        traj.lengths.append(lengths)
        traj.kinetic.append(self.inertia.kinetic_energy(theta, V[: self.N]))
        traj.strain.append(self.disc.strain_energy(theta))
        traj.gravity.append(weight_potential(self.disc, theta))
        traj.work.append(work)


def _reason(code: int) -> str:
    return reason_name(TS_REASONS, code)
