"""Kernels for cables through guides, offset end points and the arm's weight
(docs/model.md §11).  Numpy only, non-dimensional (l = 1, B = 1).

Each tendon i is a path of points: its fixed routing point r_i (the motor
end), then its guides and finally its end point, the last two on the arm:
point a sits at node m_a with offset delta_a along the left normal
n(theta_m) = (-sin theta_m, cos theta_m):

    X_a(theta) = x_{m_a}(theta) + delta_a n(theta_{m_a})

The cable is straight between consecutive points, so its length is the sum
of its segments and the potential of its tension is p_i L_i.  The weight of
the arm and of a tip mass is a dead load with potential -sum_k w_k g.x_k
(nodal trapezoid weights w_k), which puts the force G_e = q (1 - s_e) + q_tip
on element e (s_e its midpoint).  The total potential

    Pi = sum_e (theta_{e+1} - theta_e)^2/(2h) + sum_i p_i L_i(X(theta)) - sum_k w_k g.x_k

is the paper's for one point per tendon at zero offset without weight.  Each
cable segment carries its chord z_a = X_{a-1} - X_a (X_0 = r_i) as a border
unknown, u = (theta_1..theta_N, z_1..z_P).  The chord depends only on the angles
between its two points, so every border row and column is local (rows between
m_{a-1} and m_a); the Schur complement of the Jacobian on z is the Hessian of Pi
(docs/model.md §11.3).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np
from scipy.linalg import solve_banded

from .fem import Discretisation, DiscretisationError
from .model import Arm


class PathTerms(NamedTuple):
    """Quantities of a state (u, p) shared by the residual and its derivatives."""

    theta: np.ndarray        # nodal angles, theta_0 = 0 included
    y: np.ndarray            # chord unknowns z_a = X_{a-1} - X_a (P, 2)
    seg_len: np.ndarray      # length of segment a, from point a back to its predecessor
    e: np.ndarray            # unit vector of segment a, from point a to its predecessor
    point_force: np.ndarray  # f_a = p_i (e_a - e_{a+1}): the cable's pull on point a
    c: np.ndarray            # cos phi_e
    s: np.ndarray            # sin phi_e
    p: np.ndarray            # tension of each tendon
    force: np.ndarray        # sum of the forces acting beyond each element (N, 2)
    moment: np.ndarray       # delta_a f_a . t(theta_m): the offsets' moments (residual's sign)
    moment_slope: np.ndarray  # its derivative in theta_m: delta_a f_a . n(theta_m)
    node_cs: tuple           # cos, sin of theta at the points' nodes
    p_seg: np.ndarray        # tension of each segment (the tendon's, or per segment: friction)


def on_node(s: float, n: int, what: str, length_mm: float) -> int:
    """The node of arc length ``s`` (units of l) on the n-element mesh, or refuse."""
    k = int(round(s * n))
    if abs(k - s * n) > 1e-9 * n:
        h_mm = length_mm / n
        raise DiscretisationError(
            f"{what} s = {s * length_mm:g} mm is not on a node of the {n}-element mesh "
            f"(spacing {h_mm:g} mm); choose an element count that makes s / l * N an "
            f"integer (nearest node: {k * h_mm:g} mm)")
    return k


@dataclass(frozen=True)
class GuidedDiscretisation(Discretisation):
    """:class:`Discretisation` with cables through guides, offsets and weight."""

    point_nodes: tuple[int, ...] = ()          # m_a of every arm point, tendon by tendon
    point_offsets: np.ndarray = field(default_factory=lambda: np.zeros(0))
    path_starts: tuple[int, ...] = ()          # tendon i owns points path_starts[i]:[i+1]
    gravity: np.ndarray = field(default_factory=lambda: np.zeros(2))      # rho_A g l^3/B
    tip_weight: np.ndarray = field(default_factory=lambda: np.zeros(2))   # m_tip g l^2/B

    has_paths = True

    @classmethod
    def from_arm(cls, arm: Arm, n_elements: int | None = None) -> "GuidedDiscretisation":
        n = arm.elements if n_elements is None else n_elements
        if n < 2:
            raise DiscretisationError(f"need at least 2 elements, got {n}")
        nodes, offsets, starts, attach = [], [], [0], []
        for i, t in enumerate(arm.tendons, start=1):
            for j, g in enumerate(t.guides, start=1):
                nodes.append(on_node(g.s_mm / arm.length_mm, n, f"tendon {i}: guide {j} at",
                                     arm.length_mm))
                offsets.append(g.offset_mm / arm.length_mm)
            attach.append(on_node(t.attach_mm / arm.length_mm, n, f"tendon {i}: attachment",
                                  arm.length_mm))
            nodes.append(attach[-1])
            offsets.append(t.attach_offset_mm / arm.length_mm)
            starts.append(len(nodes))
        return cls(n, tuple(attach), arm.routes(), tuple(nodes), np.array(offsets),
                   tuple(starts), arm.gravity_load(), arm.tip_weight())

    # --- layout ------------------------------------------------------------------------
    @property
    def n_points(self) -> int:
        return len(self.point_nodes)

    @property
    def size(self) -> int:
        return self.n_elements + 2 * self.n_points

    @property
    def stability_border(self) -> int:
        """Border columns of H: one per cable segment (docs/model.md §11)."""
        return self.n_points

    @cached_property
    def point_tendon(self) -> np.ndarray:
        """Tendon index of each arm point."""
        return np.repeat(np.arange(self.n_tendons), np.diff(self.path_starts))

    @cached_property
    def first_point(self) -> np.ndarray:
        """True where a point follows the routing point (its segment starts at r_i)."""
        out = np.zeros(self.n_points, bool)
        out[list(self.path_starts[:-1])] = True
        return out

    @cached_property
    def last_point(self) -> np.ndarray:
        """True at each tendon's end point (no segment beyond it)."""
        out = np.zeros(self.n_points, bool)
        out[np.asarray(self.path_starts[1:]) - 1] = True
        return out

    @cached_property
    def previous_node(self) -> np.ndarray:
        """Node of each point's predecessor (1 for a routing point: G_0 = 0)."""
        m = np.asarray(self.point_nodes)
        prev = np.ones_like(m)
        inner = np.flatnonzero(~self.first_point)
        prev[inner] = m[inner - 1]
        return prev

    @cached_property
    def segment_range(self) -> tuple[np.ndarray, np.ndarray]:
        """Angle rows [lo, hi) of D_a = G_a - G_{a-1}: the nodes from m_{a-1} to m_a."""
        m = np.asarray(self.point_nodes)
        return np.minimum(m, self.previous_node) - 1, np.maximum(m, self.previous_node)

    @cached_property
    def pattern(self):
        """Two local border columns and rows per chord z_a (rows of D_a)."""
        lo, hi = self.segment_range
        return self.bordered_pattern(np.repeat(hi, 2), starts=np.repeat(lo, 2))

    @property
    def stability_pattern_supports(self) -> np.ndarray:
        return self.segment_range[1]

    @property
    def stability_pattern_starts(self) -> np.ndarray:
        return self.segment_range[0]

    @cached_property
    def _inner(self) -> np.ndarray:
        """Points that follow another arm point (not the routing point)."""
        return np.flatnonzero(~self.first_point)

    @cached_property
    def entries(self):
        """The stored rows of every D_a = G_a - G_{a-1} (docs/model.md §11.3), flat:
        (chord a, angle row k-1, weight of n_{k-1}, weight of n_k, element k clipped)
        with the weights [k-1 < m_a] - [k-1 < m_{a-1}] and [k < m_a] - [k < m_{a-1}]
        of the midpoint rule; plus, per chord, the entry of row m_a (offset -delta_a)
        and of row m_{a-1} (offset +delta_{a-1}, inner chords only)."""
        lo, hi = self.segment_range
        chord = np.repeat(np.arange(self.n_points), hi - lo)
        rows = np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)])
        k = rows + 1
        m = np.asarray(self.point_nodes)[chord]
        mp = np.where(self.first_point[chord], 0, self.previous_node[chord])
        w_left = (k - 1 < m).astype(float) - (k - 1 < mp)
        w_right = (k < m).astype(float) - (k < mp)
        start = np.concatenate(([0], np.cumsum(hi - lo)[:-1]))
        own = start + np.asarray(self.point_nodes) - 1 - lo
        inner = self._inner
        prev = start[inner] + self.previous_node[inner] - 1 - lo[inner]
        return (chord, rows, w_left, w_right, np.minimum(k, self.n_elements - 1), own, prev)

    @cached_property
    def _deposit(self) -> np.ndarray:
        """Element m_a - 1 of each point: its force acts on the elements before it."""
        return np.asarray(self.point_nodes) - 1

    @cached_property
    def element_weight(self) -> np.ndarray:
        """G_e = q (1 - s_e) + q_tip: the weight beyond element e's midpoint (N, 2)."""
        mid = (np.arange(self.n_elements) + 0.5) * self.h
        return (1.0 - mid)[:, None] * self.gravity[None] + self.tip_weight[None]

    # --- geometry -------------------------------------------------------------------------
    def point_positions(self, theta: np.ndarray, cs=None, node_cs=None) -> np.ndarray:
        """X_a = x_{m_a} + delta_a n(theta_{m_a}), shape (P, 2); ``cs``, ``node_cs``:
        cos, sin of the element angles and of theta at the points' nodes if known."""
        m = self._deposit + 1
        c, s = self.trig(theta) if cs is None else cs
        cm, sm = (np.cos(theta[m]), np.sin(theta[m])) if node_cs is None else node_cs
        out = np.empty((self.n_points, 2))
        out[:, 0] = self.h * np.cumsum(c)[m - 1] - self.point_offsets * sm
        out[:, 1] = self.h * np.cumsum(s)[m - 1] + self.point_offsets * cm
        return out

    def attachment_points(self, theta: np.ndarray) -> np.ndarray:
        return self.point_positions(theta)[np.asarray(self.path_starts[1:]) - 1]

    def chords(self, points: np.ndarray) -> np.ndarray:
        """z_a = X_{a-1} - X_a (X_0 = r_i) of the arm points' positions (P, 2)."""
        prev = self.routes[self.point_tendon].copy()
        prev[self._inner] = points[self._inner - 1]
        return prev - points

    def consistent_state(self, theta: np.ndarray) -> np.ndarray:
        return self.join(theta, self.chords(self.point_positions(theta)))

    def segment_gradients(self, theta: np.ndarray, cs=None) -> np.ndarray:
        """The stored entries of D_a = G_a - G_{a-1}, (M, 2) (:attr:`entries`), with
        G_a = dX_a/dtheta: the midpoint rule plus the turning offset -delta_a t(theta_m)."""
        chord, rows, w_left, w_right, right, own, prev = self.entries
        c, s = self.trig(theta) if cs is None else cs
        half = 0.5 * self.h
        d = np.empty((len(rows), 2))
        d[:, 0] = -half * (w_left * s[rows] + w_right * s[right])
        d[:, 1] = half * (w_left * c[rows] + w_right * c[right])
        m = np.asarray(self.point_nodes)
        turn = self.point_offsets[:, None] * np.column_stack((np.cos(theta[m]), np.sin(theta[m])))
        d[own] -= turn
        d[prev] += turn[self._inner - 1]
        return d

    def segments(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Length and unit vector (point a to its predecessor) of every segment."""
        lengths = np.sqrt(z[:, 0] ** 2 + z[:, 1] ** 2)
        return lengths, z / lengths[:, None]

    def cables(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whole-path lengths L_i and the unit direction of each tendon's last
        segment (from its end point toward the previous point)."""
        lengths, e = self.segments(y)
        ends = np.asarray(self.path_starts[1:]) - 1
        return np.add.reduceat(lengths, list(self.path_starts[:-1])), e[ends]

    def shortest_segments(self, y: np.ndarray) -> np.ndarray:
        """The shortest segment of each tendon (a cable collapses segment by segment)."""
        return np.minimum.reduceat(self.segments(y)[0], list(self.path_starts[:-1]))

    def cable_lengths_of(self, theta: np.ndarray) -> np.ndarray:
        return self.cables(self.chords(self.point_positions(theta)))[0]

    def point_table(self, theta: np.ndarray, p) -> dict:
        """Per arm point a (guides, then the end point, tendon by tendon), units of
        l: ``tendon`` (0-based), ``is_end``, ``s``, ``offset``, ``position`` X_a (P, 2),
        ``segment_length`` (from a back to its predecessor), ``wrap_angle`` (the
        angle the cable turns through at a guide, atan2(|e_a x e_a+1|, e_a . e_a+1);
        NaN at a cable's end) and ``force`` f_a = p (e_a - e_{a+1}) on the arm
        (units of B/l^2; docs/model.md §11)."""
        t = self._terms(self.consistent_state(theta), p)
        nxt = np.roll(t.e, -1, axis=0)
        wrap = np.arctan2(np.abs(t.e[:, 0] * nxt[:, 1] - t.e[:, 1] * nxt[:, 0]),
                          np.sum(t.e * nxt, axis=1))
        wrap[self.last_point] = np.nan
        return {"tendon": self.point_tendon.copy(), "is_end": self.last_point.copy(),
                "s": np.asarray(self.point_nodes) * self.h, "offset": self.point_offsets.copy(),
                "position": self.point_positions(theta), "segment_length": t.seg_len,
                "wrap_angle": wrap, "force": t.point_force}

    def potential(self, theta: np.ndarray, p, tip_moment: float = 0.0) -> float:
        """Pi of docs/model.md §11 (weight: trapezoid nodal masses, tip mass at the tip)."""
        lengths = self.cable_lengths_of(theta)
        x = self.node_positions(theta)
        weights = np.full(self.n_elements + 1, self.h)
        weights[0] = weights[-1] = 0.5 * self.h
        weight = -np.sum(weights * (x @ self.gravity)) - x[-1] @ self.tip_weight
        return (self.strain_energy(theta) + float(np.dot(p, lengths)) + weight
                - tip_moment * theta[-1])

    # --- residual and tangent ----------------------------------------------------------------
    def terms(self, u: np.ndarray, p) -> PathTerms:
        """The shared quantities of (u, p); the last state's are kept (the residual,
        the Jacobian and the inertia count ask at the same state)."""
        key = (np.asarray(u, float).tobytes(), np.asarray(p, float).tobytes())
        cached = self.__dict__.get("_last_terms")
        if cached is not None and cached[0] == key:
            return cached[1]
        t = self._terms(u, p)
        self.__dict__["_last_terms"] = (key, t)
        return t

    def segment_terms(self, u: np.ndarray, p_seg) -> PathTerms:
        """The terms of (u, p) with a tension per segment ``p_seg`` (P,) instead of one
        per tendon (capstan friction at the guides, core/friction.py, docs/model.md §27):
        f_a = P_a e_a - P_{a+1} e_{a+1}; ``p`` of the terms is then undefined (NaN)."""
        return self._terms(u, np.full(self.n_tendons, np.nan), np.asarray(p_seg, float))

    def _terms(self, u: np.ndarray, p, p_seg=None) -> PathTerms:
        theta, y = self.split(u)
        y = y.copy()                       # kept with the terms: not a view of u
        seg_len, e = self.segments(y)
        p = np.asarray(p, float)
        p_seg = p[self.point_tendon] if p_seg is None else p_seg
        pull = p_seg[:, None] * e
        f = pull.copy()
        f[self._inner - 1] -= pull[self._inner]             # f_a = P_a e_a - P_{a+1} e_{a+1}
        c, s = self.trig(theta)
        # F_e = sum of f_a over the points beyond element e: reverse cumulative sums
        force = np.empty((self.n_elements, 2))
        for j in range(2):
            force[:, j] = np.bincount(self._deposit, f[:, j], self.n_elements)[::-1].cumsum()[::-1]
        force += self.element_weight
        # the offsets' moments at rows m_a - 1 and their derivatives (docs/model.md §11.2)
        m = self._deposit + 1
        cm, sm = np.cos(theta[m]), np.sin(theta[m])
        moment = np.bincount(self._deposit, self.point_offsets * (f[:, 0] * cm + f[:, 1] * sm),
                             self.n_elements)
        slope = np.bincount(self._deposit, self.point_offsets * (f[:, 1] * cm - f[:, 0] * sm),
                            self.n_elements)
        return PathTerms(theta, y, seg_len, e, f, c, s, p, force, moment, slope, (cm, sm), p_seg)

    def residual(self, u: np.ndarray, p, tip_moment: float = 0.0,
                 terms: PathTerms | None = None) -> np.ndarray:
        t = self.terms(u, p) if terms is None else terms
        q = 0.5 * self.h * (t.c * t.force[:, 1] - t.s * t.force[:, 0])   # (h/2) n_e . F_e
        jump = np.diff(t.theta)
        f_theta = (jump - np.append(jump[1:], 0.0)) / self.h
        f_theta -= q
        f_theta[:-1] -= q[1:]
        f_theta[-1] -= tip_moment
        f_theta += t.moment
        points = self.point_positions(t.theta, (t.c, t.s), t.node_cs)
        return np.concatenate((f_theta, (t.y - self.chords(points)).ravel()))

    def band(self, theta, d, p, terms: PathTerms | None = None) -> np.ndarray:
        """Tridiagonal part T of the tangent (``d`` unused: the forces come from
        ``terms``, or from the consistent state of ``theta``)."""
        if terms is None:
            terms = self.terms(self.consistent_state(theta), p)
        band = super().band(theta, None, p, terms)
        band[:, 1] += terms.moment_slope
        return band

    def _levers(self, t: PathTerms, dg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """D_a . e_a^perp at the stored entries (M,) and e_a^perp per entry (M, 2)."""
        chord = self.entries[0]
        e_perp = np.column_stack((-t.e[chord, 1], t.e[chord, 0]))
        return dg[:, 0] * e_perp[:, 0] + dg[:, 1] * e_perp[:, 1], e_perp

    def _slots(self, pattern, width: int):
        """Where the values go in a bordered ``pattern`` (of :meth:`bordered_pattern`,
        ``width`` border columns per chord): (band slots and their entries of the
        (N, 3) band, column slots (M, width), row slots (M, width), corner slots)."""
        N, nb = self.n_elements, width * self.n_points
        src = pattern[2]
        where = np.full(3 * N + 2 * nb * N + nb, -1)
        where[src] = np.arange(len(src))
        band = np.flatnonzero(where[:3 * N] >= 0)
        chord, rows = self.entries[:2]
        border = width * chord[:, None] + np.arange(width)[None, :]
        cols = where[3 * N + rows[:, None] * nb + border]
        rows_ = where[3 * N + nb * N + border * N + rows[:, None]]
        return where[band], band, cols, rows_, where[3 * N + 2 * nb * N + np.arange(nb)]

    @cached_property
    def _jacobian_slots(self):
        return self._slots(self.pattern, 2)

    @cached_property
    def _stability_slots(self):
        return self._slots(self.stability_pattern, 1)

    def jacobian_values(self, u: np.ndarray, p, terms: PathTerms | None = None,
                        g=None) -> np.ndarray:
        """dF/du in the order of :attr:`pattern`: column z_a = -D_a^T S_a,
        S_a = (p/L_a) e_a^perp e_a^perp^T, row z_a = D_a (docs/model.md §11.3);
        ``g``: :meth:`segment_gradients` if known."""
        t = self.terms(u, p) if terms is None else terms
        dg = self.segment_gradients(t.theta, (t.c, t.s)) if g is None else g
        lever, e_perp = self._levers(t, dg)
        chord = self.entries[0]
        lever *= -t.p_seg[chord] / t.seg_len[chord]
        band_slots, band, cols, rows, corner = self._jacobian_slots
        values = np.zeros(len(self.pattern[1]))
        values[band_slots] = self.band(t.theta, None, t.p, t).ravel()[band]
        values[cols] = lever[:, None] * e_perp
        values[rows] = dg
        values[corner] = 1.0
        return values

    def stiffness_border(self, theta: np.ndarray, y: np.ndarray, p) -> np.ndarray:
        """W (P, N), one row per segment: sqrt(p/L_a) D_a^T e_a^perp, K = T + W^T W."""
        t = self.terms(self.join(theta, y), p)
        chord, rows = self.entries[:2]
        dense = np.zeros((self.n_points, self.n_elements))
        dense[chord, rows] = self._stiffness_entries(t)
        return dense

    def _stiffness_entries(self, t: PathTerms) -> np.ndarray:
        """W at the stored entries (M,): sqrt(p/L_a) D_a . e_a^perp."""
        w = self._levers(t, self.segment_gradients(t.theta, (t.c, t.s)))[0]
        weights = np.sqrt(np.maximum(t.p_seg, 0.0) / t.seg_len)
        return w * weights[self.entries[0]]

    def stability_values(self, u: np.ndarray, p) -> np.ndarray:
        """Upper-triangle entries of H = [[T, W], [W^T, -I]] (:attr:`stability_pattern`)."""
        t = self.terms(u, p)
        w = self._stiffness_entries(t)
        band_slots, band, cols, rows, corner = self._stability_slots
        values = np.zeros(len(self.stability_pattern[1]))
        values[band_slots] = self.band(t.theta, None, t.p, t).ravel()[band]
        upper = cols[:, 0] >= 0                 # the upper triangle holds the columns only
        values[cols[upper, 0]] = w[upper]
        values[corner] = -1.0
        return values

    def load_derivative(self, u: np.ndarray, g=None, d=None) -> np.ndarray:
        """dF/dp_i = grad_theta L_i = -sum_a D_a^T e_a over tendon i's segments;
        ``g``: :meth:`segment_gradients` if known."""
        theta, y = self.split(u)
        e = self.segments(y)[1]
        dg = self.segment_gradients(theta) if g is None else g
        chord, rows = self.entries[:2]
        values = -(dg[:, 0] * e[chord, 0] + dg[:, 1] * e[chord, 1])
        out = np.zeros((self.n_tendons, self.size))
        flat = self.point_tendon[chord] * self.size + rows
        out.ravel()[:] = np.bincount(flat, values, out.size)
        return out

    @property
    def length_supports(self) -> np.ndarray:
        """Rows of grad_theta L_i: up to the farthest node of cable i's points."""
        return np.maximum.reduceat(np.asarray(self.point_nodes), list(self.path_starts[:-1]))

    def length_columns(self, i: int) -> np.ndarray:
        return np.arange(2 * self.path_starts[i], 2 * self.path_starts[i + 1])

    def route_derivative(self, u: np.ndarray, p, i: int) -> np.ndarray:
        """dF/dr_i, (size, 2), at fixed u and p: r_i enters only the first chord's
        equation z_a - (r_i - X_a) = 0 (docs/model.md §11.7)."""
        a = self.path_starts[i]
        out = np.zeros((self.size, 2))
        out[self.n_elements + 2 * a:self.n_elements + 2 * a + 2] = -np.eye(2)
        return out

    def offset_derivative(self, u: np.ndarray, p, a: int) -> np.ndarray:
        """dF/ddelta_a, (size,), at fixed u and p: the offset's moment f_a . t(theta_m)
        on row m_a, +n(theta_m) on chord a's rows and -n(theta_m) on the next
        chord's (docs/model.md §11.7)."""
        t = self.terms(u, p)
        m = self.point_nodes[a]
        tangent = np.array([np.cos(t.theta[m]), np.sin(t.theta[m])])
        normal = np.array([-tangent[1], tangent[0]])
        out = np.zeros(self.size)
        out[m - 1] = t.point_force[a] @ tangent
        out[self.n_elements + 2 * a:self.n_elements + 2 * a + 2] = normal
        if not self.last_point[a]:
            out[self.n_elements + 2 * a + 2:self.n_elements + 2 * a + 4] = -normal
        return out

    def weight_derivative(self, u: np.ndarray) -> np.ndarray:
        """dF/dw, (size,), at fixed u and p of the weight scaled by a factor w at w = 1
        (F is linear in the weight: the angle rows' -(h/2) n_e . G_e terms; a change
        of B scales q = rho_A g l^3/B and the tip weight by B/B', so dF/dB = -dF/dw / B)."""
        theta = self.split(u)[0]
        c, s = self.trig(theta)
        G = self.element_weight
        q = 0.5 * self.h * (c * G[:, 1] - s * G[:, 0])
        out = np.zeros(self.size)
        out[:self.n_elements] = -q
        out[:self.n_elements - 1] -= q[1:]
        return out

    def length_gradients(self, y: np.ndarray) -> np.ndarray:
        """dL_i/dz, shape (n, 2P): e_a on chord a of tendon i."""
        grad = self.segments(y)[1]
        out = np.zeros((self.n_tendons, 2 * self.n_points))
        rows = np.repeat(self.point_tendon, 2)
        out[rows, np.arange(2 * self.n_points)] = grad.ravel()
        return out

    def linearisation(self, u: np.ndarray, p, residual: bool = True) -> tuple:
        t = self.terms(u, p)
        g = self.segment_gradients(t.theta, (t.c, t.s))
        out = (self.jacobian_values(u, p, t, g), self.load_derivative(u, g))
        return ((self.residual(u, p, terms=t),) + out) if residual else out

    # --- the unloaded state under weight ---------------------------------------------------
    def straight(self) -> np.ndarray:
        """The state at p = 0: straight without weight, else the arm sagging under its
        weight, reached by continuation in the weight from the straight arm (computed
        once per discretisation)."""
        return self._rest_state.copy()

    @cached_property
    def _rest_state(self) -> np.ndarray:
        return self.consistent_state(self.rest_angles())

    def rest_angles(self, steps: int | None = None) -> np.ndarray:
        """Nodal angles at p = 0 (Newton on the tridiagonal angle block)."""
        theta = np.zeros(self.n_elements + 1)
        load = float(np.abs(self.element_weight).max())
        if load == 0.0:
            return theta
        steps = steps or max(1, int(np.ceil(load)))
        p0 = np.zeros(self.n_tendons)
        for k in range(1, steps + 1):
            scaled = _scaled(self, k / steps)
            for _ in range(50):
                u = scaled.consistent_state(theta)
                r = scaled.residual(u, p0)[: self.n_elements]
                band = scaled.band(theta, None, p0)
                ab = np.vstack((np.append(0.0, band[:-1, 2]), band[:, 1],
                                np.append(band[1:, 0], 0.0)))
                theta[1:] -= solve_banded((1, 1), ab, r)
                if np.linalg.norm(r) < 1e-13 * max(1.0, load) * self.n_elements:
                    break
        return theta


def _scaled(disc: GuidedDiscretisation, factor: float) -> GuidedDiscretisation:
    """The same arm with its weight scaled by ``factor`` (continuation)."""
    from dataclasses import replace
    return replace(disc, gravity=factor * disc.gravity, tip_weight=factor * disc.tip_weight)
