"""Equilibria of measured rows and their exact parameter derivatives
(calibration, docs/model.md §14).

A row is driven either by tensions p (load control, Eq. (9)) or by cable
lengths L (length control with slack cables, :mod:`.lengths`, Eq. (23)).  Its
state z = (u, p, mu) solves the augmented system G(z; q) = 0 of
:class:`~elastica_petsc.solvers.lengths.AugmentedSystem` (mu = 1: no
deflation), where q = (rho, drive) are the routing points rho_i (the arm's
own frame) and the row's drive (p* or L).  By the implicit function theorem

    dz/dq = -A^{-1} dG/dq,    A = dG/dz (the bordered tangent of the
                                         sensitivities, plus tension columns)

with, on the angle rows, dF/drho_i = -dF/dy_i (F depends on rho_i only
through d_i = (rho_i - y_i)/|rho_i - y_i|: minus the border columns of
tendon i, (p_i/L_i) (dX_i/dtheta . d_i^perp) d_i^perp), on the rows of a taut
cable g_i = L_i - |rho_i - y_i|: dg_i/drho_i = -d_i^T, dg_i/dL_i = 1, and on
the tension rows of load control p_i - p_i*: -1 per p_i*.  A slack cable's row
becomes dp_i = 0 (its tension stays zero, its length does not matter).  One
LU of A (natural order, O(N)) serves the 3n right-hand sides.

The measured points are the tip and markers at arc lengths S (on element e,
x(S) = x_e + (S - s_e) t_e exactly, Eq. (2) with the midpoint rule); their
derivative follows from d phi_e = (d theta_e + d theta_{e+1}) / 2 as in
Eq. (13).

Rows are solved cold from the straight arm along their loading path (the
``loading`` order, or proportional), or warm from the same row's state at the
previous parameters: one Newton solve, accepted if no nodal angle moves by
more than ``jump_tol`` (else the cold path is used: the branch is kept).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ..core.deflation import Deflation
from ..core.fem import Discretisation
from ..core.model import Arm
from .equilibrium import EquilibriumSolver, newton_converged
from .lengths import TAUT_TOL, AugmentedSystem, LengthSolver
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm


class RowError(RuntimeError):
    """A row whose equilibrium could not be reached (the message says why)."""


@dataclass(frozen=True)
class RowState:
    """The equilibrium of one row: bordered state u and tensions p (non-dimensional)."""

    u: np.ndarray
    p: np.ndarray
    converged: bool
    message: str = ""
    warm: bool = False


class RowSolver:
    """Row equilibria and derivatives for one arm (its own frame), on ``n_elements``."""

    def __init__(self, arm: Arm, n_elements: int | None = None, jump_tol: float = 0.5, *,
                 comm=None, options_prefix: str = "calib_", petsc_options=None):
        """The contract of :mod:`.options`: the equilibrium solves use
        ``<prefix>eq_``, the length solves ``<prefix>len_``, the tangent
        solves ``<prefix>tan_`` (``petsc_options`` keys relative to ``<prefix>``)."""
        self.options = SolverOptions(options_prefix, petsc_options)
        self.comm = comm = check_comm(comm)
        self.arm, self.l_mm = arm, arm.length_mm
        self.disc = disc = Discretisation.from_arm(arm, n_elements)
        self.jump_tol = jump_tol
        part = self.options.part
        self.eq = EquilibriumSolver(disc, comm=comm, options_prefix=self.options.name("eq_"),
                                    petsc_options=part("eq_"))
        self.len = LengthSolver(disc, length_mm=arm.length_mm, comm=comm,
                                options_prefix=self.options.name("len_"),
                                petsc_options=part("len_"))
        self.load_system = AugmentedSystem(disc, "load", self.options.name("tan_"), comm=comm,
                                           petsc_options=part("tan_"))
        self.A = self.load_system.J.duplicate()
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setOptionsPrefix(self.options.name("tan_"))
        use_bordered_lu(self.ksp)
        self.options.apply(self.ksp)
        self.rhs = PETSc.Vec().createSeq(self.load_system.size, comm=comm)
        self.sol = self.rhs.duplicate()
        for obj in (self.A, self.rhs, self.sol):
            obj.setOptionsPrefix(self.options.name("tan_"))

    # --- equilibria ------------------------------------------------------------------------
    def solve(self, kind: str, drive, order=None, warm: RowState | None = None) -> RowState:
        """The row's equilibrium: ``drive`` is p (kind "tension") or L in units
        of l (lengths); warm-started from ``warm`` if it is given and the
        branch is kept, else along the loading path from the straight arm."""
        if warm is not None and warm.converged:
            state = self._warm(kind, drive, warm)
            if state is not None:
                return state
        if kind == "tension":
            eq = self.eq.solve(drive, order=order)
            return RowState(eq.u, np.asarray(eq.p, float), eq.converged, eq.message)
        return self._follow_lengths(drive, order)

    def _warm(self, kind, drive, warm: RowState) -> RowState | None:
        N = self.disc.n_elements
        if kind == "tension":
            u, _, reason = self.eq.newton(warm.u, drive)
            if not newton_converged(reason):
                return None
            p = np.asarray(drive, float)
        else:
            eq = self.len.solve(drive, start=(warm.u, warm.p))
            if not eq.converged:
                return None
            u, p = eq.u, np.asarray(eq.p, float)
        if np.max(np.abs(u[:N] - warm.u[:N])) > self.jump_tol:
            return None
        return RowState(u, p, True, warm=True)

    def _follow_lengths(self, L, order) -> RowState:
        """Length control from the straight arm: every length at once, or one
        tendon after the other in ``order`` (as a loading order)."""
        L = np.asarray(L, float)
        state = None
        current = self.len.lengths_of(self.disc.straight())
        steps = [L] if order is None else []
        for k in order or ():
            current = current.copy()
            current[k - 1] = L[k - 1]
            steps.append(current)
        for target in steps:
            state = self.len.follow(target, state)
            if not state.converged:
                return RowState(state.u, np.asarray(state.p, float), False, state.message)
        return RowState(state.u, np.asarray(state.p, float), True)

    # --- measured points and their derivatives ------------------------------------------
    def points_mm(self, u, marker_s_mm=()) -> np.ndarray:
        """Tip and markers [mm] of a state, (1 + k, 2), in the arm's frame."""
        theta = self.disc.split(u)[0]
        x = self.disc.node_positions(theta)
        out = [x[-1]]
        for s in marker_s_mm:
            e, frac = self._element(s)
            c, sn = np.cos(0.5 * (theta[e] + theta[e + 1])), np.sin(0.5 * (theta[e] + theta[e + 1]))
            out.append(x[e] + frac * np.array([c, sn]))
        return np.array(out) * self.l_mm

    def _element(self, s_mm: float) -> tuple[int, float]:
        """Element holding arc length s and the distance into it (units of l)."""
        s = s_mm / self.l_mm
        e = min(int(np.floor(s * self.disc.n_elements)), self.disc.n_elements - 1)
        return e, s - e * self.disc.h

    def point_derivatives(self, u, dtheta, marker_s_mm=()) -> np.ndarray:
        """d points [mm] along nodal angle changes ``dtheta`` (N, c) (theta_0 fixed):
        (1 + k, 2, c)."""
        disc = self.disc
        theta = disc.split(u)[0]
        dth = np.vstack((np.zeros((1, dtheta.shape[1])), dtheta))
        phi = disc.element_angles(theta)
        normals = np.column_stack((-np.sin(phi), np.cos(phi)))            # n_e (N, 2)
        dphi = 0.5 * (dth[:-1] + dth[1:])                                 # (N, c)
        steps = disc.h * normals[:, :, None] * dphi[:, None, :]           # (N, 2, c)
        nodes = np.concatenate((np.zeros((1, 2, dtheta.shape[1])), np.cumsum(steps, axis=0)))
        out = [nodes[-1]]
        for s in marker_s_mm:
            e, frac = self._element(s)
            out.append(nodes[e] + frac * normals[e][:, None] * dphi[e][None, :])
        return np.array(out) * self.l_mm

    def derivatives(self, kind: str, state: RowState, L=None, marker_s_mm=(),
                    weight: bool = False) -> np.ndarray:
        """d points [mm] / d q, (1 + k, 2, 3n): q = (rho [mm] (2n, x and y per
        tendon), drive (n): p for tension rows, L [mm] for length rows); with
        ``weight`` one more column, the arm's weight scaled by a factor w at w = 1
        (:meth:`GuidedDiscretisation.weight_derivative`)."""
        disc, n, N = self.disc, self.disc.n_tendons, self.disc.n_elements
        sys = self.len.system if kind != "tension" else self.load_system
        sys.deflation = Deflation(disc.h)
        sys.target = np.asarray(L if kind != "tension" else state.p, float)
        z = sys.augment(state.u, state.p, 1.0)
        values = sys.jacobian_values(z)
        slack = [i for i in range(n) if kind != "tension" and state.p[i] <= TAUT_TOL]
        for i in slack:                               # dp_i = 0 for a slack cable
            r = sys.ip + i
            lo, hi = sys.indptr[r], sys.indptr[r + 1]
            values[lo:hi] = np.where(sys.indices[lo:hi] == r, 1.0, 0.0)
        rhs = self._rhs(kind, sys, state, slack)
        if weight:
            column = np.zeros((sys.size, 1))
            column[:disc.size, 0] = disc.weight_derivative(state.u)
            rhs = np.hstack((rhs, column))
        self.A.setValuesCSR(sys.indptr, sys.indices, values)
        self.A.assemble()
        self.ksp.setOperators(self.A)
        try:
            self.ksp.setUp()
        except PETSc.Error as err:
            raise RowError("the tangent of a row is singular (a limit point)") from err
        dz = np.empty((sys.size, rhs.shape[1]))
        for j in range(rhs.shape[1]):
            self.rhs.setArray(-rhs[:, j])
            self.ksp.solve(self.rhs, self.sol)
            dz[:, j] = self.sol.getArray(readonly=True)
        if not np.all(np.isfinite(dz)):
            raise RowError("non-finite row derivatives: the tangent is singular")
        out = self.point_derivatives(state.u, dz[:N], marker_s_mm)
        out[:, :, : 2 * n] /= self.l_mm                  # per mm of route (rho in units of l)
        if kind != "tension":
            out[:, :, 2 * n:3 * n] /= self.l_mm          # per mm of cable
        return out

    def _rhs(self, kind, sys: AugmentedSystem, state: RowState, slack) -> np.ndarray:
        """dG/dq (size, 3n) at fixed z (module docstring), q in units of l and p.
        Cables through guides (docs/model.md §11.7): rho_i enters only the first
        chord's equation, dF/drho_i = -I there, and a cable's length is the sum of
        its chords, so g_i does not involve rho_i."""
        disc, n, N = self.disc, self.disc.n_tendons, self.disc.n_elements
        out = np.zeros((sys.size, 3 * n))
        taut = [kind != "tension" and i not in slack for i in range(n)]
        if disc.has_paths:
            for i in range(n):
                out[:disc.size, 2 * i:2 * i + 2] = disc.route_derivative(state.u, state.p, i)
        else:
            theta, y = disc.split(state.u)
            lengths, d = disc.cables(y)
            g = disc.attachment_gradients(theta)
            lever = (np.asarray(state.p) / lengths)[:, None] * disc.transverse_gradients(g, d)
            d_perp = np.column_stack((-d[:, 1], d[:, 0]))
            for i in range(n):
                out[:N, 2 * i:2 * i + 2] = -lever[i][:, None] * d_perp[i][None, :]
                if taut[i]:
                    out[sys.ip + i, 2 * i:2 * i + 2] = -d[i]
        for i in range(n):
            if taut[i]:
                out[sys.ip + i, 2 * n + i] = 1.0
            elif kind == "tension":
                out[sys.ip + i, 2 * n + i] = -1.0
        return out

    def destroy(self) -> None:
        self.eq.destroy()
        self.len.destroy()
        self.load_system.destroy()
        for obj in (self.A, self.ksp, self.rhs, self.sol):
            obj.destroy()

    def __enter__(self) -> "RowSolver":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()
