"""Starting PETSc for a program and naming its errors (used by the command line,
which itself builds no PETSc object)."""
from __future__ import annotations

import os

PETSC_ERRORS = {55: "out of memory", 56: "not supported", 60: "nonconforming sizes",
                62: "invalid argument", 63: "argument out of range", 73: "object in wrong state",
                76: "error in an external library"}


def init(program: str, options: list[str], quiet_errors: bool = True) -> None:
    """``petsc4py.init`` with ``options`` (once per process, before any solver);
    ``quiet_errors``: PETSc prints no error stack, its errors are raised only
    (the caller reports them in one line: :func:`error_text`)."""
    mpi_defaults(os.environ)
    import petsc4py
    petsc4py.init([program] + list(options))
    from petsc4py import PETSc
    if quiet_errors:
        PETSc.Sys.pushErrorHandler("ignore")


# Set by the MPI launchers (Open MPI's mpiexec, PMIx, MPICH's hydra/PMI, Slurm's srun).
LAUNCHER_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE",
                      "SLURM_PROCID")
# Open MPI started without a launcher (a singleton: one process talking to itself):
# no supporting daemon (we never spawn), the ob1 transport and no UCX one-sided
# layer.  Probing UCX and starting the daemon took 0.35 of MPI_Init's 0.47 s wall
# (BENCHMARKS.md, "Workspace maps and lengths --all at speed"); other MPI libraries
# ignore these variables.
SINGLETON_MCA = {"OMPI_MCA_ess_singleton_isolated": "1", "OMPI_MCA_pml": "ob1",
                 "OMPI_MCA_osc": "^ucx"}
# Open MPI's launcher with every rank on this node: shared memory only, so the ob1
# transport and no UCX one-sided layer likewise (0.55 -> 0.41 s for two ranks).
SINGLE_NODE_MCA = {"OMPI_MCA_pml": "ob1", "OMPI_MCA_osc": "^ucx"}


def mpi_defaults(environ) -> None:
    """Open MPI settings the user has not set, in ``environ`` (before MPI is
    initialised): :data:`SINGLETON_MCA` without a launcher,
    :data:`SINGLE_NODE_MCA` under Open MPI's launcher with all ranks on one node
    (``OMPI_COMM_WORLD_LOCAL_SIZE`` = ``OMPI_COMM_WORLD_SIZE``, the same on every
    rank); under any other launcher its environment decides."""
    if not any(name in environ for name in LAUNCHER_VARIABLES):
        chosen = SINGLETON_MCA
    elif environ.get("OMPI_COMM_WORLD_LOCAL_SIZE", "") == environ.get("OMPI_COMM_WORLD_SIZE"):
        chosen = SINGLE_NODE_MCA
    else:
        return
    for name, value in chosen.items():
        environ.setdefault(name, value)


def error_text(err: BaseException) -> str | None:
    """'argument out of range' for a PETSc error, None for any other exception."""
    from petsc4py import PETSc

    if not isinstance(err, PETSc.Error):
        return None
    return PETSC_ERRORS.get(err.ierr, f"error code {err.ierr}")
