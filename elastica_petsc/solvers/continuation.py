"""Pseudo-arclength continuation of curves on the equilibrium manifold.

For an arm with n tendons the equilibria form an n-dimensional manifold
M = {(u, p) : F(u, p) = 0} (F: the bordered residual of Eq. (9),
:mod:`elastica_petsc.core.fem`).  With two tendons, one more scalar
equation c(u, p) = 0 cuts a curve out of M: a face of the tension domain
(c = p_i, or c = p_i - p_crit, Eq. (22)), a cable about to collapse onto its
routing point (c = L_i - eps), a level curve of a restriction (Eqs. (19),
(21)) or the fold of M over tension space, where the tangent K is singular
and stability under load control is lost (Eq. (20); c = sigma, the
minimally extended system below).

Predictor-corrector (Keller's pseudo-arclength), unknowns w = (u, p):

    predictor   w* = w_k + ds t_k
    corrector   G(w) = [F(u, p); c(w); t_k . D (w - w*)] = 0    (SNES, Newton)
    tangent     [dF/dw; dc/dw; t_k^T D] t_{k+1} = [0; 0; 1],  normalised in D

D = diag(h for the angles, 1 for the attachment unknowns, 1/p_ref^2 for the
tensions) weighs the angles by the mesh size, so steps do not depend on N.
The corrector's Jacobian is the bordered Jacobian of fem with n dense
columns (dF/dp, Eq. (14)) and two dense rows, factored by a sparse LU with
partial pivoting (:func:`use_pivoting_lu`: J is singular on the fold).
Debian's PETSc 3.18 has no SNESNEWTONAL, so the extended system is set up
here on a plain SNES (Newton with line search, options prefix ``cont_``).

Step control: the step doubles after a corrector of at most 3 Newton
iterations and halves on failure, on a corrector that moved any angle by
more than ``jump_tol`` from the predictor (a jump to another branch) or on a
tip step longer than ``max_tip_step``.  Before the corrector the step is
capped so that the predicted tip step is 0.8 ``max_tip_step``
(:meth:`CurveTracer.step_limit`) and, on the boundary tracer's walks, so that
the predictor at most halves a cable that shortens (past its routing point
the cable direction of Eq. (3) flips and no corrector converges;
``studies/boundary/walker.py``, ``Walker._collapse_limit``).  Within a corrector,
once the residual is below ``lag_below`` the factored Jacobian of the
previous iterate is kept (a chord step; the stopping tests are unchanged).

Test functions along a curve (evaluated at every accepted point):
stability (negative eigenvalues of K by Sylvester inertia: a change is a
limit point of M, a *fold*); the sign of det [dG/dw] with the tangent row
(a change without a fold is a *branch point* of the curve); and the sign of
det S, S = d x_t / d p the 2 x 2 tip Jacobian (Eq. (13)), whose change marks
a fold of the tip map (where an interior fold curve of the workspace meets
this curve).

The fold constraint (minimally extended system, Griewank-Reddien): with
bordering vectors b, c (approximate right and left null vectors of J),

    [J  b] [v]   [0]          [J^T c] [psi]   [0]
    [c^T 0] [s] = [1],         [b^T 0] [ s ] = [1],     sigma(w) = s,

sigma vanishes exactly where J (hence K, its Schur complement) is singular,
and d sigma/dw = -psi^T (dJ/dw) v.  The last term is a directional second
derivative of F; it is computed as the central difference, in the direction
v, of the gradient of psi^T F (one Jacobian evaluation on each side: error
O(eps^2) ~ 1e-10 relative).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from petsc4py import PETSc

from ..core import interrupt
from ..core.fem import Discretisation
from .bordered import (PIVOTING_LU, BorderedAIJ, BorderedPattern, ContinuationError,
                       permutation_sign, use_pivoting_lu)
from .constraints import CableCollapse, Constraint, StateLevel, TensionBound, TensionRay
from .folds import Fold, FoldSystem, TipFold
from .inertia import InertiaCounter
from .manifold import Manifold
from .options import SolverOptions, check_comm
from .reasons import converged_reason

__all__ = ["BorderedAIJ", "BorderedPattern", "CableCollapse", "Constraint", "ContinuationError",
           "Curve", "CurvePoint", "CurveTracer", "Fold", "FoldSystem", "Manifold",
           "OffsetParameter", "RouteParameter", "PIVOTING_LU", "StateLevel", "TensionBound",
           "TensionRay", "TipFold", "TraceCounts",
           "permutation_sign", "use_pivoting_lu"]


@dataclass
class CurvePoint:
    """An accepted point on a curve: state, tangent and test functions."""

    w: np.ndarray
    t: np.ndarray
    tip: np.ndarray
    tip_velocity: np.ndarray          # d x_t / ds along t
    unstable_modes: int
    det_sign: float                   # sign of det [dG/dw; t^T] (branch points)
    iterations: int
    tip_det: float = np.nan           # intrinsic tip-map test (CurveTracer.tangent)
    tip_inward: np.ndarray = field(default_factory=lambda: np.full(2, np.nan))
    #                                   tip motion into the admissible side


@dataclass
class Curve:
    """Points of one traced curve and why it ended."""

    constraint: str
    points: list = field(default_factory=list)
    end: str = ""
    end_constraint: str | None = None
    active: object = field(default=None, repr=False)        # the Constraint followed
    hit: object = field(default=None, repr=False)           # the one met at the end corner


@dataclass
class TraceCounts:
    """What one trace spent: ``solves`` corrector solves (each one nonlinear
    solve of the extended system), ``rejected`` the steps among them that were
    not accepted (failed or rejected, then halved).  The caller owns it and
    passes it to every :meth:`CurveTracer.step` and :meth:`CurveTracer.correct`."""

    solves: int = 0
    rejected: int = 0


class _Correction:
    """One corrector solve's state, which the SNES callbacks read (through the
    SNES application context): the two scalar equations (callables (value,
    gradient)) and the residual norms of its iterations so far."""

    def __init__(self, rows):
        self.rows = rows
        self.fnorms = []


class RouteParameter:
    """The routing point r_i of tendon i as a design parameter (k = 2) of
    :meth:`CurveTracer.parameter_velocities`."""

    def __init__(self, manifold: Manifold, i: int):
        self.mf, self.i = manifold, i

    def residual(self, w: np.ndarray) -> np.ndarray:
        return self.mf.route_derivative(w, self.i)

    def constraint_gradient(self, constraint: Constraint, w: np.ndarray) -> np.ndarray:
        return constraint.route_gradient(w, self.i)


class OffsetParameter:
    """The offset delta (units of l) of the arm points ``points`` of a cable
    through guides, moved together (:class:`~elastica_petsc.core.guided.GuidedDiscretisation`
    order), as a design parameter (k = 1) of :meth:`CurveTracer.parameter_velocities`:
    dF/ddelta = sum of ``offset_derivative`` over the points (docs/model.md §11.7);
    a constraint depends on it only through F (:meth:`Constraint.parameter_gradient`)."""

    def __init__(self, manifold: Manifold, points):
        self.mf, self.points = manifold, list(points)

    def residual(self, w: np.ndarray) -> np.ndarray:
        u, p = self.mf.split(w)
        return sum(self.mf.disc.offset_derivative(u, p, a) for a in self.points)[:, None]

    def constraint_gradient(self, constraint: Constraint, w: np.ndarray) -> np.ndarray:
        return constraint.parameter_gradient(w, self.residual, 1)


class CurveTracer:
    """Pseudo-arclength continuation on M with one active constraint and SNES
    as the corrector; it holds no state of a trace (its counts: a
    :class:`TraceCounts` the caller passes).  The contract of :mod:`.options`: ``comm``
    (one process), ``options_prefix`` (default ``cont_``; the tangent solves
    ``<prefix>tangent_``), ``petsc_options``."""

    def __init__(self, disc: Discretisation, *, jump_tol: float = 0.5,
                 max_tip_step: float = 0.2, ds_max: float = 4.0, comm=None,
                 options_prefix: str = "cont_", petsc_options=None):
        # full Newton steps by default: the predictor is close, and a corrector
        # that would need damping is a step to halve (one residual per iteration)
        self.options = SolverOptions(options_prefix, petsc_options,
                                     {"snes_linesearch_type": "basic"})
        self.comm = comm = check_comm(comm)
        self.mf = Manifold(disc)
        mf = self.mf
        self.jump_tol, self.max_tip_step, self.ds_max = jump_tol, max_tip_step, ds_max
        self.step_max_it = 6
        self.A = BorderedAIJ(*mf.csr, mf.size, mf.n)
        self.x = PETSc.Vec().createSeq(mf.m, comm=comm)
        self.f = self.x.duplicate()
        snes = PETSc.SNES().create(comm)
        self.options.label(snes, self.A.mat, self.x, self.f)
        snes.setType(PETSc.SNES.Type.NEWTONLS)
        snes.setFunction(self._form_function, self.f)
        snes.setJacobian(self._form_jacobian, self.A.mat, self.A.mat)
        atol = max(1e-10, 1e-14 * disc.n_elements ** 1.5)
        snes.setTolerances(rtol=1e-10, atol=atol, stol=1e-14, max_it=12)
        use_pivoting_lu(snes.getKSP())
        self.options.apply(snes)
        self.rtol, self.atol, self.stol, _ = snes.getTolerances()
        self.contraction = 0.5
        self.lag_below = 1e-7          # residual norm below which the Jacobian is kept
        snes.setConvergenceTest(self._converged)
        self.snes = snes
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setOptionsPrefix(self.options.name("tangent_"))
        use_pivoting_lu(self.ksp)
        self.options.apply(self.ksp)
        self.inertia = InertiaCounter(disc, comm=comm,
                                      options_prefix=self.options.name("inertia_"))

    # --- the extended system G(w) = [F; r_1; r_2] -----------------------------
    def _form_function(self, snes, X, Fv) -> None:
        w = X.getArray(readonly=True)
        rows = snes.getAppCtx().rows
        Fv.setArray(np.concatenate((self.mf.residual(w), [value(w) for value, _ in rows])))

    def _fill(self, w, rows) -> None:
        self.A.fill(self.mf.jacobian_values(w), self.mf.load_columns(w), rows)

    def _form_jacobian(self, snes, X, J, P) -> None:
        """The extended Jacobian at the iterate, except once Newton is within
        ``lag_below`` of the root: then the previous iterate's (already
        factored) matrix is kept (PETSc does not refactor an unchanged
        operator), a chord step from an O(|dx|)-accurate Jacobian; the stopping
        tests on the residual are unchanged."""
        correction = snes.getAppCtx()
        fnorms = correction.fnorms
        if snes.getIterationNumber() > 0 and fnorms and fnorms[-1] < self.lag_below:
            return
        w = X.getArray(readonly=True)
        self._fill(w, np.array([gradient(w) for _, gradient in correction.rows]))

    def _solve(self, w0: np.ndarray, rows, counts: TraceCounts,
               max_it: int = 12) -> tuple[np.ndarray, bool, int]:
        self.options.refresh(self.snes, self.ksp)
        self.snes.setAppCtx(_Correction(rows))
        self.x.setArray(w0)
        self.snes.setTolerances(max_it=max_it)
        self.snes.solve(None, self.x)
        self.snes.setAppCtx(None)
        counts.solves += 1
        reason = self.snes.getConvergedReason()
        ok = reason > 0 and np.all(np.isfinite(self.x.getArray(readonly=True)))
        return self.x.getArray().copy(), bool(ok), self.snes.getIterationNumber()

    def reason(self) -> str:
        return converged_reason(self.snes)

    def _converged(self, snes, it, norms):
        """PETSc's tests (atol, rtol, stol, max_it) plus one for Newton from a
        close predictor: from the second iteration on, a residual that does not
        shrink by ``contraction`` per iteration is not converging quadratically
        (the step is too long or the curve jumped): stop, the step is halved."""
        xnorm, snorm, fnorm = norms
        R = PETSc.SNES.ConvergedReason
        correction = snes.getAppCtx()
        correction.fnorms = [fnorm] if it == 0 else correction.fnorms + [fnorm]
        fnorms = correction.fnorms
        if not np.isfinite(fnorm):
            return R.DIVERGED_FNORM_NAN
        if fnorm < self.atol:
            return R.CONVERGED_FNORM_ABS
        if it > 0 and fnorm < self.rtol * fnorms[0]:
            return R.CONVERGED_FNORM_RELATIVE
        if it > 0 and snorm < self.stol * xnorm:
            return R.CONVERGED_SNORM_RELATIVE
        if it >= snes.getTolerances()[3]:
            return R.DIVERGED_MAX_IT
        if it >= 2 and fnorm > self.contraction * fnorms[-2]:
            return R.DIVERGED_DTOL
        return R.ITERATING

    @staticmethod
    def _row(constraint: Constraint):
        return constraint.value, constraint.gradient

    def _arclength_row(self, t: np.ndarray, w_pred: np.ndarray):
        dt = self.mf.metric * t
        return (lambda w: float(dt @ (w - w_pred))), (lambda w: dt)

    # --- tangents and test functions --------------------------------------------
    def tangent(self, w: np.ndarray, constraint: Constraint, orient: np.ndarray) -> tuple:
        """Unit tangent (metric D) of the curve {F = 0, c = 0} at w, oriented so
        that t . D orient > 0; the sign of det B of the bordered matrix
        B = [dF/dw; dc/dw; orient^T D]; and the intrinsic tip-map test

            tip_det = sign(det B) det [T tau, T t],   B tau = e_(m-1),

        (tau: the direction in M leaving the curve with dc = 1), which does not
        depend on the two bordering rows (changing them scales det [T tau, T t]
        and det B by reciprocal factors).  In the stable region, with the rows
        picking p, it is det S det J: its sign changes exactly across a fold of
        the tip map (det S = 0), and it stays finite across the fold of M.
        Fourth, ``inward`` = side * T tau, the tip's motion as the state
        leaves the curve into the constraint's admissible side.  One sparse
        LU (scipy SuperLU, partial pivoting) gives all four."""
        t, _, sign, tip_det, inward = self.tangents(w, constraint, orient)
        return t, sign, tip_det, inward

    def tangents(self, w: np.ndarray, constraint: Constraint, orient: np.ndarray) -> tuple:
        """:meth:`tangent`'s (t, tau, sign det B, tip_det, inward) with tau, the
        direction in M that leaves the curve with dc = 1 and orient^T D tau = 0.
        At a corner where ``orient`` is D^-1 times the gradient of the other
        constraint, tau is the tangent of that other curve (both rows of B are
        its constraints' then): the corner's tangent for the curve that ends
        there, from the same LU."""
        mf = self.mf
        values = self.A.pattern.values(mf.jacobian_values(w), mf.load_columns(w),
                                       np.array([constraint.gradient(w), mf.metric * orient]))
        lu = self.A.pattern.lu_of_transpose(values)                    # of B^T
        rhs = np.zeros((mf.m, 2))
        rhs[-1, 0] = rhs[-2, 1] = 1.0
        sol = lu.solve(rhs, trans="T")
        sign = self.A.pattern.determinant_sign(lu)
        scale = mf.norm(sol[:, 0])
        t, tau = sol[:, 0] / scale, sol[:, 1]
        T = mf.tip_gradient(w)
        n = mf.size
        tip_det = sign * float(np.linalg.det(np.column_stack((T @ tau[:n], T @ t[:n]))))
        return t, tau, sign, tip_det, constraint.side * (T @ tau[:n])

    def point(self, w, t, det_sign, iterations, tip_det: float = np.nan,
              tip_inward=None) -> CurvePoint:
        u, p = self.mf.split(w)
        return CurvePoint(w=w.copy(), t=t.copy(), tip=self.mf.tip(w),
                          tip_velocity=self.mf.tip_velocity(w, t),
                          # on a face p_i = 0 a round-off -1e-17 must not reach sqrt(p)
                          unstable_modes=self.inertia.negative_eigenvalues(u, np.maximum(p, 0)),
                          det_sign=det_sign, iterations=iterations, tip_det=tip_det,
                          tip_inward=(np.full(2, np.nan) if tip_inward is None
                                      else np.array(tip_inward, float)))

    def correct(self, w_guess: np.ndarray, constraints,
                counts: TraceCounts) -> tuple[np.ndarray, bool]:
        """Solve F = 0 with two scalar constraints (a corner of two curves);
        the solve is counted in ``counts``."""
        w, ok, _ = self._solve(w_guess, [self._row(c) for c in constraints], counts)
        return w, ok

    def route_velocity(self, w: np.ndarray, rows, i: int) -> np.ndarray:
        """dw/dr_i, (m, 2), of a point of M held by two scalar equations ``rows``
        (constraints, or a constraint and a fixed linear row given as a vector
        g with g . dw = 0): differentiate [F; c_a; c_b](w, r) = 0,

            [dF/dw; dc_a/dw; dc_b/dw] dw/dr_i = -[dF/dr_i; dc_a/dr_i; dc_b/dr_i].

        At a corner both rows are constraints; inside a curve the second row
        fixes how the point slides along the curve (the normal component of
        the tip's motion does not depend on it)."""
        return self.route_velocities(w, rows, (i,))[0]

    def route_velocities(self, w: np.ndarray, rows, tendons) -> list[np.ndarray]:
        """:meth:`route_velocity` for each tendon of ``tendons``: one matrix
        filled and factored, 2 right-hand sides per tendon."""
        return self.parameter_velocities(w, rows, [RouteParameter(self.mf, i) for i in tendons])

    def parameter_velocities(self, w: np.ndarray, rows, parameters) -> list[np.ndarray]:
        """dw/dq, (m, k), for each parameter block q of ``parameters`` (k of
        them each: :class:`RouteParameter`, or any object with ``residual(w)``
        = dF/dq (size, k) and ``constraint_gradient(c, w)`` = dc/dq (k,) at
        fixed w), as :meth:`route_velocity` does for r_i: one matrix filled
        and factored for all."""
        grads = [row if isinstance(row, np.ndarray) else row.gradient(w) for row in rows]
        self._fill(w, np.array(grads))
        self.ksp.setOperators(self.A.mat)
        rv, sol, out = self.x.duplicate(), self.x.duplicate(), []
        for q in parameters:
            dF = q.residual(w)
            k_cols = dF.shape[1]
            rhs = [dF] + [np.zeros((1, k_cols)) if isinstance(row, np.ndarray)
                          else np.reshape(q.constraint_gradient(row, w), (1, k_cols))
                          for row in rows]
            b = -np.vstack(rhs)
            dw = np.empty((self.mf.m, k_cols))
            for k in range(k_cols):
                rv.setArray(b[:, k])
                self.ksp.solve(rv, sol)
                dw[:, k] = sol.getArray(readonly=True)
            out.append(dw)
        rv.destroy(); sol.destroy()
        return out

    def step_limit(self, pt: CurvePoint) -> float:
        """The step length whose predicted tip step is 0.8 max_tip_step (a
        longer one would be rejected after its corrector)."""
        speed = float(np.linalg.norm(pt.tip_velocity))
        return 0.8 * self.max_tip_step / speed if speed > 0 else self.ds_max

    def step(self, pt: CurvePoint, constraint: Constraint, ds: float, counts: TraceCounts):
        """One predictor-corrector step of length ds: (point | None, iterations),
        counted in ``counts``.  The corrector gets ``step_max_it`` Newton
        iterations: from the tangent predictor a step that needs more is too
        long (it is halved)."""
        interrupt.check()                         # a run's stop, inside long work
        w_pred = pt.w + ds * pt.t
        w, ok, its = self._solve(w_pred, [self._row(constraint), self._arclength_row(pt.t, w_pred)],
                                 counts, max_it=self.step_max_it)
        n_angles = self.mf.disc.n_elements
        if (not ok or np.max(np.abs(w[:n_angles] - w_pred[:n_angles])) > self.jump_tol
                or np.linalg.norm(self.mf.tip(w) - pt.tip) > self.max_tip_step):
            counts.rejected += 1
            return None, its
        t, det_sign, tip_det, inward = self.tangent(w, constraint, pt.t)
        return self.point(w, t, det_sign, its, tip_det, inward), its

    def destroy(self) -> None:
        self.inertia.destroy()
        for obj in (self.snes, self.ksp, self.A, self.x, self.f):
            obj.destroy()

    def __enter__(self) -> "CurveTracer":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()
