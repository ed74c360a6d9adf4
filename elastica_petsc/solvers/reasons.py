"""Why a PETSc solver stopped, as text: the one reason table of the package.

SNES, KSP, TAO, TS and SLEPc EPS report an integer converged reason; these
tables name it as PETSc does (``CONVERGED_FNORM_ABS``, ``DIVERGED_LS_FAILURE``).
Where PETSc gives one integer several names, the last one defined in
petsc4py wins (``ITERATING`` for SNES and KSP 0), except TAO's 0, named
``CONTINUE_ITERATING`` as in TAO itself.
"""
from __future__ import annotations

from functools import lru_cache

from petsc4py import PETSc


def _names(enum) -> dict[int, str]:
    return {v: k for k, v in vars(enum).items() if not k.startswith("_")}


SNES_REASONS = _names(PETSc.SNES.ConvergedReason)
KSP_REASONS = _names(PETSc.KSP.ConvergedReason)
TAO_REASONS = {**_names(PETSc.TAO.Reason), 0: "CONTINUE_ITERATING"}
TS_REASONS = _names(PETSc.TS.ConvergedReason)


@lru_cache(maxsize=1)
def eps_reasons() -> dict[int, str]:
    """SLEPc's EPS reasons (slepc4py imported only when asked)."""
    from slepc4py import SLEPc
    return _names(SLEPc.EPS.ConvergedReason)


def reason_name(table: dict[int, str], code: int) -> str:
    """The name of ``code`` in ``table``, or the integer as text if unknown."""
    return table.get(int(code), str(int(code)))


def converged_reason(obj) -> str:
    """The converged reason of a SNES, KSP, TAO, TS or EPS object, as text."""
    if isinstance(obj, PETSc.SNES):
        return reason_name(SNES_REASONS, obj.getConvergedReason())
    if isinstance(obj, PETSc.KSP):
        return reason_name(KSP_REASONS, obj.getConvergedReason())
    if isinstance(obj, PETSc.TAO):
        return reason_name(TAO_REASONS, obj.getConvergedReason())
    if isinstance(obj, PETSc.TS):
        return reason_name(TS_REASONS, obj.getConvergedReason())
    return reason_name(eps_reasons(), obj.getConvergedReason())
