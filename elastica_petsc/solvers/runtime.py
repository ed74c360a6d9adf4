"""Starting PETSc for a program and naming its errors (used by the command line,
which itself builds no PETSc object)."""
from __future__ import annotations

PETSC_ERRORS = {55: "out of memory", 56: "not supported", 60: "nonconforming sizes",
                62: "invalid argument", 63: "argument out of range", 73: "object in wrong state",
                76: "error in an external library"}


def init(program: str, options: list[str], quiet_errors: bool = True) -> None:
    """``petsc4py.init`` with ``options`` (once per process, before any solver);
    ``quiet_errors``: PETSc prints no error stack, its errors are raised only
    (the caller reports them in one line: :func:`error_text`)."""
    import petsc4py
    petsc4py.init([program] + list(options))
    from petsc4py import PETSc
    if quiet_errors:
        PETSc.Sys.pushErrorHandler("ignore")


def error_text(err: BaseException) -> str | None:
    """'argument out of range' for a PETSc error, None for any other exception."""
    from petsc4py import PETSc

    if not isinstance(err, PETSc.Error):
        return None
    return PETSC_ERRORS.get(err.ierr, f"error code {err.ierr}")
