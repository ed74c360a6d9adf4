"""Load sensitivities of an equilibrium (Eqs. (13)-(17)).

Differentiating the bordered equilibrium equations F(u(p), p) = 0 of
:mod:`elastica_petsc.core.fem` with respect to the tension p_i gives one linear
solve per tendon with the consistent tangent J = dF/du at the equilibrium:

    J du/dp_i = -dF/dp_i                                          (Eq. (14))

The theta block of du/dp_i is alpha_i = d theta / d p_i (nodal, alpha_i(0) = 0)
and its border block holds d y_j / d p_i, the sensitivities of the
attachment points; Eqs. (15)-(17) (derivatives of t, F_j and d_j) are all
inside J, which is why the same factorisation serves every tendon.  The tip
sensitivity is Eq. (13) with the midpoint rule of the positions (fem):

    d x_t / d p_i = sum_e h n_e (alpha_{i,e} + alpha_{i,e+1}) / 2,

likewise for every attachment point, and the cable lengths L_j = |r_j - x_j|
change as dL_j / dp_i = -d_j . d x_j / d p_i.

Everything is non-dimensional (docs/model.md §3): lengths per unit l, tensions
p = P l^2 / B, so d x / d p is in units of l per unit p (multiply by
l / (B / l^2) for mm per newton).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from .equilibrium import Equilibrium, EquilibriumSolver
from ..core.errors import SolverError
from ..core.fem import Discretisation
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm
from .reasons import KSP_REASONS, reason_name


class SensitivityError(SolverError):
    """The tangent at the equilibrium could not be factored (singular: a limit point)."""


@dataclass(frozen=True)
class Sensitivity:
    """Derivatives of one equilibrium with respect to the tensions.

    The first index is always the tendon i whose tension p_i is varied.

    alpha : (n, N+1) nodal d theta / d p_i [rad per unit p], alpha[:, 0] = 0.
    tip : (n, 2) d x_t / d p_i (Eq. (13)) [l per unit p].
    attachments : (n, n, 2) [i, j] = d x_j / d p_i (midpoint rule).
    attachments_border : (n, n, 2) the same read from the bordered unknowns y_j
        (equal to ``attachments`` to round-off; kept as a consistency check).
    cable_lengths : (n, n) [i, j] = d L_j / d p_i = -d_j . d x_j / d p_i.
    """

    p: np.ndarray
    alpha: np.ndarray
    tip: np.ndarray
    attachments: np.ndarray
    attachments_border: np.ndarray
    cable_lengths: np.ndarray

    @property
    def state_derivative(self) -> np.ndarray:
        """(n, size) du/dp_i of the bordered unknowns (theta_1..N, y_1..n), Eq. (14)."""
        n = len(self.p)
        return np.concatenate((self.alpha[:, 1:], self.attachments_border.reshape(n, -1)), axis=1)

    @property
    def tip_jacobian(self) -> np.ndarray:
        """(2, n) matrix S with S[:, i] = d x_t / d p_i."""
        return self.tip.T


def objective_gradient(eq: Equilibrium, sens: Sensitivity, target) -> tuple[float, np.ndarray]:
    """E = |x_d - x_t|^2 / 2 (Eq. (10)) and dE/dp (Eq. (12)); non-dimensional."""
    r = eq.tip - np.asarray(target, float)
    return 0.5 * float(r @ r), sens.tip @ r


class SensitivitySolver:
    """Owns a copy of the bordered Jacobian and one LU factorisation (KSP
    preonly, natural ordering: fill only in the border) reused for every
    equilibrium of one discretised arm.  The contract of :mod:`.options`:
    ``comm`` (one process), ``options_prefix`` (default ``sens_``, e.g.
    ``-sens_ksp_view``), ``petsc_options``."""

    def __init__(self, disc: Discretisation, *, comm=None, options_prefix: str = "sens_",
                 petsc_options=None):
        self.options = SolverOptions(options_prefix, petsc_options)
        self.comm = comm = check_comm(comm)
        self.disc = disc
        indptr, indices, _ = disc.pattern
        # J keeps these arrays (no copy): new entries are written in place, then assembled
        self._values = disc.jacobian_values(disc.straight(), np.zeros(disc.n_tendons))
        self.J = PETSc.Mat().createAIJWithArrays((disc.size, disc.size),
                                                 (indptr, indices, self._values), comm=comm)
        self.rhs = PETSc.Vec().createSeq(disc.size, comm=comm)
        self.sol = self.rhs.duplicate()
        ksp = PETSc.KSP().create(comm)
        self.options.label(ksp, self.J, self.rhs, self.sol)
        ksp.setOperators(self.J)
        use_bordered_lu(ksp)
        self.options.apply(ksp)
        self.ksp = ksp
        # the nodes whose motion is reported: each cable's end, then the tip
        if disc.has_paths:
            self._ends = np.asarray(disc.path_starts[1:]) - 1
            self._nodes = np.append(np.asarray(disc.point_nodes)[self._ends], disc.n_elements)
        else:
            self._nodes = np.append(disc.attach_nodes, disc.n_elements)

    @classmethod
    def for_solver(cls, solver: EquilibriumSolver, **kw) -> "SensitivitySolver":
        return cls(solver.disc, **kw)

    def compute(self, eq: Equilibrium) -> Sensitivity:
        """Sensitivities at the equilibrium ``eq`` (one factorisation, n solves)."""
        disc = self.disc
        self.options.refresh(self.ksp)
        if not eq.converged:
            raise SensitivityError(
                "sensitivities need a converged equilibrium: " + (eq.message or eq.reason))
        u, p = eq.u, np.asarray(eq.p, float)
        dFdp = disc.load_derivative(u)
        n, N = disc.n_tendons, disc.n_elements
        du = self.tangent_solves(u, p, -dFdp)
        alpha = np.zeros((n, N + 1))
        alpha[:, 1:] = du[:, :N]
        border = du[:, N:].reshape(n, -1, 2)
        theta = eq.theta
        moved = disc.position_derivative(theta, du, self._nodes)        # (n, n + 1, 2)
        tip, attach = moved[:, -1], moved[:, :-1]                       # Eq. (13)
        if disc.has_paths:       # dL_j/dp_i = grad_theta L_j . alpha_i (docs/model.md §11)
            m = self._nodes[:-1]
            turn = disc.point_offsets[self._ends] * alpha[:, m]           # delta dtheta_m
            attach = attach - turn[..., None] * np.column_stack(
                (np.cos(theta[m]), np.sin(theta[m])))[None]              # end points (n, n, 2)
            dL = du[:, :N] @ dFdp[:, :N].T
        else:
            dL = -(attach * eq.directions[None]).sum(axis=2)            # -d_j . dx_j/dp_i
        return Sensitivity(p=p.copy(), alpha=alpha, tip=tip, attachments=attach,
                           attachments_border=border, cable_lengths=dL)

    def tangent_solves(self, u: np.ndarray, p: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """Rows x_k with J(u, p) x_k = rhs_k (J = dF/du; one factorisation for
        all rows), at any (u, p), an equilibrium or not; SensitivityError if J
        is singular (a limit point) or a solve fails."""
        self._assemble(u, p)
        try:
            self.ksp.setUp()
        except PETSc.Error as err:
            raise SensitivityError(
                f"the tangent at p = {np.array2string(p, precision=4)} is singular "
                "(a limit point: the sensitivities are unbounded)") from err
        return self.solve_again(rhs)

    def solve_again(self, rhs: np.ndarray) -> np.ndarray:
        """Rows x_k with J x_k = rhs_k for the J factored last (by
        :meth:`tangent_solves` or :meth:`compute`): no new factorisation."""
        out = np.empty((len(rhs), self.disc.size))
        for k, row in enumerate(rhs):
            self.rhs.setArray(row)
            self.ksp.solve(self.rhs, self.sol)
            reason = self.ksp.getConvergedReason()
            if reason < 0:
                raise SensitivityError("sensitivity solve failed, KSP reason "
                                       + reason_name(KSP_REASONS, reason))
            out[k] = self.sol.getArray(readonly=True)
        if not np.all(np.isfinite(out)):
            raise SensitivityError("non-finite sensitivities: the tangent is singular")
        return out

    def parameter_derivative(self, eq: Equilibrium, dFdq: np.ndarray):
        """du/dq and d x_t/dq at fixed tensions for a design parameter q whose
        dF/dq (size,) is given (a routing point's coordinate, a guide's offset:
        docs/model.md §11.7): J du/dq = -dF/dq, then Eq. (13)."""
        disc = self.disc
        self._assemble(eq.u, np.asarray(eq.p, float))
        self.rhs.setArray(-np.asarray(dFdq, float))
        self.ksp.solve(self.rhs, self.sol)
        if self.ksp.getConvergedReason() < 0:
            raise SensitivityError(f"design sensitivity solve failed, KSP reason "
                                   f"{self.ksp.getConvergedReason()}")
        du = self.sol.getArray(readonly=True).copy()
        return du, disc.position_derivative(eq.theta, du[None], [disc.n_elements])[0, 0]

    def _assemble(self, u: np.ndarray, p: np.ndarray) -> None:
        """The tangent J = dF/du at (u, p), in place, as the operator of the KSP."""
        self._values[:] = self.disc.jacobian_values(u, p)
        self.J.assemble()
        self.ksp.setOperators(self.J)

    def destroy(self) -> None:
        for obj in (self.ksp, self.J, self.rhs, self.sol):
            obj.destroy()

    def __enter__(self) -> "SensitivitySolver":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()


def compute_sensitivity(solver: EquilibriumSolver, eq: Equilibrium) -> Sensitivity:
    """One-off sensitivities of ``eq`` (builds and destroys a SensitivitySolver).

    For repeated use (optimisation, paths) keep a :class:`SensitivitySolver`."""
    with SensitivitySolver.for_solver(solver) as sens:
        return sens.compute(eq)
