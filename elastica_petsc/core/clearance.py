"""Cables clear of the arm: does a cable's straight segment cross the arm?

The model (docs/model.md §1, Eqs. (3)-(4)) routes cable i in a straight line
from its attachment point x_i = x(s_i) to the fixed routing point r_i and
ignores contact: nothing stops that segment from passing through the arm
(e.g. tendon 2 in the paper's state 3 at p = (25.2, 10.8), order 1,2, as
drawn by ``equilibria``).  Such a state is not physical for a real cable.

:func:`cable_clear` tests each cable segment [x_i, r_i] against every
segment of the arm's centreline polyline (the FE nodes, Eq. (2)) except the
one or two elements that end at the attachment node itself (the cable starts
there).  Two segments cross when each one's end points lie strictly on
opposite sides of the other's line, or when they touch within ``tol``
(units of l).  Numpy only, O(N n).
"""
from __future__ import annotations

import numpy as np


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z of (a - o) x (b - o), broadcast over rows."""
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - \
        (a[..., 1] - o[..., 1]) * (b[..., 0] - o[..., 0])


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(np.einsum("...i,...i->...", p - a, ab) / np.maximum(
        np.einsum("...i,...i->...", ab, ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(a + t[..., None] * ab - p, axis=-1)


def segment_hits(c0: np.ndarray, c1: np.ndarray, a: np.ndarray, b: np.ndarray,
                 tol: float = 0.0) -> np.ndarray:
    """For one segment [c0, c1] against segments [a_k, b_k] (arrays (m, 2)):
    True where they cross or come closer than ``tol``."""
    d1, d2 = _cross(a, b, c0[None, :]), _cross(a, b, c1[None, :])
    d3, d4 = _cross(c0[None, :], c1[None, :], a), _cross(c0[None, :], c1[None, :], b)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    if tol <= 0:
        return proper
    near = np.minimum.reduce([
        _point_segment_distance(c0[None, :], a, b), _point_segment_distance(c1[None, :], a, b),
        _point_segment_distance(a, c0[None, :], c1[None, :]),
        _point_segment_distance(b, c0[None, :], c1[None, :])])
    return proper | (near < tol)


def cable_clear(nodes: np.ndarray, attach_nodes, routes: np.ndarray,
                tol: float = 0.0) -> np.ndarray:
    """(n,) bool: cable i's segment [x_i, r_i] does not cross the arm.

    nodes : (N+1, 2) centreline nodes (any length unit; ``tol`` in the same).
    attach_nodes : node index of each attachment.
    routes : (n, 2) routing points r_i.
    The elements ending at the attachment node are not tested (the cable
    starts on them)."""
    nodes = np.asarray(nodes, float)
    routes = np.asarray(routes, float)
    a, b = nodes[:-1], nodes[1:]
    out = np.ones(len(routes), dtype=bool)
    for i, (k, r) in enumerate(zip(attach_nodes, routes)):
        keep = np.ones(len(a), dtype=bool)
        keep[max(k - 1, 0):k + 1] = False          # elements k-1 and k share node k
        hits = segment_hits(nodes[k], r, a[keep], b[keep], tol)
        out[i] = not np.any(hits)
    return out


def crossing_elements(nodes: np.ndarray, attach_node: int, route: np.ndarray) -> np.ndarray:
    """Indices of the elements crossed by the cable from node ``attach_node`` to
    ``route`` (for messages and figures)."""
    nodes = np.asarray(nodes, float)
    a, b = nodes[:-1], nodes[1:]
    hits = segment_hits(nodes[attach_node], np.asarray(route, float), a, b)
    hits[max(attach_node - 1, 0):attach_node + 1] = False
    return np.flatnonzero(hits)


def path_clear(nodes: np.ndarray, paths) -> np.ndarray:
    """(n,) bool: no straight segment of cable i's path crosses the arm
    (cables through guides, docs/model.md §11).

    paths : per cable, (points (k+1, 2) from the routing point to the end,
    node of each point or -1 for the routing point, offset of each point).
    A point on the centreline (offset 0) starts on the elements that end at
    its node: those are not tested for the segments that touch it."""
    nodes = np.asarray(nodes, float)
    a, b = nodes[:-1], nodes[1:]
    out = np.ones(len(paths), dtype=bool)
    for i, (points, point_nodes, offsets) in enumerate(paths):
        for j in range(1, len(points)):
            keep = np.ones(len(a), dtype=bool)
            for k, off in ((point_nodes[j - 1], offsets[j - 1]), (point_nodes[j], offsets[j])):
                if k >= 0 and off == 0.0:
                    keep[max(k - 1, 0):k + 1] = False
            if np.any(segment_hits(points[j - 1], points[j], a[keep], b[keep])):
                out[i] = False
                break
    return out


def state_cable_clear(eq) -> np.ndarray:
    """:func:`cable_clear` of a solved state (an ``Equilibrium``: its nodes,
    attachment nodes and routing points, units of l); every segment of a
    cable through guides (:func:`path_clear`)."""
    disc = eq.disc
    if not disc.has_paths:
        return cable_clear(eq.x, disc.attach_nodes, disc.routes)
    starts = disc.path_starts
    paths = [(points, [-1] + list(disc.point_nodes[starts[i]:starts[i + 1]]),
              [1.0] + list(disc.point_offsets[starts[i]:starts[i + 1]]))
             for i, points in enumerate(eq.cable_points)]
    return path_clear(eq.x, paths)
