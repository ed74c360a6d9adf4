"""Sylvester inertia of the consistent tangent K without forming it.

K = T + W W^T (tridiagonal plus rank n, docs/model.md §2) is the Schur complement of
the symmetric bordered matrix H = [[T, W], [W^T, -I]] (see
:meth:`Discretisation.stability_values`).  By Haynsworth's inertia
additivity In(H) = In(K) + (0, n, 0), so one LDL^T of H in the natural order
(fill only in the border) counts the negative eigenvalues of K in O(N).  Under
load control an equilibrium is stable iff that count is zero (energy
criterion, docs/model.md §2).  The factorisation is the compiled
:func:`~elastica_petsc.core.fem.ldlt_negatives` (the pivots of PETSc's Cholesky on
SBAIJ storage in the natural order, without a PETSc matrix: docs/model.md §20).
"""
from __future__ import annotations

import numpy as np

from ..core.fem import Discretisation, ldlt_negatives
from .options import SolverOptions, check_comm


class BorderedInertia:
    """Sylvester inertia of a symmetric bordered matrix (tridiagonal block and
    dense borders, upper-triangle CSR ``pattern``) by one LDL^T in the natural
    order; subclasses give the entries and how many negative eigenvalues the
    border itself contributes (Haynsworth); they set ``disc`` (whose
    ``n_elements`` angle rows come first) before calling this constructor.  It owns no PETSc object; the
    contract of :mod:`.options` is checked (``comm``: one process, a legal
    ``options_prefix``) and ``petsc_options`` must be empty: the compiled
    factorisation has no options."""

    def __init__(self, pattern, size: int, values: np.ndarray, *, comm=None,
                 options_prefix: str = "inertia_", petsc_options=None):
        self.options = SolverOptions(options_prefix, petsc_options)
        check_comm(comm)
        if self.options.options:
            raise ValueError(f"the inertia count ({options_prefix}) takes no PETSc options")
        self._csr = (np.ascontiguousarray(pattern[0], np.int32),
                     np.ascontiguousarray(pattern[1], np.int32))
        self._angles = self.disc.n_elements         # the tridiagonal block's rows
        ldlt_negatives(self._csr, values, self._angles)        # refuses another pattern

    def count(self, values: np.ndarray, border_negatives: int) -> int:
        """Negative plus zero eigenvalues of the matrix with entries ``values``,
        less ``border_negatives``; 1 if the factorisation meets a zero pivot
        (numerically singular: marginal at best)."""
        negative = ldlt_negatives(self._csr, values, self._angles)
        return 1 if negative is None else negative - border_negatives

    def destroy(self) -> None:
        """Nothing to free (kept for the callers' solver contract)."""


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
