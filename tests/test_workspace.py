"""Workspace maps (issue 4; paper Sec. 4.3, Eqs. (18)-(22), Figs. 4-5), run as a user does:
``elastica-petsc workspace`` in a subprocess, on 1 rank and under ``mpiexec -n 2``.

Grids are coarse (60 mm, 60 elements; tensions on a 5 x 5 lattice at 30 elements)
so that the whole file runs in well under 90 s.  The target box
x in [-120, 480], y in [60, 420] mm holds both reached targets (green in Fig. 4)
and targets outside W_0 on the P_1 < 0 side (red), and no target of the
hard band near y = 0 where the paper also reports convergence difficulties.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

pytestmark = pytest.mark.slow          # left out by scripts/test.sh --fast

ROOT = Path(__file__).resolve().parents[1]
MPIEXEC = shutil.which("mpiexec")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")
# checkpoint after every chunk (chunks.CHECKPOINT_ENV), so an interruption finds a file early
FAST_CHECKPOINTS = dict(ENV, ELASTICA_PETSC_CHECKPOINT_SECONDS="0")

ELEMENTS = 60                                                  # multiple of 3: s_1 = l/3 on a node
# the global-search sampler (the default before boundary-fill, tested against it in
# tests/test_workspace_fill.py): these tests are about its global search
LOCAL_TARGETS = ["--box", "-120", "480", "60", "420", "--spacing", "60",
                 "--elements", str(ELEMENTS), "--chunk", "4", "--local-only"]
TARGETS = LOCAL_TARGETS[:-1] + ["--sampler", "global-search"]
# a finer grid for the MPI interruptions: Open MPI passes a signal on to the ranks ~2 s
# after mpiexec receives it, so the run must last well beyond that (1581 targets: 5.5 s on
# 2 ranks; 30 mm spacing, 273 targets, took 1.6 s once tip control got faster, and the
# ranks could finish before the signal reached them)
# (--local-only: the interruption machinery is the same for both samplers, and the
# global search would make the uninterrupted reference run several times longer)
SLOW_TARGETS = ["--box", "-120", "480", "60", "420", "--spacing", "12",
                "--elements", str(ELEMENTS), "--chunk", "4", "--local-only"]
TENSIONS = ["--mode", "tensions", "--tension-spacing", "5", "--tension-max", "20",
            "--elements", "30", "--chunk", "4"]
TIMEOUT = 120
needs_mpi = pytest.mark.skipif(MPIEXEC is None, reason="mpiexec not found")


def command(*args, ranks: int = 1) -> list[str]:
    cli = [sys.executable, "-m", "elastica_petsc.cli", "workspace", *map(str, args)]
    return cli if ranks == 1 else [MPIEXEC, "-n", str(ranks), "--oversubscribe", *cli]


def workspace(*args, ranks: int = 1, env=None) -> subprocess.CompletedProcess:
    return subprocess.run(command(*args, ranks=ranks), capture_output=True, text=True,
                          cwd=ROOT, env=env or ENV, timeout=TIMEOUT)


def ok(run: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    assert run.returncode == 0, run.stderr[-3000:]
    return run


def samples(path) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as fh:
        return {name: fh["samples"][name][()] for name in fh["samples"]}


def assert_same_samples(a, b) -> None:
    """Every dataset under /samples except the wall times: bitwise, NaN-aware."""
    da, db = samples(a), samples(b)
    assert set(da) == set(db)
    compared = [name for name in da if not name.startswith("seconds_")]
    assert {"tip", "tensions", "status", "lambda_min", "lambda_min_raw"} <= set(compared)
    for name in compared:
        x, y = da[name], db[name]
        same = (np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f"
                else np.array_equal(x, y))
        assert same, f"/samples/{name} differs between {a} and {b}"


def attrs_of(path) -> dict:
    with h5py.File(path, "r") as fh:
        return dict(fh.attrs)


# --- reference runs (module scope: each is used by several tests) ----------------------
@pytest.fixture(scope="module")
def targets_1(tmp_path_factory):
    """The target grid on one rank, with --plot (Fig. 4 and Fig. 5)."""
    d = tmp_path_factory.mktemp("targets_1")
    ok(workspace(*TARGETS, "--out", d / "ws.h5", "--plot", d / "ws.png", "--json"))
    return d / "ws.h5"


@pytest.fixture(scope="module")
def local_1(tmp_path_factory):
    """The target grid on one rank without the global search (the local verdicts)."""
    d = tmp_path_factory.mktemp("local_1")
    ok(workspace(*LOCAL_TARGETS, "--out", d / "ws.h5"))
    return d / "ws.h5"


@pytest.fixture(scope="module")
def slow_targets_1(tmp_path_factory):
    d = tmp_path_factory.mktemp("slow_targets_1")
    ok(workspace(*SLOW_TARGETS, "--out", d / "ws.h5"))
    return d / "ws.h5"


@pytest.fixture(scope="module")
def tensions_1(tmp_path_factory):
    d = tmp_path_factory.mktemp("tensions_1")
    ok(workspace(*TENSIONS, "--out", d / "ws.h5"))
    return d / "ws.h5"


# --- a. MPI equals serial ------------------------------------------------------------------
@pytest.mark.mpi
@needs_mpi
@pytest.mark.parametrize("mode", ["targets", "tensions"])
def test_two_ranks_equal_one_rank(mode, targets_1, tensions_1, tmp_path):
    reference, args = (targets_1, TARGETS) if mode == "targets" else (tensions_1, TENSIONS)
    out = tmp_path / "ws2.h5"
    ok(workspace(*args, "--out", out, ranks=2))
    assert_same_samples(reference, out)
    a, b = attrs_of(reference), attrs_of(out)
    assert a["complete"] and b["complete"]
    with h5py.File(out, "r") as fh:
        assert fh["timing"].attrs["ranks"] == 2
        assert fh["grid/chunk_done"][()].all()


# --- b. interruption and resume --------------------------------------------------------------
def wait_for_checkpoint(path: Path, proc: subprocess.Popen, timeout: float = 60.0) -> int:
    """Poll the file until some chunks are stored; returns samples_done."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            pytest.fail(f"the run ended (status {proc.returncode}) before it could be "
                        "interrupted: " + proc.stderr.read()[-2000:])
        if path.exists():
            try:
                done = int(attrs_of(path)["samples_done"])
            except (OSError, KeyError):
                done = 0                                      # being replaced: try again
            if done > 0:
                return done
        time.sleep(0.01)
    pytest.fail("no checkpoint appeared")


def start(*args, ranks: int = 1) -> subprocess.Popen:
    return subprocess.Popen(command(*args, ranks=ranks), cwd=ROOT, env=FAST_CHECKPOINTS,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def finish(proc: subprocess.Popen) -> tuple[int, str]:
    """Wait for the run (no hang allowed: its process group is killed after 60 s);
    returns (exit status, stderr)."""
    try:
        _, stderr = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail("the run did not end after the signal (hang)")
    return proc.returncode, stderr


def assert_valid_partial(path: Path) -> None:
    """A partial file opens, says it is incomplete, and holds what docs/model.md §23
    guarantees whatever the moment a rank died at: every sample of a chunk flagged
    in grid/chunk_done (authoritative) and every sample whose status is set has its
    fields written; rows of chunks not flagged may hold an update that was not
    committed (a kill between the data and the commit), and are read back empty."""
    from elastica_petsc.studies.workspace.driver import read_map

    with h5py.File(path, "r") as fh:
        assert not fh.attrs["complete"]
        order, bounds = fh["grid/chunk_order"][()], fh["grid/chunk_bounds"][()]
        flagged = np.zeros(fh.attrs["samples_total"], bool)
        for c in np.flatnonzero(fh["grid/chunk_done"][()]):
            flagged[order[bounds[c]:bounds[c + 1]]] = True
        status, tip = fh["samples/status"][()], fh["samples/tip"][()]
        assert 0 < flagged.sum() < flagged.size
        assert np.all(status[flagged] > 0)
        assert np.all(np.isfinite(tip[status > 0]))
    partial = read_map(path)
    assert not partial.complete and 0 < partial.samples_done < partial.samples_total
    assert np.array_equal(partial.done, flagged)
    assert np.all(np.isnan(partial.samples["tip"][~partial.done]))
    assert np.all(partial.samples["status"][~partial.done] == 0)


def test_interrupt_and_resume_one_rank(targets_1, tmp_path):
    out = tmp_path / "ws.h5"
    proc = start(*TARGETS, "--out", out)
    wait_for_checkpoint(out, proc)
    proc.send_signal(signal.SIGINT)
    status, stderr = finish(proc)
    assert status == 130, stderr
    assert "continue with --resume" in stderr
    assert_valid_partial(out)
    ok(workspace(*TARGETS, "--out", out, "--resume"))
    assert attrs_of(out)["complete"]
    assert_same_samples(targets_1, out)


@pytest.mark.mpi
@needs_mpi
@pytest.mark.parametrize("target", ["mpiexec", "rank 0", "group", "rank 1"])
def test_interrupt_and_resume_two_ranks(target, slow_targets_1, tmp_path):
    """SIGINT to mpiexec (Open MPI passes a SIGTERM on to every rank), SIGTERM to rank 0
    or to rank 1 alone (it stops the others through the chunk counter), SIGINT to the
    whole process group (Ctrl-C): every rank stops, rank 0 writes a last checkpoint and
    the job ends; --resume completes it to the uninterrupted map (issue 15; the
    20-trial study is scripts/studies/fault_study.py)."""
    out = tmp_path / "ws.h5"
    proc = start(*SLOW_TARGETS, "--out", out, ranks=2)
    wait_for_checkpoint(out, proc)
    if target == "mpiexec":
        proc.send_signal(signal.SIGINT)
    elif target == "group":
        os.killpg(proc.pid, signal.SIGINT)
    else:
        os.kill(rank_pids(proc.pid)[int(target[-1])], signal.SIGTERM)
    status, stderr = finish(proc)
    assert status == 130 if target.startswith("rank") else status != 0
    assert "continue with --resume" in stderr
    assert_valid_partial(out)
    ok(workspace(*SLOW_TARGETS, "--out", out, "--resume", ranks=2))
    assert_same_samples(slow_targets_1, out)


def _fault_study():
    """scripts/studies/fault_study.py (its helpers find the ranks of an mpiexec)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("fault_study",
                                                  ROOT / "scripts" / "studies" / "fault_study.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def rank_pids(mpiexec_pid: int) -> dict[int, int]:
    """{rank: pid} of the processes that mpiexec started."""
    return _fault_study().rank_pids(mpiexec_pid)


@pytest.mark.mpi
@needs_mpi
@pytest.mark.parametrize("victim", [1, 0], ids=["worker", "writer"])
def test_killed_rank_ends_job_and_leaves_a_resumable_file(victim, slow_targets_1, tmp_path):
    """SIGKILL one rank (the worker, or rank 0 which writes the file): the job ends
    (no hang), the file on disk is a checkpoint (valid), and --resume completes it to
    the uninterrupted result."""
    out = tmp_path / "ws.h5"
    proc = start(*SLOW_TARGETS, "--out", out, ranks=2)
    wait_for_checkpoint(out, proc)
    pids = rank_pids(proc.pid)
    assert set(pids) == {0, 1}, pids
    os.kill(pids[victim], signal.SIGKILL)
    assert finish(proc)[0] != 0
    assert_valid_partial(out)
    ok(workspace(*SLOW_TARGETS, "--out", out, "--resume", ranks=2))
    assert_same_samples(slow_targets_1, out)


# --- c. HDF5 layout ------------------------------------------------------------------------
def test_file_layout_attributes_and_units(targets_1):
    with h5py.File(targets_1, "r") as fh:
        for key in ("kind", "config_json", "mode", "grid_json", "petsc_version",
                    "command_line", "complete", "samples_done", "samples_total", "elements"):
            assert key in fh.attrs, key
        assert fh.attrs["kind"] == "workspace" and fh.attrs["mode"] == "targets"
        assert fh.attrs["complete"] and fh.attrs["samples_done"] == fh.attrs["samples_total"]
        assert fh.attrs["elements"] == ELEMENTS
        assert json.loads(fh.attrs["config_json"])["arm"]["length_mm"] == 600.0
        assert json.loads(fh.attrs["grid_json"])["spacing"] == 60.0
        assert "--spacing 60" in fh.attrs["command_line"]
        n = int(fh.attrs["samples_total"])
        assert n == 11 * 7
        units = {"target": "mm", "tip": "mm", "tip_error": "mm", "tensions": "1",
                 "tensions_N": "N", "cable_lengths": "mm", "kappa_max": "1",
                 "lambda_min": "1", "lambda_min_raw": "1", "strain_energy": "1",
                 "iterations": "1", "status": "1", "reason": "1", "done": "1",
                 "seconds_control": "s", "seconds_eigen": "s"}
        for name, unit in units.items():
            dset = fh["samples"][name]
            assert dset.attrs["units"] == unit, name
            assert dset.attrs["description"], name
            assert dset.shape[0] == n
        assert fh["samples/tensions"].shape == (n, 2)
        for group in ("grid", "masks"):
            for name, dset in fh[group].items():
                assert "units" in dset.attrs and "description" in dset.attrs, (group, name)
        timing = dict(fh["timing"].attrs)
        assert timing["ranks"] == 1 and timing["seconds_wall"] > 0 and timing["seconds_io"] >= 0
        # masks W_0..W_P recomputed from the fields and the limits stored with them
        limits = dict(fh["masks"].attrs)
        assert limits["kappa_limit"] == pytest.approx(10.0)       # 2 eps_Y l / h (Eq. (19))
        assert limits["strain_energy_max"] == 18.0
        assert limits["max_tension"] == pytest.approx(112.9 / 0.2 * 0.36)   # P_crit l^2 / B
        s = {name: fh["samples"][name][()] for name in fh["samples"]}
        w0 = s["status"] == 1
        expected = {
            "W0": w0,
            "WY": w0 & (s["kappa_max"] < limits["kappa_limit"]),
            "WS": w0 & (s["lambda_min"] > 0),
            "WE": w0 & (s["strain_energy"] < limits["strain_energy_max"]),
            "WP": w0 & np.all(s["tensions"] < limits["max_tension"], axis=1),
            "WC": w0 & np.all(s["cable_clear"], axis=1),
        }
        for name, mask in expected.items():
            assert np.array_equal(fh["masks"][name][()], mask), name
        assert set(fh["masks"]) == set(expected) | {"sample"}    # "sample": its dimension scale
        assert 0 < expected["WE"].sum() < w0.sum()           # the energy limit cuts this grid


def test_tensions_mode_fields(tensions_1):
    s = samples(tensions_1)
    with h5py.File(tensions_1, "r") as fh:
        points = fh["grid/points"][()]
        assert fh["grid/points"].attrs["units"] == "1"
        assert "P l^2/B" in fh["grid/points"].attrs["long_name"]
        assert fh.attrs["mode"] == "tensions"
    assert len(points) == 25
    assert np.all(s["status"] == 1)                      # p_2 <= 20: no cable collapses
    assert np.all(np.isnan(s["target"])) and np.all(np.isnan(s["tip_error"]))
    np.testing.assert_array_equal(s["tensions"], points)
    assert np.allclose(s["tensions_N"], points * 0.2 / 0.36)   # B / l^2 = 0.2 / 0.6^2 N
    straight = np.all(points == 0, axis=1)
    np.testing.assert_allclose(s["tip"][straight], [[600.0, 0.0]], atol=1e-9)


# --- d. physics sanity (Fig. 4) ---------------------------------------------------------------
def test_physics_of_the_target_map(local_1):
    """The local sampler's picture (``--local-only``): reached targets and the red
    ones where tip control ended on P_1 = 0, one on each side of the P_1 = 0 locus."""
    s = samples(local_1)
    status, target, tip, p = s["status"], s["target"], s["tip"], s["tensions"]
    reached, outside = status == 1, status == 2
    assert reached.sum() >= 30 and outside.sum() >= 20 and not np.any(status == 0)
    # reached: the tip on the target within 1e-5 mm (E < eps, Sec. 4.5 (iv)), P >= 0
    assert np.all(s["tip_error"][reached] < 1e-5)
    assert np.all(np.linalg.norm(tip[reached] - target[reached], axis=1) < 1e-5)
    assert np.all(p[reached] >= 0)
    # stable (Eq. (20)): the smallest eigenvalue is positive at (almost) every reached sample
    assert np.mean(s["lambda_min"][reached] > 0) >= 0.95
    assert np.all(np.isfinite(s["lambda_min_raw"][reached]))
    # the paper's raw eigenvalue of K scales with the element size: lambda l^2/B ~ N lambda_raw
    ratio = s["lambda_min"][reached] / s["lambda_min_raw"][reached]
    assert np.all((ratio > 0.99 * ELEMENTS) & (ratio < 1.03 * ELEMENTS))
    # outside W_0 (Fig. 4, red): the closest tip is on the boundary P_1 = 0 ("require P_1 < 0")
    assert np.all(p[outside, 0] == 0.0) and np.all(p[outside, 1] > 0)
    assert np.all(s["tip_error"][outside] > 1.0)
    # ... and bound W_0 from one side: on every row and column of the grid, the reached
    # targets form one unbroken run (no red point between two green ones), and every red
    # point of a row lies left of its green ones or beyond them (over the top of the P_1 = 0
    # locus, which runs from (l, 0) up and to the left).
    for axis in (0, 1):
        for value in np.unique(target[:, 1 - axis]):
            line = np.flatnonzero(target[:, 1 - axis] == value)
            line = line[np.argsort(target[line, axis])]
            green = np.flatnonzero(reached[line])
            if green.size:
                assert np.all(reached[line][green[0]:green[-1] + 1]), (axis, value)
    for k in np.flatnonzero(outside):
        row = reached & (target[:, 1] == target[k, 1])
        if row.any() and target[k, 0] > target[row, 0].min():
            # right of green: only over the top of the locus, which passes x ~ 580 mm at
            # y ~ 130 mm (p_2 = 5) and (336, 379) mm (p_2 = 10)
            assert target[k, 1] >= 240.0, target[k]
        elif row.any():
            assert target[k, 0] < target[row, 0].min()


@pytest.mark.parametrize("fixture, codes", [("local_1", (2,)), ("targets_1", (4, 6))])
def test_outside_tips_lie_on_the_p1_zero_locus(fixture, codes, request):
    """The tip recorded for a red target (local sampler), or for an undecided or
    proven-outside one whose local solve ended on P_1 = 0 (global search), is the equilibrium at p = (0, p_2) (a
    forward solve from the straight arm reproduces it): the edge of the local picture is
    x_t(0, P_2)."""
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.equilibrium import EquilibriumSolver
    from elastica_petsc.core.fem import Discretisation

    s = samples(request.getfixturevalue(fixture))
    outside = np.flatnonzero(np.isin(s["status"], codes) & (s["reason"] == b"STATIONARY"))
    assert len(outside) >= 20
    arm = load_config(ROOT / "configs" / "paper.toml")
    solver = EquilibriumSolver(Discretisation.from_arm(arm, ELEMENTS))
    try:
        for k in outside[:: max(1, len(outside) // 8)]:
            eq = solver.solve(s["tensions"][k])
            assert eq.converged
            np.testing.assert_allclose(eq.tip * arm.length_mm, s["tip"][k], atol=1e-6)
    finally:
        solver.destroy()


def test_backward_sweep_reaches_targets_behind_a_collapse():
    """Row y = 46.68 mm from x = 23.3 to 116.7 mm, left to right: from the head guess the
    first targets end at tendon 2's collapse (under its routing point), 105 mm is
    reached; solved again backwards from their reached neighbours, 58-93 mm are reached
    too (they are in W_0; only 23-47 mm are not reached either way)."""
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import CABLE_COLLAPSE
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.studies.workspace import Status
    from elastica_petsc.studies.workspace.samplers import TargetSampler

    arm = load_config(ROOT / "configs" / "paper.toml")
    sampler = TargetSampler(arm, Discretisation.from_arm(arm, 60), global_search=False)
    try:
        points = np.column_stack([11.67 * np.arange(2, 11), np.full(9, 46.68)])
        forward = sampler.controller.solve_mm(points[3], p0=[2.0, 2.0])
        out = sampler.solve_chunk(points, lambda: False)
    finally:
        sampler.destroy()
    assert forward.reason == CABLE_COLLAPSE
    np.testing.assert_array_equal(out["status"], [Status.NOT_CONVERGED] * 3 + [Status.REACHED] * 6)
    assert np.all(out["tip_error"][3:] < 1e-5)
    assert [r.decode() for r in out["reason"][:3]] == [CABLE_COLLAPSE] * 3


# --- e. errors -------------------------------------------------------------------------------
def one_error_line(run: subprocess.CompletedProcess, *words: str) -> None:
    assert run.returncode == 2, run.stderr
    first = run.stderr.strip().splitlines()[0]
    assert first.startswith("elastica-petsc: error:"), run.stderr
    assert "Traceback" not in run.stderr and "MPI_ABORT" not in run.stderr
    for word in words:
        assert word in first, first


@pytest.mark.parametrize("ranks", [1, pytest.param(2, marks=[needs_mpi, pytest.mark.mpi])])
def test_resume_with_another_spacing_is_refused(ranks, targets_1, tmp_path):
    out = tmp_path / "ws.h5"
    shutil.copy(targets_1, out)
    changed = list(TARGETS)
    changed[changed.index("--spacing") + 1] = "50"
    run = workspace(*changed, "--out", out, "--resume", ranks=ranks)
    one_error_line(run, "cannot resume", "spacing 60.0 (now 50.0)")
    if ranks == 1:
        assert len(run.stderr.strip().splitlines()) == 1
    assert_same_samples(targets_1, out)                       # the file is untouched


@pytest.mark.parametrize("args, words", [
    (["--out", "{existing}"], ["exists", "--overwrite"]),
    ([], ["--out"]),
    (["--out", "{new}", "--box", "0", "-10", "0", "100"], ["--box", "xmin < xmax"]),
    (["--out", "{new}", "--box", "0", "100", "50", "50"], ["--box"]),
    (["--out", "{new}", "--spacing", "-5"], ["--spacing"]),
])
def test_bad_input_exits_2_with_one_line(args, words, targets_1, tmp_path):
    args = [a.format(existing=targets_1, new=tmp_path / "new.h5") for a in args]
    run = workspace("--elements", "30", *args)
    one_error_line(run, *words)
    assert len(run.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "new.h5").exists()


def test_bad_checkpoint_interval_is_an_input_error(tmp_path):
    env = dict(ENV, ELASTICA_PETSC_CHECKPOINT_SECONDS="soon")
    run = workspace(*TARGETS, "--out", tmp_path / "ws.h5", env=env)
    one_error_line(run, "ELASTICA_PETSC_CHECKPOINT_SECONDS")


# --- f. plots ----------------------------------------------------------------------------------
def test_plot_files(targets_1):
    import matplotlib.image as mpimg

    fig4 = targets_1.with_name("ws.png")
    fig5 = targets_1.with_name("ws_restrictions.png")
    for path in (fig4, fig5):
        image = mpimg.imread(path)
        assert image.shape[0] > 400 and image.shape[1] > 800, (path, image.shape)
        assert image[..., :3].std() > 0.05                    # not blank
    # Fig. 4 shows green (reached), orange (not reached after the global search) and
    # purple (proven outside the traced boundary) points
    rgb = mpimg.imread(fig4)[..., :3]
    green = (rgb[..., 1] > 0.5) & (rgb[..., 0] < 0.3) & (rgb[..., 2] < 0.3)
    orange = (rgb[..., 0] > 0.8) & (rgb[..., 1] > 0.35) & (rgb[..., 1] < 0.65) & (rgb[..., 2] < 0.2)
    purple = ((rgb[..., 0] > 0.45) & (rgb[..., 0] < 0.7) & (rgb[..., 1] > 0.3) & (rgb[..., 1] < 0.5)
              & (rgb[..., 2] > 0.6))
    assert green.sum() > 200 and orange.sum() > 50 and purple.sum() > 200


def test_fig4_legend_names_routing_points_and_reasons(targets_1):
    """The legend of Fig. 4 counts the not-converged samples by stopping reason, and the
    routing points r_i (the cable-collapse corners of the workspace) are drawn."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from elastica_petsc.plots.workspace import plot_samples, read_workspace

    data = read_workspace(targets_1)
    data["status"][:3] = 3                                   # pretend: 3 not converged
    data["reason"][:3] = [b"CABLE_COLLAPSE", b"CABLE_COLLAPSE", b"MAX_ITERATIONS"]
    fig, ax = plt.subplots()
    try:
        plot_samples(data, ax)
        labels = ax.get_legend_handles_labels()[1]
        routes = next(line for line in ax.lines if line.get_label().startswith("routing"))
    finally:
        plt.close(fig)
    assert "not converged (3: CABLE_COLLAPSE 2, MAX_ITERATIONS 1)" in labels
    assert "routing points r_1, r_2" in labels
    np.testing.assert_allclose(np.column_stack(routes.get_data()), [[46.3, -97.1], [26.1, 51.1]])


# --- g. the library entry point (issue 10) ------------------------------------------------------
def test_run_map_returns_the_arrays_without_a_file(targets_1, tmp_path, monkeypatch):
    """``run_map`` in this process, no ``out``: the same samples and masks as the
    command line's file, in mm and N, status and reasons as strings; nothing written."""
    from elastica_petsc.core.model import load_config
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.studies.workspace import run_map

    monkeypatch.chdir(tmp_path)
    arm = load_config(ROOT / "configs" / "paper.toml")
    ws = run_map(arm, Discretisation.from_arm(arm, ELEMENTS), box_mm=(-120, 480, 60, 420),
                 spacing_mm=60, chunk=4, progress=False, sampler="global-search")
    assert list(tmp_path.iterdir()) == [] and ws.file is None
    assert ws.complete and ws.samples_done == ws.samples_total == 77 and ws.ranks == 1
    reference = samples(targets_1)
    for name in ("tip", "tensions", "tensions_N", "lambda_min", "status"):
        assert np.array_equal(ws.samples[name], reference[name], equal_nan=True), name
    with h5py.File(targets_1, "r") as fh:
        for name in ("W0", "WY", "WS", "WE", "WP"):
            assert ws.masks[name].dtype == bool
            assert np.array_equal(ws.masks[name], fh["masks"][name][()]), name
    assert set(ws.status) == {"REACHED", "UNDECIDED", "BEYOND_REACH", "OUTSIDE_BOUNDARY"}
    assert ws.sampler == "global-search"
    assert np.array_equal(ws.status == "REACHED", ws.masks["W0"])
    assert ws.reason[ws.masks["W0"]][0] == "TARGET_REACHED"
    w0 = ws.masks["W0"]
    np.testing.assert_allclose(ws.tensions_N[w0], ws.tensions[w0] * arm.force_scale_N)
    assert not ws.tip_mm.flags.writeable


def test_read_map_gives_back_the_file(targets_1):
    """``read_map`` (behind ``ep.read``) rebuilds the map the command line wrote."""
    from elastica_petsc.studies.workspace import read_map

    ws = read_map(targets_1)
    assert ws.complete and ws.samples_total == 77 and ws.mode == "targets"
    reference = samples(targets_1)
    for name in ("tip", "tensions", "status", "reason", "lambda_min"):
        x = ws.samples[name]
        assert (np.array_equal(x, reference[name], equal_nan=True) if x.dtype.kind == "f"
                else np.array_equal(x, reference[name])), name
    with h5py.File(targets_1, "r") as fh:
        for name, mask in ws.masks.items():
            assert np.array_equal(mask, fh["masks"][name][()]), name
    assert ws.summary()["masks"]["W0"] == int(ws.masks["W0"].sum()) > 0


# --- h. the global search in the sampler (issue 11) ------------------------------------------
def test_global_search_changes_only_what_local_control_did_not_reach(targets_1, local_1):
    """The same grid with and without the global search: the local passes are the same,
    so every target reached locally is reached alike (bitwise); a target the local sampler
    left red (ended on P_1 = 0) is now reached, proven outside the traced boundary or
    undecided, never given a global verdict from a local run; (480, 420) mm, |x| = 638 mm > l, is proven beyond reach without a
    solve."""
    g, loc = samples(targets_1), samples(local_1)
    assert attrs_of(targets_1)["sampler"] == "global-search"
    assert attrs_of(local_1)["sampler"] == "local"
    before = loc["status"] == 1
    assert np.all(g["status"][before] == 1) and np.all(g["strategy"][before] == b"local")
    np.testing.assert_array_equal(g["tensions"][before], loc["tensions"][before])
    assert set(np.unique(g["status"])) == {1, 4, 5, 6}
    beyond = np.linalg.norm(g["target"], axis=1) > 600.0
    np.testing.assert_array_equal(g["status"] == 5, beyond)
    assert beyond.sum() == 1 and np.all(np.isnan(g["tip"][beyond]))
    assert g["reason"][beyond][0] == b"BEYOND_REACH" and g["iterations"][beyond][0] == 0
    found = (g["status"] == 1) & ~before
    assert found.sum() >= 3 and np.all(loc["status"][found] == 2)
    assert any(s.startswith(b"seed") for s in g["strategy"][found])
    assert all(s.startswith((b"seed", b"neighbour")) for s in g["strategy"][found])
    assert np.all(g["tip_error"][found] < 1e-5) and np.all(g["tensions"][found] >= 0)
    assert np.all(g["lambda_min"][found] > 0)                        # stable (Eq. (20))
    undecided = g["status"] == 4
    assert np.all(g["strategy"][undecided] == b"global search: not reached")


def test_samples_proven_outside_are_outside_the_traced_boundary(targets_1, local_1):
    """OUTSIDE_BOUNDARY (status 6) is given only to samples no local pass reached, each
    with the boundary's own proof (docs/model.md §9.1: unbounded face, farther than 3
    cells from every traced curve), and no reached tip of the map lies in that outside
    region: the sampled map and the traced boundary do not contradict each other."""
    from elastica_petsc.core.model import load_config
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.studies.boundary import trace_boundary

    arm = load_config(ROOT / "configs" / "paper.toml")
    g, loc = samples(targets_1), samples(local_1)
    outside = g["status"] == 6
    assert outside.sum() >= 3 and np.all(loc["status"][outside] != 1)
    result = trace_boundary(arm, Discretisation.from_arm(arm, ELEMENTS), restricted=False)
    assert all(result.outside(t)[0].startswith("OUTSIDE_BOUNDARY") for t in g["target"][outside])
    assert not any(result.outside(t)[0] for t in g["target"][g["status"] == 4])
    reached = g["tip"][g["status"] == 1]
    assert not result.outside_map.outside(reached).any()


def test_targets_found_by_the_search_are_in_w0(targets_1):
    """Independent check: each target reached by the global search is the tip of the
    equilibrium at its tensions loaded from the straight arm (P >= 0 throughout) in some
    loading order (Fig. 8), i.e. it lies in W_0; the local sampler had said P_1 < 0."""
    import elastica_petsc as ep
    from elastica_petsc.core.model import load_config

    arm = load_config(ROOT / "configs" / "paper.toml")
    g = samples(targets_1)
    found = np.flatnonzero((g["status"] == 1) & (g["strategy"] != b"local"))
    assert len(found) >= 3
    for k in found:
        tips = [ep.solve(arm, tensions=g["tensions"][k], order=order, elements=ELEMENTS).tip_mm
                for order in (None, [1, 2], [2, 1])]
        miss = min(float(np.linalg.norm(t - g["target"][k])) for t in tips)
        assert miss < 1e-6, (g["target"][k], tips)


def test_resume_needs_the_same_sampler_and_old_files_still_read(local_1, tmp_path):
    """A local-only file is not resumed by the global sampler (one line, exit 2); a file
    written before the sampler attribute and the strategy field existed reads back as a
    local map (``ep.read``) and resumes with --local-only."""
    import elastica_petsc as ep

    out = tmp_path / "ws.h5"
    shutil.copy(local_1, out)
    run = workspace(*TARGETS, "--out", out, "--resume")
    one_error_line(run, "cannot resume", "'local' sampler", "--local-only")
    assert_same_samples(local_1, out)
    with h5py.File(out, "r+") as fh:                         # as written before this issue
        del fh.attrs["sampler"], fh["samples/strategy"]
    old = ep.read(out)
    assert old.sampler == "local" and old.complete
    assert set(old.status) == {"REACHED", "NEEDS_NEGATIVE"} and set(old.strategy) == {""}
    ok(workspace(*LOCAL_TARGETS, "--out", out, "--resume"))
