"""Start-up of a command (elastica_petsc.solvers.runtime): Open MPI's singleton
settings without a launcher, the single-node ones under Open MPI's launcher on one
node, nothing under others, never over the user's."""
from __future__ import annotations

from elastica_petsc.solvers.runtime import SINGLE_NODE_MCA, SINGLETON_MCA, mpi_defaults


def test_singleton_gets_the_fast_settings():
    env = {"PATH": "/usr/bin"}
    mpi_defaults(env)
    assert {k: env[k] for k in SINGLETON_MCA} == SINGLETON_MCA


def test_the_users_settings_win():
    env = {"OMPI_MCA_pml": "ucx"}
    mpi_defaults(env)
    assert env["OMPI_MCA_pml"] == "ucx"
    assert env["OMPI_MCA_ess_singleton_isolated"] == "1"


def test_under_another_launcher_nothing_is_set():
    for env in ({"PMIX_RANK": "0"}, {"PMI_SIZE": "2"},
                {"OMPI_COMM_WORLD_SIZE": "4", "OMPI_COMM_WORLD_LOCAL_SIZE": "2"}):
        before = dict(env)
        mpi_defaults(env)
        assert env == before


def test_open_mpi_on_one_node_gets_shared_memory_settings():
    env = {"OMPI_COMM_WORLD_SIZE": "2", "OMPI_COMM_WORLD_LOCAL_SIZE": "2", "PMIX_RANK": "1",
           "OMPI_MCA_osc": "pt2pt"}
    mpi_defaults(env)
    assert env["OMPI_MCA_pml"] == SINGLE_NODE_MCA["OMPI_MCA_pml"]
    assert env["OMPI_MCA_osc"] == "pt2pt"                      # the user's
    assert "OMPI_MCA_ess_singleton_isolated" not in env
