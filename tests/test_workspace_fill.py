"""The boundary-filled workspace map (issue 25; sampler "boundary-fill",
studies/workspace/fill.py) against the global-search sampler on small maps:
the same class for every sample, the tensions of every reached sample within
the tip-control tolerance, equal on 1 and 2 ranks, and resumable.

Maps: the paper's arm at 60 elements, the box x in [-120, 480], y in [-60, 420] mm
(the hole around r_1 and the band near y = 0 included) at 40 mm, chunks of 4.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
MPIEXEC = shutil.which("mpiexec")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")
ELEMENTS = 60
BOX = (-120.0, 480.0, -60.0, 420.0)
SPACING = 40.0
CLI_ARGS = ["--box", *map(str, BOX), "--spacing", str(SPACING), "--elements", str(ELEMENTS),
            "--chunk", "4"]
TIP_TOL_MM = 1e-5                       # tip control's tolerance (solvers/tip_problem.py)


def run(arm, sampler: str, out: Path, **kw):
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.studies.workspace import run_map

    return run_map(arm, Discretisation.from_arm(arm, ELEMENTS), box_mm=BOX, spacing_mm=SPACING,
                   chunk=4, out=out, progress=False, sampler=sampler, **kw)


def samples(path) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as fh:
        return {name: fh["samples"][name][()] for name in fh["samples"]}


def assert_same_samples(a, b) -> None:
    """Every /samples dataset except the wall times, bitwise (NaN-aware)."""
    da, db = samples(a), samples(b)
    assert set(da) == set(db)
    for name in da:
        if name.startswith("seconds_"):
            continue
        x, y = da[name], db[name]
        same = (np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f"
                else np.array_equal(x, y))
        assert same, f"/samples/{name} differs between {a} and {b}"


@pytest.fixture(scope="module")
def arm():
    from elastica_petsc.core.model import load_config
    return load_config(ROOT / "configs" / "paper.toml")


@pytest.fixture(scope="module")
def maps(arm, tmp_path_factory):
    """(global-search file, boundary-fill file) of the same grid, one rank."""
    d = tmp_path_factory.mktemp("fill")
    run(arm, "global-search", d / "global.h5")
    ws = run(arm, "boundary-fill", d / "fill.h5")
    assert ws.complete and ws.sampler == "boundary-fill"
    return d / "global.h5", d / "fill.h5"


def test_classes_equal_the_global_search_map(maps):
    """Every sample has the class of the global-search map; the grid holds every
    class the global search gives (reached, undecided, beyond reach, outside)."""
    g, f = (samples(p) for p in maps)
    np.testing.assert_array_equal(f["status"], g["status"])
    assert set(np.unique(g["status"])) >= {1, 5, 6}
    assert np.count_nonzero(f["strategy"] == b"boundary fill") >= 10


def test_tensions_within_the_tip_tolerance(arm, maps):
    """Reached samples: both tips within 1e-5 mm of the target, and the tensions
    differ by at most what that tip difference allows, |dp| <= |S^-1| |dx_t|
    (S = dx_t/dp at the global search's state, Eq. (13)), with 10 % for the
    nonlinearity; the other fields of a state agree to the same order."""
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.solvers.equilibrium import EquilibriumSolver
    from elastica_petsc.solvers.sensitivity import compute_sensitivity

    g, f = (samples(p) for p in maps)
    reached = np.flatnonzero(g["status"] == 1)
    assert np.all(f["tip_error"][reached] < TIP_TOL_MM)
    assert np.all(g["tip_error"][reached] < TIP_TOL_MM)
    solver = EquilibriumSolver(Discretisation.from_arm(arm, ELEMENTS))
    try:
        for k in reached:
            eq = solver.solve(g["tensions"][k], start=None)
            eq = eq if np.linalg.norm(eq.tip * arm.length_mm - g["tip"][k]) < 1e-6 else None
            if eq is None:               # another branch from the straight arm: skip the bound
                continue
            s_inv = np.linalg.norm(np.linalg.inv(compute_sensitivity(solver, eq).tip_jacobian), 2)
            dx = np.linalg.norm(f["tip"][k] - g["tip"][k]) / arm.length_mm
            dp = np.linalg.norm(f["tensions"][k] - g["tensions"][k])
            assert dp <= 1.1 * s_inv * dx + 1e-12, (k, dp, s_inv * dx)
    finally:
        solver.destroy()
    np.testing.assert_allclose(f["lambda_min"][reached], g["lambda_min"][reached], rtol=1e-3,
                               atol=1e-6)


def test_proofs_need_no_solve(maps):
    """Beyond reach and outside the traced boundary: classed before any solve
    (no iterations, no tip), with the proof as the reason."""
    _, f = maps
    f = samples(f)
    for code, reason in ((5, b"BEYOND_REACH"), (6, b"OUTSIDE_BOUNDARY")):
        k = f["status"] == code
        assert k.any() and np.all(f["reason"][k] == reason)
        assert np.all(f["iterations"][k] == 0) and np.all(np.isnan(f["tip"][k]))


def test_resume_of_a_partial_file_equals_the_whole_run(arm, maps, tmp_path):
    """A file whose later chunks are not done (as after an interruption) resumes
    to the map of one uninterrupted run, bit for bit."""
    _, whole = maps
    out = tmp_path / "partial.h5"
    shutil.copy(whole, out)
    with h5py.File(out, "r+") as fh:
        done = fh["grid/chunk_done"]
        flags = done[()]
        flags[len(flags) // 3:] = False
        done[...] = flags
        fh.attrs["complete"] = False
    ws = run(arm, "boundary-fill", out, resume=True)
    assert ws.complete
    assert_same_samples(whole, out)


def cli(*args, ranks: int = 1) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "elastica_petsc.cli", "workspace", *map(str, args)]
    if ranks > 1:
        cmd = [MPIEXEC, "-n", str(ranks), "--oversubscribe", *cmd]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=ENV, timeout=180)


@pytest.mark.mpi
@pytest.mark.skipif(MPIEXEC is None, reason="mpiexec not found")
def test_two_ranks_equal_one_rank(maps, tmp_path):
    """``mpiexec -n 2 elastica-petsc workspace`` (the default sampler) writes the
    samples of the one-rank map."""
    _, one = maps
    out = tmp_path / "two.h5"
    done = cli(*CLI_ARGS, "--out", out, ranks=2)
    assert done.returncode == 0, done.stderr[-2000:]
    with h5py.File(out, "r") as fh:
        assert fh.attrs["sampler"] == "boundary-fill" and fh["timing"].attrs["ranks"] == 2
    assert_same_samples(one, out)


@pytest.mark.parametrize("args, words", [
    (["--sampler", "global-search", "--local-only"], "contradicts --sampler global-search"),
    (["--sampler", "boundary-fill", "--mode", "tensions"], "--sampler applies to mode targets"),
])
def test_bad_sampler_requests_are_one_line(args, words, tmp_path):
    done = cli(*CLI_ARGS, *args, "--out", tmp_path / "x.h5")
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.strip().splitlines()[0].startswith("elastica-petsc: error:")
    assert words in done.stderr
