"""Start-up of a command (elastica_petsc.solvers.runtime): Open MPI's one-node
settings without a launcher and under Open MPI's launcher on one node, nothing
under others, never over the user's, never the isolated singleton (its processes
share one session directory: two commands started together could fail)."""
from __future__ import annotations

from elastica_petsc.solvers.runtime import ONE_NODE_MCA, mpi_defaults


def test_without_a_launcher_the_one_node_settings():
    env = {"PATH": "/usr/bin"}
    mpi_defaults(env)
    assert {k: env[k] for k in ONE_NODE_MCA} == ONE_NODE_MCA
    assert "OMPI_MCA_ess_singleton_isolated" not in env


def test_the_users_settings_win():
    env = {"OMPI_MCA_pml": "ucx"}
    mpi_defaults(env)
    assert env["OMPI_MCA_pml"] == "ucx"
    assert env["OMPI_MCA_osc"] == ONE_NODE_MCA["OMPI_MCA_osc"]


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
    assert env["OMPI_MCA_pml"] == ONE_NODE_MCA["OMPI_MCA_pml"]
    assert env["OMPI_MCA_osc"] == "pt2pt"                      # the user's
