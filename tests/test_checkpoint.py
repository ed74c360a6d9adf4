"""Checkpoints O(new samples) (issue 25): the chunk engine writes a workspace file
in full once, then only the rows of the chunks finished since the previous
checkpoint, in place (io/inplace.py).  A synthetic sampler (values computed
from the points, no solve) keeps these tests fast; the real samplers go
through the same engine (tests/test_workspace.py, tests/test_design_area.py).

Run as a script (``mpiexec -n 2 python tests/test_checkpoint.py OUT STOP_AFTER``)
it makes one map over the ranks, stopped after STOP_AFTER chunks of rank 1
(0: not stopped), for the 2-rank test.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from elastica_petsc.io import inplace
from elastica_petsc.studies import chunks
from elastica_petsc.studies.workspace.schema import Results

ROOT = Path(__file__).resolve().parents[1]
SPACING = 10.0
ATTRS = {"mode": "targets", "sampler": "local", "grid_json": '{"spacing": 10.0}',
         "n_tendons": 2, "command_line": "test_checkpoint"}
LIMITS = {"kappa_limit": 1.5, "strain_energy_max": 2.0, "max_tension": 3.0}
# provenance of each run; object addresses of the dimension scales
VARYING_ATTRS = ("command_line", "resumed_command_lines", "DIMENSION_LIST", "REFERENCE_LIST")


def make_grid(nx: int = 23, ny: int = 9, chunk: int = 5, mode: str = "targets") -> chunks.Grid:
    """A lattice of nx * ny targets (or tensions), rows cut into chunks."""
    x, y = np.meshgrid(SPACING * np.arange(nx), SPACING * np.arange(ny))
    points = np.column_stack([x.ravel(), y.ravel()])
    rows = [np.arange(j * nx, (j + 1) * nx) for j in range(ny)]
    return chunks.Grid(mode, points, chunks.rows_to_chunks(rows, chunk),
                       {"spacing": SPACING})


class Synthetic:
    """Every field of the workspace schema as a function of the point alone;
    ``stop_after`` chunks into the run it raises a stop (as SIGINT would)."""

    def __init__(self, stop: chunks.Stop, stop_after: int = 0):
        self.stop, self.stop_after, self.done = stop, stop_after, 0

    def solve_chunk(self, points, stop):
        if self.stop_after and self.done == self.stop_after:
            self.stop.signalled = True
            return None
        self.done += 1
        return self.values(points)

    @staticmethod
    def values(points) -> dict:
        n = len(points)
        a = np.sin(points[:, 0] / 7.0 + points[:, 1] / 13.0)
        pair = np.column_stack([a, 2 * a])
        status = np.where(a > -0.3, 1, 2).astype("i1")
        return {"target": points, "tip": points + a[:, None], "tip_error": np.abs(a),
                "tensions": 3 * np.abs(pair), "tensions_N": 30 * np.abs(pair),
                "cable_lengths": 100 + pair, "kappa_max": 1 + a, "lambda_min": a,
                "lambda_min_raw": 2 * a, "strain_energy": 2 + a, "iterations": np.full(n, 3),
                "status": status, "reason": np.full(n, b"TARGET_REACHED"),
                "strategy": np.full(n, b"local"), "seconds_control": np.full(n, 1e-3),
                "seconds_eigen": np.full(n, 1e-4), "cable_clear": pair > -0.5,
                "shared": np.zeros(n, bool)}


def run(grid, out, comm=None, resume=False, stop_after=0, seconds=0.0) -> Results:
    from mpi4py import MPI

    stop = chunks.Stop()
    return chunks.run(grid, Synthetic(stop, stop_after), out, dict(ATTRS), LIMITS,
                      comm=comm or MPI.COMM_SELF, resume=resume, stop=stop,
                      new_results=lambda: Results(grid, 2), checkpoint_seconds=seconds)


def content(path) -> dict:
    """Every dataset and attribute of a file but the run's provenance and timing."""
    out = {}
    with h5py.File(path, "r") as fh:
        def visit(name, obj):
            if name == "timing":
                return
            for key, value in obj.attrs.items():
                if key not in VARYING_ATTRS:
                    out[f"{name}@{key}"] = value
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind != "O":
                out[name] = obj[()]
        visit("", fh)
        fh.visititems(visit)
    return out


def assert_same_content(a, b) -> None:
    ca, cb = content(a), content(b)
    assert set(ca) == set(cb)
    for key in ca:
        x, y = np.asarray(ca[key]), np.asarray(cb[key])
        same = (np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f"
                else np.array_equal(x, y))
        assert same, f"{key} differs between {a} and {b}"


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The grid in one uninterrupted run, checkpointed after every chunk."""
    out = tmp_path_factory.mktemp("reference") / "ws.h5"
    results = run(make_grid(), out)
    assert results.chunk_done.all()
    kinds = [kind for kind, _, _ in results.checkpoints]
    assert kinds[0] == kinds[-1] == "full" and kinds.count("in place") > 10
    return out


def assert_consistent(path, complete: bool) -> None:
    """The per-chunk flags, per-sample flags and samples_done of a file agree."""
    with h5py.File(path, "r") as fh:
        order, bounds = fh["grid/chunk_order"][()], fh["grid/chunk_bounds"][()]
        expected = np.zeros(fh.attrs["samples_total"], bool)
        for c in np.flatnonzero(fh["grid/chunk_done"][()]):
            expected[order[bounds[c]:bounds[c + 1]]] = True
        assert np.array_equal(fh["samples/done"][()], expected)
        assert fh.attrs["samples_done"] == expected.sum()
        assert bool(fh.attrs["complete"]) == complete
        status = fh["samples/status"][()]
        assert np.all(status[expected] > 0)


def test_interrupted_and_resumed_equals_uninterrupted(reference, tmp_path):
    out = tmp_path / "ws.h5"
    partial = run(make_grid(), out, stop_after=17)
    assert 0 < partial.samples_done < partial.grid.size
    assert_consistent(out, complete=False)
    assert run(make_grid(), out, resume=True).chunk_done.all()
    assert_same_content(reference, out)


@pytest.mark.parametrize("mode", ["targets", "tensions"])
def test_an_in_place_checkpoint_equals_a_full_write(mode, tmp_path):
    """The file updated in place holds what a full write of the same results holds
    (masks, map cells of a target map, samples_done, timing)."""
    grid = make_grid(mode=mode)
    results = Results(grid, 2)
    timing = {"ranks": 1, "seconds_io": 0.25, "seconds_wall": 1.0}
    half = len(grid.chunks) // 2
    for c in range(half):
        results.store(c, Synthetic.values(grid.points[grid.chunks[c]]))
    attrs = dict(ATTRS, mode=mode)
    layout = results.write(tmp_path / "a.h5", attrs, LIMITS, timing)
    for c in range(half, len(grid.chunks) - 3):
        results.store(c, Synthetic.values(grid.points[grid.chunks[c]]))
    timing.update(seconds_io=0.5, seconds_wall=2.0)
    assert results.update(layout, results.unsaved[half:], LIMITS, timing)
    results.write(tmp_path / "b.h5", attrs, LIMITS, timing)
    assert_same_content(tmp_path / "a.h5", tmp_path / "b.h5")
    with h5py.File(tmp_path / "a.h5", "r") as fh:
        assert ("map" in fh) == (mode == "targets")
        assert fh["timing"].attrs["seconds_wall"] == 2.0
        assert fh["timing"].attrs["seconds_io"] == 0.5


def written_bytes(monkeypatch) -> list[int]:
    """Bytes written by each in-place pwrite from now on."""
    sizes = []
    real = inplace._pwrite_all

    def counting(fd, data, offset):
        sizes.append(memoryview(data).nbytes)
        real(fd, data, offset)

    monkeypatch.setattr(inplace, "_pwrite_all", counting)
    return sizes


def checkpoint_bytes(done_before: int, path: Path, monkeypatch) -> tuple[list[int], int]:
    """(bytes of each pwrite, file size) of one in-place checkpoint of the 4 chunks
    116-119 (the last lattice row's end, 20 samples) of a file holding
    ``done_before`` chunks of 5 samples (of 120)."""
    grid = make_grid(nx=25, ny=24)
    results = Results(grid, 2)
    new = [116, 117, 118, 119]
    for c in list(range(done_before)) + new:
        results.store(c, Synthetic.values(grid.points[grid.chunks[c]]))
        if c == done_before - 1:
            timing = {"ranks": 1, "seconds_io": 0.0, "seconds_wall": 1.0}
            layout = results.write(path, ATTRS, LIMITS, timing)
    size = path.stat().st_size
    sizes = written_bytes(monkeypatch)
    assert results.update(layout, new, LIMITS, timing)
    monkeypatch.undo()
    assert path.stat().st_size == size
    return sizes, size


def test_a_checkpoint_writes_only_the_new_rows(tmp_path, monkeypatch):
    """The same 4 new chunks cost the same writes, of the same bytes, whether 10 or
    100 chunks are already in the file: exactly their rows (each dataset's rows
    of the 20 new samples, one pwrite per dataset as they are consecutive; their
    map cells; 4 chunk flags; 3 counters of 8 bytes)."""
    few, size_few = checkpoint_bytes(10, tmp_path / "few.h5", monkeypatch)
    many, size_many = checkpoint_bytes(100, tmp_path / "many.h5", monkeypatch)
    assert few == many and size_few == size_many
    expected, writes = 3 * 8, 3
    with h5py.File(tmp_path / "many.h5", "r") as fh:
        for group in ("samples", "masks", "map", "grid"):
            for name, dset in fh[group].items():
                lead = 2 if group == "map" else 1
                if h5py.h5ds.is_scale(dset.id):
                    continue                              # a dimension scale
                rows = {"grid": 4 if name == "chunk_done" else 0}.get(group, 20)
                row = dset.dtype.itemsize * int(np.prod(dset.shape[lead:]))
                expected += rows * row
                writes += rows > 0
    assert sum(many) == expected and len(many) == writes
    assert sum(many) < size_many * 20 / 600          # 20 of the 600 samples


@pytest.mark.parametrize("phase", ["rows", "derived", "commit", "full"])
def test_a_crash_inside_the_writer_leaves_a_resumable_file(phase, reference, tmp_path,
                                                           monkeypatch):
    """An error raised inside a checkpoint (as if the process died there) leaves a
    valid file whose done flags hold only stored chunks; resuming it gives the
    uninterrupted run's file.  ``rows``: while writing the new rows; ``derived``:
    while writing their masks (their status, written after, still says not
    computed); ``commit``: while writing the chunk flags, after their status;
    ``full``: inside the final full write, after the in-place checkpoints have
    stored every chunk."""
    out = tmp_path / "ws.h5"
    calls = {"n": 0}
    if phase == "full":
        real = Results.write

        def write(self, *args):
            calls["n"] += 1
            if calls["n"] == 2:                 # the final full write
                raise RuntimeError("crash")
            return real(self, *args)
        monkeypatch.setattr(Results, "write", write)
    else:
        real_put = inplace.Layout._put

        def put(self, fd, name, index, values):
            calls["n"] += 1
            first = {"rows": "samples/kappa_max", "derived": "masks/W0",
                     "commit": "grid/chunk_done"}[phase]
            crash = name == first and calls["n"] > 100       # a few checkpoints in
            if crash:
                raise RuntimeError("crash")
            real_put(self, fd, name, index, values)
        monkeypatch.setattr(inplace.Layout, "_put", put)
    with pytest.raises(RuntimeError, match="crash"):
        run(make_grid(), out)
    monkeypatch.undo()
    assert_consistent(out, complete=False)
    from elastica_petsc.studies.workspace.driver import read_map

    with h5py.File(out, "r") as fh:                 # rows of the chunks not committed
        done, status = fh["samples/done"][()], fh["samples/status"][()]
        written = ~done & np.isfinite(fh["samples/tip"][()]).all(axis=1)
        marked = ~done & (status > 0)
        values = {name: fh["samples"][name][()] for name in ("tip", "lambda_min", "tensions")}
    assert written.any() == (phase != "full")
    # a sample whose status says computed has all its fields written, committed or not
    assert marked.any() == (phase == "commit")
    for name, value in values.items():
        assert np.isfinite(value[marked]).all(), name
    partial = read_map(out)                          # ... are read back empty
    assert 0 < partial.samples_done < partial.samples_total or phase == "full"
    assert partial.complete == (phase == "full")     # full: every chunk stored already
    assert np.all(np.isnan(partial.samples["tip"][~partial.done]))
    assert np.all(partial.samples["status"][~partial.done] == 0)
    assert run(make_grid(), out, resume=True).chunk_done.all()
    assert_same_content(reference, out)


class SweepSynthetic(Synthetic):
    """Per-design fields of ``design --sweep`` as functions of the design alone."""

    @staticmethod
    def values(designs) -> dict:
        a = designs.sum(axis=1)
        return {"area": a ** 2, "area_converged": a > 30, "cables_clear": a > 20,
                "det_sign_changes": (a % 3).astype("i4"), "path_misfit": np.sqrt(a),
                "path_reached": np.full(len(a), -1, "i4"), "error": np.full(len(a), b""),
                "seconds": np.full(len(a), 0.5)}


def sweep(out, stop_after=0, resume=False):
    """A synthetic 9 x 7 design sweep through the chunk engine (one design per chunk)."""
    from mpi4py import MPI

    from elastica_petsc.studies.design_sweep import SweepResults

    axes = [{"name": "tendon1.attach", "values": list(range(10, 19))},
            {"name": "tendon2.route.y", "values": list(range(20, 27))}]
    points = np.array([[u, v] for u in axes[0]["values"] for v in axes[1]["values"]], float)
    grid = chunks.Grid("design-sweep", points, tuple(np.array([k]) for k in range(len(points))),
                       {"axes": axes})
    attrs = {"mode": "design-sweep", "sampler": "design-sweep",
             "grid_json": json.dumps({"axes": axes}), "command_line": "test_checkpoint"}
    stop = chunks.Stop()
    return chunks.run(grid, SweepSynthetic(stop, stop_after), out, attrs, {},
                      comm=MPI.COMM_SELF, resume=resume, stop=stop, checkpoint_seconds=0.0,
                      new_results=lambda: SweepResults(grid))


def test_the_design_sweep_is_checkpointed_in_place(tmp_path):
    """``design --sweep`` goes through the same engine: in-place checkpoints, and an
    interrupted-and-resumed sweep's file equals the uninterrupted one's."""
    whole = sweep(tmp_path / "whole.h5")
    kinds = [kind for kind, _, _ in whole.checkpoints]
    assert kinds[0] == kinds[-1] == "full" and kinds.count("in place") == len(kinds) - 2 > 50
    assert not sweep(tmp_path / "resumed.h5", stop_after=20).chunk_done.all()
    assert sweep(tmp_path / "resumed.h5", resume=True).chunk_done.all()
    assert_same_content(tmp_path / "whole.h5", tmp_path / "resumed.h5")


MPIEXEC = shutil.which("mpiexec")


@pytest.mark.mpi
@pytest.mark.skipif(MPIEXEC is None, reason="mpiexec not found")
def test_two_ranks_interrupted_and_resumed_equal_one_rank(reference, tmp_path):
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    out = tmp_path / "ws.h5"
    for stop_after in (12, 0):                   # stopped by rank 1, then resumed
        done = subprocess.run([MPIEXEC, "-n", "2", "--oversubscribe", sys.executable,
                               __file__, str(out), str(stop_after)],
                              cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr[-3000:]
        if stop_after:
            assert_consistent(out, complete=False)
    assert_same_content(reference, out)
    with h5py.File(out, "r") as fh:
        assert fh["timing"].attrs["ranks"] == 2


def main(out: str, stop_after: int) -> None:
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    run(make_grid(), Path(out), comm=comm, resume=stop_after == 0,
        stop_after=stop_after if comm.rank == 1 else 0)


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    main(sys.argv[1], int(sys.argv[2]))
