"""How an equilibrium is reached from the straight arm: its loading path.

Under load control the equilibrium at given tensions depends on the loading
history (Fig. 8: state 1 or state 3 at the same p = (25.2, 10.8)).  A result
is reproducible only with that history, so every tip-control and trace result
carries a :class:`Loading`: a piecewise-linear path in tension space
(non-dimensional p = P l^2 / B) from p = 0 (the straight, unloaded arm)
through its vertices, each segment followed by continuation
(:meth:`elastica_petsc.solvers.equilibrium.EquilibriumSolver.solve` with
``start`` the previous vertex's state).  A loading *order* (1-based tendon
numbers, Fig. 8) is the special case of one vertex per tendon.

The path is stored as a linked list (each vertex points at its parent), so
the many results of a trace share their common history; :meth:`vertices`
materialises it.  Numpy only.
"""
from __future__ import annotations

import numpy as np

from .errors import InputError


class Loading:
    """A loading path: the straight arm (p = 0), then ``vertices`` in turn.

    Create with :meth:`straight`, :meth:`proportional`, :meth:`ordered` or
    :meth:`from_vertices`; extend with :meth:`then` (returns a new object,
    this one is unchanged)."""

    __slots__ = ("p", "parent", "_depth")

    def __init__(self, p: np.ndarray, parent: "Loading | None"):
        self.p = np.array(p, dtype=float)
        self.parent = parent
        self._depth = 0 if parent is None else parent._depth + 1

    # --- construction ------------------------------------------------------------
    @classmethod
    def straight(cls, n_tendons: int) -> "Loading":
        """The unloaded straight arm, p = 0: the root of every path."""
        return cls(np.zeros(n_tendons), None)

    @classmethod
    def proportional(cls, p) -> "Loading":
        """All tensions raised together from zero to ``p``."""
        p = np.asarray(p, float)
        return cls.straight(p.size).then(p)

    @classmethod
    def ordered(cls, p, order) -> "Loading":
        """Tendons brought to their tension one after another in ``order``
        (1-based numbers, a permutation), e.g. (2, 1): tendon 2 first (Fig. 8)."""
        p = np.asarray(p, float)
        if order is None:
            return cls.proportional(p)
        if sorted(order) != list(range(1, p.size + 1)):
            raise InputError(f"loading order {order} is not a permutation of 1..{p.size}")
        path, now = cls.straight(p.size), np.zeros(p.size)
        for number in order:
            now = now.copy()
            now[number - 1] = p[number - 1]
            path = path.then(now)
        return path

    @classmethod
    def from_vertices(cls, vertices) -> "Loading":
        """A path through ``vertices`` (k, n); a leading p = 0 vertex is implied."""
        v = np.asarray(vertices, dtype=float)
        if v.ndim != 2 or len(v) == 0 or not np.all(np.isfinite(v)) or np.any(v < 0):
            raise InputError("a loading path needs rows of finite, non-negative tensions")
        path = cls.straight(v.shape[1])
        for row in v:
            if np.any(row != 0.0) or path.parent is not None:
                path = path.then(row)
        return path

    def then(self, p) -> "Loading":
        """This path continued by a straight segment to tensions ``p``
        (repeated vertices are not stored; a segment continuing the last one in
        the same direction extends it: continuation follows the same path)."""
        p = np.asarray(p, dtype=float)
        if p.shape != self.p.shape:
            raise InputError(f"expected {self.p.size} tensions, got {p.size}")
        if np.array_equal(p, self.p):
            return self
        if self.parent is not None:
            a, b = self.p - self.parent.p, p - self.p
            na, nb = np.linalg.norm(a), np.linalg.norm(b)
            if na > 0 and nb > 0 and float(a @ b) >= (1.0 - 1e-14) * na * nb:
                return Loading(p, self.parent)
        return Loading(p, self)

    # --- reading -------------------------------------------------------------------
    def vertices(self) -> np.ndarray:
        """(k, n): the tensions after p = 0, in loading order (k >= 0)."""
        out, node = [], self
        while node.parent is not None:
            out.append(node.p)
            node = node.parent
        return np.array(out[::-1]).reshape(-1, self.p.size)

    def __len__(self) -> int:
        return self._depth

    def order(self) -> tuple[int, ...] | None:
        """The loading order if this path is one (each vertex raises exactly one
        tendon from 0 to its final tension), else None; proportional: None too."""
        v = self.vertices()
        if len(v) != self.p.size or self.p.size < 2:
            return None
        prev, order = np.zeros(self.p.size), []
        for row in v:
            changed = np.flatnonzero(row != prev)
            if len(changed) != 1 or prev[changed[0]] != 0.0 or row[changed[0]] != self.p[changed[0]]:
                return None
            order.append(int(changed[0]) + 1)
            prev = row
        return tuple(order)

    def describe(self) -> str:
        """One line: 'proportional', 'order 2,1' or 'path of k vertices'."""
        if len(self) <= 1:
            return "proportional from zero" if len(self) == 1 else "straight arm (p = 0)"
        order = self.order()
        if order is not None:
            return "order " + ",".join(map(str, order))
        return f"loading path of {len(self)} vertices"

    def to_json(self, digits: int = 12) -> dict:
        """``{"kind", "order", "vertices"}``: plain data for the JSON output."""
        order = self.order()
        kind = ("proportional" if len(self) == 1 else "order" if order is not None else "path")
        return {"kind": kind, "order": list(order) if order is not None else None,
                "description": self.describe(),
                "vertices": np.round(self.vertices(), digits).tolist(),
                "units": "P l^2/B, from p = 0 (straight arm); each segment followed by "
                         "continuation"}
