"""The wall follower around the region D of tension space (docs/model.md §9.1):
the walk once around D (:class:`Walker`), the sign changes of the tip-map
test on its loop (:func:`tip_fold_crossings`), the fold curves of the tip
map traced from them (:class:`FoldTracer`) and the scan rays that look for
folds the loop does not meet (:func:`scan_rays`).  The package docstring
(:mod:`elastica_petsc.studies.boundary`) describes the method."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...core.geometry import segments_cross
from ...core.model import Arm
from ...solvers.continuation import (CableCollapse, Curve, CurveTracer, Fold, FoldSystem,
                                     StateLevel, TensionBound, TensionRay, TipFold, TraceCounts)
from ...solvers.equilibrium import COLLAPSE_LENGTH


@dataclass
class RegionBoundary:
    """The closed loop around a region of M and its tip image.

    curves: the pieces, in order; each :class:`Curve` holds the points.
    closed: the walk came back to the straight arm.
    """

    name: str
    curves: list
    closed: bool
    message: str = ""

    def nodes(self) -> dict:
        """Concatenated curve nodes: tip (mm-free, units of l), p, curve index."""
        tips, ps, index, vel = [], [], [], []
        for k, curve in enumerate(self.curves):
            for pt in curve.points:
                tips.append(pt.tip); ps.append(pt.w[-2:]); index.append(k)
                vel.append(pt.tip_velocity)
        return {"tip": np.array(tips), "p": np.array(ps), "curve": np.array(index),
                "tip_velocity": np.array(vel)}


def constraints_for(tracer: CurveTracer, arm: Arm, restricted: bool) -> list:
    """Bounds of D (and D_r): faces, motor limit, collapse; fold handled apart."""
    mf = tracer.mf
    out = [TensionBound(mf, i, 0.0) for i in range(mf.n)]
    if arm.max_tension is not None:
        out += [TensionBound(mf, i, arm.max_tension, upper=True) for i in range(mf.n)]
    out += [CableCollapse(mf, i, COLLAPSE_LENGTH) for i in range(mf.n)]
    if restricted:
        out += [StateLevel(mf, "kappa", arm.kappa_limit),
                StateLevel(mf, "energy", arm.limits.strain_energy_max_SE0)]
    return out


DS0 = 0.3                 # first step length of each curve (metric D)
SCAN_TIP_STEP = 0.5       # largest tip step of the scan rays (units of l)


class Walker:
    """The wall follower around D of the module docstring."""

    def __init__(self, tracer: CurveTracer, constraints: list, *, ds0: float = DS0,
                 ds_min: float = 1e-5, max_points: int = 400, progress=None, known=(),
                 counts: TraceCounts | None = None):
        self.tr, self.progress = tracer, progress        # progress(solves, note) per step
        self.counts = TraceCounts() if counts is None else counts   # the walk's solves
        self.constraints = constraints
        self.known = list(known)       # an earlier walk's curves, nodes to take over
        self.fold_system = FoldSystem(tracer.mf)
        self.fold = Fold(self.fold_system)
        self.ds0, self.ds_min, self.max_points = ds0, ds_min, max_points

    def destroy(self) -> None:
        self.fold_system.destroy()

    def _orient(self, constraint) -> np.ndarray:
        """D^-1 times the gradient of side * c: tangents with t . grad > 0 move into
        the admissible side of ``constraint``."""
        return lambda w: constraint.side * constraint.gradient(w) / self.tr.mf.metric

    def _start_point(self, w, active, into):
        """(the first point of the curve on ``active`` from the corner w, into
        the admissible side given by ``into``; tau, the tangent at w of the
        curve whose constraint ``into`` orients to: :meth:`CurveTracer.tangents`)."""
        t, tau, det_sign, tip_det, inward = self.tr.tangents(w, active, into(w))
        return self.tr.point(w, t, det_sign, 0, tip_det, inward), tau

    def _corner_tangent(self, curve, tau=None) -> None:
        """Give the corner ending ``curve`` the curve's own tangent there (``tau``
        from the next curve's start point, else solved for), oriented along the
        tangent of the node before, which the corner was made with: the tip
        image's last piece into the corner is then a cubic Hermite arc like
        the others (:func:`~.faces.loop_polygon`).  Before, the last piece was
        the straight chord; on configs/aluminium.toml (W_0 a crescent 2-3 mm
        wide along arcs of radius about l) the chords' sagitta,
        (0.16 l)^2 / (8 l) ~ 2 mm, made the area 34 % too large.  The corner
        keeps no tip-map test (tip_det NaN: the comparison runs between the
        nodes around it)."""
        corner, mf = curve.points[-1], self.tr.mf
        t = self.tr.tangent(corner.w, curve.active, corner.t)[0] if tau is None else tau
        t = t / mf.norm(t)
        corner.t = t if float(mf.metric * t @ corner.t) > 0 else -t
        corner.tip_velocity = mf.tip_velocity(corner.w, corner.t)

    def _locate(self, a, b, active, hit) -> np.ndarray | None:
        """Corner where ``hit`` becomes active between accepted points a and b."""
        if hit is self.fold:
            guess_v = self.fold_system.null_vector(b.w)
            self.fold_system.set_vectors(guess_v)
        ma, mb = hit.value(a.w), hit.value(b.w)
        frac = ma / (ma - mb) if ma != mb else 0.5
        frac = min(max(frac, 0.0), 1.0)
        guess = a.w + frac * (b.w - a.w)
        w, ok = self.tr.correct(guess, [active, hit], self.counts)
        if not ok:
            return None
        if hit is self.fold:
            self.fold.update(w)
            # the stable side (a is stable) is the admissible one
            self.fold.side = 1.0 if self.fold.value(a.w) >= 0 else -1.0
        return w

    def _events(self, a, b, active):
        """Constraints that became active between a and b (stability loss: fold),
        the one crossed first (linearly interpolated margins) first: the corner
        is located with the first of them that converges, and a constraint
        crossed later lies beyond that corner (before issue 25 they came in
        list order: on configs/aluminium.toml a step that crossed the curvature
        limit and then P1 = P_crit cornered on P1 = P_crit)."""
        crossed = [(c.margin(a.w), c.margin(b.w), c) for c in self.constraints if c is not active]
        crossed = [(max(ma, 0.0) / (max(ma, 0.0) - mb), c) for ma, mb, c in crossed if mb < 0]
        hits = [c for _, c in sorted(crossed, key=lambda fc: fc[0])]
        if b.unstable_modes > 0 and a.unstable_modes == 0 and active is not self.fold:
            hits.append(self.fold)
        return hits

    def _collapse_limit(self, pt, active) -> float:
        """The step length at which the predictor w + ds t brings a cable to half
        the collapse length eps (linearised; a cable's length is convex along the
        predictor's line, so the predicted length stays above eps/2).  Past its
        routing point the cable direction of Eq. (3) flips, and a corrector
        started there fails whatever the step: the step is cut to reach the
        event (L_i = eps) instead of being halved after failed correctors."""
        limit = np.inf
        for c in self.constraints:
            if isinstance(c, CableCollapse) and c is not active:
                rate = float(c.gradient(pt.w) @ pt.t)
                if rate < 0:
                    limit = min(limit, 0.5 * (c.value(pt.w) + c.eps) / -rate)
        return limit

    def _land_on_collapse(self, pt, active, ds: float, tried: dict):
        """(constraint, corner point) when a cable collapse is within the step ds
        (linearised): the corner of ``active`` and L_i = eps solved directly
        from the linear predictor, accepted if it lies ahead on the curve
        within the step's limits and no other constraint or stability is lost
        on the way (:meth:`_corner_point`); else None.  Approaching a collapse
        by steps took 4-7 ever shorter steps (:meth:`_collapse_limit`); after
        a failed landing the next is tried only once the distance has halved
        (``tried``: constraint -> distance of its last failed try)."""
        for c in self.constraints:
            if not isinstance(c, CableCollapse) or c is active:
                continue
            rate = float(c.gradient(pt.w) @ pt.t)
            if rate >= 0:
                continue
            reach = c.value(pt.w) / -rate
            if reach > ds or reach > 0.5 * tried.get(c.name, np.inf):
                continue
            w, ok = self.tr.correct(pt.w + reach * pt.t, [active, c], self.counts)
            corner = self._corner_point(pt, w, active, c, reach * pt.t) if ok else None
            if corner is not None:
                return c, corner
            tried[c.name] = reach
        return None

    def _corner_point(self, pt, w, active, hit, step):
        """The corner point at w (directly solved) if it is the next event along
        the curve from ``pt``: ahead of it, within the tracer's jump and
        tip-step limits, inside every other constraint and as stable as
        ``pt``; else None."""
        tr = self.tr
        n = tr.mf.disc.n_elements
        if (float(tr.mf.metric * pt.t @ (w - pt.w)) <= 0
                or np.max(np.abs(w[:n] - pt.w[:n] - step[:n])) > tr.jump_tol
                or np.linalg.norm(tr.mf.tip(w) - pt.tip) > tr.max_tip_step
                or any(c.margin(w) < 0 for c in self.constraints
                       if c is not active and c is not hit)):
            return None
        corner = tr.point(w, pt.t, pt.det_sign, 0)
        return corner if corner.unstable_modes == pt.unstable_modes else None

    @staticmethod
    def _end(curve, hit, corner):
        """Close ``curve`` at the corner with ``hit``: (curve, hit, corner state)."""
        curve.end, curve.end_constraint, curve.hit = "corner", hit.name, hit
        curve.points.append(corner)
        return curve, hit, corner.w

    def follow(self, start, active) -> tuple[Curve, object, np.ndarray | None]:
        """Follow ``active`` from the point ``start`` until another constraint
        becomes active: (curve, the new constraint, the corner state w).  The
        nodes of a curve of ``known`` (an earlier walk's) on the same
        constraint are taken over while no constraint of this walk becomes
        active (:meth:`_replay`)."""
        curve = Curve(active.name, [start], active=active)
        done = self._replay(curve, active)
        if done is not None:
            return done
        pt, ds, tried = curve.points[-1], self.ds0, {}
        while len(curve.points) < self.max_points:
            ds = min(ds, self.tr.step_limit(pt))
            landed = self._land_on_collapse(pt, active, ds, tried)
            if landed is not None:
                return self._end(curve, *landed)
            ds = min(ds, self._collapse_limit(pt, active))
            new, its = self.tr.step(pt, active, ds, self.counts)
            if self.progress is not None:
                self.progress(self.counts.solves, f"along {active.name}, point {len(curve.points)}")
            if new is None:
                ds *= 0.5
                if ds < self.ds_min:
                    curve.end = f"step below {self.ds_min:g} ({self.tr.reason()})"
                    return curve, None, None
                continue
            hits = self._events(pt, new, active)
            if hits:
                for hit in hits:
                    w = self._locate(pt, new, active, hit)
                    if w is not None:
                        return self._end(curve, hit, self.tr.point(w, pt.t, pt.det_sign, 0))
                ds *= 0.5
                if ds < self.ds_min:
                    curve.end = "could not locate the corner with " + hits[0].name
                    return curve, None, None
                continue
            if new.det_sign != pt.det_sign and new.unstable_modes == pt.unstable_modes:
                curve.points.append(new)
                curve.end = "branch point (det of the extended Jacobian changed sign)"
                return curve, None, None
            if active is self.fold or isinstance(active, TipFold):
                active.update(new.w)
            curve.points.append(new)
            pt = new
            ds = min(ds * 2.0 if its <= 3 else ds, self.tr.ds_max)
        curve.end = f"more than {self.max_points} points"
        return curve, None, None

    def _replay(self, curve, active):
        """Take over the nodes of a known curve on ``active`` (:attr:`known`,
        e.g. the W_0 walk's curves for the restricted walk, whose region lies
        inside D) from the start of ``curve`` on, while no constraint of this
        walk becomes active between two of them; at such an event its corner
        is solved for as after a step, and where the known curve ends its
        corner is solved again with this walk's constraint.  Returns
        (curve, hit, w) when the curve is done, None to go on by steps from
        its last node."""
        found = _find_on(self.known, active.name, curve.points[0], self.tr.mf.metric)
        if found is None:
            return None
        known, j = found
        by_name = {c.name: c for c in self.constraints + [self.fold]}
        end = by_name.get(known.end_constraint) if known.hit is not None else None
        pt = curve.points[0]
        for k in range(j + 1, len(known.points)):
            b, last = known.points[k], k == len(known.points) - 1
            hits = [h for h in self._events(pt, b, active) if not (last and h is end)]
            if not hits and not last:
                curve.points.append(b)
                pt = b
                continue
            break
        if active is self.fold:                  # bordering vectors at the last node taken
            active.update(pt.w)
        for hit in hits or ([end] if end is not None and last else []):
            w = self._locate(pt, b, active, hit)
            if w is not None:
                return self._end(curve, hit, self.tr.point(w, pt.t, pt.det_sign, 0))
        return None

    def walk(self, name: str, w0: np.ndarray, first, previous, max_corners: int = 16):
        """Once around the region from the corner w0 (constraints ``previous`` and
        ``first`` active), leaving along ``first`` into ``previous``'s admissible side."""
        curves, active, w, closed, message = [], first, w0, False, ""
        into = self._orient(previous)
        for _ in range(max_corners):
            start, tau = self._start_point(w, active, into)
            if curves:                              # the corner w ends the last curve
                self._corner_tangent(curves[-1], tau)
            else:
                first_tau = tau                     # along ``previous`` at w0
            curve, hit, w_next = self.follow(start, active)
            curves.append(curve)
            if hit is None:
                message = f"{curve.constraint}: {curve.end}"
                break
            if hit is first and np.linalg.norm(w_next[-2:] - w0[-2:]) < 1e-6:
                closed = True
                self._corner_tangent(curve, first_tau if curve.active is previous else None)
                break
            into, active, w = self._orient(active), hit, w_next
        else:
            message = f"more than {max_corners} corners"
        return RegionBoundary(name, curves, closed, message)


    def parameter_velocities(self, region: RegionBoundary, start_rows,
                             parameters) -> list[np.ndarray]:
        """d x_t/d q (units of l per unit of l) at every node of the loop, in the
        order of :meth:`RegionBoundary.nodes`, shape (nodes, 2 tip, k), for each
        parameter block of ``parameters`` (``solvers/continuation.py``: RouteParameter,
        k = 2, OffsetParameter, k = 1; one factorisation per node).

        Corners (the ends of each curve, and the start, where ``start_rows``
        are active) move with both of their constraints; a node inside a curve
        slides orthogonally (metric D) to the curve's tangent.  Only the normal
        component of the tip motion matters for the area
        (:func:`~elastica_petsc.core.geometry.union_area_gradient`)."""
        mf, out = self.tr.mf, [[] for _ in parameters]
        for k, curve in enumerate(region.curves):
            for j, pt in enumerate(curve.points):
                if j == 0:
                    rows = start_rows if k == 0 else [region.curves[k - 1].active, curve.active]
                elif j == len(curve.points) - 1 and curve.hit is not None:
                    rows = [curve.active, curve.hit]
                else:
                    rows = [curve.active, mf.metric * pt.t]
                for row in rows:
                    if row is self.fold:
                        self.fold.update(pt.w)
                for dest, dw in zip(out, self.tr.parameter_velocities(pt.w, rows, parameters)):
                    dest.append(np.column_stack([mf.tip_velocity(pt.w, dw[:, c])
                                                 for c in range(dw.shape[1])]))
        return [np.array(v) for v in out]


def _find_on(curves, name: str, start, metric: np.ndarray, tol: float = 0.1):
    """(curve, j): the curve of ``curves`` on constraint ``name`` that passes
    through the point ``start`` between its nodes j and j + 1, travelled the
    way start's tangent points (start within ``tol`` of the chord's length,
    metric D, from the chord); None if there is none."""
    best = None
    for curve in curves:
        if curve.constraint != name or len(curve.points) < 2:
            continue
        nodes = np.array([pt.w for pt in curve.points])
        chord, rel = np.diff(nodes, axis=0), start.w - nodes[:-1]
        length2 = np.maximum(np.sum(metric * chord * chord, axis=1), 1e-300)
        along = np.sum(metric * rel * chord, axis=1) / length2
        off = rel - along[:, None] * chord
        dist = np.sqrt(np.sum(metric * off * off, axis=1) / length2)
        ahead = (chord @ (metric * start.t)) > 0
        ok = (along >= 0) & (along <= 1) & (dist <= tol) & ahead
        for j in np.flatnonzero(ok):
            if best is None or dist[j] < best[2]:
                best = (curve, int(j), dist[j])
    return None if best is None else best[:2]


@dataclass
class Crossing:
    """Where the intrinsic tip-map test changes sign on the loop: between nodes
    ``a`` and ``b`` of curve ``curve`` (b = -1: across the corner at its end)."""

    curve: int
    a: int
    b: int
    tip: np.ndarray                    # midpoint of the two nodes' tips (units of l)
    p: np.ndarray                      # midpoint of their tensions
    w_a: np.ndarray = field(default=None, repr=False)    # the states of the two nodes
    w_b: np.ndarray = field(default=None, repr=False)
    constraint: str = ""               # the loop curve's constraint (b = -1: the next one's)
    traced: bool = False
    note: str = ""


def tip_fold_crossings(region: RegionBoundary) -> list[Crossing]:
    """Sign changes of the intrinsic tip-map test (:meth:`CurveTracer.tangent`)
    between consecutive nodes of the loop, corners included (the corner nodes
    carry no test value: the comparison is between the last node before and
    the first node after).  Each is where a fold curve of the tip map inside
    D meets the loop (or, for a pair of changes within one step, two that
    meet it close together: a step hides an even number)."""
    nodes = [(k, j, pt) for k, c in enumerate(region.curves) for j, pt in enumerate(c.points)
             if np.isfinite(pt.tip_det) and pt.tip_det != 0.0]
    out = []
    for (k0, j0, a), (k1, j1, b) in zip(nodes, nodes[1:] + nodes[:1]):
        if np.sign(a.tip_det) == np.sign(b.tip_det):
            continue
        same = k0 == k1 and j1 == j0 + 1
        name = region.curves[k0].constraint
        out.append(Crossing(k0, j0, j1 if same else -1, 0.5 * (a.tip + b.tip),
                            0.5 * (a.w[-2:] + b.w[-2:]), a.w, b.w, name))
    return out


class FoldTracer:
    """Fold curves of the tip map inside D (det S = 0, :class:`TipFold`), each
    followed by :meth:`Walker.follow` from a loop crossing into D until it
    leaves D (another constraint becomes active, or stability is lost)."""

    def __init__(self, walker: Walker):
        self.walker = walker
        self.tipfold = TipFold(walker.tr.mf)

    def _start(self, region: RegionBoundary, x: Crossing):
        """Corner of the loop curve and det S = 0 near crossing ``x``, and the
        direction into D; None where the loop curve is the fold of M (det S
        is unbounded there) or the corrector fails."""
        walker, curves = self.walker, region.curves
        curve = curves[x.curve]
        if x.b == -1:                                 # across a corner: start at the corner
            nxt = curves[(x.curve + 1) % len(curves)]
            corner = curve.points[-1].w
            self.tipfold.reset(corner)
            if abs(self.tipfold.value(corner)) > 1e-8 * _scale(self.tipfold, corner):
                return None, "sign change across a corner away from det S = 0"
            into = [walker._orient(curve.active), walker._orient(nxt.active)]
            return corner, (lambda w: into[0](w) + into[1](w))
        if curve.active is walker.fold:
            return None, "on the fold of M (the frame of TipFold.reset is singular there)"
        a, b = curve.points[x.a], curve.points[x.b]
        self.tipfold.reset(a.w)
        frac = a.tip_det / (a.tip_det - b.tip_det)
        w, ok = walker.tr.correct(a.w + frac * (b.w - a.w), [curve.active, self.tipfold],
                                  walker.counts)
        if not ok:
            return None, f"corrector failed ({walker.tr.reason()})"
        return w, walker._orient(curve.active)

    def trace(self, region: RegionBoundary, crossings: list[Crossing]) -> list[Curve]:
        """Trace a fold curve from every crossing not yet reached by an earlier
        one (a curve ending within 1e-6 l (tip) of a crossing marks it traced)."""
        curves = []
        for x in crossings:
            if x.traced:
                continue
            w, into = self._start(region, x)
            if w is None:
                x.note = into
                continue
            start, _ = self.walker._start_point(w, self.tipfold, into)
            curve, hit, _ = self.walker.follow(start, self.tipfold)
            if hit is not None:
                self.walker._corner_tangent(curve)
            curves.append(curve)
            x.traced = True
            for y in crossings:
                if not y.traced and curve.end == "corner" and self._ends_at(curve, y):
                    y.traced = True
        return curves

    def _ends_at(self, curve: Curve, x: Crossing) -> bool:
        """The traced curve ends on the loop curve of crossing ``x``, between its
        two nodes (inside the ellipse with foci at their states, metric D, whose
        axis is 1.5 times their distance); for a crossing across a corner, on
        either curve at the corner."""
        norm = self.walker.tr.mf.norm
        end = curve.points[-1].w
        if x.b == -1:
            return norm(end - x.w_a) < 0.5 * norm(x.w_b - x.w_a)
        if curve.end_constraint != x.constraint:
            return False
        return norm(end - x.w_a) + norm(end - x.w_b) <= 1.5 * norm(x.w_b - x.w_a)


SCAN_ANGLES = (np.radians(20.0), np.radians(45.0), np.radians(70.0))


def scan_rays(walker: Walker, w0: np.ndarray, fold_curves: list, angles=SCAN_ANGLES,
              max_tip_step: float = SCAN_TIP_STEP) -> list[tuple[str, int, int]]:
    """A coarse scan of D for folds of the tip map that do not meet the loop:
    proportional loading rays p = s (cos a, sin a) followed by continuation
    from the straight arm until they leave D, the intrinsic test evaluated at
    every node.  A sign change between two nodes must be a traced fold curve
    crossing the ray there (the fold curve's tension polyline crosses the
    ray's segment); (ray, changes, unexplained) per ray.  The rays draw no
    polygon: their steps may move the tip up to ``max_tip_step`` (units of l)."""
    out = []
    folds_p = [np.array([pt.w[-2:] for pt in c.points]) for c in fold_curves]
    tracer = walker.tr
    cap, tracer.max_tip_step = tracer.max_tip_step, max_tip_step
    ds_max, tracer.ds_max = tracer.ds_max, 4 * tracer.ds_max
    try:
        for angle in angles:
            ray = TensionRay(tracer.mf, angle)
            start, _ = walker._start_point(w0, ray,
                                           lambda w, r=ray: _p_direction(walker, r.direction))
            out.append(_scan_one(walker, start, ray, folds_p))
    finally:
        tracer.max_tip_step, tracer.ds_max = cap, ds_max
    return out


def _scan_one(walker: Walker, start, ray: TensionRay, folds_p: list) -> tuple[str, int, int]:
    """One scan ray of :func:`scan_rays`."""
    curve, _, _ = walker.follow(start, ray)
    nodes = [pt for pt in curve.points if np.isfinite(pt.tip_det) and pt.tip_det != 0.0]
    changes = unexplained = 0
    for a, b in zip(nodes, nodes[1:]):
        if np.sign(a.tip_det) != np.sign(b.tip_det):
            changes += 1
            crossed = any(segments_cross(a.w[-2:], b.w[-2:], f) for f in folds_p)
            unexplained += not crossed
    return ray.name, changes, unexplained


def _p_direction(walker: Walker, direction: np.ndarray) -> np.ndarray:
    """D^-1 (0, ..., direction): an orientation vector pointing along +direction in p."""
    v = np.zeros(walker.tr.mf.m)
    v[-2:] = direction
    return v / walker.tr.mf.metric


def _scale(constraint, w) -> float:
    return max(float(np.linalg.norm(constraint.gradient(w))), 1e-300)
