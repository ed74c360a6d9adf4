"""The arm in motion on PETSc TS (docs/model.md §16).

The unknowns are U = (theta_1..theta_N, Lambda_1..Lambda_n): the nodal angles
and the tension impulses, whose rates are the tensions, p = Lambda' (a
tension is then a velocity of the integrator, determined at the end of each
step like every velocity, and the displacement-like Lambda is smooth enough
for the alpha method's recursions).  The second-order residual (TSALPHA2,
``setI2Function``) is

    F_theta = M(theta) theta'' + c(theta, theta') + (a M + b L) theta' + R(theta, p)
    F_p_i   = p_i - pbar_i(t)                (force control)
            = grad L_i . theta' - Lbar_i'(t) (taut cable: the tension is a multiplier)
            = p_i                            (slack cable)

with the kernels of :mod:`elastica_petsc.core.dynamics` and R the static
residual of docs/model.md §8 (so every load the static model has is in the
dynamics).  A taut cable's constraint is imposed on the velocities (index
2): then a step of any size starts from velocities that satisfy it, and the
tension stays bounded as the step shrinks (at an event, say); imposed on the
positions (index 3) the multiplier of a step dt grows like 1/dt.  Its
length drifts by O(dt^2) (the rule integrates the rate; not yet reported).
Time integration: generalized-alpha for second-order systems (TSALPHA2) in
PETSc's parametrisation by the spectral radius rho_inf at infinite step
(``radius``; 1, the default: the implicit midpoint member, no numerical
dissipation; docs/model.md §16.4 on why alpha_f = 1 is not used).  Fixed
equal steps by default, or (``adaptive``) TSAdapt ``basic`` on the alpha
method's local error estimate of the angles (the tension impulses are
left out of the norm).  Newton: SNES with KSP ``preonly`` and a PC that
solves the principal part of the Jacobian exactly in O(N):

    J ~ [[sigma M + shift_V b L + K(theta, p),  shift_V C],   C = [grad L_i]
         [shift_V C_taut^T or identity rows              ]]

(sigma = shift_A + a shift_V; K = T + W diag(p/L) W^T the static tangent of
§2; the derivatives of M(theta) theta'' and of the velocity terms with respect
to theta, O(dt^2) and O(dt) relative, are left out, so Newton converges
linearly at that rate: a modified Newton).  T and sigma M are one banded
system (:class:`~elastica_petsc.core.dynamics.BandedInverse`), the tendon
terms a Woodbury correction of rank n, the taut cables an n x n Schur
complement: O(n N) per factorisation and per solve.

Slack and taut cables (length control): TSEvent watches p_i of taut cables
(going through 0 downwards: the cable goes slack) and the gap
Lbar_i(t) - |r_i - x_i| of slack ones (through 0 downwards: it tightens).
At an event the integration stops, the cable's mode switches and the
integration restarts from the event's state.  A cable that tightens stops
the attachment's motion along it at once: the velocities jump by the
plastic impulse theta'+ = theta'- - M^{-1} C lambda with C^T theta'+ =
Lbar' for the taut cables (M^{-1} is the banded solve with T = 0).
Options prefix ``sim_`` (``-sim_ts_monitor``, ``-sim_snes_monitor``,
``-sim_ts_adapt_monitor``, ...).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from petsc4py import PETSc

from ..core.drive import LengthDrive, TensionDrive
from ..core.dynamics import BandedInverse, Inertia, elastic_band, solve_lcp
from ..core.fem import Discretisation
from .options import SolverOptions, check_comm
from .reasons import TS_REASONS, reason_name

FORCE, TAUT, SLACK = 0, 1, 2
MODE_NAMES = {FORCE: "force", TAUT: "taut", SLACK: "slack"}
EXCLUDED = 1e30            # atol of the tension unknowns: out of the error norm


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
    (adaptive steps and TSEvent's shortened ones refresh it every iteration);
    ``max_steps``: cap on accepted steps.  ``comm``, ``options_prefix``
    (``sim_``), ``petsc_options``: the contract of :mod:`.options`.
    """

    def __init__(self, disc: Discretisation, inertia: Inertia, *, rtol: float = 1e-6,
                 atol: float = 1e-8, radius: float = 1.0, dt0: float = 1e-3,
                 adaptive: bool = True, contact_tol: float = 1e-6, max_steps: int = 10**7,
                 lag_jacobian: int = 10,
                 comm=None, options_prefix: str = "sim_", petsc_options=None):
        self.options = SolverOptions(options_prefix, petsc_options, {
            "ts_alpha_radius": radius, "ts_adapt_type": "basic" if adaptive else "none",
            "snes_linesearch_type": "basic", "snes_lag_jacobian": lag_jacobian,
            "snes_lag_jacobian_persists": True})
        self.comm = check_comm(comm)
        self.adaptive = adaptive
        self.disc, self.inertia = disc, inertia
        self.rtol, self.atol, self.radius, self.dt0 = rtol, atol, radius, dt0
        self.prefix, self.max_steps = self.options.prefix, max_steps
        self.N, self.n = disc.n_elements, disc.n_tendons
        self.L_band = elastic_band(disc)
        self.attach = list(disc.attach_nodes)
        self.modes = np.full(self.n, FORCE)
        self.offsets = np.zeros(self.n)     # L_i - Lbar_i when cable i last went slack
        # a slack cable tightens when its gap falls below -contact_tol (l): the start
        # of a step's position error, not a cable that re-tightens on round-off
        self.contact_tol = contact_tol
        self._fired = []
        self.drive = None

    # --- model pieces -------------------------------------------------------------
    def theta_of(self, U: np.ndarray) -> np.ndarray:
        return np.concatenate(([0.0], U[: self.N]))

    def cable_lengths(self, theta: np.ndarray) -> np.ndarray:
        x = self.disc.node_positions(theta)[self.attach]
        return np.linalg.norm(self.disc.routes - x, axis=1)

    def residual(self, t, U, V, A) -> np.ndarray:
        N = self.N
        theta, p = self.theta_of(U), V[N:]
        out = np.empty(N + self.n)
        out[:N] = self.inertia.residual(theta, V[:N], A[:N], p)
        out[N:] = self._tendon_rows(t, theta, V[:N], p)
        return out

    def _tendon_rows(self, t, theta, omega, p) -> np.ndarray:
        rows = p.copy()
        force = self.modes == FORCE
        if force.any():
            rows[force] -= self.drive.tensions(t)[force]
        taut = self.modes == TAUT
        if taut.any():
            grad = self._grad_lengths(theta)
            rows[taut] = (grad @ omega - self.drive.rates(t))[taut]
        return rows

    def _factor(self, U, V, shift_v, shift_a):
        """Set the PC to the exact inverse of the principal Jacobian at (U, V)
        (d p / d Lambda = shift_v)."""
        disc, inert, N = self.disc, self.inertia, self.N
        theta, p = self.theta_of(U), V[N:]
        u = disc.consistent_state(theta)
        t = disc.terms(u, p)
        g = disc.attachment_gradients(theta, (t.c, t.s))
        sigma = shift_a + inert.viscous * shift_v
        band = disc.band(theta, t.d, p, t) + shift_v * inert.kelvin_voigt * self.L_band \
            + sigma * inert.rotary
        inv = BandedInverse(disc, theta, inert.weights, sigma, band)
        Ut = disc.transverse_gradients(g, t.d).T            # (N, n)
        c = p / t.lengths
        C = -(g[..., 0] * t.d[:, :1] + g[..., 1] * t.d[:, 1:]).T   # grad L_i, (N, n)
        Z = inv.solve(np.column_stack((Ut, C)))
        Zu, Zc = Z[:, : self.n], Z[:, self.n:]
        woodbury = np.linalg.solve(np.eye(self.n) + c[:, None] * (Ut.T @ Zu),
                                   c[:, None] * Ut.T)       # cap^-1 diag(c) Ut^T, (n, N)

        def inverse(r2):           # (A + Ut diag(c) Ut^T)^{-1} r2 by Woodbury
            return r2 - Zu @ (woodbury @ r2)

        Y = inverse(Zc)                                      # A'^{-1} C
        taut = np.flatnonzero(self.modes == TAUT)
        known = np.flatnonzero(self.modes != TAUT)
        S = C[:, taut].T @ Y[:, taut]

        def apply(r):
            dp = np.zeros(self.n)
            dp[known] = r[N:][known]
            x = inverse(inv.solve(r[:N] - C[:, known] @ dp[known])[:, None])[:, 0]
            if len(taut):
                dp[taut] = np.linalg.solve(S, C[:, taut].T @ x - r[N:][taut] / shift_v)
                x = x - Y[:, taut] @ dp[taut]
            return np.concatenate((x, dp / shift_v))

        self.pc_ctx.apply_fn = apply

    # --- contact: the cables' complementarity (docs/model.md §16.3) -----------------------
    def _delassus(self, theta, idx):
        """(C, M^{-1} C, W = C^T M^{-1} C, M^{-1}) of the cables ``idx``; C = [grad L_i]."""
        C = self._grad_lengths(theta)[idx].T                  # (N, k)
        inv = BandedInverse(self.disc, theta, self.inertia.weights, 1.0, self.inertia.rotary)
        MinvC = inv.solve(C).reshape(self.N, len(idx))
        return C, MinvC, C.T @ MinvC, inv

    def _unforced(self, t, theta, omega, idx):
        """(W, q) of the cables ``idx`` at the acceleration level: with tensions
        p on them (and none on the others), gap_i'' = Lbar_i'' - d^2 L_i/dt^2 = q + W p."""
        disc = self.disc
        C, _, W, inv = self._delassus(theta, idx)
        f = -(self.inertia.force(theta, omega, np.zeros(self.N))
              + disc.residual(disc.consistent_state(theta), np.zeros(self.n))[: self.N])
        eps = 1e-7
        pad = np.concatenate(([0.0], omega))
        curvature = (self._grad_lengths(theta + eps * pad)
                     - self._grad_lengths(theta - eps * pad))[idx] @ omega / (2 * eps)
        return W, self.drive.rates(t, 2)[idx] - curvature - C.T @ inv.solve(f)

    def consistent_tensions(self, t, theta, omega, p) -> np.ndarray:
        """The tensions of the taut cables that the equations of motion and
        the constraints' second derivative (gap_i'' = 0) give at (t, theta,
        theta'), negative values allowed (the event function); other entries
        from ``p``.  A function of the state alone, continuous in time, unlike
        the integrator's multiplier: the velocities are first projected on the
        taut cables' constraints C^T theta' = Lbar' (the alpha method imposes
        them at mid-step, so the step-end velocities carry a component
        alternating in sign from step to step that does not vanish as the step
        shrinks; left in, it makes the event function jump and TSEvent stall).
        """
        taut = np.flatnonzero(self.modes == TAUT)
        p = np.array(p, float)
        if len(taut):
            C, MinvC, W, _ = self._delassus(theta, taut)
            omega = omega - MinvC @ np.linalg.solve(W, C.T @ omega - self.drive.rates(t)[taut])
            W, q = self._unforced(t, theta, omega, taut)
            p[taut] = np.linalg.solve(W, -q)
        return p

    def _grad_lengths(self, theta) -> np.ndarray:
        """grad_theta L_i, (n, N)."""
        return self.disc.load_derivative(self.disc.consistent_state(theta))[:, : self.N]

    def event_values(self, t, U, V) -> np.ndarray:
        """p_i (taut, :meth:`consistent_tensions`), gap_i (slack), 1 (force
        control): an event is a fall through 0."""
        theta = self.theta_of(U)
        p = self.consistent_tensions(t, theta, V[: self.N], V[self.N:])
        out = np.ones(self.n)
        taut, slack = self.modes == TAUT, self.modes == SLACK
        out[taut] = p[taut]
        if slack.any():
            gap = self.drive.lengths(t) + self.offsets - self.cable_lengths(theta)
            out[slack] = gap[slack] + self.contact_tol
        return out

    # --- the TS ----------------------------------------------------------------------
    def _make_ts(self, t0, t_end, U0, V0, record, dt0):
        comm = self.comm
        size = self.N + self.n
        ts = PETSc.TS().create(comm)
        ts.setOptionsPrefix(self.prefix)
        ts.setType(PETSc.TS.Type.ALPHA2)
        self.pc_ctx = _Principal(self)
        F = PETSc.Vec().createSeq(size, comm=comm)

        def i2function(ts_, t, U, V, A, Fv):
            Fv.setArray(self.residual(t, U.getArray(readonly=True), V.getArray(readonly=True),
                                      A.getArray(readonly=True)))

        def i2jacobian(ts_, t, U, V, A, shift_v, shift_a, J, P):
            self._factor(U.getArray(readonly=True), V.getArray(readonly=True), shift_v, shift_a)

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
            ts.setTimeStep(dt0)
            ts.setMaxSteps(self.max_steps)
            ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
        elif (self.modes == FORCE).all():   # equal steps ending on t_end (no sliver)
            count = max(1, math.ceil((t_end - t0) / dt0 - 1e-9))
            ts.setTimeStep((t_end - t0) / count)
            ts.setMaxTime(t_end + 0.5 * (t_end - t0) / count)
            ts.setMaxSteps(count)
            ts.setExactFinalTime(PETSc.TS.ExactFinalTime.STEPOVER)
        else:       # steps dt0 with events (TSEvent may shorten some)
            ts.setTimeStep(dt0)
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
        if (self.modes != FORCE).any():
            def events(ts_, t, U, fvalue):
                V = ts_.getSolution2()[1]
                fvalue[:] = self.event_values(t, U.getArray(readonly=True),
                                              V.getArray(readonly=True))

            def post(ts_, events_fired, t, U, forward):
                self._fired = [int(i) for i in events_fired]

            ts.setEventHandler([-1] * self.n, [True] * self.n, events, post)
        self.options.label(F, J, U, V)
        self.options.apply(ts)
        return ts, (U, V, F, J, atol, rtol)

    def run(self, theta0, omega0, p0, drive, modes, t_end: float, *,
            on_step=None, trajectory: Trajectory | None = None) -> Trajectory:
        """Integrate from (theta0 (N+1,), omega0 (N,), p0 (n,)) at t = 0 to ``t_end``.

        ``drive``: a TensionDrive (every cable force-controlled) or a
        LengthDrive; ``modes``: initial TAUT/SLACK of each cable under a
        LengthDrive.  ``on_step(t)`` after every accepted step.  The trajectory
        (also when interrupted) holds every accepted step.
        """
        self.drive = drive
        self.offsets = np.zeros(self.n)
        self.modes = np.asarray(modes, int).copy() if isinstance(drive, LengthDrive) \
            else np.full(self.n, FORCE)
        if self.adaptive or isinstance(drive, LengthDrive):
            # the step changes (TSAdapt, TSEvent's location): a PC kept for another step's
            # shift stalls Newton, so it is refreshed at every iteration
            self.options.update({"snes_lag_jacobian": 1})
        traj = trajectory if trajectory is not None else Trajectory()
        U0 = np.concatenate((np.asarray(theta0, float)[1:], np.zeros(self.n)))
        V0 = np.concatenate((np.asarray(omega0, float), p0))
        if isinstance(drive, LengthDrive):      # the start: cables at zero gap in contact
            self._switch(None, 0.0, U0, V0, contact=self.modes == TAUT)
        t, dt = 0.0, self.dt0
        self._record(traj, t, U0, V0)
        while True:
            ts, objs = self._make_ts(t, t_end, U0, V0, self._monitor(traj, on_step), dt)
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
                traj.rejected += ts.getStepRejections()
                traj.snes_failures += ts.getSNESFailures()
                t, dt = ts.getTime(), ts.getTimeStep()
                U, V = (v.getArray().copy() for v in ts.getSolution2())
            finally:
                ts.destroy()
                for obj in objs:
                    obj.destroy()
            if reason != PETSc.TS.ConvergedReason.CONVERGED_EVENT:
                traj.completed = reason > 0 and t >= t_end * (1 - 1e-12)
                traj.reason = _reason(reason)
                return traj
            U0, V0 = U, V
            self._switch(traj, t, U0, V0)
            dt = max(dt, self.dt0) if self.adaptive else self.dt0

    def _switch(self, traj, t, U, V, contact=None):
        """Resolve the cables' complementarity at an event (or at the start).

        The cables in contact are the taut ones and those whose gap closed
        (``contact``: a boolean mask; by default the taut cables and the fired
        ones).  Velocity level (the impact, plastic): impulses lam >= 0 with
        gap rates w = Lbar' - C^T theta'+ >= 0, lam w = 0, theta'+ = theta'- -
        M^{-1} C lam; a cable with w > 0 separates.  Acceleration level for the
        others: tensions p >= 0 with gap'' >= 0, p gap'' = 0; p > 0 keeps a
        cable taut, otherwise it goes slack with its length drift (index 2,
        module docstring) kept as an offset, so that its gap starts at exactly 0.
        ``V`` is changed in place (velocities and tensions)."""
        N = self.N
        theta = self.theta_of(U)
        if contact is None:
            contact = self.modes == TAUT
            contact[self._fired] = True
        before = self.modes.copy()
        idx = np.flatnonzero(contact)
        new = np.full(self.n, SLACK)
        p = np.zeros(self.n)
        if len(idx):
            _, MinvC, W, _ = self._delassus(theta, idx)
            lam, w = solve_lcp(W, self.drive.rates(t)[idx]
                               - self._grad_lengths(theta)[idx] @ V[:N])
            V[:N] -= MinvC @ lam
            stay = idx[w <= 1e-9 * max(1.0, float(np.max(np.abs(w))))]
            if len(stay):
                W2, q2 = self._unforced(t, theta, V[:N], stay)
                p_stay, _ = solve_lcp(W2, q2)
                p[stay] = p_stay
                new[stay[p_stay > 1e-8 * max(1.0, float(np.max(p_stay)))]] = TAUT
        lengths, Lbar = self.cable_lengths(theta), self.drive.lengths(t)
        for i in range(self.n):
            if new[i] == SLACK and contact[i]:
                self.offsets[i] = lengths[i] - Lbar[i]
            if new[i] != before[i] and traj is not None:
                traj.events.append((t, i + 1, MODE_NAMES[new[i]]))
        self.modes = new
        V[N:] = p

    def _monitor(self, traj, on_step):
        def monitor(ts, step, t, U):
            if step == 0:
                return
            u, v = ts.getSolution2()
            self._record(traj, t, u.getArray(readonly=True).copy(),
                         v.getArray(readonly=True).copy())
            if on_step is not None:
                on_step(t)
        return monitor

    def _record(self, traj, t, U, V):
        theta = self.theta_of(U)
        p = self.drive.tensions(t) if isinstance(self.drive, TensionDrive) else \
            self.consistent_tensions(t, theta, V[: self.N], V[self.N:])
        lengths = self.cable_lengths(theta)
        work = 0.0
        if traj.time:
            work = traj.work[-1] - 0.5 * float((traj.p[-1] + p) @ (lengths - traj.lengths[-1]))
        traj.time.append(float(t))
        traj.theta.append(theta)
        traj.omega.append(V[: self.N].copy())
        traj.p.append(p)
        traj.lengths.append(lengths)
        traj.kinetic.append(self.inertia.kinetic_energy(theta, V[: self.N]))
        traj.strain.append(self.disc.strain_energy(theta))
        traj.work.append(work)


def _reason(code: int) -> str:
    return reason_name(TS_REASONS, code)
