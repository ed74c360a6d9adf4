"""Sylvester inertia of the consistent tangent K without forming it.

K = T + W W^T (tridiagonal plus rank n, docs/model.md §2) is the Schur complement of
the symmetric bordered matrix H = [[T, W], [W^T, -I]] (see
:meth:`Discretisation.stability_values`).  By Haynsworth's inertia
additivity In(H) = In(K) + (0, n, 0), so one sparse LDL^T of H (PETSc's
Cholesky on SBAIJ storage, natural order: fill only in the border) counts
the negative eigenvalues of K in O(N).  Under load control an equilibrium is
stable iff that count is zero (energy criterion, docs/model.md §2).
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..core.fem import Discretisation
from .linalg import bordered_ldlt
from .options import SolverOptions, check_comm


class BorderedInertia:
    """Sylvester inertia of a symmetric bordered matrix (tridiagonal block and
    dense borders, upper-triangle CSR ``pattern``) by one LDL^T in the natural
    order; subclasses give the entries and how many negative eigenvalues the
    border itself contributes (Haynsworth).  The contract of :mod:`.options`:
    ``comm`` (one process), ``options_prefix`` (of the matrix and its LDL^T
    PC, e.g. ``-eq_inertia_pc_factor_mat_solver_type``), ``petsc_options``."""

    def __init__(self, pattern, size: int, values: np.ndarray, *, comm=None,
                 options_prefix: str = "inertia_", petsc_options=None):
        self.options = SolverOptions(options_prefix, petsc_options)
        comm = check_comm(comm)
        indptr, indices = pattern[0], pattern[1]
        self._csr = (indptr, indices)
        self.H = PETSc.Mat().createSBAIJ(size=(size, size), bsize=1, comm=comm,
                                         csr=(indptr, indices, values))
        self.pc = bordered_ldlt(self.H)
        self.options.label(self.H, self.pc)
        self.options.apply(self.pc)

    def count(self, values: np.ndarray, border_negatives: int) -> int:
        """Negative plus zero eigenvalues of the matrix with entries ``values``,
        less ``border_negatives``; 1 if the factorisation meets a zero pivot
        (numerically singular: marginal at best)."""
        self.H.setValuesCSR(*self._csr, values)
        self.H.assemble()
        self.pc.setOperators(self.H)
        try:
            self.pc.setUp()
        except PETSc.Error:
            return 1
        negative, zero, _ = self.pc.getFactorMatrix().getInertia()
        return negative + zero - border_negatives

    def destroy(self) -> None:
        self.pc.destroy()
        self.H.destroy()


class InertiaCounter(BorderedInertia):
    """Counts negative eigenvalues of K(u, p) for one discretised arm."""

    def __init__(self, disc: Discretisation, **contract):
        self.disc = disc
        u0 = disc.consistent_state(np.zeros(disc.n_elements + 1))
        super().__init__(disc.stability_pattern, disc.n_elements + disc.stability_border,
                         disc.stability_values(u0, np.zeros(disc.n_tendons)), **contract)

    def negative_eigenvalues(self, u: np.ndarray, p) -> int:
        """Number of negative eigenvalues of the tangent K at state ``u``."""
        return self.count(self.disc.stability_values(u, p), self.disc.stability_border)
