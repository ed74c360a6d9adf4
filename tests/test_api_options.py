"""The library's manners (issue 20): it prints nothing unless asked, takes PETSc
options per call (applied whether or not an earlier call solved; unread ones
refused), and runs in one process unless given a communicator."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import elastica_petsc as ep

MPI_ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")

QUIET_SCRIPT = """\
import elastica_petsc as ep
arm = ep.Arm.paper()
s = ep.solve(arm, tensions_N=[14.0, 6.0], order=(2, 1), elements=30)
ep.control(arm, [535.8, 222.6], elements=30)
ep.workspace(arm, spacing_mm=200, elements=30)
ep.boundary(arm, restricted=False, elements=30)
ep.equilibria(arm, tensions_N=[14.0, 6.0], elements=30)
"""


@pytest.mark.slow
def test_the_library_prints_nothing_unless_asked(tmp_path):
    done = subprocess.run([sys.executable, "-c", QUIET_SCRIPT], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "" and done.stderr == ""


@pytest.mark.slow
def test_progress_true_reports_on_stderr(tmp_path):
    # a log (stderr not a terminal) says nothing of a run shorter than its log_seconds
    # (ui/progress.py): set to 0 so that the test does not depend on the machine's speed
    script = ("import elastica_petsc as ep\n"
              "from elastica_petsc.ui import progress\n"
              "progress.configure(log_seconds=0)\n"
              "ep.workspace(ep.Arm.paper(), spacing_mm=100, elements=30, progress=True)\n")
    done = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "" and "workspace" in done.stderr


def test_petsc_options_apply_after_the_first_solve():
    """A first solve has set PETSc up; options of a later call still act on it:
    looser Newton tolerances take fewer iterations, and are gone afterwards."""
    arm = ep.Arm.paper()
    first = ep.solve(arm, tensions_N=[14.0, 6.0], elements=30).equilibrium
    assert first.converged
    loose = ep.solve(arm, tensions_N=[14.0, 6.0], elements=30,
                     petsc_options={"eq_snes_atol": 1e-3, "-eq_snes_rtol": 1e-3}).equilibrium
    assert loose.converged and loose.iterations < first.iterations
    again = ep.solve(arm, tensions_N=[14.0, 6.0], elements=30).equilibrium
    assert again.iterations == first.iterations
    np.testing.assert_array_equal(again.u, first.u)


def test_petsc_options_nobody_reads_are_refused():
    arm = ep.Arm.paper()
    with pytest.raises(ep.InputError, match="-eq_snes_rtoll"):
        ep.solve(arm, tensions_N=[1.0, 1.0], elements=30,
                 petsc_options={"eq_snes_rtoll": 1e-10})
    with pytest.raises(ep.InputError, match="mapping"):
        ep.solve(arm, tensions_N=[1.0, 1.0], elements=30, petsc_options=["-snes_rtol"])


# every rank solves and computes a stability first: PETSc's and SLEPc's initialisation
# and finalisation are collective over COMM_WORLD (a rank that alone started SLEPc waits
# at exit for the others forever), as in any script where all ranks use the library;
# then rank 0 alone maps the workspace
ONE_RANK_SCRIPT = """\
from mpi4py import MPI
import elastica_petsc as ep
arm = ep.Arm.paper()
ep.stability(ep.solve(arm, tensions_N=[1.0, 1.0], elements=30))
if MPI.COMM_WORLD.rank == 0:
    w = ep.workspace(arm, spacing_mm=200, elements=30)
    print("map", w.ranks, len(w.status), flush=True)
MPI.COMM_WORLD.Barrier()
"""


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="needs mpiexec")
def test_workspace_on_one_rank_of_two_runs_locally(tmp_path):
    """Under mpiexec -n 2, ep.workspace called by rank 0 alone maps in that process
    (COMM_SELF by default) instead of waiting for rank 1 forever."""
    done = subprocess.run(["mpiexec", "-n", "2", sys.executable, "-c", ONE_RANK_SCRIPT],
                          cwd=tmp_path, capture_output=True, text=True, timeout=240, env=MPI_ENV)
    assert done.returncode == 0, done.stderr
    words = done.stdout.split()
    assert words[:2] == ["map", "1"] and int(words[2]) > 0


def test_environment_variables_are_read_by_the_command_line_only():
    """Settings from the environment (checkpoint interval, progress delay) are the
    command line's; the library reads none.  Allowed: the progress UI asking the
    MPI launcher which rank it is, and workspace_job passing its environment on."""
    from pathlib import Path

    package = Path(ep.__file__).resolve().parent
    allowed = {"ui/progress.py", "studies/workspace_job.py"}
    readers = {str(p.relative_to(package)) for p in package.rglob("*.py")
               if "os.environ" in p.read_text() or "getenv" in p.read_text()}
    assert {r for r in readers if not r.startswith("cli/")} <= allowed


def test_petsc_options_of_a_call_reach_its_solver_and_are_removed_afterwards(monkeypatch):
    """One mechanism (solvers/options.py): a call's options are in PETSc's database
    while its solvers run (over an earlier value, which comes back afterwards)
    and nowhere after it; the solver reads them (looser Newton tolerances: fewer
    iterations than the same solve without them)."""
    from petsc4py import PETSc

    import elastica_petsc.solvers.equilibrium as equilibrium

    arm = ep.Arm.paper()
    plain = ep.solve(arm, tensions_N=[14.0, 6.0], elements=30).equilibrium
    opts = PETSc.Options()
    opts["eq_snes_stol"] = "1e-30"                        # set before the call (a user's)
    before = opts.getAll()
    seen = {}
    original = equilibrium.solve_equilibrium

    def spy(*args, **kwargs):
        seen.update(opts.getAll())
        return original(*args, **kwargs)

    monkeypatch.setattr(equilibrium, "solve_equilibrium", spy)
    try:
        loose = ep.solve(arm, tensions_N=[14.0, 6.0], elements=30,
                         petsc_options={"eq_snes_atol": 1e-3, "-eq_snes_stol": 1e-8,
                                        "eq": {"snes_rtol": 1e-3}}).equilibrium
        assert opts.getAll() == before                    # removed, the earlier value back
    finally:
        opts.delValue("eq_snes_stol")
    assert seen["eq_snes_atol"] == "0.001" and seen["eq_snes_stol"] == "1e-08"
    assert seen["eq_snes_rtol"] == "0.001"
    assert loose.converged and loose.iterations < plain.iterations
