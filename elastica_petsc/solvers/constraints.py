"""Scalar constraints c(w) = 0 that cut curves out of the equilibrium
manifold (solvers/continuation.py): faces of the tension domain, a ray of
proportional loading, cable collapse and level curves of the restrictions
(Eqs. (19), (21), (22))."""
from __future__ import annotations

import numpy as np

from .manifold import Manifold

# --- constraints c(w) = 0 cutting curves out of M ----------------------------------
class Constraint:
    """A scalar c(w); the admissible side is ``side * c >= 0``."""

    name = "constraint"
    side = 1.0

    def value(self, w: np.ndarray) -> float:
        raise NotImplementedError

    def gradient(self, w: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def margin(self, w: np.ndarray) -> float:
        """side * c: >= 0 on the admissible side."""
        return self.side * self.value(w)

    def route_gradient(self, w: np.ndarray, i: int) -> np.ndarray:
        """dc/dr_i at fixed w, (2,): zero unless c involves the routing points."""
        return np.zeros(2)

    def parameter_gradient(self, w: np.ndarray, residual, k: int) -> np.ndarray:
        """dc/dq at fixed w, (k,), for a parameter q that enters F alone
        (``residual(w)`` = dF/dq, (size, k)): zero unless c involves F's
        derivatives (the fold of M, :class:`~.folds.Fold`)."""
        return np.zeros(k)


class TensionBound(Constraint):
    """Face of the tension domain: p_i = bound (0 below, p_crit above, Eq. (22))."""

    def __init__(self, manifold: Manifold, i: int, bound: float, upper: bool = False):
        self.mf, self.i, self.bound = manifold, i, float(bound)
        self.side = -1.0 if upper else 1.0
        self.name = f"P{i + 1}=P_crit" if upper else f"P{i + 1}=0"

    def value(self, w):
        return float(w[self.mf.size + self.i] - self.bound)

    def gradient(self, w):
        g = np.zeros(self.mf.m)
        g[self.mf.size + self.i] = 1.0
        return g


class TensionRay(Constraint):
    """The ray p = s (cos a, sin a), s >= 0, of the tension plane: c = n . p with
    n = (-sin a, cos a) (proportional loading in a fixed ratio; a scan line)."""

    def __init__(self, manifold: Manifold, angle: float):
        self.mf = manifold
        self.normal = np.array([-np.sin(angle), np.cos(angle)])
        self.direction = np.array([np.cos(angle), np.sin(angle)])
        self.name = f"ray {np.degrees(angle):.0f} deg"

    def value(self, w):
        return float(self.normal @ w[self.mf.size:])

    def gradient(self, w):
        g = np.zeros(self.mf.m)
        g[self.mf.size:] = self.normal
        return g


class CableCollapse(Constraint):
    """L_i = eps: the attachment point of tendon i within eps (units of l) of its
    routing point; beyond it the cable direction of Eq. (3) is undefined.  For a
    cable through guides (docs/model.md §11): its shortest segment, between
    point a and its predecessor (the routing point for the first)."""

    def __init__(self, manifold: Manifold, i: int, eps: float):
        self.mf, self.i, self.eps = manifold, i, float(eps)
        self.name = f"L{i + 1}=0"

    def _offset(self) -> int:
        return self.mf.disc.n_elements + 2 * self.i

    def _segment(self, w):
        """(length, unit vector, index) of the cable's shortest chord z_a."""
        disc = self.mf.disc
        lengths, e = disc.segments(disc.split(self.mf.split(w)[0])[1])
        first, last = disc.path_starts[self.i], disc.path_starts[self.i + 1]
        a = first + int(np.argmin(lengths[first:last]))
        return lengths[a], e[a], a

    def value(self, w):
        if self.mf.disc.has_paths:
            return float(self._segment(w)[0] - self.eps)
        y = w[self._offset():self._offset() + 2]
        return float(np.linalg.norm(self.mf.disc.routes[self.i] - y) - self.eps)

    def gradient(self, w):
        g = np.zeros(self.mf.m)
        if self.mf.disc.has_paths:                     # d|z_a|/dz_a = e_a
            _, e, a = self._segment(w)
            N = self.mf.disc.n_elements
            g[N + 2 * a:N + 2 * a + 2] = e
            return g
        y = w[self._offset():self._offset() + 2]
        chord = self.mf.disc.routes[self.i] - y
        g[self._offset():self._offset() + 2] = -chord / np.linalg.norm(chord)
        return g

    def route_gradient(self, w, i):
        if i != self.i:
            return np.zeros(2)
        if self.mf.disc.has_paths:          # |z_a| does not involve r_i (F does)
            return np.zeros(2)
        y = w[self._offset():self._offset() + 2]
        chord = self.mf.disc.routes[self.i] - y
        return chord / np.linalg.norm(chord)                      # d|r_i - y_i|/dr_i


class StateLevel(Constraint):
    """A level curve limit - f(theta) >= 0 of a function of the angles only:
    l*kappa_max (Eq. (19)) or the strain energy in units of SE_0 (Eq. (21))."""

    def __init__(self, manifold: Manifold, kind: str, limit: float):
        if kind not in ("kappa", "energy"):
            raise ValueError(kind)
        self.mf, self.kind, self.limit = manifold, kind, float(limit)
        self.name = "l*kappa_max=limit" if kind == "kappa" else "SE=SE_max"

    def _theta(self, w):
        return self.mf.disc.split(self.mf.split(w)[0])[0]

    def value(self, w):
        theta, disc = self._theta(w), self.mf.disc
        if self.kind == "kappa":
            return float(self.limit - np.max(np.abs(disc.curvature(theta))))
        return float(self.limit - 2.0 * disc.strain_energy(theta))

    def gradient(self, w):
        theta, disc = self._theta(w), self.mf.disc
        jump = np.diff(theta)
        dtheta = np.zeros(len(theta))
        if self.kind == "kappa":                       # the element of largest |theta'|
            e = int(np.argmax(np.abs(jump)))
            sign = np.sign(jump[e]) / disc.h
            dtheta[e + 1] -= sign
            dtheta[e] += sign
        else:                                          # d(2 sum jump^2/(2h))/dtheta
            dtheta[1:] -= 2.0 * jump / disc.h
            dtheta[:-1] += 2.0 * jump / disc.h
        g = np.zeros(self.mf.m)
        g[: disc.n_elements] = dtheta[1:]
        return g
