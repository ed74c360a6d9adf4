"""Load-controlled equilibrium (Eq. (9)) with PETSc SNES and load stepping.

:class:`EquilibriumSolver` owns one SNES (Newton with line search, options
prefix ``eq_``) on the bordered system of :mod:`elastica_petsc.core.fem`, its
Jacobian matrix and work vectors.  :meth:`EquilibriumSolver.solve` follows a
loading path in tension space (continuation with a secant predictor and
adaptive step) so that the equilibrium reached is the one the loading
history selects (Fig. 8).  Each arm is a small problem: it lives on
``PETSc.COMM_SELF``; parallelism is across arms (see ``workspace``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from petsc4py import PETSc

from ..core import interrupt
from ..core.results import Result
from ..core.errors import InputError
from ..core.fem import Discretisation
from .bifurcation import (BIFURCATION_TOL, AmplitudeContinuation, Bifurcation, critical_mode,
                          orthogonality, tip_side)
from .inertia import InertiaCounter
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm
from .reasons import SNES_REASONS

# A cable shorter than this (in units of l) has collapsed onto its routing point.
COLLAPSE_LENGTH = 2e-3
# The reason reported then (the same name as tip control's, solvers/control.py).
CABLE_COLLAPSE = "CABLE_COLLAPSE"
# A stable branch ends at a bifurcation (not a limit point) and no stable
# post-critical state was found (a subcritical bifurcation): solvers/bifurcation.py.
BIFURCATION = "BIFURCATION"
# How a bifurcating branch ended before the end load (AmplitudeContinuation.branch).
BRANCH_ENDS = {
    "subcritical": "bends back below the critical load (subcritical: the arm would snap)",
    "collapse": "pulls the attachment point onto its routing point before the end load",
    "lost": "could not be followed",
    "unstable": "reaches the end load unstable",
    "reached": "reaches the end load"}
# Which branch to take at a symmetric bifurcation (solvers/bifurcation.py, tip_side).
SIDES = ("left", "right")


@dataclass(frozen=True, repr=False)
class Equilibrium(Result):
    """A solved state of the arm, non-dimensional (lengths / l, p = P l^2 / B)."""

    disc: Discretisation
    p: np.ndarray                 # tensions reached
    u: np.ndarray                 # bordered state (theta_1..N, y_1..n)
    converged: bool
    reason: str                   # PETSc's SNES reason of the last solve
    iterations: int               # Newton iterations, all load steps
    load_steps: int
    message: str = ""
    unstable_modes: int = 0       # negative eigenvalues of K (0: stable under load control)
    snaps: tuple = ()             # tensions at which the loading path snapped (limit points)
    bifurcations: tuple = ()      # Bifurcation crossed on the way, each with the branch taken
    p_requested: np.ndarray | None = field(default=None, repr=False)

    @property
    def stable(self) -> bool:
        """Stable under load control: K positive definite (docs/model.md §2)."""
        return self.unstable_modes == 0

    @cached_property
    def theta(self) -> np.ndarray:
        """Nodal angles theta_0..theta_N [rad]."""
        return self.disc.split(self.u)[0]

    @cached_property
    def x(self) -> np.ndarray:
        """Centreline at the nodes, (N+1, 2), units of l (Eq. (2))."""
        return self.disc.node_positions(self.theta)

    @property
    def tip(self) -> np.ndarray:
        return self.x[-1]

    @cached_property
    def attachments(self) -> np.ndarray:
        """Where each cable ends (its offset included, docs/model.md §11)."""
        if self.disc.has_paths:
            return self.disc.attachment_points(self.theta)
        return self.x[self.disc.attach_index]

    @cached_property
    def cable_lengths(self) -> np.ndarray:
        """L_i = |r_i - x_i| in units of l (through the guides: the whole path)."""
        if self.disc.has_paths:
            return self.disc.cable_lengths_of(self.theta)
        chord = self.disc.routes - self.attachments
        return np.hypot(chord[:, 0], chord[:, 1])

    @property
    def directions(self) -> np.ndarray:
        """Unit cable directions d_i (Eq. (3)); through guides, those of each
        cable's last segment, from its end point toward the previous point."""
        if self.disc.has_paths:
            return self.disc.cables(self.disc.split(self.disc.consistent_state(self.theta))[1])[1]
        return (self.disc.routes - self.attachments) / self.cable_lengths[:, None]

    @cached_property
    def cable_points(self) -> list[np.ndarray]:
        """Each cable's polyline from its routing point to its end, units of l."""
        disc = self.disc
        if not disc.has_paths:
            return [np.vstack((r, a)) for r, a in zip(disc.routes, self.attachments)]
        points = disc.point_positions(self.theta)
        starts = disc.path_starts
        return [np.vstack((disc.routes[i], points[starts[i]:starts[i + 1]]))
                for i in range(disc.n_tendons)]

    @property
    def strain_energy(self) -> float:
        """Strain energy in units of SE_0 = B/(2l) (Eq. (21))."""
        return 2.0 * self.disc.strain_energy(self.theta)

    @property
    def curvature(self) -> np.ndarray:
        """l * theta' per element."""
        return self.disc.curvature(self.theta)

    @property
    def kappa_max(self) -> float:
        """max_s l |theta'| (Fig. 5a)."""
        return float(np.max(np.abs(self.curvature)))


def loading_path(p_start, p_end, order=None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Segments of a piecewise-linear loading path in tension space.

    ``order=None`` changes all tensions proportionally; ``order=(2, 1)`` (1-based
    tendon numbers, a permutation) brings tendon 2 to its final tension first,
    then tendon 1 (Fig. 8: the order selects the equilibrium).
    """
    p_start = np.asarray(p_start, float)
    p_end = np.asarray(p_end, float)
    if order is None:
        return [(p_start, p_end)]
    segments, current = [], p_start.copy()
    for number in order:
        nxt = current.copy()
        nxt[number - 1] = p_end[number - 1]
        segments.append((current, nxt))
        current = nxt
    return segments


def check_order(order, n_tendons: int) -> tuple[int, ...] | None:
    """Validate a loading order: a permutation of 1..n, or None."""
    if order is None:
        return None
    order = tuple(int(k) for k in order)
    if sorted(order) != list(range(1, n_tendons + 1)):
        raise InputError(
            f"loading order {','.join(map(str, order))} is not a permutation of the tendon "
            f"numbers 1..{n_tendons}")
    return order


def newton_converged(reason: str) -> bool:
    """Whether a Newton solve that ended with ``reason``
    (:meth:`EquilibriumSolver.newton`) converged."""
    return reason.startswith("CONVERGED")


@dataclass
class _Path:
    """What one :meth:`EquilibriumSolver.solve` learns on its way (per solve)."""

    side: str | None                  # the branch asked for at a bifurcation
    modes: int                        # negative eigenvalues of K at the current state
    snaps: list = field(default_factory=list)
    bifurcations: list = field(default_factory=list)
    p_critical: np.ndarray | None = None       # a bifurcation with no stable side
    branch_ends: list = field(default_factory=list)


def check_tensions(p, n_tendons: int) -> np.ndarray:
    """Non-negative, finite, one per tendon (a cable cannot push)."""
    p = np.asarray(p, dtype=float).ravel()
    if p.size != n_tendons:
        raise InputError(f"expected {n_tendons} tensions (one per tendon), got {p.size}")
    if (p >= 0).all() and np.isfinite(p).all():           # the common case, checked fast
        return p
    if not np.isfinite(p).all():
        raise InputError("tensions must be finite numbers")
    if (p < 0).any():
        i = int(np.argmax(p < 0)) + 1
        raise InputError(f"tension of tendon {i} is negative ({p[i - 1]:g}): a cable cannot push")
    return p


class EquilibriumSolver:
    """SNES on the bordered system of one arm, reused across solves.

    Parameters
    ----------
    disc : the discretised arm.
    max_step : largest change of any tension (non-dimensional) per load step.
    jump_tol : largest change of any nodal angle [rad] between the predictor
        and the converged state of one load step; a larger change means Newton
        jumped to another branch, and the step is halved.  Load steps that land
        on an unstable state are refused likewise when the path started stable.
        When the step cannot shrink further (a limit point), the arm snaps: a
        distant state is accepted only if it is stable, and the snap recorded.
    tip_moment : applied end moment M l / B (closed-form checks only).
    comm : one process (default ``PETSc.COMM_SELF``).
    options_prefix : PETSc options prefix of the SNES, its Jacobian and
        vectors; e.g. ``-eq_snes_monitor``.
    petsc_options : options without the prefix (nested dicts flatten,
        :mod:`.options`); the command line wins.

    The tensions of the current Newton solve (``_p``) are the context of the
    SNES callbacks; everything else a solve learns is returned.
    """

    def __init__(self, disc: Discretisation, *, max_step: float = 2.0, jump_tol: float = 0.5,
                 tip_moment: float = 0.0, comm=None, options_prefix: str = "eq_",
                 petsc_options=None):
        self.options = SolverOptions(options_prefix, petsc_options)
        self.comm = comm = check_comm(comm)
        self.disc = disc
        self.max_step = max_step
        self.jump_tol = jump_tol
        self.tip_moment = tip_moment
        self._p = np.zeros(disc.n_tendons)
        indptr, indices, _ = disc.pattern
        # J keeps these arrays (no copy): the Jacobian callback writes its entries
        # in place and assembles, with no MatSetValues
        self._values = disc.jacobian_values(disc.straight(), self._p)
        self.J = PETSc.Mat().createAIJWithArrays(
            (disc.size, disc.size), (indptr, indices, self._values), comm=comm)
        self.x = PETSc.Vec().createSeq(disc.size, comm=comm)
        self.f = self.x.duplicate()
        snes = PETSc.SNES().create(comm)
        self.options.label(snes, self.J, self.x, self.f)
        snes.setType(PETSc.SNES.Type.NEWTONLS)
        snes.setFunction(self._form_function, self.f)
        snes.setJacobian(self._form_jacobian, self.J, self.J)
        # Round-off in the residual grows like N^(3/2) (entries ~ eps/h, N of them):
        # an absolute tolerance below that floor would only make Newton stall.
        atol = max(1e-10, 1e-14 * disc.n_elements ** 1.5)
        snes.setTolerances(rtol=1e-10, atol=atol, stol=1e-14, max_it=40)
        self.atol = atol
        # at least one Newton step: a warm start whose residual is already below
        # atol (tension change < ~1e-8) must still respond to the change, or the
        # tip would be piecewise constant in p at the optimiser's last steps
        snes.setForceIteration(True)
        use_bordered_lu(snes.getKSP())
        self.options.apply(snes)
        self.snes = snes
        self.inertia = InertiaCounter(disc, comm=comm,
                                      options_prefix=self.options.name("inertia_"))

    # --- PETSc callbacks ------------------------------------------------------
    def _form_function(self, snes, X, F) -> None:
        F.setArray(self.disc.residual(X.getArray(readonly=True), self._p, self.tip_moment))

    def _form_jacobian(self, snes, X, J, P) -> None:
        self._values[:] = self.disc.jacobian_values(X.getArray(readonly=True), self._p)
        P.assemble()                    # P is self.J: its entries are self._values

    # --- one Newton solve -----------------------------------------------------
    def newton(self, u0: np.ndarray, p) -> tuple[np.ndarray, int, str]:
        """One SNES solve at fixed tensions from ``u0``: (u, iterations,
        reason); converged if :func:`newton_converged` (reason)."""
        self._p = np.asarray(p, dtype=float)
        self.x.setArray(u0)
        self.snes.solve(None, self.x)
        reason = self.snes.getConvergedReason()
        # a forced step from a state already at round-off cannot decrease the
        # residual, and the line search then reports failure: still converged
        converged = reason > 0 or self.snes.getFunctionNorm() <= self.snes.getTolerances()[1]
        name = SNES_REASONS[reason] if reason > 0 or not converged else "CONVERGED_FNORM_ABS"
        return self.x.getArray().copy(), self.snes.getIterationNumber(), name

    def refresh_options(self) -> bool:
        """Apply PETSc options given since the solver was configured (under its
        prefix in the database, or by ``self.options.update``); True if any
        were.  Every :meth:`solve` does this first."""
        return self.options.refresh(self.snes)

    # --- load stepping ----------------------------------------------------------
    def solve(self, p, order=None, start: Equilibrium | None = None,
              tangent: np.ndarray | None = None, side: str | None = None) -> Equilibrium:
        """Equilibrium at tensions ``p`` reached along a loading path.

        From ``start`` (a previous equilibrium; default the straight, unloaded
        arm), tensions follow :func:`loading_path`.  Never returns a silently
        wrong state: if the path cannot be followed, ``converged`` is False and
        ``message`` says why, at which tensions, and PETSc's reason.
        ``tangent``: du/dp at ``start``, shape (n, size) (Eq. (14),
        :meth:`Sensitivity.state_derivative`), for a first-order (Euler)
        predictor of the first load step instead of ``start`` itself.

        Where a stable path loses stability at a bifurcation (the critical
        mode orthogonal to dF/dp, :mod:`elastica_petsc.solvers.bifurcation`)
        the solve switches onto the bifurcating branches on both sides and
        continues on a stable one: ``side`` ("left" or "right": where the tip
        moves relative to its tangent) if given, else the one of lower
        potential energy Pi at the end of the load segment, and on equal
        energies (a symmetric pitchfork) the left one.  Each crossing is
        recorded in ``bifurcations`` and described in ``message``.  If
        neither side has a stable state (subcritical), ``converged`` is False
        with reason ``BIFURCATION``.
        """
        p = check_tensions(p, self.disc.n_tendons)
        order = check_order(order, self.disc.n_tendons)
        if side is not None and side not in SIDES:
            raise InputError(f"side must be one of {', '.join(SIDES)} (or None), got {side!r}")
        return self.follow(p, order=order, start=start, tangent=tangent, side=side)

    def follow(self, p: np.ndarray, order=None, start: Equilibrium | None = None,
               tangent: np.ndarray | None = None, side: str | None = None) -> Equilibrium:
        """:meth:`solve` for arguments already checked (``p``: a float array
        from :func:`check_tensions`, ``order`` from :func:`check_order`), for
        callers that validated them once, such as tip control."""
        disc = self.disc
        self.refresh_options()
        u = disc.straight() if start is None else start.u.copy()
        p_now = np.zeros(disc.n_tendons) if start is None else np.asarray(start.p, float)
        path = _Path(side, start.unstable_modes if start is not None
                     else self.inertia.negative_eigenvalues(u, p_now))
        keep_stable = path.modes == 0
        iterations = steps = 0
        reason = "CONVERGED_FNORM_ABS"
        ok = True
        for pa, pb in loading_path(p_now, p, order):
            u, p_now, its, nsteps, reason, ok = self._follow(path, u, pa, pb, keep_stable,
                                                             tangent)
            tangent = None                               # valid at the start only
            iterations += its
            steps += nsteps
            if not ok:
                break
        result = dict(converged=ok, reason=reason, iterations=iterations, load_steps=steps,
                      unstable_modes=path.modes, snaps=tuple(path.snaps),
                      bifurcations=tuple(path.bifurcations), p_requested=p,
                      message="; ".join(b.describe() for b in path.bifurcations))
        if not ok:
            result["message"] = self._failure_message(path, u, p_now, p, reason)
        return Equilibrium(disc, p_now, u, **result)

    def _follow(self, path: _Path, u, pa, pb, keep_stable: bool, tangent=None,
                min_fraction: float = 1e-5):
        """Continuation from the equilibrium ``u`` at ``pa`` to tensions ``pb``
        (``tangent``: du/dp at ``pa`` for the first predictor, else a secant)."""
        span = float(np.abs(pb - pa).max()) if len(pa) else 0.0
        full = 1.0 if span <= self.max_step else self.max_step / span
        dlam, lam, iterations, steps = full, 0.0, 0, 0
        u_prev, dlam_prev = None, None
        reason = "CONVERGED_ITERATING"
        n_angles = self.disc.n_elements
        while lam < 1.0:
            interrupt.check()                     # a run's stop, inside long work
            step = min(dlam, 1.0 - lam)
            if u_prev is not None:
                predictor = u + (u - u_prev) * (step / dlam_prev)
            elif tangent is not None and lam == 0.0:
                predictor = u + (step * (pb - pa)) @ tangent
            else:
                predictor = u
            target = pa + (lam + step) * (pb - pa)
            u_new, its, reason = self.newton(predictor, target)
            iterations += its
            limit_point = step <= min_fraction
            if newton_converged(reason):
                # a branch jump only makes sense along a path: with fixed tensions
                # (span 0) this is a plain Newton solve
                jumped = span > 0 and \
                    np.abs(u_new[:n_angles] - predictor[:n_angles]).max() > self.jump_tol
                modes = self.inertia.negative_eigenvalues(u_new, target)
                if keep_stable and modes > 0:
                    reason = "UNSTABLE_STATE"
                elif jumped and not limit_point:
                    reason = "BRANCH_JUMP"
                else:
                    if jumped:
                        path.snaps.append(target)
                        u_prev = None          # no secant across a snap
                    else:
                        u_prev, dlam_prev = u, step
                    u, lam, steps, path.modes = u_new, lam + step, steps + 1, modes
                    if self.disc.shortest_segments(u[n_angles:].reshape(-1, 2)).min() < \
                            COLLAPSE_LENGTH:
                        # a cable collapsed onto its routing point: no load beyond
                        return u, pa + lam * (pb - pa), iterations, steps, CABLE_COLLAPSE, False
                    if its <= 4:
                        dlam = min(2.0 * dlam, full)
                    continue
            if limit_point and reason == "UNSTABLE_STATE":
                switched = self._switch(path, u, lam, u_new, lam + step, pa, pb)
                if switched is not None:
                    u, its, path.modes = switched
                    return u, pb, iterations + its, steps + 1, "CONVERGED_FNORM_ABS", True
                if path.p_critical is not None:
                    reason = BIFURCATION
            if limit_point:
                return u, pa + lam * (pb - pa), iterations, steps, reason, False
            dlam = 0.5 * step
        return u, pb, iterations, steps, reason, True

    def _switch(self, path: _Path, u, lam: float, u_unstable, lam_unstable: float, pa, pb):
        """At a loss of stability between the stable ``u`` (at ``lam``) and the
        unstable ``u_unstable``: if it is a bifurcation, the stable state at
        ``pb`` on the side chosen by the rule of :meth:`solve`, as (u,
        iterations, unstable modes); None at a limit point or if no side has
        a stable state (then ``path.p_critical`` is set for a bifurcation)."""
        disc = self.disc
        mu0, v = critical_mode(disc, u, pa + lam * (pb - pa))
        if orthogonality(disc, u, pb - pa, v) > BIFURCATION_TOL:
            return None                                  # a limit point: v . f != 0
        mu1, _ = critical_mode(disc, u_unstable, pa + lam_unstable * (pb - pa))
        # the smallest eigenvalue is linear in the load near its zero
        lam_c = lam + (lam_unstable - lam) * mu0 / (mu0 - mu1) if mu0 > 0 > mu1 else lam
        path.p_critical = pa + lam_c * (pb - pa)
        continuation = AmplitudeContinuation(disc, pa, pb, self.atol)
        found, its, path.branch_ends = {}, 0, []
        for sign in (1.0, -1.0):
            outcome, ends = continuation.branch(u, lam, v, sign)
            path.branch_ends.append(outcome)
            if outcome != "reached":          # (ends[0] is None if lost at the first step)
                continue
            (u0, l0), (u1, l1) = ends
            u_end, n, end_reason = self.newton(u0 + (1.0 - l0) / (l1 - l0) * (u1 - u0), pb)
            its += n
            if newton_converged(end_reason) and self.inertia.negative_eigenvalues(u_end, pb) == 0:
                found.setdefault(tip_side(disc, u, u_end), u_end)
            else:
                path.branch_ends[-1] = "unstable"
        side, rule = self._choose_side(path.side, found, pb)
        if side is None:
            return None
        path.bifurcations.append(Bifurcation(path.p_critical.copy(), side, rule))
        path.p_critical = None
        return found[side], its, 0

    def _choose_side(self, asked: str | None, found: dict, p) -> tuple[str | None, str]:
        """The rule of :meth:`solve`: the ``asked`` side, else the lower
        potential energy, else (equal energies) the left side."""
        if asked is not None:
            return (asked, "requested") if asked in found else (None, "")
        if len(found) < 2:
            return next(iter(found), None), "the only side with a stable state"
        energy = {k: self.disc.potential(self.disc.split(u)[0], p) for k, u in found.items()}
        if abs(energy["left"] - energy["right"]) <= 1e-9 * (1.0 + abs(energy["left"])):
            return "left", "both sides have the same energy: the left one by convention"
        low = min(energy, key=energy.get)
        return low, "the lower potential energy"

    def _failure_message(self, path: _Path, u, p_reached, p_target, reason: str) -> str:
        lengths = self.disc.shortest_segments(self.disc.split(u)[1])
        shortest = int(np.argmin(lengths))
        where = "tensions p = (" + ", ".join(f"{v:.4g}" for v in p_reached) + ")"
        if lengths[shortest] < COLLAPSE_LENGTH:
            what = ("pulled two points of its path together (segment length" if
                    self.disc.has_paths else
                    "pulled its attachment point onto its routing point (cable length")
            return (f"tendon {shortest + 1} {what} {lengths[shortest]:.2e} l) at {where}: the "
                    "cable direction is undefined beyond this load")
        if reason == BIFURCATION:
            side = f"on the {path.side} side" if path.side else "on either side"
            return (f"the stable branch ends at {where} at a bifurcation (the critical mode is "
                    "orthogonal to the load, not a limit point) and no stable post-critical "
                    f"state was found {side}: " + "; ".join(
                        f"{k} branch: {BRANCH_ENDS[e]}" for k, e in
                        zip(("one", "other"), path.branch_ends)))
        if reason in ("BRANCH_JUMP", "UNSTABLE_STATE"):
            return (f"the stable equilibrium branch ends at {where} (limit point: the arm "
                    "snaps) and no stable state to snap to was found")
        return (f"no equilibrium reached beyond {where} on the way to ("
                + ", ".join(f"{v:.4g}" for v in p_target) + f"); PETSc SNES reason {reason}")

    def destroy(self) -> None:
        self.inertia.destroy()
        for obj in (self.snes, self.J, self.x, self.f):
            obj.destroy()

    def __enter__(self) -> "EquilibriumSolver":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()


def solve_equilibrium(disc: Discretisation, p, *, order=None, side: str | None = None,
                      start: Equilibrium | None = None) -> Equilibrium:
    """One equilibrium (Eq. (9)) reached along a loading path, with a solver
    made and destroyed for it: :meth:`EquilibriumSolver.solve` (``side``: the
    branch to take at a symmetric bifurcation, "left" or "right";
    non-dimensional tensions p = P l^2/B)."""
    with EquilibriumSolver(disc) as solver:
        return solver.solve(p, order=order, start=start, side=side)
