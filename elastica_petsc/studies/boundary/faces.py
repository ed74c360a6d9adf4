"""The faces of the plane minus the traced curves' images: the loop's tip image
as a polygon (:func:`loop_polygon`), the unbounded component on a grid
(:class:`OutsideMap`), and each bounded face's preimage count
(:func:`preimage_counts`, :func:`classify_faces`), docs/model.md §9.1."""
from __future__ import annotations

import numpy as np

from ...core.geometry import (hermite_densify, monotone_slopes, ray_hits, segments_distance,
                              winding_number)
from ...solvers.continuation import Curve
from .walker import RegionBoundary


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
            out = np.minimum(out, segments_distance(a, b, pts))
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
        if len(fa) and ray_hits(y, d, fa, fb).any(axis=1).all():
            continue
        blocked = ray_hits(y, d, fa, fb).any(axis=1) if len(fa) else np.zeros(len(y), bool)
        hits = ray_hits(y, d, a, b)                                 # (points, edges)
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


def loop_polygon(region: RegionBoundary, length_mm: float, per_segment: int = 8,
                 node_values: np.ndarray | None = None, monotone: bool = False):
    """The tip image of the loop, densified per curve by :func:`hermite_densify`
    (every piece, the one into the corner at a curve's end too: the corner
    carries its curve's tangent, ``Walker._corner_tangent``), in mm (closing
    point dropped).  With ``node_values`` (one row per node, in the order of
    :meth:`RegionBoundary.nodes`) also returns them interpolated at the dense
    points: linearly in the Hermite parameter, or with ``monotone`` by cubic
    Hermite interpolation along each curve's chord lengths with
    :func:`monotone_slopes` (docs/model.md §26.2)."""
    pieces, values, start = [], [], 0
    for curve in region.curves:
        tip = np.array([pt.tip for pt in curve.points])
        vel = np.array([pt.tip_velocity for pt in curve.points])
        dense, (seg, s) = hermite_densify(tip, vel, per_segment, parameters=True)
        pieces.append(dense)
        if node_values is not None:
            nv = node_values[start:start + len(tip)]
            values.append(_interpolate(nv, tip, seg, s, monotone))
        start += len(tip)
    poly = np.vstack(pieces) * length_mm
    keep = np.concatenate(([True], np.linalg.norm(np.diff(poly, axis=0), axis=1) > 1e-9))
    if np.linalg.norm(poly[keep][0] - poly[keep][-1]) < 1e-9:
        keep[np.flatnonzero(keep)[-1]] = False
    if node_values is None:
        return poly[keep]
    return poly[keep], np.concatenate(values)[keep]


def _interpolate(nv: np.ndarray, tip: np.ndarray, seg: np.ndarray, s: np.ndarray,
                 monotone: bool) -> np.ndarray:
    """Node values ``nv`` of one curve at the dense points (segment ``seg``,
    Hermite parameter ``s``): linear in s, or monotone cubic Hermite in the
    chord length (:func:`monotone_slopes`)."""
    nxt = np.minimum(seg + 1, len(nv) - 1)
    sh = s.reshape((-1,) + (1,) * (nv.ndim - 1))
    if not monotone or len(nv) < 2:
        return nv[seg] + sh * (nv[nxt] - nv[seg])
    lengths = np.linalg.norm(np.diff(tip, axis=0), axis=1)
    m = monotone_slopes(nv, lengths)
    L = lengths[np.minimum(seg, len(lengths) - 1)].reshape(sh.shape)
    h00, h10 = 2 * sh**3 - 3 * sh**2 + 1, sh**3 - 2 * sh**2 + sh
    h01, h11 = -2 * sh**3 + 3 * sh**2, sh**3 - sh**2
    return h00 * nv[seg] + h10 * L * m[seg] + h01 * nv[nxt] + h11 * L * m[nxt]


def curve_polyline(curve: Curve, length_mm: float) -> np.ndarray:
    """Tip image of one curve in mm, Hermite-densified (:func:`hermite_densify`)."""
    tip = np.array([pt.tip for pt in curve.points])
    vel = np.array([pt.tip_velocity for pt in curve.points])
    return hermite_densify(tip, vel) * length_mm
