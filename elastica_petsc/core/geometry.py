"""Plane polygon geometry in NumPy: areas, winding, clipping, intersections.

One home for the geometry that the workspace boundary (studies/boundary) and
the area objective of ``design`` (studies/design_area) share.  A polygon is
an (n, 2) array of vertices, closed implicitly (the last vertex joins the
first).  Two areas of a set are here, for two kinds of input:
:func:`union_area` is the area where a closed polygon's winding number is
nonzero (exact up to its scan lines: the boundary's loop, which may cross
itself); :func:`triangles_union_area` is the area of a union of triangles
counted on a square lattice (the re-sampled image of a tension grid).
"""
from __future__ import annotations

import numpy as np


def shoelace(poly: np.ndarray) -> float:
    """Signed area of a closed polygon (positive: counter-clockwise)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def shoelace_normals(loop: np.ndarray) -> np.ndarray:
    """d(signed shoelace)/d x_k, (K, 2): half the chord across node k turned by
    -90 degrees, the discrete outward normal times the node's share of length."""
    nxt, prv = np.roll(loop, -1, axis=0), np.roll(loop, 1, axis=0)
    return 0.5 * np.column_stack((nxt[:, 1] - prv[:, 1], prv[:, 0] - nxt[:, 0]))


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


def inside_polygon(poly: np.ndarray, points: np.ndarray) -> np.ndarray:
    """True where the closed polygon winds around the point (nonzero rule)."""
    return winding_number(poly, points) != 0


def distance_to_edges(poly: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest edge of the closed polygon."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    out = np.full(len(points), np.inf)
    for k in range(len(a)):
        denom = max(float(ab[k] @ ab[k]), 1e-300)
        t = np.clip((points - a[k]) @ ab[k] / denom, 0.0, 1.0)
        out = np.minimum(out, np.linalg.norm(points - (a[k] + t[:, None] * ab[k]), axis=1))
    return out


def polyline_distance(line: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest segment of the open polyline
    ``line`` (k, 2)."""
    return segments_distance(line[:-1], line[1:], points)


def segments_distance(a: np.ndarray, b: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest of the segments a_k b_k, all at once."""
    ab = b - a
    denom = np.maximum(np.einsum("kc,kc->k", ab, ab), 1e-300)
    t = np.clip(((points[:, None, :] - a[None]) * ab[None]).sum(-1) / denom, 0.0, 1.0)
    near = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - near, axis=-1).min(axis=1)


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


def segments_cross(a: np.ndarray, b: np.ndarray, polyline: np.ndarray) -> bool:
    """The segment [a, b] crosses the polyline (or touches it at a vertex)."""
    if len(polyline) < 2:
        return False
    p, q = polyline[:-1], polyline[1:]

    def orient(u, v, w):
        return np.sign((v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1])
                       - (v[..., 1] - u[..., 1]) * (w[..., 0] - u[..., 0]))

    return bool(np.any((orient(a, b, p) * orient(a, b, q) <= 0)
                       & (orient(p, q, a) * orient(p, q, b) <= 0)))


def ray_hits(points: np.ndarray, d: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
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


def hermite_densify(tip, velocity, per_segment: int = 8, parameters: bool = False):
    """Cubic Hermite curve through the nodes with their tip velocities d x_t/ds
    (per unit of the curve's arclength parameter), ``per_segment`` points each
    (a segment with a zero chord or velocity keeps only its end node).  With
    ``parameters`` also returns, per dense point, its segment k and its
    Hermite parameter s in [0, 1] (the point is node k at s = 0, node k + 1
    at s = 1), to interpolate values given at the nodes."""
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
    dense = np.vstack((tip[:1], curve[keep]))
    if not parameters:
        return dense
    segment = np.broadcast_to(np.arange(len(a))[:, None], keep.shape)[keep]
    param = np.broadcast_to(s[:, 0][None], keep.shape)[keep]
    return dense, (np.concatenate(([0], segment)), np.concatenate(([0.0], param)))


def monotone_slopes(values: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Slopes d values/d s at the nodes of a polyline whose segments have the
    ``lengths`` (s: its length parameter), per component of ``values`` (nodes,
    ...): the weighted harmonic mean of the two neighbouring secants
    (Fritsch-Butland, as in PCHIP), 0 where they differ in sign (a node at an
    extremum), the one secant at the ends.  A cubic Hermite interpolant with
    these slopes is monotone between nodes: it does not overshoot where
    values change steeply (near a cable collapse or the fold of M)."""
    values = np.asarray(values, float)
    out = np.zeros_like(values)
    if len(values) < 2:
        return out
    shape = (-1,) + (1,) * (values.ndim - 1)
    L = np.asarray(lengths, float).reshape(shape)
    d = np.divide(np.diff(values, axis=0), L, out=np.zeros_like(values[1:]), where=L > 0)
    out[0], out[-1] = d[0], d[-1]
    a, b = d[:-1], d[1:]
    w1, w2 = 2 * L[1:] + L[:-1], L[1:] + 2 * L[:-1]
    ok = a * b > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        harmonic = (w1 + w2) / (w1 / np.where(ok, a, 1.0) + w2 / np.where(ok, b, 1.0))
    out[1:-1] = np.where(ok, harmonic, 0.0)
    return out


def triangles_union_area(triangles: np.ndarray, h: float) -> float:
    """Area (mm^2) of the union of triangles, counted on a square lattice of
    spacing ``h`` mm (a point counts once however many triangles hold it)."""
    if len(triangles) == 0:
        return 0.0
    lo = triangles.reshape(-1, 2).min(axis=0)
    hi = triangles.reshape(-1, 2).max(axis=0)
    shape = np.ceil((hi - lo) / h).astype(int) + 1
    covered = np.zeros(shape, bool)
    for tri in triangles:
        i0, j0 = np.floor((tri.min(axis=0) - lo) / h).astype(int)
        i1, j1 = np.ceil((tri.max(axis=0) - lo) / h).astype(int) + 1
        gx, gy = np.meshgrid(lo[0] + h * np.arange(i0, i1), lo[1] + h * np.arange(j0, j1),
                             indexing="ij")
        covered[i0:i1, j0:j1] |= _inside_triangle(tri, gx, gy)
    return float(covered.sum()) * h * h


def _inside_triangle(tri: np.ndarray, gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    (x0, y0), (x1, y1), (x2, y2) = tri
    det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if det == 0.0:
        return np.zeros(gx.shape, bool)
    l1 = ((gx - x0) * (y2 - y0) - (x2 - x0) * (gy - y0)) / det
    l2 = ((x1 - x0) * (gy - y0) - (gx - x0) * (y1 - y0)) / det
    return (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
