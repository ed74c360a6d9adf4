"""Starting PETSc for a program and naming its errors (used by the command line,
which itself builds no PETSc object)."""
from __future__ import annotations

PETSC_ERRORS = {55: "out of memory", 56: "not supported", 60: "nonconforming sizes",
                62: "invalid argument", 63: "argument out of range", 73: "object in wrong state",
                76: "error in an external library"}


def init(program: str, options: list[str], environ, quiet_errors: bool = True) -> None:
    """``petsc4py.init`` with ``options`` (once per process, before any solver),
    after :func:`mpi_defaults` in ``environ`` (the command line passes its process
    environment); ``quiet_errors``: PETSc prints no error stack, its errors are
    raised only (the caller reports them in one line: :func:`error_text`)."""
    mpi_defaults(environ)
    import petsc4py
    petsc4py.init([program] + list(options))
    from petsc4py import PETSc
    if quiet_errors:
        PETSc.Sys.pushErrorHandler("ignore")


# Set by the MPI launchers (Open MPI's mpiexec, PMIx, MPICH's hydra/PMI, Slurm's srun).
LAUNCHER_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE",
                      "SLURM_PROCID")
# Open MPI on one node (started without a launcher, or by its own mpiexec with every
# rank on this node): the ob1 transport and no UCX one-sided layer.  Probing UCX
# took 0.22 of MPI_Init's 0.36 s wall (BENCHMARKS.md, "Workspace maps and lengths
# --all at speed"); other MPI libraries ignore these variables.  Not set: the
# isolated singleton (no helper daemon, a further 0.1 s), whose processes all share
# one session directory, so that two commands started together could fail in
# MPI_Init (seen in the test suite; 6 of 200 staggered starts).
ONE_NODE_MCA = {"OMPI_MCA_pml": "ob1", "OMPI_MCA_osc": "^ucx"}


def mpi_defaults(environ) -> None:
    """Open MPI settings the user has not set, in ``environ`` (before MPI is
    initialised): :data:`ONE_NODE_MCA` without a launcher, and under Open MPI's
    launcher with all ranks on one node (``OMPI_COMM_WORLD_LOCAL_SIZE`` =
    ``OMPI_COMM_WORLD_SIZE``, the same on every rank); under any other launcher
    its environment decides."""
    launched = any(name in environ for name in LAUNCHER_VARIABLES)
    if launched and environ.get("OMPI_COMM_WORLD_LOCAL_SIZE", "") != environ.get(
            "OMPI_COMM_WORLD_SIZE"):
        return
    for name, value in ONE_NODE_MCA.items():
        environ.setdefault(name, value)


def error_text(err: BaseException) -> str | None:
    """'argument out of range' for a PETSc error, None for any other exception."""
    from petsc4py import PETSc

    if not isinstance(err, PETSc.Error):
        return None
    return PETSC_ERRORS.get(err.ierr, f"error code {err.ierr}")
