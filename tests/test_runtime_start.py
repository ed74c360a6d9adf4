"""Start-up of a command (elastica_petsc.solvers.runtime): Open MPI's singleton
settings only without a launcher, never over the user's."""
from __future__ import annotations

from elastica_petsc.solvers.runtime import SINGLETON_MCA, singleton_mpi_defaults


def test_singleton_gets_the_fast_settings():
    env = {"PATH": "/usr/bin"}
    singleton_mpi_defaults(env)
    assert {k: env[k] for k in SINGLETON_MCA} == SINGLETON_MCA


def test_the_users_settings_win():
    env = {"OMPI_MCA_pml": "ucx"}
    singleton_mpi_defaults(env)
    assert env["OMPI_MCA_pml"] == "ucx"
    assert env["OMPI_MCA_ess_singleton_isolated"] == "1"


def test_under_a_launcher_nothing_is_set():
    for launcher in ("OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"):
        env = {launcher: "2"}
        singleton_mpi_defaults(env)
        assert env == {launcher: "2"}
