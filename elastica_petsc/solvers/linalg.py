"""How the bordered systems of :mod:`elastica_petsc.core.fem` are factored.

Every matrix here has the angle unknowns first (a tridiagonal block) and a
few dense border rows and columns last.  A direct factorisation in the
natural order then fills only the border: O(N) memory and time.  Any other
ordering (PETSc's default nested dissection) may move the dense border
first and fill everything.
"""
from __future__ import annotations

from petsc4py import PETSc


def use_bordered_lu(ksp: PETSc.KSP) -> PETSc.KSP:
    """A direct solve: KSP preonly with LU in the natural order."""
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.LU)
    pc.setFactorOrdering(PETSc.Mat.OrderingType.NATURAL)
    return ksp


def bordered_ldlt(matrix: PETSc.Mat) -> PETSc.PC:
    """LDL^T (PETSc Cholesky on symmetric storage) in the natural order, for
    Sylvester inertia counts (``getFactorMatrix().getInertia()``)."""
    pc = PETSc.PC().create(matrix.getComm())
    pc.setOperators(matrix)
    pc.setType(PETSc.PC.Type.CHOLESKY)
    pc.setFactorOrdering(PETSc.Mat.OrderingType.NATURAL)
    return pc
