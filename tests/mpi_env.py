"""The environment for a child `mpiexec` started by a test."""
import os

ROOT_AND_OVERSUBSCRIBE = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
                          "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def mpi_env() -> dict:
    """os.environ without what an MPI run in this process left behind (a
    singleton's OMPI_/PMIX_/OPAL_ variables would make a child mpiexec fail),
    with Open MPI allowed to run as root and to oversubscribe the 2 cores, so
    that a test passes under plain pytest as under scripts/test.sh."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("OMPI_", "PMIX_", "OPAL_"))}
    env.update(ROOT_AND_OVERSUBSCRIBE)
    return env
