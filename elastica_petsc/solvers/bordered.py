"""Bordered sparse systems of the continuation (solvers/continuation.py):
the CSR pattern of fem's Jacobian bordered by dense rows and columns, its
PETSc matrix, the sign of its determinant from SuperLU's factors, and the
pivoting LU that the extended systems need (their leading block is singular
on the fold of M)."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from ..core.errors import SolverError
from .linalg import use_bordered_lu

# LU with partial pivoting for the extended systems: their leading block J is
# singular on the fold and their last rows have no diagonal entry, so the
# natural-order LU without pivoting of linalg.use_bordered_lu would break down.
PIVOTING_LU = ("klu", "umfpack", "superlu", "mumps")


def use_pivoting_lu(ksp: PETSc.KSP) -> PETSc.KSP:
    """KSP preonly with a sparse LU that pivots (first available package)."""
    use_bordered_lu(ksp)
    pc = ksp.getPC()
    for package in PIVOTING_LU:
        try:
            pc.setFactorSolverType(package)
            return ksp
        except PETSc.Error:
            continue
    raise ContinuationError("no pivoting sparse LU (UMFPACK, SuperLU or MUMPS) in this PETSc")


class ContinuationError(SolverError):
    """The curve could not be followed (step too small, singular system)."""


class BorderedPattern:
    """CSR structure of [[A, C], [R]]: the sparse pattern A (size x size) of
    fem's Jacobian bordered by k dense columns C and k dense rows R."""

    def __init__(self, indptr, indices, size: int, k: int):
        nnz_rows = np.diff(indptr)
        counts = np.concatenate((nnz_rows + k, np.full(k, size + k)))
        new_ptr = np.concatenate(([0], np.cumsum(counts))).astype(np.int32)
        row_of = np.repeat(np.arange(size), nnz_rows)
        self.base_pos = new_ptr[row_of] + (np.arange(len(indices)) - indptr[row_of])
        self.col_pos = (new_ptr[:size] + nnz_rows)[:, None] + np.arange(k)
        self.row_pos = new_ptr[size:size + k][:, None] + np.arange(size + k)
        new_idx = np.empty(new_ptr[-1], np.int32)
        new_idx[self.base_pos] = indices
        new_idx[self.col_pos] = size + np.arange(k)
        new_idx[self.row_pos] = np.arange(size + k)
        self.csr = (new_ptr, new_idx)
        self.n = size + k
        self._transpose = None

    def values(self, base_values, columns, rows, out: np.ndarray | None = None) -> np.ndarray:
        """The CSR values of [[A, C], [R]] (into ``out`` if given)."""
        out = np.empty(self.csr[0][-1]) if out is None else out
        out[self.base_pos] = base_values
        out[self.col_pos] = columns
        out[self.row_pos] = rows
        return out

    @staticmethod
    def determinant_sign(lu) -> float:
        """Sign of det B from the SuperLU factors of B^T (:meth:`lu_of_transpose`):
        P_r B^T P_c = L U with L unit lower triangular, so
        sign det B = sign(P_r) sign(P_c) prod sign(U_kk) (no dense LU needed)."""
        U = lu.U
        natural = np.arange(U.shape[0])
        last = U.indptr[1:] - 1            # SuperLU keeps U_kk last in column k
        diagonal = U.data[last] if np.array_equal(U.indices[last], natural) else U.diagonal()
        sign = float(np.prod(np.sign(diagonal)))
        for perm in (lu.perm_r, lu.perm_c):         # perm_c: the identity in natural order
            if np.any(perm != natural):
                sign *= permutation_sign(perm)
        return sign

    def lu_of_transpose(self, values):
        """SuperLU (scipy, partial pivoting) of B^T, B the CSR matrix with these
        values (its CSR arrays are the CSC arrays of B^T): B x = b is
        ``lu.solve(b, trans="T")``, B^T y = c is ``lu.solve(c)``."""
        from scipy.sparse.linalg import splu
        if self._transpose is None:            # built (and checked) once, values reset
            self._transpose = sp.csc_matrix((values, self.csr[1], self.csr[0]),
                                            shape=(self.n, self.n))
        self._transpose.data[:] = values
        # natural order: the dense border is last, so its fill stays in the border
        return splu(self._transpose, permc_spec="NATURAL")


def permutation_sign(perm: np.ndarray) -> float:
    """Sign (+1 or -1) of a permutation, (-1)^(n - number of cycles): each
    element's cycle is labelled by its smallest member by pointer doubling
    (log2 n rounds of indexing, no Python loop over the elements)."""
    perm = np.asarray(perm)
    label, step = np.minimum(np.arange(len(perm)), perm), perm
    for _ in range(max(int(np.ceil(np.log2(max(len(perm), 2)))), 1)):
        label = np.minimum(label, label[step])
        step = step[step]
    cycles = np.count_nonzero(label == np.arange(len(perm)))
    return -1.0 if (len(perm) - cycles) % 2 else 1.0


class BorderedAIJ:
    """A PETSc AIJ matrix [[A, C], [R]]: the sparse pattern A (size x size) of
    fem's Jacobian bordered by k dense columns C and k dense rows R
    (k x (size + k)); the pattern is fixed, values are reset in one call."""

    def __init__(self, indptr, indices, size: int, k: int):
        self.pattern = BorderedPattern(indptr, indices, size, k)
        self.csr, self.size, self.k = self.pattern.csr, size, k
        # the matrix keeps this array (no copy): fill writes the values in place and
        # assembles (which raises the matrix state: the LU is refactored), no setValuesCSR
        self.values = np.zeros(self.csr[0][-1])
        self.mat = PETSc.Mat().createAIJWithArrays((size + k, size + k),
                                                   (*self.csr, self.values), comm=PETSc.COMM_SELF)

    def fill(self, base_values, columns, rows) -> None:
        self.pattern.values(base_values, columns, rows, out=self.values)
        self.mat.assemble()

    def destroy(self) -> None:
        self.mat.destroy()
