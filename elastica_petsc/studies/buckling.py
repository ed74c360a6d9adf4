"""Buckling of the straight segment under length control (paper Sec. 4.6, Fig. 7).

Handral & Rangarajan (2019), Sec. 4.6: "At the critical state, the first
tendon loads the arm and the second tendon is just taut.  The section of the
arm between the two attachment points x_1 and x_2 is nominally straight,
and crucially, aligned with the orientation of the second tendon.  Engaging
the second tendon, by reducing its length by a few millimeters while leaving
the length of the first tendon unchanged, compresses the straight section
of the arm like an Euler column and causes it to buckle to one of two
states."  This module computes that scenario on a two-tendon arm (tendon 1
attached at s_1, tendon 2 further out at s_2 > s_1; the paper's arm: s_1 =
200 mm, s_2 = l = 600 mm) and draws the figure.

Non-dimensional internally (lengths in units of l, tensions p = P l^2/B,
docs/model.md §3); lengths in mm at the boundary (``*_mm`` fields, from the length
solver's arm length), tensions non-dimensional as everywhere in the package
(``Arm.tensions_to_N`` converts; :meth:`Fig7Result.summary` does).

Critical configuration
----------------------
With p_2 = 0 nothing loads the arm beyond x_1: the moment vanishes there and
the segment beyond x_1 is straight, whatever p_1.  As p_1 grows the segment
turns; at p_1* the line of that segment passes through the routing point
r_2.  The alignment t x (r_2 - x_1) (t the unit chord x_1 -> tip,
:func:`segment_geometry`) changes sign there; p_1* is its root, found by
Brent's method on load-controlled equilibria at (p_1, 0)
(:func:`critical_configuration`).  Its cable lengths are L0 = (L_1, L_2):
cable 2 is just taut (p_2 = 0, g_2 = 0) and lies along the segment.

The perfect column (aligned family)
-----------------------------------
Shortening L_2 puts tendon 2 in tension, and its force, along the segment
towards r_2, compresses the segment.  The segment stays exactly straight
only if the force stays aimed along it, i.e. only if the alignment stays
zero; with L_1 held fixed it does not (the base x_1 rotates as p_2 loads
the first segment).  The "perfect column" is the one-parameter family of
length-controlled states with alignment 0: for every shortening dL_2 of L_2,
L_1 is found by a secant iteration on the alignment (L_1 is let out as L_2
is taken in, about 2 mm per mm), each state a VI Newton solve of the
length-controlled problem (:class:`~elastica_petsc.solvers.lengths.LengthSolver`)
warm-started from the previous one (:func:`aligned_family`).

Constrained eigenvalue crossing
-------------------------------
Under length control a taut state is stable iff K (the tangent of the
load-controlled problem) is positive definite on null(C^T), C = [grad L_i]
of the taut cables (:mod:`elastica_petsc.solvers.lengths`).  Along the aligned
family the eigenvalue of K v = lambda h v on null(C^T) nearest zero
(:func:`~elastica_petsc.solvers.lengths.constrained_mode`) decreases about linearly
with dL_2 and crosses zero: a bifurcation of the straight column.  The
critical shortening dL_2,cr is the linear interpolation of the zero between
the last aligned state with lambda > 0 and the next one; the critical
lengths L_cr and tension p_2,cr are interpolated likewise.  (K alone, i.e.
stability under load control, is lost earlier: the cable constraints
stabilise the column.)

Clamped-column estimate
-----------------------
The segment from x_1 to x_2 (length a = s_2 - s_1) as a column clamped at
x_1 whose end load p_2 is aimed at r_2, a distance c = L_2 from x_2 on the
column's axis (c > a: r_2 lies behind x_1).  With k^2 = p_2 and w the
deflection, linearised: w'' + k^2 w = k^2 w_t (1 - (a - xi)/c), w(0) = w'(0)
= 0, w(a) = w_t; a non-trivial solution needs

    tan(k a) = -k (c - a),     pi/2 < k a < pi

(c -> infinity: the dead-load cantilever, k a = pi/2; c = a: k a = pi).
p_clamped = k^2 bounds the measured p_2,cr from above: the real base is not
a clamp (the first segment bends and lets x_1 rotate).

Continuation, post-buckling states and the paper's experiment
------------------------------------------------------------
:meth:`LengthSolver.path` along the aligned lengths (warm starts, inertia
after every step) must report the loss of stability near dL_2,cr
(``instabilities``) and jump to a buckled state (``jumps``).  Past the
critical point :meth:`LengthSolver.branches` perturbs the last stable
aligned state along +- its constrained buckling mode and finds the two
stable post-buckling states, bent to either side; they are not mirror
images (the first segment is curved: nothing makes the bifurcation
symmetric).  The straight state at the same lengths is still an
equilibrium, unstable under length control, and carries more tension.

The paper's own experiment holds L_1 and shortens L_2 by a few mm.  That
path leaves the aligned family at once: it is an imperfect column, which
bows continuously to one side, with p_2 levelling off below the perfect
column's p_2,cr; it stays stable under length control although K alone
becomes indefinite.
"""
from __future__ import annotations

import math
import time

import numpy as np
from scipy.optimize import brentq

from ..core.deflation import Deflation
from ..solvers.equilibrium import Equilibrium, EquilibriumSolver
from ..core.errors import InputError, SolverError
from ..solvers.lengths import LengthEquilibrium, LengthSolver, constrained_mode
from .buckling_result import Fig7Result

# default shortenings of L_2 [mm]: the aligned family, and the paper's experiment (L_1 held)
ALIGNED_SHORTENINGS_MM = (0.5, 1.0, 1.5, 2.0)
EXPERIMENT_SHORTENINGS_MM = tuple(np.round(np.arange(0.25, 6.0001, 0.25), 10))


class BucklingError(SolverError):
    """The Fig. 7 scenario could not be computed (no critical configuration,
    no crossing, a solve that did not converge); the message says where."""


# --- geometry of the segment beyond x_1 -------------------------------------------------
def segment_geometry(disc, u, s_index: int) -> tuple[float, float]:
    """(alignment, signed max deviation) of the segment beyond node ``s_index``
    (attachment 1): alignment = t x (r_2 - x_1) with t the unit chord direction
    x_1 -> tip (0 when the line of the segment passes through r_2); deviation
    = the largest distance of the segment from that chord (units of l,
    signed: positive to the left of t)."""
    theta = disc.split(u)[0]
    x = disc.node_positions(theta)
    x1, tip = x[s_index], x[-1]
    t = (tip - x1) / np.linalg.norm(tip - x1)
    r2 = disc.routes[1]
    X = x[s_index:] - x1
    dev = X[:, 0] * t[1] - X[:, 1] * t[0]
    return float(np.cross(t, r2 - x1)), float(dev[np.argmax(np.abs(dev))])


def segment_profile(disc, u, s_index: int) -> tuple[np.ndarray, np.ndarray]:
    """(xi, w) along the segment beyond node ``s_index``: distance along the
    chord x_1 -> tip and deviation from it, signed as in :func:`segment_geometry`
    (units of l)."""
    theta = disc.split(u)[0]
    x = disc.node_positions(theta)
    x1, tip = x[s_index], x[-1]
    t = (tip - x1) / np.linalg.norm(tip - x1)
    X = x[s_index:] - x1
    return X @ t, X[:, 0] * t[1] - X[:, 1] * t[0]


def scenario_problem(disc) -> str | None:
    """Why the Fig. 7 scenario does not apply to the arm of ``disc`` (None: it does)."""
    if disc.n_tendons != 2:
        return f"the Fig. 7 scenario needs an arm with two tendons, got {disc.n_tendons}"
    m1, m2 = disc.attach_nodes
    if not m1 < m2:
        return ("the Fig. 7 scenario needs tendon 1 attached closer to the clamp than "
                "tendon 2 (s_1 < s_2)")
    return None


def _check_arm(disc) -> int:
    problem = scenario_problem(disc)
    if problem is not None:
        raise InputError(problem)
    return disc.attach_nodes[0]


def _length_mm(length_solver: LengthSolver) -> float:
    if length_solver.length_mm is None:
        raise InputError("the arm length is unknown: build the length solver with "
                         "LengthSolver.from_arm()")
    return float(length_solver.length_mm)


# --- critical configuration --------------------------------------------------------------
def critical_configuration(eq_solver: EquilibriumSolver, bracket=None, *, scan_step: float = 1.0,
                           scan_max: float = 200.0) -> tuple[float, Equilibrium]:
    """p_1* and the load-controlled equilibrium at (p_1*, 0): the segment
    beyond x_1 straight and its line through r_2 (module docstring).

    ``bracket`` (p_lo, p_hi): tensions p_1 around the root; default: the
    first sign change of the alignment on a warm-started loading path
    p_1 = scan_step, 2 scan_step, ... <= scan_max from the straight arm.
    Every equilibrium of the root search is started from the one at p_lo."""
    disc = eq_solver.disc
    m1 = _check_arm(disc)

    def state(p1, start):
        eq = eq_solver.solve([p1, 0.0], start=start)
        if not eq.converged:
            raise BucklingError(f"load-controlled solve at p = ({p1:g}, 0) failed: {eq.message}")
        return eq

    def alignment(eq):
        return segment_geometry(disc, eq.u, m1)[0]

    if bracket is None:
        prev = Equilibrium(disc, np.zeros(2), disc.straight(), True, "STRAIGHT", 0, 0)
        c_prev, p1 = alignment(prev), 0.0
        while True:
            p1 += scan_step
            if p1 > scan_max:
                raise BucklingError(
                    f"the line of the segment beyond x_1 never passes through r_2 for "
                    f"p_1 <= {scan_max:g} (p_2 = 0): no critical configuration of Fig. 7")
            eq = state(p1, prev)
            c = alignment(eq)
            if c_prev * c <= 0.0:
                bracket, base = (p1 - scan_step, p1), prev
                break
            prev, c_prev = eq, c
    else:
        lo, hi = (float(v) for v in bracket)
        base = state(lo, None)
    lo, hi = bracket
    f_lo, f_hi = alignment(state(lo, base)), alignment(state(hi, base))
    if f_lo * f_hi > 0.0:
        raise BucklingError(f"the alignment t x (r_2 - x_1) does not change sign for p_1 in "
                            f"[{lo:g}, {hi:g}] (p_2 = 0)")
    p1s = brentq(lambda p1: alignment(state(p1, base)), lo, hi, xtol=1e-13)
    return p1s, state(p1s, base)


# --- the perfect column --------------------------------------------------------------------
def aligned_family(eq_solver: EquilibriumSolver, length_solver: LengthSolver,
                   shortenings_mm=ALIGNED_SHORTENINGS_MM, *, critical=None,
                   tol: float = 1e-13, max_iterations: int = 20) -> dict[float, LengthEquilibrium]:
    """The aligned ("perfect column") family: {dL_2 [mm]: state}, starting
    with 0.0, the critical configuration held at its own cable lengths L0.

    For each shortening dL_2 (increasing, mm) L_2 = L0_2 - dL_2 and L_1 is
    found by a secant iteration on the alignment of the segment beyond x_1
    (|t x (r_2 - x_1)| < ``tol``), its first guess extrapolated from the
    previous shortenings.  ``critical``: (p_1*, equilibrium) from
    :func:`critical_configuration` (computed if not given)."""
    _check_arm(length_solver.disc)
    _length_mm(length_solver)
    p1s, e0 = critical if critical is not None else critical_configuration(eq_solver)
    state = length_solver.solve(e0.cable_lengths, e0)
    if not state.converged:
        raise BucklingError(f"the critical configuration held at its cable lengths: "
                            f"{state.message}")
    return extend_family(length_solver, {0.0: state}, shortenings_mm, tol=tol,
                         max_iterations=max_iterations)


def extend_family(length_solver: LengthSolver, aligned: dict, shortenings_mm, *,
                  tol: float = 1e-13, max_iterations: int = 20) -> dict[float, LengthEquilibrium]:
    """Continue an aligned family {dL_2 [mm]: state} (with the entry 0.0,
    the critical configuration at its cable lengths L0) to further
    shortenings, each warm-started from the last state; returns the same
    dict, extended.  See :func:`aligned_family`."""
    disc = length_solver.disc
    m1 = _check_arm(disc)
    l_mm = _length_mm(length_solver)
    L0 = aligned[0.0].lengths_requested
    keys = sorted(aligned)
    state = aligned[keys[-1]]
    history = [(d, aligned[d].lengths_requested[0]) for d in keys]
    for dl in (float(d) for d in shortenings_mm):          # mm of L_2 shortening
        if dl <= history[-1][0]:
            raise InputError(f"aligned family: shortenings must increase from 0 mm, got {dl:g} "
                             f"after {history[-1][0]:g}")
        L2 = L0[1] - dl / l_mm
        (a, La), (b, Lb) = history[-2:] if len(history) > 1 else (history[0], history[0])
        L1 = Lb + (Lb - La) / (b - a) * (dl - b) if b > a else L0[0] + 2.2 * dl / l_mm
        prev = None
        for _ in range(max_iterations):                      # secant on the alignment
            s = length_solver.solve([L1, L2], state)
            if not s.converged:
                raise BucklingError(f"aligned family at dL_2 = {dl:g} mm: {s.message}")
            c = segment_geometry(disc, s.u, m1)[0]
            if abs(c) < tol:
                break
            if prev is None:
                prev, L1 = (L1, c), L1 + 1e-4 / l_mm
            else:
                (L1b, cb), prev = prev, (L1, c)
                L1 = L1 - c * (L1 - L1b) / (c - cb)
        else:
            if abs(c) > 1e3 * tol:
                raise BucklingError(f"aligned family at dL_2 = {dl:g} mm: the secant on L_1 "
                                    f"did not align the segment (t x (r_2 - x_1) = {c:.3g})")
        state = s
        aligned[dl] = s
        history.append((dl, L1))
    return aligned


def constrained_eigenvalue(length_solver: LengthSolver, state) -> float:
    """Eigenvalue of K v = lambda h v on null(C_taut^T) nearest zero
    (:func:`~elastica_petsc.solvers.lengths.constrained_mode`), non-dimensional."""
    sys = length_solver.system
    sys.deflation = Deflation(length_solver.disc.h)
    return float(constrained_mode(sys, sys.augment(state.u, state.p, 1.0))[0])


def clamped_column_estimate(a: float, c: float) -> tuple[float, float]:
    """(k a, p_clamped = k^2) of the column of length ``a`` clamped at its
    base with its end load aimed at a point ``c`` > a behind the end on its
    axis: the root of tan(k a) = -k (c - a) in (pi/2, pi) (units of l)."""
    if not c > a > 0:
        raise ValueError(f"need c > a > 0, got a = {a:g}, c = {c:g}")
    ka = brentq(lambda x: math.tan(x) + (c - a) / a * x, math.pi / 2 + 1e-12, math.pi - 1e-12,
                xtol=1e-14)
    return ka, (ka / a) ** 2


# --- the whole figure ------------------------------------------------------------------
def _interpolate(x, xs, values):
    """Piecewise-linear interpolation of vector ``values`` (K, n) at ``x`` in ``xs``."""
    xs = np.asarray(xs, float)
    k = int(np.clip(np.searchsorted(xs, x) - 1, 0, len(xs) - 2))
    w = (x - xs[k]) / (xs[k + 1] - xs[k])
    return (1 - w) * np.asarray(values[k]) + w * np.asarray(values[k + 1])


def family_to_crossing(length_solver: LengthSolver, L0, e0, shortenings_mm,
                       max_shortening_mm: float):
    """The aligned (perfect-column) family of Fig. 7 held at the critical cable
    lengths ``L0`` minus each shortening dL_2, extended by its last spacing
    until the constrained eigenvalue changes sign: ``(states by dL_2 [mm],
    eigenvalues by dL_2, (last positive dL_2, first non-positive dL_2))``.  A point
    where Newton fails on the straight column (its Jacobian is singular at the
    crossing) is moved on by 0.3 or 0.6 of the spacing."""
    state = length_solver.solve(L0, e0)
    if not state.converged:
        raise BucklingError(f"the critical configuration held at its cable lengths: "
                            f"{state.message}")
    aligned = {0.0: state}
    lam = {0.0: constrained_eigenvalue(length_solver, state)}

    def add(dl, spacing):
        for shift in (0.0, 0.3, 0.6):
            d = round(dl + shift * spacing, 10)
            try:
                extend_family(length_solver, aligned, [d])
            except BucklingError:
                if shift == 0.6:
                    raise
                continue
            lam[d] = constrained_eigenvalue(length_solver, aligned[d])
            return

    def crossing():
        keys = sorted(aligned)
        if lam[keys[1]] <= 0:
            raise BucklingError(
                f"the straight column is already unstable under length control at the first "
                f"shortening dL_2 = {keys[1]:g} mm: give smaller shortenings_mm")
        for lo, hi in zip(keys[1:-1], keys[2:]):
            if lam[lo] > 0 >= lam[hi]:
                return lo, hi
        return None

    dls = [float(d) for d in shortenings_mm]
    if not dls or dls[0] <= 0 or np.any(np.diff(dls) <= 0):
        raise InputError("fig7: shortenings_mm must be positive and increasing")
    for k, dl in enumerate(dls):
        if dl > max(aligned):
            add(dl, dls[k + 1] - dl if k + 1 < len(dls) else dl - max(aligned))
    while crossing() is None:
        keys = sorted(aligned)
        step = keys[-1] - keys[-2]
        if keys[-1] + step > max_shortening_mm:
            raise BucklingError(
                f"the straight column did not lose stability under length control up to "
                f"dL_2 = {keys[-1]:g} mm (constrained eigenvalue {lam[keys[-1]]:.3g})")
        add(keys[-1] + step, step)
    return aligned, lam, crossing()


def post_buckling(length_solver: LengthSolver, aligned: dict, lam: dict, bracket, dl_cr: float,
                  post_shortening_mm: float | None):
    """States at the aligned lengths a little beyond the crossing ``dl_cr``
    [mm] (default 60 % into the bracketing interval, at least a quarter of the
    way past the crossing): the straight (unstable) column and the buckled
    branches, sorted by the deviation of the free segment from the straight
    line [mm].  Returns (dL_2 [mm], lengths / l, straight, buckled, deviations)."""
    disc = length_solver.disc
    m1, l_mm = _check_arm(disc), _length_mm(length_solver)
    keys, (lo, hi) = sorted(aligned), bracket
    if post_shortening_mm is None:
        post = max(lo + 0.6 * (hi - lo), dl_cr + 0.25 * (hi - dl_cr))
    else:
        post = float(post_shortening_mm)
        if not dl_cr < post <= keys[-1]:
            raise InputError(f"post_shortening_mm = {post:g} mm must lie beyond the critical "
                             f"{dl_cr:.3f} mm and within the aligned family (<= {keys[-1]:g} mm)")
    L_post = _interpolate(post, keys, [aligned[d].lengths_requested for d in keys])
    nxt = keys[int(np.searchsorted(keys, post))]             # first aligned point >= post
    prv = keys[int(np.searchsorted(keys, post)) - 1]
    last_stable = aligned[prv] if lam[prv] > 0 else aligned[lo]
    straight = length_solver.solve(L_post, aligned[nxt])
    if not straight.converged:
        raise BucklingError(f"the straight column at dL_2 = {post:g} mm: {straight.message}")
    buckled = length_solver.branches(last_stable.u, last_stable.p, L_post)
    dev = np.array([segment_geometry(disc, s.u, m1)[1] * l_mm for s in buckled])
    order = np.argsort(dev)
    return post, L_post, straight, tuple(buckled[k] for k in order), dev[order]


def fig7(eq_solver: EquilibriumSolver, length_solver: LengthSolver, *,
         shortenings_mm=ALIGNED_SHORTENINGS_MM, experiment_shortenings_mm=EXPERIMENT_SHORTENINGS_MM,
         post_shortening_mm: float | None = None, max_shortening_mm: float = 20.0,
         critical=None) -> Fig7Result:
    """The Fig. 7 scenario of the paper (Sec. 4.6) on the arm of ``length_solver``
    (``eq_solver`` on the same discretisation), see the module docstring.

    shortenings_mm : dL_2 of the aligned family (positive, increasing);
        extended by its last spacing, up to ``max_shortening_mm``, until the
        constrained eigenvalue changes sign.  A point where Newton fails on
        the straight column (at the crossing its Jacobian is singular) is
        moved on by 0.3 or 0.6 of the spacing.
    experiment_shortenings_mm : dL_2 of the paper's experiment (L_1 held).
    post_shortening_mm : where the post-buckling states are computed (on the
        aligned lengths); default 60 % of the way through the bracketing
        interval of the crossing, but at least a quarter of the way from the
        crossing to its end (paper's arm: 1.8 mm).
    critical : (p_1*, equilibrium) if already known.
    """
    t0 = time.perf_counter()
    disc = length_solver.disc
    m1 = _check_arm(disc)
    if eq_solver.disc.n_elements != disc.n_elements or \
            tuple(eq_solver.disc.attach_nodes) != tuple(disc.attach_nodes):
        raise InputError("fig7: the equilibrium and length solvers discretise different arms")
    l_mm = _length_mm(length_solver)
    critical = critical if critical is not None else critical_configuration(eq_solver)
    p1s, e0 = critical
    L0 = e0.cable_lengths.copy()

    aligned, lam, (lo, hi) = family_to_crossing(length_solver, L0, e0, shortenings_mm,
                                                max_shortening_mm)
    keys = sorted(aligned)
    states = [aligned[d] for d in keys]

    # interpolated critical point
    dl_cr = lo + (hi - lo) * lam[lo] / (lam[lo] - lam[hi])
    w = (dl_cr - lo) / (hi - lo)
    L_cr = (1 - w) * aligned[lo].lengths_requested + w * aligned[hi].lengths_requested
    p2_cr = float((1 - w) * aligned[lo].p[1] + w * aligned[hi].p[1])
    s1, s2 = (np.asarray(disc.attach_nodes) * disc.h)
    a = float(s2 - s1)
    ka, p_clamped = clamped_column_estimate(a, float(L_cr[1]))

    # continuation along the aligned lengths up to the first unstable one
    upto = keys.index(hi)
    path = length_solver.path([aligned[d].lengths_requested for d in keys[1:upto + 1]],
                              aligned[0.0])
    event = next((s.instabilities[0] for s in path if s.instabilities), None)
    event_kind = next((s.instability_kinds[0] for s in path if s.instability_kinds), None)
    jumped = next((s for s in path if s.jumps), None)

    post, L_post, straight, buckled, dev = post_buckling(
        length_solver, aligned, lam, (lo, hi), dl_cr, post_shortening_mm)

    # the paper's experiment: L_1 held, L_2 shortened
    exp_dl = np.asarray([float(d) for d in experiment_shortenings_mm])
    experiment = length_solver.path([L0 - np.array([0.0, d / l_mm]) for d in exp_dl], e0) \
        if exp_dl.size else []
    experiment = [s for s in experiment if s.converged]

    return Fig7Result(
        length_mm=l_mm, segment_length_mm=a * l_mm, p1_star=float(p1s), critical=e0,
        L0_mm=L0 * l_mm,
        aligned_shortenings_mm=np.array(keys), aligned=tuple(states),
        aligned_lambda=np.array([lam[d] for d in keys]), bracket=(keys.index(lo), upto),
        dL2_cr_mm=float(dl_cr), L_cr_mm=L_cr * l_mm, p2_cr=p2_cr,
        ka_clamped=float(ka), p_clamped=float(p_clamped),
        path=tuple(path),
        path_deviation_mm=np.array([segment_geometry(disc, s.u, m1)[1] * l_mm for s in path]),
        event_L_mm=None if event is None else np.asarray(event) * l_mm, event_kind=event_kind,
        event_dL2_mm=None if event is None else float((L0[1] - event[1]) * l_mm),
        jump_L_mm=None if jumped is None else np.asarray(jumped.jumps[0]) * l_mm,
        jumped=jumped,
        post_dL2_mm=float(post), post_L_mm=L_post * l_mm, post_buckling=buckled,
        post_deviation_mm=dev,
        post_p2=np.array([s.p[1] for s in buckled]),
        straight=straight,
        straight_deviation_mm=segment_geometry(disc, straight.u, m1)[1] * l_mm,
        experiment_shortenings_mm=exp_dl[: len(experiment)], experiment=tuple(experiment),
        experiment_deviation_mm=np.array([segment_geometry(disc, s.u, m1)[1] * l_mm
                                          for s in experiment]),
        experiment_p2=np.array([s.p[1] for s in experiment]),
        seconds=time.perf_counter() - t0)
