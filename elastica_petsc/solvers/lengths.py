"""Length-controlled equilibria and their stability (Sec. 4.1, 4.6, Figs. 7-8;
docs/model.md §4.7).

Everything is non-dimensional (docs/model.md §3): lengths in units of l, tensions
p = P l^2 / B; ``*_mm`` helpers convert with the arm length.

The pieces: the augmented VI system (unknowns, complementarity, deflation)
is :mod:`.length_system`; stability under length control (the constrained
inertia count, the buckling mode, limit point or bifurcation) is
:mod:`.length_stability`; this module holds the results and
:class:`LengthSolver` (one solve, continuation in the cable lengths, the
branches past a critical point).  The searches built on them live in
:mod:`elastica_petsc.studies.search`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.budget import TIME_LIMIT
from ..core.deflation import Deflation
from ..core.errors import InputError
from ..core.fem import Discretisation
from .equilibrium import Equilibrium
from .inertia import InertiaCounter
from .length_stability import (LENGTH_BIFURCATION_TOL, LengthInertia, constrained_mode,
                               instability_kind)
from .length_system import TAUT_TOL, AugmentedSystem
from .options import SolverOptions

__all__ = ["DEFLATED_DIVERGENCE_FACTOR", "DEFLATION_OPTIONS", "LENGTH_BIFURCATION_TOL", "MAX_SNAP_SEARCHES", "SAME_SHAPE_TOL",
           "TAUT_TOL", "AugmentedSystem", "LengthEquilibrium", "LengthInertia", "LengthSolver",
           "check_lengths", "constrained_mode", "instability_kind", "same_shape"]

# Global searches for a state to snap to (``post_critical`` of LengthSolver.follow) per path.
MAX_SNAP_SEARCHES = 3
# Two states are the same equilibrium if no nodal angle differs by more (rad).
SAME_SHAPE_TOL = 1e-4
# PETSc options (under the solver's prefix) for deflated solves, unless the
# user sets them: the secant ("l2") line search explores beyond the start's basin.
DEFLATION_OPTIONS = {"snes_linesearch_type": "l2"}
# A deflated solve whose residual norm grows past this factor times its best is
# given up (length_system.DivergenceStop, measured there): a search's failures cost less.
DEFLATED_DIVERGENCE_FACTOR = 50.0


# --- results -----------------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class LengthEquilibrium(Equilibrium):
    """An equilibrium found under length control (or a load-controlled one
    re-examined under length control).

    Inherited fields keep their meaning: ``p`` the tensions found,
    ``unstable_modes`` the negative eigenvalues of K (stability under *load*
    control, ``stable``).  Added:

    lengths_requested : prescribed cable lengths L_i / l.
    length_unstable_modes : negative eigenvalues of K on null(C^T) of the
        taut cables (0: stable under length control); -1 if not computed.
    length_mm : the arm length, for the ``*_mm`` properties (None: unknown).
    jumps : cable lengths (units of l) at which a continuation path jumped
        to a distant state (snap or buckling); empty for a smooth path.
    instabilities : cable lengths at which the continued branch ended: it
        lost stability under length control or Newton could not continue it
        at any step size.
    instability_kinds : for each of ``instabilities``, "bifurcation" (the
        critical mode does not change the path's lengths: buckling, two
        branches) or "limit point" (a fold: the arm snaps), by
        :func:`instability_kind`.
    label : where the state came from (start and method), for searches.
    """

    lengths_requested: np.ndarray | None = None
    length_unstable_modes: int = -1
    length_mm: float | None = None
    jumps: tuple = ()
    instabilities: tuple = ()
    instability_kinds: tuple = ()
    label: str = ""

    @property
    def slack(self) -> np.ndarray:
        """L_i - |r_i - x_i| in units of l (>= 0; > 0 only for a slack cable)."""
        return self.lengths_requested - self.cable_lengths

    @property
    def taut(self) -> np.ndarray:
        """True for every cable that carries tension (p_i > TAUT_TOL)."""
        return np.asarray(self.p) > TAUT_TOL

    @property
    def stable_under_length_control(self) -> bool:
        return self.length_unstable_modes == 0

    def _mm(self, values):
        if self.length_mm is None:
            raise ValueError("the arm length is unknown: build the solver with from_arm()")
        return np.asarray(values) * self.length_mm

    @property
    def slack_mm(self) -> np.ndarray:
        return self._mm(self.slack)

    @property
    def cable_lengths_mm(self) -> np.ndarray:
        return self._mm(self.cable_lengths)

    @property
    def tip_mm(self) -> np.ndarray:
        return self._mm(self.tip)



def check_lengths(lengths, n_tendons: int) -> np.ndarray:
    """Positive, finite, one per tendon (units of l)."""
    L = np.asarray(lengths, dtype=float).ravel()
    if L.size != n_tendons:
        raise InputError(f"expected {n_tendons} cable lengths (one per tendon), got {L.size}")
    if not np.all(np.isfinite(L)) or np.any(L <= 0):
        raise InputError("cable lengths must be positive finite numbers")
    return L


def same_shape(a: Equilibrium, b: Equilibrium, tol: float = SAME_SHAPE_TOL) -> bool:
    return float(np.max(np.abs(a.theta - b.theta))) <= tol




# --- the length-control solver ----------------------------------------------------------
class LengthSolver:
    """Length-controlled equilibria of one discretised arm (SNES VI, prefix ``len_``).

    Parameters
    ----------
    disc : the discretised arm.
    length_mm : arm length for the ``*_mm`` helpers (set by :meth:`from_arm`).
    jump_tol : largest change of any nodal angle [rad] between the predictor
        and the converged state of one continuation step before the step is
        halved (a larger change is a jump to another branch).
    max_step : largest change of any cable length (units of l) per
        continuation step.
    comm : one process (default ``PETSc.COMM_SELF``).
    options_prefix : PETSc options prefix, e.g. ``-len_snes_monitor``,
        ``-len_snes_vi_monitor``; the deflated solves use ``<prefix>defl_``.
    petsc_options : options without the prefix (``{"defl": {...}}`` for the
        deflated solves), :mod:`.options`.
    """

    def __init__(self, disc: Discretisation, *, length_mm: float | None = None,
                 jump_tol: float = 0.5, max_step: float = 0.02, comm=None,
                 options_prefix: str = "len_", petsc_options=None):
        self.disc = disc
        self.length_mm = length_mm
        self.jump_tol = jump_tol
        self.max_step = max_step
        given = SolverOptions(options_prefix, petsc_options)
        deflated = given.part("defl_")
        plain = {k: v for k, v in given.options.items() if not k.startswith("defl_")}
        self.system = AugmentedSystem(disc, "length", options_prefix, petsc_options=plain,
                                      comm=comm)
        self.prefix, self.comm = self.system.options.prefix, self.system.comm
        # deflated solves explore: the l2 (secant) line search leaves the basin
        # of the start far more often than backtracking (measured on Fig. 8)
        self.deflated_system = AugmentedSystem(disc, "length", self.prefix + "defl_",
                                               petsc_options={**DEFLATION_OPTIONS, **deflated},
                                               comm=comm,
                                               divergence_factor=DEFLATED_DIVERGENCE_FACTOR)
        self.inertia = LengthInertia(disc, comm=comm, options_prefix=self.prefix + "inertia_")
        self.load_inertia = InertiaCounter(disc, comm=comm,
                                           options_prefix=self.prefix + "load_inertia_")

    @classmethod
    def from_arm(cls, arm, n_elements: int | None = None, **kw) -> "LengthSolver":
        return cls(Discretisation.from_arm(arm, n_elements), length_mm=arm.length_mm, **kw)

    # --- helpers -----------------------------------------------------------------------
    def _start(self, start) -> tuple[np.ndarray, np.ndarray]:
        if start is None:
            return self.disc.straight(), np.zeros(self.disc.n_tendons)
        if isinstance(start, Equilibrium):
            return np.asarray(start.u, float), np.asarray(start.p, float)
        u, p = start
        return np.asarray(u, float), np.asarray(p, float)

    def lengths_of(self, u) -> np.ndarray:
        """Cable chords |r_i - y_i| of a bordered state (units of l)."""
        return self.disc.cables(self.disc.split(u)[1])[0]

    def to_l(self, lengths_mm) -> np.ndarray:
        if self.length_mm is None:
            raise InputError("the arm length is unknown: build the solver with from_arm()")
        return np.asarray(lengths_mm, float) / self.length_mm

    def stability(self, u, p) -> tuple[int, int]:
        """(negative eigenvalues of K, of K on null(C_taut^T)): load and length control."""
        return (self.load_inertia.negative_eigenvalues(u, p),
                self.inertia.negative_eigenvalues(u, p))

    def _result(self, z, lengths, its, reason, ok, *, steps=1, message="", jumps=(),
                instabilities=(), kinds=(), label="") -> LengthEquilibrium:
        u, p, _ = self.system.parts(z)
        p = np.where(p <= 0.0, 0.0, p)
        modes = self.stability(u, p) if ok else (-1, -1)
        return LengthEquilibrium(
            self.disc, p.copy(), u.copy(), ok, reason, its, steps, message=message,
            unstable_modes=modes[0], lengths_requested=np.asarray(lengths, float).copy(),
            length_unstable_modes=modes[1], length_mm=self.length_mm, jumps=tuple(jumps),
            instabilities=tuple(instabilities), instability_kinds=tuple(kinds), label=label)

    # --- one VI Newton solve ------------------------------------------------------------
    def solve(self, lengths, start=None, *, deflate=None, label: str = "",
              max_it: int | None = None) -> LengthEquilibrium:
        """Equilibrium with cable lengths ``lengths`` (units of l) by one VI
        Newton solve from ``start`` (an Equilibrium, a pair (u, p), or None:
        the straight arm with p = 0).  ``deflate``: a :class:`Deflation`
        holding states Newton must not converge to again; ``max_it``: at most
        this many Newton iterations (default: the SNES's, 50)."""
        L = check_lengths(lengths, self.disc.n_tendons)
        u0, p0 = self._start(start)
        if deflate is None:
            sys = self.system
            sys.deflation = Deflation(self.disc.h)
            z, its, reason, ok = sys.newton(sys.augment(u0, p0), L, max_it)
        else:
            sys = self.deflated_system
            sys.deflation = deflate
            try:
                z, its, reason, ok = sys.newton(sys.augment(u0, p0), L, max_it)
            finally:
                sys.deflation = Deflation(self.disc.h)
        msg = "" if ok else (f"no length-controlled equilibrium reached from the start "
                             f"(PETSc SNES reason {reason})")
        return self._result(z, L, its, reason, ok, message=msg, label=label)

    def solve_mm(self, lengths_mm, start=None, **kw) -> LengthEquilibrium:
        return self.solve(self.to_l(lengths_mm), start, **kw)

    # --- continuation in the cable lengths -------------------------------------------------
    def follow(self, lengths, start=None, *, keep_stable: bool = True,
               min_fraction: float = 1e-4, label: str = "",
               post_critical=None, budget=None) -> LengthEquilibrium:
        """Continuation from ``start`` (an equilibrium; its own cable chords are
        the initial lengths, or for a slack cable of a LengthEquilibrium its
        prescribed length) to ``lengths`` (units of l) along the straight
        segment in length space, warm-started with a secant predictor and an
        adaptive step (at most ``max_step`` change of any length per step).

        A step is halved when Newton fails, when its result is far from the
        predictor (``jump_tol``: another branch) or, with ``keep_stable`` and
        a stable path, when the result is unstable under length control.
        When the step cannot shrink below ``min_fraction`` of the first one,
        the path has reached a limit point or a bifurcation at the current
        lengths: they are recorded in ``instabilities``, and the path jumps to
        a stable state found by perturbing the last state along +- its
        constrained buckling mode (:meth:`branches`), or to the distant state
        Newton found if that one is stable; the lengths are recorded in
        ``jumps``.  If the mode finds none and ``post_critical`` is given,
        ``post_critical(lengths, u, p)`` (a global search at the critical
        lengths, e.g. :func:`elastica_petsc.studies.search.snap_targets`)
        returns stable states (u, p) there, nearest shape first, and the path
        jumps to the first that differs from the critical state by more than
        ``jump_tol`` (at most :data:`MAX_SNAP_SEARCHES` searches per path).  If no stable state is found the result has
        ``converged=False`` and a message that says it was not found (not that
        none exists).  Without ``keep_stable`` unstable states are followed
        like stable ones (used by searches).  ``budget`` (a
        :class:`~elastica_petsc.core.budget.TimeBudget`): once spent, the path
        stops before its next step: ``converged=False``, reason TIME_LIMIT, the
        last state reached and its lengths.
        """
        L_end = check_lengths(lengths, self.disc.n_tendons)
        u, p = self._start(start)
        sys = self.system
        sys.deflation = Deflation(self.disc.h)
        L_start = self.lengths_of(u)
        if isinstance(start, LengthEquilibrium) and start.lengths_requested is not None:
            L_start = np.where(np.asarray(start.p) > TAUT_TOL, L_start,
                               np.maximum(L_start, start.lengths_requested))
        z = sys.augment(u, p, 1.0)
        span = float(np.max(np.abs(L_end - L_start)))
        full = 1.0 if span <= self.max_step else self.max_step / span
        keep = keep_stable and self.inertia.negative_eigenvalues(u, p) == 0
        lam, dlam, its_total, steps = 0.0, full, 0, 0
        z_prev = dlam_prev = None
        jumps, instabilities, kinds = [], [], []
        searches = 0
        reason = "CONVERGED_ITERATING"
        n_ang = self.disc.n_elements

        def where(t):
            return L_start + t * (L_end - L_start)

        while lam < 1.0:
            if budget is not None and budget.expired():
                return self._stopped(z, where(lam), L_end, its_total, steps, jumps,
                                     instabilities, kinds, label)
            step = min(dlam, 1.0 - lam)
            pred = z if z_prev is None else z + (z - z_prev) * (step / dlam_prev)
            pred[sys.ip:sys.imu] = np.maximum(pred[sys.ip:sys.imu], 0.0)
            L_t = where(lam + step)
            z_new, its, reason, ok = sys.newton(pred, L_t)
            its_total += its
            jumped = lost = False
            if ok:
                jumped = np.max(np.abs(z_new[:n_ang] - pred[:n_ang])) > self.jump_tol
                lost = keep and self.inertia.negative_eigenvalues(
                    z_new[: sys.nu], z_new[sys.ip:sys.imu]) > 0
                if not (jumped or lost):
                    z_prev, dlam_prev = z, step
                    z, lam, steps = z_new, lam + step, steps + 1
                    if its <= 4:
                        dlam = min(2.0 * dlam, full)
                    continue
            if step > min_fraction * full:
                dlam = 0.5 * step
                continue
            # a limit point or bifurcation at L_t: the branch cannot be followed
            if lost or not ok:
                instabilities.append(L_t.copy())
                kinds.append(instability_kind(sys, z, L_end - L_start))
            candidates = self._post_critical(z_new if ok else z, where, lam, step, full)
            if not candidates and post_critical is not None and searches < MAX_SNAP_SEARCHES:
                searches += 1           # a distant state only: never back onto this branch
                candidates = [(lam, sys.augment(u, q, 1.0)) for u, q in post_critical(
                    where(lam), z[: sys.nu], z[sys.ip:sys.imu])
                    if np.max(np.abs(u[:n_ang] - z[:n_ang])) > self.jump_tol][:1]
            if ok and jumped and (not lost or not keep):
                candidates.append((lam + step, z_new))
            if candidates:
                t_best, z_best = min(candidates, key=lambda c: (c[0], self.disc.strain_energy(
                    self.disc.split(c[1][: sys.nu])[0])))
                jumps.append(where(t_best))
                z, z_prev, lam, dlam, steps = z_best, None, t_best, full, steps + 1
                continue
            kind = f" at a {kinds[-1]}" if kinds else ""
            msg = (("lost stability under length control" + kind if lost else
                    f"length continuation stopped{kind} (PETSc SNES reason {reason})")
                   + " at L/l = (" + ", ".join(f"{v:.6g}" for v in where(lam))
                   + ") on the way to (" + ", ".join(f"{v:.6g}" for v in L_end)
                   + "), and no stable state to jump to was found")
            return self._result(z, where(lam), its_total, "UNSTABLE_STATE" if lost else reason,
                                False, steps=steps, message=msg, jumps=jumps,
                                instabilities=instabilities, kinds=kinds, label=label)
        return self._result(z, L_end, its_total, reason, True, steps=steps, jumps=jumps,
                            instabilities=instabilities, kinds=kinds, label=label)

    def _stopped(self, z, lengths, L_end, its, steps, jumps, instabilities, kinds,
                 label) -> LengthEquilibrium:
        """The state a continuation reached when its time budget was spent:
        not converged, reason TIME_LIMIT, at the lengths it had reached."""
        msg = (f"{TIME_LIMIT}: the length continuation stopped by its time budget at L/l = ("
               + ", ".join(f"{v:.6g}" for v in lengths) + ") on the way to ("
               + ", ".join(f"{v:.6g}" for v in L_end) + ")")
        return self._result(z, lengths, its, TIME_LIMIT, False, steps=steps, message=msg,
                            jumps=jumps, instabilities=instabilities, kinds=kinds, label=label)

    def _post_critical(self, base, where, lam: float, step: float, full: float) -> list:
        """Stable states past a critical point of a continuation: the state
        ``base`` perturbed along +- its buckling mode (:meth:`branches`) at the
        path parameter lam + step, or a little further along the path if the
        critical point is too close; as (parameter, augmented state) pairs."""
        sys = self.system
        for t in sorted({lam + step, min(1.0, lam + 0.1 * full), min(1.0, lam + 0.5 * full)}):
            found = self.branches(base[: sys.nu], base[sys.ip:sys.imu], where(t))
            if found:
                return [(t, sys.augment(b.u, b.p, 1.0)) for b in found]
        return []

    def _tension_guess(self, u) -> np.ndarray:
        """Least-squares tensions for a shape: min_p |F(u, p)| (F is linear in p)."""
        F0 = self.disc.residual(u, np.zeros(self.disc.n_tendons))
        A = self.disc.load_derivative(u).T
        p, *_ = np.linalg.lstsq(A, -F0, rcond=None)
        return np.maximum(p, 0.0)

    def branches(self, u, p, lengths, amplitudes=(0.05, 0.2)) -> list[LengthEquilibrium]:
        """Stable states at ``lengths`` near the state (u, p): the state is
        perturbed along +- its constrained buckling mode (the eigenvector of
        K on null(C_taut^T) with the eigenvalue nearest zero,
        :func:`constrained_mode`) by each amplitude (max nodal angle, rad)
        and re-solved.  Distinct, converged, stable (length control) states
        are returned; for a symmetric bifurcation these are the two
        post-buckling states."""
        L = check_lengths(lengths, self.disc.n_tendons)
        sys = self.system
        sys.deflation = Deflation(self.disc.h)
        z_c = sys.augment(np.asarray(u, float), np.asarray(p, float), 1.0)
        try:
            _, v = constrained_mode(sys, z_c)
        except RuntimeError:                 # singular saddle matrix: fall back to no mode
            return []
        found: list[LengthEquilibrium] = []
        theta_c = self.disc.split(z_c[: sys.nu])[0]
        for sign in (1.0, -1.0):
            for a in amplitudes:
                theta = theta_c.copy()
                theta[1:] += sign * a * v
                u0 = self.disc.consistent_state(theta)
                z0 = sys.augment(u0, self._tension_guess(u0), 1.0)
                z, its, reason, ok = sys.newton(z0, L)
                if not ok:
                    continue
                state = self._result(z, L, its, reason, True,
                                     label=f"mode {'+' if sign > 0 else '-'}{a:g}")
                if state.length_unstable_modes != 0:
                    continue
                if not any(same_shape(state, f) for f in found):
                    found.append(state)
                break
        return found

    def path(self, schedule, start=None, *, keep_stable: bool = True) -> list[LengthEquilibrium]:
        """Step through a schedule of cable lengths (K, n) (units of l), each
        point reached by :meth:`follow` from the previous one (the first from
        ``start``, default the straight arm).  Stops after a point that could
        not be reached (its ``converged`` is False)."""
        schedule = np.atleast_2d(np.asarray(schedule, float))
        out, state = [], start
        for k, L in enumerate(schedule):
            state = self.follow(L, state, keep_stable=keep_stable, label=f"point {k}")
            out.append(state)
            if not state.converged:
                break
        return out

    def follow_mm(self, lengths_mm, start=None, **kw) -> LengthEquilibrium:
        return self.follow(self.to_l(lengths_mm), start, **kw)

    def destroy(self) -> None:
        self.system.destroy()
        self.deflated_system.destroy()
        self.inertia.destroy()
        self.load_inertia.destroy()

    def __enter__(self) -> "LengthSolver":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()

