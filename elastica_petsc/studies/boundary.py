"""Workspace boundaries by continuation (two tendons).

W_0 (used alike by tip control, the sampled map and this module) is the set
of tips of the stable equilibria connected to the straight arm by
quasi-static loading with all P_i >= 0 (Eq. (18)): the image under the tip
map of D, the connected component of the straight arm in the stable part of
the equilibrium manifold M = {(u, p): F(u, p) = 0, p >= 0}.  D is bounded by

* the faces P_i = 0 (and P_i = P_crit when the config sets a motor limit,
  Eq. (22)),
* cable collapse, L_i = 0 (the attachment point on its routing point, beyond
  which the load direction of Eq. (3) is undefined; traced at L_i = eps =
  COLLAPSE_LENGTH, 1.2 mm on the paper's arm),
* the fold of M over tension space, where K is singular (lambda_min = 0,
  Eq. (20)): the limit points beyond which the arm snaps.

:func:`trace_region_boundary` walks once around D (a wall follower): it
follows one of these curves by pseudo-arclength continuation
(:class:`~elastica_petsc.solvers.continuation.CurveTracer`) with D on its
left in tension space until another constraint becomes active (a bound is
crossed or stability is lost), solves for that corner, and turns onto the
new curve, until it is back at the straight arm.

The tip map can fold inside D (det S = 0, S = d x_t / d p, Eq. (13)); the
boundary of W_0 = f(D) lies in the image of the loop and of these fold
curves (docs/model.md §9.1).  Each loop node carries an intrinsic tip-map
test (:meth:`CurveTracer.tangent`); its sign changes (:func:`tip_fold_crossings`)
are where fold curves meet the loop, and each is traced into D until it
leaves it (:class:`FoldTracer`); three proportional-loading rays scan D for
sign changes that no traced fold explains (:func:`scan_rays`).  W_0 is then
assembled from the faces of the plane minus these images
(:func:`classify_faces`: the preimage count along rays avoiding fold
images); :meth:`BoundaryResult.outside` proves a target outside W_0 when it
lies in the unbounded face (the verdict OUTSIDE_BOUNDARY of tip control).
On the paper's arm: six sign changes, the ends of three fold curves (one
from the straight arm, where det S = 0), all traced; the face of winding
number 0 around r_1 has no preimage (a hole), so the area is exact.

Limits found (issue 13): at a corner where a cable collapses (the tip on
r_2) several equilibria with P_1 = 0 can share the corner, and which one the
walk continues from can depend on the step sizes and the mesh; with a
routing point moved (r_1 = (-53.7, -21.6), r_2 = (81.8, 10.0) mm) the walk
took different loops at 60 and 180 elements.  A fold curve that is a closed
loop inside D missing the scan rays, and states reached only by snapping
onto another sheet, are not covered (docs/model.md §9.1).

The restricted workspace W_0 ∩ W_Y ∩ W_E ∩ W_P (Eqs. (19), (21), (22); W_S
is W_0 itself under this definition, since D holds only stable states) is
the image of the region D_r of D where also l*kappa_max <= 2 eps_Y l / h and
SE <= SE_max: the same walk with those two level curves as extra
constraints.  Where l*kappa_max switches between elements the constraint is
only piecewise smooth; the corrector copes with it (the kink is a corner).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.model import Arm
from ..solvers.continuation import (CableCollapse, Curve, CurveTracer, Fold, FoldSystem,
                                    StateLevel, TensionBound, TensionRay, TipFold)
from ..solvers.equilibrium import COLLAPSE_LENGTH


class BoundaryError(InputError):
    """An arm whose boundary this method cannot trace (e.g. not two tendons)."""


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


@dataclass
class BoundaryResult:
    """W_0 and restricted boundaries of one arm (units: mm and mm^2).

    fold_curves: fold curves of the tip map inside D (:class:`FoldTracer`),
    fold_polylines_mm their tip images; crossings: where the intrinsic tip-map
    test changes sign on the W0 loop (each traced or with a note why not).
    """

    arm: Arm
    regions: dict                       # name -> RegionBoundary ("W0", "restricted")
    polygons_mm: dict                   # name -> list of (k, 2) closed polygons
    areas_mm2: dict
    tip_folds_mm: np.ndarray            # where det S changes sign on the W0 loop
    solves: int
    seconds: float
    messages: list = field(default_factory=list)
    area_gradients: dict = field(default_factory=dict)   # name -> d area/d routes [mm^2/mm]
    fold_curves: list = field(default_factory=list)
    fold_polylines_mm: list = field(default_factory=list)
    crossings: list = field(default_factory=list)
    cell_mm: float = 0.0
    faces: list = field(default_factory=list)            # classify_faces (W0)
    scan: list = field(default_factory=list)             # scan_rays: (ray, changes, unexplained)
    scan_solves: int = 0                                 # of ``solves``, spent on the scan
    rejected_steps: int = 0                              # of ``solves``, steps not accepted
    area_bounds_mm2: tuple = (np.nan, np.nan)            # W0: (proven in, not proven out)
    _outside: object = field(default=None, repr=False)

    @property
    def area_mm2(self) -> float:
        return self.areas_mm2["W0"]

    @property
    def untraced_folds(self) -> list[str]:
        """Why each loop crossing of a tip-map fold was not traced, and curves
        that did not end on the region's boundary ([] when all are traced)."""
        out = [f"crossing at ({x.tip[0] * self.arm.length_mm:.1f}, "
               f"{x.tip[1] * self.arm.length_mm:.1f}) mm: {x.note or 'not traced'}"
               for x in self.crossings if not x.traced]
        out += [f"fold curve from ({c.points[0].tip[0] * self.arm.length_mm:.1f}, "
                f"{c.points[0].tip[1] * self.arm.length_mm:.1f}) mm ended: {c.end}"
                for c in self.fold_curves if c.end != "corner"]
        out += [f"{ray}: {bad} sign change(s) of the tip-map test on no traced fold curve"
                for ray, _, bad in self.scan if bad]
        return out

    @property
    def outside_map(self) -> "OutsideMap":
        """The unbounded component of the plane minus the W0 loop's image and
        the fold images (:class:`OutsideMap`, built on first use)."""
        if self._outside is None:
            lines = self.polygons_mm["W0"] + self.fold_polylines_mm
            self._outside = OutsideMap(lines, self.cell_mm, closed=(0,))
        return self._outside

    def contains(self, points_mm) -> np.ndarray:
        """True where a point is in W_0 as assembled (:func:`_assemble_w0`): the
        W0 loop winds around it, or it lies in a face of winding number 0
        covered twice (N > 0).  Points on the walls count by the winding rule."""
        pts = np.atleast_2d(np.asarray(points_mm, float))
        inside = winding_number(self.polygons_mm["W0"][0], pts) != 0
        twice = [f["label"] for f in self.faces if f["winding"] == 0 and (f["preimages"] or 0) > 0]
        if twice:
            inside |= np.isin(self.outside_map.label(pts), twice)
        return inside

    def preimages(self, target_mm, margin_mm: float | None = None) -> tuple[int | None, float]:
        """(N, distance in mm): the number N of states of D whose tip is
        ``target_mm``, when the traced boundary decides it (docs/model.md
        §9.1): the loop is closed, every fold of the tip map meeting it is
        traced to the region's boundary, the target lies farther than
        ``margin_mm`` (default 3 cells) from the loop's and the folds'
        images, and its face of the plane minus them is the unbounded one
        (N = 0) or a bounded face whose preimage count (:func:`classify_faces`)
        is decided and consistent with its winding number (N >= |w|,
        N = w mod 2).  N is None otherwise.  The distance is to the nearest
        traced curve."""
        target = np.asarray(target_mm, float).reshape(1, 2)
        margin = 3 * self.cell_mm if margin_mm is None else margin_mm
        dist = float(self.outside_map.distance(target)[0])
        if not self.regions["W0"].closed or self.untraced_folds or dist <= margin:
            return None, dist
        if self.outside_map.outside(target)[0]:
            return 0, dist
        label = int(self.outside_map.label(target)[0])
        for f in self.faces:
            n, w = f["preimages"], f["winding"]
            if f["label"] == label and n is not None and n >= abs(w) and (n - w) % 2 == 0:
                return n, dist
        return None, dist

    def outside(self, target_mm, margin_mm: float | None = None) -> tuple[str, float]:
        """(evidence, distance in mm): evidence is '' unless ``target_mm`` is
        proven outside W_0 by docs/model.md §9.1, i.e. :meth:`preimages` is 0:
        the target lies in the unbounded face or in a hole of W_0."""
        n, dist = self.preimages(target_mm, margin_mm)
        if n != 0:
            return "", dist
        curves = (f"loop of {len(self.regions['W0'].curves)} curves and "
                  f"{len(self.fold_curves)} tip-map fold curves")
        if self.outside_map.outside(np.asarray(target_mm, float).reshape(1, 2))[0]:
            return (f"OUTSIDE_BOUNDARY: the target lies outside the traced boundary of W_0 "
                    f"({curves}), {dist:.3g} mm from it (docs/model.md §9.1)"), dist
        return (f"OUTSIDE_BOUNDARY: the target lies in a hole of W_0, a bounded face of the "
                f"plane minus the traced boundary ({curves}) with no preimage, counted along "
                f"a ray to infinity; {dist:.3g} mm from the boundary (docs/model.md §9.1)"), dist


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


class Walker:
    """The wall follower around D of the module docstring."""

    def __init__(self, tracer: CurveTracer, constraints: list, *, ds0: float = 0.3,
                 ds_min: float = 1e-5, max_points: int = 400, progress=None):
        self.tr, self.progress = tracer, progress        # progress(solves, note) per step
        self.constraints = constraints
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
        t, det_sign, tip_det = self.tr.tangent(w, active, into(w))
        return self.tr.point(w, t, det_sign, 0, tip_det, self.tr.last_inward)

    def _locate(self, a, b, active, hit) -> np.ndarray | None:
        """Corner where ``hit`` becomes active between accepted points a and b."""
        if hit is self.fold:
            guess_v = self.fold_system.null_vector(b.w)
            self.fold_system.set_vectors(guess_v)
        ma, mb = hit.value(a.w), hit.value(b.w)
        frac = ma / (ma - mb) if ma != mb else 0.5
        frac = min(max(frac, 0.0), 1.0)
        guess = a.w + frac * (b.w - a.w)
        w, ok = self.tr.correct(guess, [active, hit])
        if not ok:
            return None
        if hit is self.fold:
            self.fold.update(w)
            # the stable side (a is stable) is the admissible one
            self.fold.side = 1.0 if self.fold.value(a.w) >= 0 else -1.0
        return w

    def _events(self, a, b, active):
        """Constraints that became active between a and b (stability loss: fold)."""
        hits = [c for c in self.constraints if c is not active and c.margin(b.w) < 0]
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

    def follow(self, start, active) -> tuple[Curve, object, np.ndarray | None]:
        """Follow ``active`` from the point ``start`` until another constraint
        becomes active: (curve, the new constraint, the corner state w)."""
        curve = Curve(active.name, [start], active=active)
        pt, ds = start, self.ds0
        while len(curve.points) < self.max_points:
            ds = min(ds, self.tr.step_limit(pt), self._collapse_limit(pt, active))
            new, its = self.tr.step(pt, active, ds)
            if self.progress is not None:
                self.progress(self.tr.solves, f"along {active.name}, point {len(curve.points)}")
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
                        curve.end, curve.end_constraint, curve.hit = "corner", hit.name, hit
                        corner = self.tr.point(w, pt.t, pt.det_sign, 0)
                        curve.points.append(corner)
                        return curve, hit, w
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

    def walk(self, name: str, w0: np.ndarray, first, previous, max_corners: int = 16):
        """Once around the region from the corner w0 (constraints ``previous`` and
        ``first`` active), leaving along ``first`` into ``previous``'s admissible side."""
        curves, active, w, closed, message = [], first, w0, False, ""
        into = self._orient(previous)
        for _ in range(max_corners):
            start = self._start_point(w, active, into)
            curve, hit, w_next = self.follow(start, active)
            curves.append(curve)
            if hit is None:
                message = f"{curve.constraint}: {curve.end}"
                break
            if hit is first and np.linalg.norm(w_next[-2:] - w0[-2:]) < 1e-6:
                closed = True
                break
            into, active, w = self._orient(active), hit, w_next
        else:
            message = f"more than {max_corners} corners"
        return RegionBoundary(name, curves, closed, message)


    def route_velocities(self, region: RegionBoundary, start_rows, tendon: int) -> np.ndarray:
        """d x_t/d r_i (units of l per unit of l) at every node of the loop, in the
        order of :meth:`RegionBoundary.nodes`, shape (nodes, 2 tip, 2 route).

        Corners (the ends of each curve, and the start, where ``start_rows``
        are active) move with both of their constraints; a node inside a curve
        slides orthogonally (metric D) to the curve's tangent.  Only the normal
        component of the tip motion matters for the area (:func:`area_gradient`)."""
        mf, out = self.tr.mf, []
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
                dw = self.tr.route_velocity(pt.w, rows, tendon)
                out.append(np.column_stack([mf.tip_velocity(pt.w, dw[:, c]) for c in range(2)]))
        return np.array(out)


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
        w, ok = walker.tr.correct(a.w + frac * (b.w - a.w), [curve.active, self.tipfold])
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
            start = self.walker._start_point(w, self.tipfold, into)
            curve, _, _ = self.walker.follow(start, self.tipfold)
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
              max_tip_step: float = 0.5) -> list[tuple[str, int, int]]:
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
            start = walker._start_point(w0, ray, lambda w, r=ray: _p_direction(walker, r.direction))
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
            crossed = any(_segments_cross(a.w[-2:], b.w[-2:], f) for f in folds_p)
            unexplained += not crossed
    return ray.name, changes, unexplained


def _p_direction(walker: Walker, direction: np.ndarray) -> np.ndarray:
    """D^-1 (0, ..., direction): an orientation vector pointing along +direction in p."""
    v = np.zeros(walker.tr.mf.m)
    v[-2:] = direction
    return v / walker.tr.mf.metric


def _segments_cross(a: np.ndarray, b: np.ndarray, polyline: np.ndarray) -> bool:
    """The segment [a, b] crosses the polyline (or touches it at a vertex)."""
    if len(polyline) < 2:
        return False
    p, q = polyline[:-1], polyline[1:]

    def orient(u, v, w):
        return np.sign((v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1])
                       - (v[..., 1] - u[..., 1]) * (w[..., 0] - u[..., 0]))

    return bool(np.any((orient(a, b, p) * orient(a, b, q) <= 0)
                       & (orient(p, q, a) * orient(p, q, b) <= 0)))


def _scale(constraint, w) -> float:
    return max(float(np.linalg.norm(constraint.gradient(w))), 1e-300)


class OutsideMap:
    """The unbounded component of the plane minus a set of polylines (mm), on
    a grid: every cell that a polyline touches is a wall (segments sampled at
    half a cell, each sample walling its 3 x 3 block of cells, so no touched
    cell is missed), and the free cells 4-connected to the grid's border are
    outside.  A point whose cell is outside can be joined to infinity by a
    path of closed free cells, which meets no polyline: it lies in the
    unbounded component (sound up to the polylines standing for the curves)."""

    def __init__(self, polylines: list, cell_mm: float, closed: tuple = ()):
        from scipy import ndimage

        pts = np.vstack(polylines)
        self.cell = float(cell_mm)
        self.origin = pts.min(axis=0) - 4 * self.cell
        shape = np.ceil((pts.max(axis=0) + 4 * self.cell - self.origin) / self.cell).astype(int)
        wall = np.zeros(shape, bool)
        self.segments = []
        for k, line in enumerate(polylines):
            line = np.vstack((line, line[:1])) if k in closed else line
            a, b = line[:-1], line[1:]
            self.segments.append((a, b))
            n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / (0.5 * self.cell)), 1)
            n = n.astype(int)
            seg = np.repeat(np.arange(len(a)), n + 1)
            # samples k / n_seg, k = 0..n_seg, of every segment (as np.linspace rounds them)
            k = np.arange(len(seg)) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
            frac = np.where(k == n[seg], 1.0, k * (1.0 / n[seg]))
            ij = np.floor((a[seg] + frac[:, None] * (b - a)[seg] - self.origin)
                          / self.cell).astype(int)
            for di in (-1, 0, 1):
                for dj in (-1, 0, 1):
                    wall[np.clip(ij[:, 0] + di, 0, shape[0] - 1),
                         np.clip(ij[:, 1] + dj, 0, shape[1] - 1)] = True
        labels, self.n_labels = ndimage.label(~wall)
        border = np.unique(np.concatenate((labels[0], labels[-1], labels[:, 0], labels[:, -1])))
        on_border = np.zeros(self.n_labels + 1, bool)
        on_border[border[border > 0]] = True
        self.outside_cells = on_border[labels]
        self.labels, self.border_labels, self.shape = labels, border[border > 0], shape

    def bounded_faces(self) -> list[tuple[np.ndarray, float]]:
        """Each bounded face (free cells not outside, 4-connected): a point of it
        farthest from the walls (mm) and its area (mm^2, cells only)."""
        from scipy import ndimage

        free = (self.labels > 0) & ~self.outside_cells
        if not free.any():
            return []
        depth = ndimage.distance_transform_edt(free)
        ids = [k for k in range(1, self.n_labels + 1) if k not in set(self.border_labels)]
        boxes = ndimage.find_objects(self.labels)
        where = []
        for k in ids:                           # of the deepest cells, the first in C order
            box = boxes[k - 1]
            hit = np.argmax(np.where(self.labels[box] == k, depth[box], -1.0))
            where.append(tuple(int(i) + sl.start for i, sl in
                               zip(np.unravel_index(hit, self.labels[box].shape), box)))
        sizes = ndimage.sum(free, self.labels, ids)
        return [(self.origin + (np.array(ij) + 0.5) * self.cell, float(n) * self.cell**2, k)
                for ij, n, k in zip(where, sizes, ids)]

    def label(self, points_mm: np.ndarray) -> np.ndarray:
        """The face label of each point's cell (0: a wall; off the grid: -1)."""
        ij = np.floor((np.atleast_2d(points_mm) - self.origin) / self.cell).astype(int)
        on = np.all((ij >= 0) & (ij < self.shape), axis=1)
        out = np.full(len(ij), -1)
        out[on] = self.labels[ij[on, 0], ij[on, 1]]
        return out

    def outside(self, points_mm: np.ndarray) -> np.ndarray:
        """True where the point's cell is outside (off the grid: outside)."""
        ij = np.floor((np.atleast_2d(points_mm) - self.origin) / self.cell).astype(int)
        on = np.all((ij >= 0) & (ij < self.shape), axis=1)
        out = np.ones(len(ij), bool)
        out[on] = self.outside_cells[ij[on, 0], ij[on, 1]]
        return out

    def distance(self, points_mm: np.ndarray) -> np.ndarray:
        """Distance (mm) from each point to the nearest polyline."""
        pts = np.atleast_2d(points_mm)
        out = np.full(len(pts), np.inf)
        for a, b in self.segments:
            ab = b - a
            denom = np.maximum(np.einsum("kc,kc->k", ab, ab), 1e-300)
            t = np.clip(((pts[:, None, :] - a[None]) * ab[None]).sum(-1) / denom, 0.0, 1.0)
            near = a[None] + t[..., None] * ab[None]
            out = np.minimum(out, np.linalg.norm(pts[:, None, :] - near, axis=-1).min(axis=1))
        return out

    def hull_area(self) -> float:
        """Area (mm^2) of the cells not outside (walls included): an upper
        bound of the area enclosed, within a wall's width of the curves."""
        return float(np.sum(~self.outside_cells)) * self.cell**2


def preimage_counts(poly: np.ndarray, inward_left: np.ndarray, folds: list, points: np.ndarray,
                    n_directions: int = 24) -> np.ndarray:
    """N(y), the number of states of D whose tip is y, for each point y (NaN:
    undecided).  N = 0 far away; walking in from infinity along a ray, N
    changes by +-1 at each crossing of the loop's image (+1 when stepping to
    the side the image of D's interior lies on next to that edge) and by +-2
    at a fold image.  Rays that cross a fold image are not used (their +-2
    needs the fold's side): the first of ``n_directions`` that crosses none
    decides; if all do, NaN.  ``inward_left``: per vertex of the closed
    polygon ``poly``, +1 if D's interior maps to the left of the direction of
    travel along the edge starting there, -1 if to the right
    (:func:`inward_sides`)."""
    a, b = poly, np.roll(poly, -1, axis=0)
    edge = b - a
    normal = np.column_stack((-edge[:, 1], edge[:, 0]))                 # left normal
    side = np.sign(inward_left)
    fa = np.vstack([f[:-1] for f in folds]) if folds else np.zeros((0, 2))
    fb = np.vstack([f[1:] for f in folds]) if folds else np.zeros((0, 2))
    out = np.full(len(points), np.nan)
    for angle in np.linspace(0, 2 * np.pi, n_directions, endpoint=False) + 0.1234:
        d = np.array([np.cos(angle), np.sin(angle)])
        todo = np.isnan(out)
        if not todo.any():
            break
        y = points[todo]
        if len(fa) and _ray_hits(y, d, fa, fb).any(axis=1).all():
            continue
        blocked = _ray_hits(y, d, fa, fb).any(axis=1) if len(fa) else np.zeros(len(y), bool)
        hits = _ray_hits(y, d, a, b)                                 # (points, edges)
        # walking in from infinity the motion is -d: +1 entering the interior's side
        step = np.sign(-normal @ d) * side
        counts = np.where(hits, step[None, :], 0.0).sum(axis=1)
        idx = np.flatnonzero(todo)[~blocked]
        out[idx] = counts[~blocked]
    return out


def inward_sides(region: RegionBoundary) -> np.ndarray:
    """Per node of the loop (order of :meth:`RegionBoundary.nodes`): +1 if the
    interior of D maps to the left of the loop's image (travelled along the
    curves' tangents t), -1 if to the right.  The side of inward = side * T tau
    relative to T t is sign det [T t, inward] = -side sign(tip_det) sign(det B)
    (:meth:`CurveTracer.tangent`): a sign, exact at the nodes even where T tau
    is nearly parallel to T t (near folds).  Corners take the previous node's."""
    out = []
    for curve in region.curves:
        for pt in curve.points:
            if np.isfinite(pt.tip_det) and pt.tip_det != 0.0:
                out.append(-curve.active.side * np.sign(pt.tip_det) * pt.det_sign)
            else:
                out.append(out[-1] if out else np.nan)
    out = np.array(out, float)
    if np.isnan(out[0]):
        out[0] = out[np.flatnonzero(np.isfinite(out))[-1]]
    # a lone node against both neighbours (a near-singular B at one node) follows them
    lone = (out != np.roll(out, 1)) & (np.roll(out, 1) == np.roll(out, -1))
    out[lone] = np.roll(out, 1)[lone]
    return out


def classify_faces(result: "BoundaryResult") -> list[dict]:
    """The bounded faces of the plane minus the W0 loop's and the folds' images
    (:meth:`OutsideMap.bounded_faces`), each with the loop's winding number and
    the preimage count N (:func:`preimage_counts`) at its deepest point: a face
    lies in W_0 iff N > 0 (N is constant on a face: its points are no tip of
    a boundary or fold state).  Areas in mm^2 (grid cells)."""
    region = result.regions["W0"]
    poly, left = loop_polygon(region, result.arm.length_mm,
                              node_values=inward_sides(region)[:, None])
    faces = result.outside_map.bounded_faces()
    if not faces:
        return []
    points = np.array([f[0] for f in faces])
    counts = preimage_counts(poly, left[:, 0], result.fold_polylines_mm, points)
    winding = winding_number(poly, points)
    return [{"point_mm": p.tolist(), "area_mm2": a, "winding": int(w),
             "preimages": None if np.isnan(n) else int(n), "label": int(k)}
            for p, (_, a, k), w, n in zip(points, faces, winding, counts)]


def _ray_hits(points: np.ndarray, d: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(points, segments): the ray y + t d, t > 0, meets the segment [a, b)."""
    e = b - a
    denom = d[0] * e[:, 1] - d[1] * e[:, 0]                         # cross(d, e)
    ay = a[None, :, :] - points[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ay[..., 0] * e[:, 1] - ay[..., 1] * e[:, 0]) / denom
        u = (ay[..., 0] * d[1] - ay[..., 1] * d[0]) / denom
    return (denom != 0) & (t > 0) & (u >= 0) & (u < 1)


def union_area(poly: np.ndarray, step: float | None = None) -> float:
    """Area of the set where the closed polygon's winding number is nonzero
    (the region W_0 when the loop crosses itself; the shoelace area would
    count a doubly wound part twice).  Scan lines at the midpoints of strips
    of height ``step`` (default 1/2000 of the height): on each, the crossings
    are sorted and the winding number accumulated.  Only the (line, edge)
    pairs that cross are formed (each edge spans a range of lines), then
    sorted together by line and abscissa."""
    a, b = poly, np.roll(poly, -1, axis=0)
    y0, y1 = float(np.min(poly[:, 1])), float(np.max(poly[:, 1]))
    step = (y1 - y0) / 2000 if step is None else step
    ys = np.arange(y0 + step / 2, y1, step)
    lo, hi = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
    first = np.searchsorted(ys, lo, side="left")                 # lines with lo <= y < hi
    count = np.searchsorted(ys, hi, side="left") - first
    edge = np.repeat(np.arange(len(a)), count)
    line = np.arange(len(edge)) - np.repeat(np.cumsum(count) - count - first, count)
    dy = np.where(b[:, 1] != a[:, 1], b[:, 1] - a[:, 1], 1.0)
    x = a[edge, 0] + (ys[line] - a[edge, 1]) / dy[edge] * (b[edge, 0] - a[edge, 0])
    order = np.lexsort((x, line))
    x, line = x[order], line[order]
    up = np.where(b[:, 1] > a[:, 1], 1, -1)[edge][order]       # crossing direction
    winding = np.cumsum(up)
    starts = np.flatnonzero(np.diff(line, prepend=-1))          # first crossing of each line
    winding -= np.repeat(winding[starts] - up[starts], np.diff(np.append(starts, len(line))))
    same = line[1:] == line[:-1]
    return float(np.sum(np.where(same & (winding[:-1] != 0), np.diff(x), 0.0))) * step


def union_area_gradient(nodes: np.ndarray, velocity: np.ndarray,
                        subdivide: int = 8) -> np.ndarray:
    """d(union area)/dq: the boundary integral of the outward normal velocity over
    the edges of the node polygon that separate winding number 0 from nonzero
    (edges inside the region, between windings 1 and 2, do not count).
    ``velocity``: (nodes, 2, q), the motion of each node per unit of q.  Each
    edge is cut into ``subdivide`` pieces (velocity linear along it) and each
    piece classified on its own, so an edge crossed by another counts in part."""
    s = np.arange(subdivide) / subdivide
    nxt, vnxt = np.roll(nodes, -1, axis=0), np.roll(velocity, -1, axis=0)
    poly = (nodes[:, None] + s[None, :, None] * (nxt - nodes)[:, None]).reshape(-1, 2)
    vel = (velocity[:, None] + s[None, :, None, None] * (vnxt - velocity)[:, None])
    vel = vel.reshape(-1, *velocity.shape[1:])
    a, b = poly, np.roll(poly, -1, axis=0)
    va, vb = vel, np.roll(vel, -1, axis=0)
    edge = b - a
    length = np.linalg.norm(edge, axis=1)
    ok = length > 0
    normal = np.zeros_like(edge)
    normal[ok] = np.column_stack((edge[ok, 1], -edge[ok, 0])) / length[ok, None]   # right side
    mid = 0.5 * (a + b)
    offset = 1e-6 * max(float(np.ptp(nodes[:, 0])), float(np.ptp(nodes[:, 1])))
    right = winding_number(poly, mid + offset * normal) != 0
    left = winding_number(poly, mid - offset * normal) != 0
    outward = np.where(right & ~left, -1.0, np.where(left & ~right, 1.0, 0.0)) * ok
    vmid = 0.5 * (va + vb)                                               # (edges, 2, q)
    vn = np.einsum("kc,kcq->kq", normal, vmid)                           # along the right normal
    return np.einsum("k,k,kq->q", outward, length, vn)


def shoelace(poly: np.ndarray) -> float:
    """Signed area of a closed polygon (positive: counter-clockwise)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def hermite_densify(tip, velocity, per_segment: int = 8) -> np.ndarray:
    """Cubic Hermite curve through the nodes with their tip velocities d x_t/ds
    (per unit of the curve's arclength parameter), ``per_segment`` points each
    (a segment with a zero chord or velocity keeps only its end node)."""
    tip, velocity = np.asarray(tip, float), np.asarray(velocity, float)
    a, b = tip[:-1], tip[1:]
    chord = np.linalg.norm(b - a, axis=1)
    na, nb = np.linalg.norm(velocity[:-1], axis=1), np.linalg.norm(velocity[1:], axis=1)
    smooth = (chord != 0) & (na != 0) & (nb != 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ma = velocity[:-1] / na[:, None] * chord[:, None]       # tangents scaled to the chord
        mb = velocity[1:] / nb[:, None] * chord[:, None]
    s = np.linspace(0, 1, per_segment + 1)[1:, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    curve = (h00[None] * a[:, None] + h10[None] * ma[:, None] + h01[None] * b[:, None]
             + h11[None] * mb[:, None])                          # (segments, per_segment, 2)
    keep = np.where(smooth[:, None], True, np.arange(per_segment)[None] == per_segment - 1)
    curve[~smooth, -1] = b[~smooth]
    return np.vstack((tip[:1], curve[keep]))


def loop_polygon(region: RegionBoundary, length_mm: float, per_segment: int = 8,
                 node_values: np.ndarray | None = None):
    """The tip image of the loop, densified per curve by :func:`hermite_densify`,
    in mm (closing point dropped).  With ``node_values`` (one row per node, in
    the order of :meth:`RegionBoundary.nodes`) also returns them interpolated
    linearly (in the Hermite parameter) at the dense points."""
    pieces, values, start = [], [], 0
    for curve in region.curves:
        tip = np.array([pt.tip for pt in curve.points])
        vel = np.array([pt.tip_velocity for pt in curve.points])
        # corners carry the previous curve's tangent: no Hermite into a corner
        dense = hermite_densify(tip[:-1], vel[:-1], per_segment) if len(tip) > 2 else tip[:1]
        pieces.append(np.vstack((dense, tip[-1:])))
        if node_values is not None:
            nv = node_values[start:start + len(tip)]
            s = np.linspace(0, 1, per_segment + 1)[1:]
            rows = [nv[:1]]
            for k in range(len(tip) - 2):
                rows.append(nv[k][None] + np.multiply.outer(s, nv[k + 1] - nv[k]))
            rows.append(nv[-1:])
            values.append(np.concatenate(rows))
        start += len(tip)
    poly = np.vstack(pieces) * length_mm
    keep = np.concatenate(([True], np.linalg.norm(np.diff(poly, axis=0), axis=1) > 1e-9))
    if np.linalg.norm(poly[keep][0] - poly[keep][-1]) < 1e-9:
        keep[np.flatnonzero(keep)[-1]] = False
    if node_values is None:
        return poly[keep]
    return poly[keep], np.concatenate(values)[keep]


def self_intersections(poly: np.ndarray) -> int:
    """Number of crossings between non-adjacent edges of a closed polygon.
    Only pairs whose x-ranges overlap are tested (a crossing inside both edges
    needs it): edges sorted by their left end, each against the later ones
    starting left of its right end."""
    a, b = poly, np.roll(poly, -1, axis=0)
    n = len(a)
    left, right = np.minimum(a[:, 0], b[:, 0]), np.maximum(a[:, 0], b[:, 0])
    order = np.argsort(left, kind="stable")
    stop = np.searchsorted(left[order], right[order], side="right")
    count = np.maximum(stop - np.arange(n) - 1, 0)
    first = np.repeat(np.arange(n), count)
    second = np.arange(len(first)) - np.repeat(np.cumsum(count) - count, count) + first + 1
    i, j = order[first], order[second]
    i, j = np.minimum(i, j), np.maximum(i, j)
    keep = (j - i >= 2) & ~((i == 0) & (j == n - 1))      # adjacent edges share a vertex
    i, j = i[keep], j[keep]
    p, r = a[i], b[i] - a[i]
    q, s = a[j], b[j] - a[j]
    denom = r[:, 0] * s[:, 1] - r[:, 1] * s[:, 0]
    qp = q - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[:, 0] * s[:, 1] - qp[:, 1] * s[:, 0]) / denom
        u = (qp[:, 0] * r[:, 1] - qp[:, 1] * r[:, 0]) / denom
    return int(np.sum((denom != 0) & (t > 0) & (t < 1) & (u > 0) & (u < 1)))


def _area_gradient(walker: Walker, region: RegionBoundary, start_rows, tendons,
                   length_mm: float) -> np.ndarray:
    """d|A|/d(r_i x, r_i y) for each tendon i in ``tendons`` [mm^2 per mm]."""
    grads = []
    for i in tendons:
        velocity = walker.route_velocities(region, start_rows, i)     # (nodes, 2, 2), l per l
        poly, dense_velocity = loop_polygon(region, length_mm, node_values=velocity)
        grads.append(union_area_gradient(poly, dense_velocity))          # mm^2 per mm
    return np.concatenate(grads)


def trace_boundary(arm: Arm, disc: Discretisation | None = None, *, restricted: bool = True,
                   tip_folds: bool = True, route_gradients=(), progress=None) -> BoundaryResult:
    """The boundary of W_0 (and of the restricted workspace) of a two-tendon arm.

    Returns polygons in mm and areas in mm^2 (module docstring for the
    definitions).  ``solves`` counts nonlinear solves of the continuation's
    extended system (each: a few Newton iterations, like one warm-started
    equilibrium solve).  Raises :class:`BoundaryError` for n != 2 tendons.

    ``route_gradients``: tendon indices (0-based) whose routing points'
    derivatives of each area are wanted: ``area_gradients[name]`` holds
    d area / d(r_x, r_y) per tendon, in mm^2 per mm, from the boundary
    integral of the normal velocity of the loop's nodes (exact for the node
    polygon; the area itself is that of the Hermite-densified polygon).
    ``progress(solves, note)``, if given, is called after every continuation
    step (the number of solves is not known in advance).
    """
    disc = Discretisation.from_arm(arm) if disc is None else disc
    if disc.n_tendons != 2:
        raise BoundaryError(
            f"boundary traces curves in a 2-D tension space: it needs exactly 2 tendons, this "
            f"arm has {disc.n_tendons} (with 3 or more the faces of the tension domain map to "
            "2-D patches of tip positions; use `workspace` to sample)")
    t0 = time.perf_counter()
    regions, polygons, areas, messages, gradients = {}, {}, {}, [], {}
    fold_crossings, fold_curves, scan, scan_solves = [], [], [], 0
    with CurveTracer(disc) as tracer:
        w0 = np.concatenate((disc.straight(), np.zeros(2)))
        wanted = (("W0", False), ("restricted", True)) if restricted else (("W0", False),)
        for name, extra in wanted:
            cons = constraints_for(tracer, arm, extra)
            walker = Walker(tracer, cons, progress=progress)
            try:
                region = walker.walk(name, w0, first=cons[1], previous=cons[0])
                if name == "W0" and tip_folds:
                    fold_crossings = tip_fold_crossings(region)
                    fold_curves = FoldTracer(walker).trace(region, fold_crossings)
                    before = tracer.solves
                    scan = scan_rays(walker, w0, fold_curves)
                    scan_solves = tracer.solves - before
                if route_gradients and region.closed:
                    gradients[name] = _area_gradient(walker, region, cons[1::-1],
                                                     route_gradients, arm.length_mm)
            finally:
                walker.destroy()
            regions[name] = region
            poly = loop_polygon(region, arm.length_mm)
            polygons[name] = [poly]
            areas[name] = union_area(poly)
            if not region.closed:
                messages.append(f"{name}: the walk around the region did not close: "
                                f"{region.message}")
            crossings = self_intersections(poly)
            if crossings:
                faces = (", plus the faces of winding number 0 covered twice (docs/model.md "
                         "§9.1)") if name == "W0" and tip_folds else ""
                messages.append(f"{name}: the loop's image crosses itself {crossings} times "
                                "(the tip map is not one-to-one on the region); the area is "
                                f"that of the set it winds around{faces}")
        solves, rejected = tracer.solves, tracer.rejected
    folds = np.array([x.tip for x in fold_crossings]).reshape(-1, 2) * arm.length_mm
    result = BoundaryResult(arm, regions, polygons, areas, folds, solves,
                            time.perf_counter() - t0, messages, gradients, fold_curves,
                            [curve_polyline(c, arm.length_mm) for c in fold_curves], fold_crossings,
                            cell_mm=arm.length_mm / 500, scan=scan, scan_solves=scan_solves,
                            rejected_steps=rejected)
    messages += [f"W0: tip-map fold not traced: {why} (no OUTSIDE_BOUNDARY verdicts)"
                 for why in result.untraced_folds]
    if tip_folds and regions["W0"].closed and not result.untraced_folds:
        _assemble_w0(result)
    result.seconds = time.perf_counter() - t0
    if progress is not None:
        progress(solves, "traced")
    return result


def _assemble_w0(result: BoundaryResult) -> None:
    """W_0's area from the faces (docs/model.md §9): the set the loop winds
    around, plus the faces of winding number 0 covered twice (N > 0);
    faces whose N is undecided widen ``area_bounds_mm2``."""
    result.faces = classify_faces(result)
    extra = sum(f["area_mm2"] for f in result.faces
                if f["winding"] == 0 and (f["preimages"] or 0) > 0)
    undecided = sum(f["area_mm2"] for f in result.faces
                    if f["winding"] == 0 and f["preimages"] is None)
    bad = [f for f in result.faces if f["preimages"] is not None
           and (f["preimages"] < abs(f["winding"]) or (f["preimages"] - f["winding"]) % 2)]
    lower = result.areas_mm2["W0"] + extra
    result.areas_mm2["W0"] = lower
    result.area_bounds_mm2 = (lower, lower + undecided)
    if undecided:
        result.messages.append(f"W0: {undecided:.0f} mm^2 of faces with winding number 0 are "
                               "undecided (every ray from them crosses a fold image)")
    if bad:
        result.messages.append(f"W0: {len(bad)} faces with a preimage count inconsistent with "
                               "their winding number (N >= |w|, N = w mod 2): check the loop")


def curve_polyline(curve: Curve, length_mm: float) -> np.ndarray:
    """Tip image of one curve in mm, Hermite-densified (:func:`hermite_densify`)."""
    tip = np.array([pt.tip for pt in curve.points])
    vel = np.array([pt.tip_velocity for pt in curve.points])
    if len(tip) < 3:
        return tip * length_mm
    return np.vstack((hermite_densify(tip[:-1], vel[:-1]), tip[-1:])) * length_mm


def winding_number(poly: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Winding number of the closed polygon around each point (Sunday's rule:
    an upward edge with the point on its left counts +1, a downward edge with
    the point on its right -1, each edge half-open in y).  Only the (edge,
    point) pairs whose y-ranges match are formed (points sorted by y)."""
    a, b = poly, np.roll(poly, -1, axis=0)
    points = np.atleast_2d(points)
    order = np.argsort(points[:, 1], kind="stable")
    ys = points[order, 1]
    first = np.searchsorted(ys, np.minimum(a[:, 1], b[:, 1]), side="left")
    count = np.searchsorted(ys, np.maximum(a[:, 1], b[:, 1]), side="left") - first
    edge = np.repeat(np.arange(len(a)), count)
    point = order[np.arange(len(edge)) - np.repeat(np.cumsum(count) - count - first, count)]
    a, b = a[edge], b[edge]
    x, y = points[point, 0], points[point, 1]
    cross = (b[:, 0] - a[:, 0]) * (y - a[:, 1]) - (x - a[:, 0]) * (b[:, 1] - a[:, 1])
    up = (a[:, 1] <= y) & (b[:, 1] > y) & (cross > 0)
    down = (a[:, 1] > y) & (b[:, 1] <= y) & (cross < 0)
    return np.bincount(point, weights=up.astype(float) - down, minlength=len(points)).astype(int)


def _inside(poly: np.ndarray, points: np.ndarray) -> np.ndarray:
    return winding_number(poly, points) != 0


def _distance_to_edges(poly: np.ndarray, points: np.ndarray) -> np.ndarray:
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    out = np.full(len(points), np.inf)
    for k in range(len(a)):
        denom = max(float(ab[k] @ ab[k]), 1e-300)
        t = np.clip((points - a[k]) @ ab[k] / denom, 0.0, 1.0)
        out = np.minimum(out, np.linalg.norm(points - (a[k] + t[:, None] * ab[k]), axis=1))
    return out


def clip_half_plane(poly: np.ndarray, y_min: float = 0.0) -> np.ndarray:
    """The part of a closed polygon with y >= y_min (Sutherland-Hodgman, one edge)."""
    out = []
    for k in range(len(poly)):
        a, b = poly[k], poly[(k + 1) % len(poly)]
        ina, inb = a[1] >= y_min, b[1] >= y_min
        if ina:
            out.append(a)
        if ina != inb:
            t = (y_min - a[1]) / (b[1] - a[1])
            out.append(a + t * (b - a))
    return np.array(out).reshape(-1, 2)


def compare_restricted(poly_mm: np.ndarray, targets_mm: np.ndarray, masks: dict,
                       spacing_mm: float) -> dict:
    """Agreement of the restricted polygon with a sampled map's masks (Eqs. (18)-(22)):
    samples in W0 ∩ WY ∩ WS ∩ WE ∩ WP outside it by more than one spacing, and
    reached samples failing a restriction inside it by more than one spacing."""
    admissible = masks["W0"] & masks["WY"] & masks["WS"] & masks["WE"] & masks["WP"]
    failing = masks["W0"] & ~admissible
    inside = _inside(poly_mm, targets_mm)
    far = _distance_to_edges(poly_mm, targets_mm) > spacing_mm
    return {"admissible": int(admissible.sum()),
            "admissible_outside": int(np.sum(admissible & ~inside & far)),
            "reached_inadmissible": int(failing.sum()),
            "reached_inadmissible_inside": int(np.sum(failing & inside & far))}


def compare_with_samples(poly_mm: np.ndarray, targets_mm: np.ndarray, status: np.ndarray,
                         spacing_mm: float, inside: np.ndarray | None = None,
                         distance: np.ndarray | None = None) -> dict:
    """Agreement of a W_0 polygon with a sampled target map (Fig. 4, y >= 0).

    status: 1 reached, 2 needs a negative tension, 3 not converged
    (:mod:`elastica_petsc.studies.workspace`).  Counts reached samples outside
    the polygon by more than one spacing, needing-negative samples inside by
    more than one spacing, and, for the map of Fig. 4 (the half-disc y >= 0
    within reach), compares the polygon's area in y >= 0 with
    the sample count estimate (row y = 0 counts half a cell) and its
    sampling error, taken as half a cell per unit length of boundary.
    ``inside``: membership of the targets in W_0 if not the polygon's winding
    rule (:meth:`BoundaryResult.contains`); ``distance``: their distance (mm)
    to the boundary if not to the polygon's edges (e.g. folds included).
    """
    inside = _inside(poly_mm, targets_mm) if inside is None else inside
    distance = _distance_to_edges(poly_mm, targets_mm) if distance is None else distance
    far = distance > spacing_mm
    reached, negative = status == 1, status == 2
    out = {
        "reached": int(reached.sum()),
        "reached_outside": int(np.sum(reached & ~inside & far)),
        "needs_negative": int(negative.sum()),
        "needs_negative_inside": int(np.sum(negative & inside & far)),
        "not_converged_inside": int(np.sum((status == 3) & inside)),
    }
    reach = np.max(np.abs(targets_mm))
    half_disc = (np.min(targets_mm[:, 1]) == 0.0
                 and np.ptp(targets_mm[:, 0]) >= 2 * (reach - spacing_mm))
    if not half_disc:                    # e.g. a --box map: no area comparison
        return out
    clipped = clip_half_plane(poly_mm)
    weight = np.where(np.isclose(targets_mm[:, 1], 0.0), 0.5, 1.0)
    estimate = float(np.sum(weight[reached])) * spacing_mm**2
    perimeter = float(np.sum(np.linalg.norm(np.diff(np.vstack((clipped, clipped[:1])), axis=0),
                                            axis=1)))
    return out | {
        "area_y_ge_0_mm2": union_area(clipped) if len(clipped) > 2 else 0.0,
        "sample_area_mm2": estimate,
        "sampling_error_mm2": 0.5 * spacing_mm * perimeter,
    }


_TRACED: dict = {}          # W_0 boundary per arm and mesh, in-process (traced_w0)


def traced_w0(arm: Arm, disc: Discretisation) -> BoundaryResult:
    """The W_0 boundary of a two-tendon arm (no restricted level curves),
    traced on the first call and kept per arm and mesh for the process: the
    one trace that tip control's proof and the sampled map share."""
    key = (arm.length_mm, disc.n_elements, disc.attach_nodes, np.asarray(disc.routes).tobytes(),
           arm.max_tension)
    if key not in _TRACED:
        _TRACED[key] = trace_boundary(arm, disc, restricted=False)
    return _TRACED[key]


def boundary_proof(arm: Arm, disc: Discretisation | None = None):
    """A callable for :class:`~elastica_petsc.solvers.reach.Reacher`'s ``boundary``:
    target (units of l) -> (evidence, distance in units of l), from
    :meth:`BoundaryResult.outside` on :func:`traced_w0` (traced on the first
    call); arms with other than two tendons give no evidence ('')."""
    disc = Discretisation.from_arm(arm) if disc is None else disc

    def outside(target: np.ndarray) -> tuple[str, float]:
        if disc.n_tendons != 2:
            return "", float("nan")
        evidence, dist = traced_w0(arm, disc).outside(np.asarray(target, float) * arm.length_mm)
        return evidence, dist / arm.length_mm

    return outside


def compare_map(result: BoundaryResult, targets_mm: np.ndarray, status: np.ndarray,
                spacing_mm: float) -> dict:
    """:func:`compare_with_samples` for W_0 as assembled (faces and folds):
    membership by :meth:`BoundaryResult.contains`, distances to the loop's and
    the fold curves' images."""
    inside = result.contains(targets_mm) if result.faces else None
    distance = (result.outside_map.distance(targets_mm) if result.fold_polylines_mm else None)
    return compare_with_samples(result.polygons_mm["W0"][0], targets_mm, status, spacing_mm,
                                inside=inside, distance=distance)
