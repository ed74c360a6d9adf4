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


class InertiaCounter:
    """Counts negative eigenvalues of K(u, p) for one discretised arm."""

    def __init__(self, disc: Discretisation):
        self.disc = disc
        indptr, indices, _ = disc.stability_pattern
        self._csr = (indptr, indices)
        n = disc.n_elements + disc.n_tendons
        self.H = PETSc.Mat().createSBAIJ(
            size=(n, n), bsize=1, comm=PETSc.COMM_SELF,
            csr=(indptr, indices, disc.stability_values(disc.straight(), np.zeros(disc.n_tendons))))
        self.pc = bordered_ldlt(self.H)

    def negative_eigenvalues(self, u: np.ndarray, p) -> int:
        """Number of negative eigenvalues of the tangent K at state ``u``."""
        self.H.setValuesCSR(*self._csr, self.disc.stability_values(u, p))
        self.H.assemble()
        self.pc.setOperators(self.H)
        try:
            self.pc.setUp()
        except PETSc.Error:      # zero pivot: K (numerically) singular, marginal at best
            return 1
        negative, zero, _ = self.pc.getFactorMatrix().getInertia()
        return negative + zero - self.disc.n_tendons

    def destroy(self) -> None:
        self.pc.destroy()
        self.H.destroy()
