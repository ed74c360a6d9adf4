"""Kernels of the P1 finite-element elastica (compiled in fem_kernels.c; no PETSc here).

Non-dimensional throughout (docs/model.md §3): l = 1, B = 1, tensions p.

Discretisation (Eq. (9))
----------------------
Nodes s_k = k h, k = 0..N, h = 1/N; theta is P1 with theta_0 = 0 (clamp).
Every integral over an element uses the midpoint rule at the element angle
phi_e = (theta_e + theta_{e+1}) / 2, with t_e = (cos phi_e, sin phi_e) and
n_e = (-sin phi_e, cos phi_e):

    x_k = sum_{e<k} h t_e                                   (Eq. (2))

Because the positions and the tendon load integrals of Eq. (9) share this
quadrature, the discrete residual is exactly the gradient of the discrete
potential (docs/model.md §2)

    Pi(theta) = sum_e (theta_{e+1} - theta_e)^2 / (2h) + sum_i p_i |r_i - X_i(theta)|
                - m theta_N,

with X_i = x_{m_i} the attachment node of tendon i and m an optional applied
tip moment (used only for the closed-form check of docs/model.md §7).  Its Hessian,
the consistent tangent K, is symmetric.

Bordered system
---------------
X_i depends on every angle before the attachment point, so K has a dense
rank-2 term per tendon.  To stay O(N) the attachment positions y_i are
carried as extra unknowns, u = (theta_1..theta_N, y_1, ..., y_n), with

    F_theta = d Pi/d theta evaluated with d_i = (r_i - y_i)/|r_i - y_i|   (Eqs. (3)-(4), (9))
    F_y_i   = y_i - X_i(theta)                                           (Eq. (2))

Its Jacobian is tridiagonal in the theta block with 2n dense border rows and
columns; eliminating y (Schur complement) gives back K exactly.  With the
theta unknowns first, LU in the natural order fills only the border.

The residual, the Jacobian values, dF/dp, the band, the attachment gradients
and the stability values are compiled (``fem_kernels.c``, docs/model.md §20);
the methods here convert their arguments and hold the pattern data.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from .errors import InputError
from .model import Arm

try:
    from . import fem_kernels
except ImportError as err:      # a source tree whose extension was never built
    raise ImportError(
        "elastica_petsc's compiled kernels (elastica_petsc/core/fem_kernels.c) are not built: "
        "run `bash scripts/setup.sh` (it needs gcc and python3-dev) or `python -m pip install "
        f"--no-deps --no-build-isolation -e .` in the source tree ({err})") from err


def ldlt_negatives(pattern, values: np.ndarray, n_angles: int) -> int | None:
    """Negative pivots of the LDL^T, natural order and no pivoting (the inertia of
    PETSc's Cholesky on SBAIJ storage), of the symmetric bordered matrix whose upper
    triangle is the CSR ``pattern`` (indptr, indices: int32) with entries ``values``:
    a tridiagonal block of ``n_angles`` rows, then dense border rows and columns
    (:meth:`Discretisation.bordered_pattern`; compiled, O(N nb^2)).  None at a zero
    pivot (|d| <= 100 eps, PETSc's default): the matrix is numerically singular."""
    count = fem_kernels.inertia(pattern[0], pattern[1], _floats(values), int(n_angles))
    if count == -2:
        raise ValueError("not a bordered tridiagonal pattern: rows of the angle block may "
                         "reach only the next angle and the border")
    return None if count < 0 else count


def _floats(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array (no copy when it already is one)."""
    return np.ascontiguousarray(a, dtype=float)


class DiscretisationError(InputError):
    """An arm that cannot be put on the requested mesh."""


class Terms(NamedTuple):
    """Quantities of a state (u, p) shared by the residual and its derivatives."""

    theta: np.ndarray        # nodal angles, theta_0 = 0 included
    y: np.ndarray            # attachment unknowns (n, 2)
    lengths: np.ndarray      # cable lengths L_i (Eq. (3))
    d: np.ndarray            # unit cable directions d_i (n, 2)
    c: np.ndarray            # cos phi_e of the element angles
    s: np.ndarray            # sin phi_e
    p: np.ndarray            # tensions
    force: np.ndarray        # sum of the tendon forces acting on each element (N, 2)


MAX_AUTO_ELEMENTS = 100_000


def nearest_element_count(arm: Arm, near: int | None = None) -> int:
    """The element count nearest ``near`` (default the config's ``elements``; the
    larger one on a tie) that puts every attachment on a node: s_i / l * N an
    integer (to 1e-9 N, as :meth:`Discretisation.from_arm` checks)."""
    near = max(2, arm.elements if near is None else near)
    s = np.asarray(arm.attachments(), float)
    for gap in range(MAX_AUTO_ELEMENTS):
        for n in (near + gap, near - gap):
            if 2 <= n <= MAX_AUTO_ELEMENTS and np.all(np.abs(s * n - np.rint(s * n)) <= 1e-9 * n):
                return n
    raise DiscretisationError(
        f"no element count up to {MAX_AUTO_ELEMENTS} puts every attachment on a node (s_i / l "
        f"= {', '.join(f'{v:.6g}' for v in s)}); round the attachments or give --elements N")


@dataclass(frozen=True)
class Discretisation:
    """Mesh and tendon data of one arm, non-dimensional."""

    n_elements: int
    attach_nodes: tuple[int, ...]   # m_i: node index of tendon i's attachment
    routes: np.ndarray              # (n, 2) routing points r_i / l

    # cables through guides, offsets or weight (core/guided.py, docs/model.md §11)
    has_paths = False
    _path_kernels = []            # the subclass with has_paths, registered on definition

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        if cls.has_paths:
            Discretisation._path_kernels[:] = [cls]

    @classmethod
    def from_arm(cls, arm: Arm, n_elements: int | None = None) -> "Discretisation":
        """Put ``arm`` on a uniform mesh; attachments must fall on nodes.  An arm
        with guides, offsets or weight gets the kernel of docs/model.md §11
        (:class:`~.guided.GuidedDiscretisation`, registered when the package
        ``core`` is imported); the paper's cables keep this kernel."""
        if cls is Discretisation and arm.has_paths:
            return cls._path_kernels[0].from_arm(arm, n_elements)
        n = arm.elements if n_elements is None else n_elements
        if n < 2:
            raise DiscretisationError(f"need at least 2 elements, got {n}")
        nodes = []
        for i, s in enumerate(arm.attachments(), start=1):
            k = int(round(s * n))
            if abs(k - s * n) > 1e-9 * n:
                h_mm = arm.length_mm / n
                raise DiscretisationError(
                    f"tendon {i}: attachment s = {s * arm.length_mm:g} mm is not on a node of "
                    f"the {n}-element mesh (spacing {h_mm:g} mm); choose an element count that "
                    f"makes s_i / l * N an integer (nearest node: {k * h_mm:g} mm), or "
                    "--elements auto")
            nodes.append(k)
        return cls(n, tuple(nodes), arm.routes())

    # --- sizes and layout ---------------------------------------------------
    @property
    def h(self) -> float:
        return 1.0 / self.n_elements

    @property
    def n_tendons(self) -> int:
        return len(self.attach_nodes)

    @property
    def size(self) -> int:
        """Unknowns of the bordered system: N angles + 2 per tendon."""
        return self.n_elements + 2 * self.n_tendons

    @property
    def stability_border(self) -> int:
        """Border columns of the stability matrix H: one per tendon."""
        return self.n_tendons

    @cached_property
    def support(self) -> np.ndarray:
        """(n, N) mask: element e lies before tendon i's attachment (e < m_i)."""
        e = np.arange(self.n_elements)
        return e[None, :] < np.asarray(self.attach_nodes)[:, None]

    def split(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nodal angles theta_0..theta_N (theta_0 = 0) and attachment unknowns (n, 2)."""
        theta = np.concatenate(([0.0], u[: self.n_elements]))
        return theta, u[self.n_elements:].reshape(-1, 2)

    def join(self, theta: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Inverse of split (theta including the clamped node)."""
        return np.concatenate((theta[1:], np.asarray(y, dtype=float).ravel()))

    def straight(self) -> np.ndarray:
        """The undeformed arm as a bordered state vector."""
        theta = np.zeros(self.n_elements + 1)
        return self.join(theta, self.node_positions(theta)[self.attach_index])

    def consistent_state(self, theta: np.ndarray) -> np.ndarray:
        """Bordered state with y_i = X_i(theta) exactly."""
        return self.join(theta, self.node_positions(theta)[self.attach_index])

    def attachment_points(self, theta: np.ndarray) -> np.ndarray:
        """Where each cable ends, (n, 2)."""
        return self.node_positions(theta)[self.attach_index]

    def cable_lengths_of(self, theta: np.ndarray) -> np.ndarray:
        """L_i = |r_i - x_i| of the state ``theta`` (Eq. (3))."""
        return np.linalg.norm(self.routes - self.attachment_points(theta), axis=1)

    # --- geometry (Eqs. (1)-(2)) -------------------------------------------------
    @staticmethod
    def element_angles(theta: np.ndarray) -> np.ndarray:
        """phi_e, the midpoint angle of each element."""
        return 0.5 * (theta[:-1] + theta[1:])

    def node_positions(self, theta: np.ndarray) -> np.ndarray:
        """x_k at every node, shape (N+1, 2): x_0 = 0, x_{k+1} = x_k + h t_k (Eq. (2),
        midpoint rule; compiled)."""
        out = np.empty((self.n_elements + 1, 2))
        fem_kernels.positions(_floats(theta[1:]), out)
        return out

    def trig(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """cos phi_e and sin phi_e of the element angles (shared by the kernels)."""
        phi = self.element_angles(theta)
        return np.cos(phi), np.sin(phi)

    def attachment_gradients(self, theta: np.ndarray, cs=None) -> np.ndarray:
        """g[i, k-1] = d X_i / d theta_k, shape (n, N, 2): (h/2) n_e of the elements
        k-1 and k left of m_i (compiled; ``cs``, :meth:`trig` of theta, is
        accepted for the subclasses' interface and recomputed)."""
        g = np.empty((self.n_tendons, self.n_elements, 2))
        fem_kernels.gradients(_floats(theta[1:]), self.attach_index, g)
        return g

    @cached_property
    def attach_index(self) -> np.ndarray:
        """The attachment nodes m_i as int64, for the compiled kernels."""
        return np.asarray(self.attach_nodes, dtype=np.int64)

    @cached_property
    def _routes(self) -> np.ndarray:
        """The routing points as a contiguous float64 (n, 2) array."""
        return _floats(self.routes)

    def position_derivative(self, theta: np.ndarray, dstate: np.ndarray, nodes) -> np.ndarray:
        """d x_m / dq at the nodes ``nodes`` (0..N) for each row of ``dstate``
        ((k, >= N): variations of theta_1..theta_N first), shape (k, len(nodes), 2):
        d x_m = sum_{e < m} h n_e (dtheta_e + dtheta_{e+1}) / 2, Eq. (2) differentiated
        (Eq. (13) at the tip, m = N; compiled)."""
        dstate = _floats(dstate).reshape(len(dstate), -1)
        nodes = np.ascontiguousarray(nodes, dtype=np.int64)
        out = np.empty((len(dstate), len(nodes), 2))
        fem_kernels.position_derivative(_floats(theta[1:]), dstate, nodes, out)
        return out

    @cached_property
    def _support_matrix(self) -> np.ndarray:
        """:attr:`support` as floats, (n, N), for sums over tendons or elements."""
        return self.support.astype(float)

    def tendon_sums(self, values: np.ndarray) -> np.ndarray:
        """sum over tendons i with e < m_i of values[i], for every element e.

        ``values`` has shape (n, k); the result (N, k).  One (N x n) product,
        O(nN) (n, the number of tendons, is small).
        """
        return self._support_matrix.T @ values

    # --- energies (Eq. (21)) ----------------------------------------------------
    def strain_energy(self, theta: np.ndarray) -> float:
        """int theta'^2/2 ds in units of B/l (multiply by 2 for units of SE_0)."""
        return float(np.sum(np.diff(theta) ** 2) / (2.0 * self.h))

    def curvature(self, theta: np.ndarray) -> np.ndarray:
        """l * theta' on each element (piecewise constant for P1)."""
        return np.diff(theta) / self.h

    def potential(self, theta: np.ndarray, p, tip_moment: float = 0.0) -> float:
        """Discrete total potential Pi(theta) (docs/model.md §2)."""
        x = self.node_positions(theta)[self.attach_index]
        lengths = np.linalg.norm(self.routes - x, axis=1)
        return self.strain_energy(theta) + float(np.dot(p, lengths)) - tip_moment * theta[-1]

    # --- bordered residual and Jacobian --------------------------------------
    def cables(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cable lengths L_i = |r_i - y_i| and unit directions d_i (Eq. (3))."""
        chord = self.routes - y
        lengths = np.hypot(chord[:, 0], chord[:, 1])
        return lengths, chord / lengths[:, None]

    def shortest_segments(self, y: np.ndarray) -> np.ndarray:
        """The shortest straight segment of each cable (here: the whole cable)."""
        return self.cables(y)[0]

    @property
    def length_supports(self) -> np.ndarray:
        """Rows of grad_theta L_i that can be nonzero: 0..length_supports[i]-1."""
        return np.asarray(self.attach_nodes)

    def length_columns(self, i: int) -> np.ndarray:
        """Columns of y (0-based in the border) that cable i's length depends on."""
        return 2 * i + np.arange(2)

    def length_gradients(self, y: np.ndarray) -> np.ndarray:
        """dL_i/dy, shape (n, 2n): -d_i in tendon i's two columns."""
        d = self.cables(y)[1]
        out = np.zeros((self.n_tendons, 2 * self.n_tendons))
        for i in range(self.n_tendons):
            out[i, 2 * i: 2 * i + 2] = -d[i]
        return out

    def terms(self, u: np.ndarray, p) -> Terms:
        """The shared quantities of (u, p) (:class:`Terms`)."""
        theta, y = self.split(u)
        lengths, d = self.cables(y)
        c, s = self.trig(theta)
        p = np.asarray(p, float)
        force = self.tendon_sums(p[:, None] * d)                # sum of F_i per element
        return Terms(theta, y, lengths, d, c, s, p, force)

    def residual(self, u: np.ndarray, p, tip_moment: float = 0.0,
                 terms: Terms | None = None) -> np.ndarray:
        """F(u) of the bordered system (Eq. (9) with the midpoint rule, plus y - X(theta)):
        F_theta_k = (2 theta_k - theta_{k-1} - theta_{k+1}) / h - (h/2) (t_e x F_e) on the
        elements e = k-1, k (compiled; ``terms`` is accepted for the subclasses'
        interface and recomputed)."""
        out = np.empty(self.size)
        fem_kernels.residual(_floats(u), _floats(p), self._routes, self.attach_index,
                          float(tip_moment), out)
        return out

    def bordered_pattern(self, supports, upper: bool = False, starts=None):
        """CSR structure of a tridiagonal N x N block bordered by one column and
        one row per entry of ``supports`` (column b is nonzero in rows
        starts[b]..supports[b]-1, ``starts`` default 0), with a diagonal corner block.

        Returns (indptr, indices, src): ``src`` maps each stored entry to the flat
        source array concatenating band (N, 3), border columns (N, nb), border
        rows (nb, N) and corner diagonal (nb,).  ``upper`` keeps col >= row only
        (for symmetric SBAIJ storage).
        """
        N, nb = self.n_elements, len(supports)
        rows, cols, src = [], [], []
        k = np.arange(N)
        for off in (-1, 0, 1):                          # band[r, off+1] = A[r, r+off]
            ok = (k + off >= 0) & (k + off < N)
            rows.append(k[ok]); cols.append(k[ok] + off); src.append(3 * k[ok] + off + 1)
        col_base, row_base, corner_base = 3 * N, 3 * N + nb * N, 3 * N + 2 * nb * N
        starts = np.zeros(nb, int) if starts is None else starts
        for b, (lo, m) in enumerate(zip(starts, supports)):
            r = np.arange(lo, m)
            rows.append(r); cols.append(np.full(len(r), N + b))
            src.append(col_base + r * nb + b)
            rows.append(np.full(len(r), N + b)); cols.append(r); src.append(row_base + b * N + r)
            rows.append(np.array([N + b])); cols.append(np.array([N + b]))
            src.append(np.array([corner_base + b]))
        rows, cols, src = (np.concatenate(a) for a in (rows, cols, src))
        if upper:
            keep = cols >= rows
            rows, cols, src = rows[keep], cols[keep], src[keep]
        order = np.lexsort((cols, rows))
        indptr = np.searchsorted(rows[order], np.arange(N + nb + 1)).astype(np.int32)
        return indptr, cols[order].astype(np.int32), src[order]

    @cached_property
    def pattern(self):
        """CSR structure of the bordered Jacobian (2 border columns per tendon)."""
        return self.bordered_pattern(np.repeat(self.attach_nodes, 2))

    @property
    def stability_pattern_supports(self) -> np.ndarray:
        """Rows reached by each border column of H (W's columns): up to this one."""
        return np.asarray(self.attach_nodes)

    @property
    def stability_pattern_starts(self) -> np.ndarray:
        """The first row reached by each border column of H."""
        return np.zeros(self.n_tendons, int)

    @cached_property
    def stability_pattern(self):
        """Upper-triangle CSR structure of the symmetric stability matrix H
        (one border column per tendon)."""
        return self.bordered_pattern(self.stability_pattern_supports, upper=True,
                                     starts=self.stability_pattern_starts)

    def band(self, theta, d, p, terms: Terms | None = None) -> np.ndarray:
        """Tridiagonal part T of the tangent, (N, 3) = (lower, diag, upper);
        ``terms``: :meth:`terms` of the state if already known."""
        # the stiffness of theta'^2/2 plus d/dtheta of -(h/2) t_e x F on element e:
        # (h/4) t_e.F on its two nodes (compiled)
        if terms is None:
            c, s = self.trig(theta)
            force = self.tendon_sums(np.asarray(p, float)[:, None] * d)
        else:
            c, s, force = terms.c, terms.s, terms.force
        band = np.empty((self.n_elements, 3))
        fem_kernels.band(_floats(c), _floats(s), _floats(force), band)
        return band

    def jacobian_values(self, u: np.ndarray, p, terms: Terms | None = None,
                        g=None) -> np.ndarray:
        """Entries of dF/du in the order of :attr:`pattern` (consistent tangent): the
        band T, dF_theta/dy_i = p_i/L_i (d_i^perp . g_i) d_i^perp (Eq. (17)),
        dF_y/dtheta = -dX/dtheta and the identity (compiled; ``terms`` and ``g`` are
        accepted for the subclasses' interface and recomputed)."""
        out = np.empty(len(self._pattern_src))
        fem_kernels.jacobian(_floats(u), _floats(p), self._routes, self.attach_index,
                          self._pattern_src, out)
        return out

    @cached_property
    def _pattern_src(self) -> np.ndarray:
        return np.ascontiguousarray(self.pattern[2], dtype=np.int64)

    @cached_property
    def _stability_src(self) -> np.ndarray:
        return np.ascontiguousarray(self.stability_pattern[2], dtype=np.int64)

    def stability_values(self, u: np.ndarray, p) -> np.ndarray:
        """Upper-triangle entries of H = [[T, W], [W^T, -I]] (:attr:`stability_pattern`).

        W[:, i] = sqrt(p_i / L_i) dX_i/dtheta^T d_i^perp, so that the Schur
        complement T + W W^T is the consistent tangent K (docs/model.md §2) and, by
        Haynsworth's inertia additivity, In(K) = In(H) - (0, n, 0)
        (compiled; a tension p_i <= 0 gives a zero column).
        """
        out = np.empty(len(self._stability_src))
        fem_kernels.stability(_floats(u), _floats(p), self._routes, self.attach_index,
                           self._stability_src, out)
        return out

    def stiffness_border(self, theta: np.ndarray, y: np.ndarray, p) -> np.ndarray:
        """W, shape (n, N): W[i] = sqrt(p_i / L_i) (dX_i/dtheta)^T d_i^perp, so that
        K = T + W^T W (docs/model.md §2); a tension p_i <= 0 gives a zero row (compiled)."""
        out = np.empty((self.n_tendons, self.n_elements))
        fem_kernels.stiffness(_floats(self.join(theta, y)), _floats(p), self._routes,
                              self.attach_index, out)
        return out

    @staticmethod
    def transverse_gradients(g: np.ndarray, d: np.ndarray) -> np.ndarray:
        """(dX_i/dtheta_k) . d_i^perp, shape (n, N), from the attachment gradients
        ``g`` (n, N, 2) and unit cable directions ``d`` (n, 2): how each angle
        turns cable i (Eq. (17))."""
        return g[..., 0] * (-d[:, 1:2]) + g[..., 1] * d[:, :1]

    def load_derivative(self, u: np.ndarray, g=None, d=None) -> np.ndarray:
        """dF/dp, shape (n, size): row i is dF/dp_i = -(dX_i/dtheta)^T d_i on the
        angles, zero on the border (right-hand sides of Eq. (14); compiled, ``g`` and
        ``d`` are accepted for the subclasses' interface and recomputed)."""
        out = np.empty((self.n_tendons, self.size))
        fem_kernels.load_derivative(_floats(u), self._routes, self.attach_index, out)
        return out

    def linearisation(self, u: np.ndarray, p, residual: bool = True) -> tuple:
        """F (:meth:`residual`), the entries of dF/du (:meth:`jacobian_values`) and
        dF/dp (:meth:`load_derivative`) at (u, p).  With ``residual=False`` only
        (dF/du, dF/dp)."""
        out = (self.jacobian_values(u, p), self.load_derivative(u))
        return ((self.residual(u, p),) + out) if residual else out
