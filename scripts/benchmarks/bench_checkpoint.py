"""Cost of one workspace checkpoint against the samples already in the file
(issue 25): a full write of the file (what every checkpoint did before, and
what the first and last checkpoints of a run still do) and an in-place
checkpoint of the samples finished since the previous one (io/inplace.py),
on synthetic target lattices of 1e3 ... 1e6 samples (random values, the
workspace schema with 2 tendons, chunks of 24).

Usage:
  .venv/bin/python scripts/benchmarks/bench_checkpoint.py [--sizes 1e3 1e4 1e5 1e6]
      [--new 1000] [--repeats 7] [--full-repeats 3]
  mpiexec -n 8 --oversubscribe .venv/bin/python scripts/benchmarks/bench_checkpoint.py
      --engine [--sizes 1e4 1e5 1e6] [--new 9600] [--sample-ms 10]

The first form times the writers alone (medians; ratios to the smallest size).
The second runs the chunk engine (studies/chunks.py) over the ranks: a file
holding all but ``--new`` samples is resumed with a synthetic sampler
(``--sample-ms`` of sleep per sample) and a checkpoint after every stored
chunk (rank 0 checkpoints when it stores a chunk of its own); it reports
the in-place checkpoints' median cost per size.  The sampling must outlast
the resumed run's first (full) write, 7 s or more at 1e6 samples, for rank 0
to make in-place checkpoints at all.
Prints Markdown tables.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import median_time  # noqa: E402

SPACING = 1.0
ATTRS = {"mode": "targets", "sampler": "local", "n_tendons": 2, "command_line": "bench"}
LIMITS = {"kappa_limit": 1.5, "strain_energy_max": 2.0, "max_tension": 3.0}


def lattice(size: int, chunk: int = 24):
    """A square target lattice of about ``size`` points (rows cut into chunks)."""
    from elastica_petsc.studies import chunks

    side = int(round(np.sqrt(size)))
    ny = int(np.ceil(size / side))
    x, y = np.meshgrid(SPACING * np.arange(side), SPACING * np.arange(ny))
    points = np.column_stack([x.ravel(), y.ravel()])[:size]
    rows = [np.arange(j * side, min((j + 1) * side, size)) for j in range(ny)]
    return chunks.Grid("targets", points, chunks.rows_to_chunks(rows, chunk),
                       {"spacing": SPACING})


def synthetic(schema: dict, n: int, rng) -> dict:
    """Random values of every field of ``schema`` for ``n`` samples."""
    out = {}
    for name, (shape, dtype, _, _) in schema.items():
        if dtype[0] == "f":
            out[name] = rng.random((n,) + shape)
        elif dtype[0] == "S":
            out[name] = np.full((n,) + shape, b"TARGET_REACHED", dtype)
        elif dtype[0] == "?":
            out[name] = rng.random((n,) + shape) > 0.3
        else:
            out[name] = rng.integers(1, 3, (n,) + shape).astype(dtype)
    return out


def filled(size: int, new: int):
    """Results of a lattice of ``size`` samples, all stored; the last chunks holding
    at least ``new`` samples are returned as the new ones."""
    from elastica_petsc.studies.workspace.schema import Results

    grid = lattice(size)
    results = Results(grid, 2)
    for name, values in synthetic(results.schema, size, np.random.default_rng(1)).items():
        results.data[name][...] = values
    results.chunk_done[:] = True
    lengths = np.cumsum([len(c) for c in grid.chunks[::-1]])
    count = min(int(np.searchsorted(lengths, new) + 1), len(grid.chunks))
    return results, list(range(len(grid.chunks) - count, len(grid.chunks)))


def writers(args) -> None:
    """Full write and in-place checkpoint of ``--new`` samples, per size."""
    from elastica_petsc.io import inplace

    rows = []
    with tempfile.TemporaryDirectory(dir=".") as tmp:
        out = Path(tmp) / "ws.h5"
        for size in args.sizes:
            results, new = filled(size, args.new)
            timing = {"ranks": 1, "seconds_io": 0.0, "seconds_wall": 1.0}
            attrs = dict(ATTRS, grid_json='{"spacing": 1.0}')
            repeats = args.full_repeats if size < 10 ** 6 else 1
            layouts = []
            full = median_time(lambda: layouts.append(
                results.write(out, attrs, LIMITS, timing)), repeats)
            layout = layouts[-1]
            written = []
            real = inplace._pwrite_all
            inplace._pwrite_all = lambda fd, data, offset: (
                written.append(memoryview(data).nbytes), real(fd, data, offset))
            try:
                assert results.update(layout, new, LIMITS, timing)
            finally:
                inplace._pwrite_all = real
            in_place = median_time(lambda: results.update(layout, new, LIMITS, timing),
                                   args.repeats)
            samples = sum(len(results.grid.chunks[c]) for c in new)
            rows.append((size, out.stat().st_size, full, repeats, in_place, samples,
                         sum(written), len(written)))
            del results, layout, layouts
    base = rows[0][4]
    print(f"load average {os.getloadavg()[0]:.1f}; in-place: median of {args.repeats}\n")
    print("| samples in file | file | full write (every checkpoint before) | in-place "
          "checkpoint | new samples | bytes written (pwrite calls) | in-place / smallest |")
    print("|---|---|---|---|---|---|---|")
    for size, nbytes, full, repeats, in_place, samples, written, calls in rows:
        print(f"| {size:.0e} | {nbytes / 1e6:.1f} MB | {full:.3f} s (median of {repeats}) | "
              f"{1e3 * in_place:.2f} ms | {samples} | {written} ({calls}) | "
              f"{in_place / base:.2f} |")


class Sleeper:
    """A sampler that sleeps ``seconds`` per sample and returns random values."""

    def __init__(self, schema: dict, seconds: float):
        self.schema, self.seconds = schema, seconds
        self.rng = np.random.default_rng(os.getpid())

    def solve_chunk(self, points, stop):
        time.sleep(self.seconds * len(points))
        return synthetic(self.schema, len(points), self.rng)


def engine(args) -> None:
    """The chunk engine over the ranks, resuming files of each size."""
    from mpi4py import MPI

    from elastica_petsc.studies import chunks
    from elastica_petsc.studies.workspace.schema import Results

    comm = MPI.COMM_WORLD
    rows = []
    tmp = comm.bcast(tempfile.mkdtemp(dir=".") if comm.rank == 0 else None)
    out = Path(tmp) / "ws.h5"
    for size in args.sizes:
        grid = lattice(size)
        attrs = dict(ATTRS, grid_json='{"spacing": 1.0}')
        if comm.rank == 0:
            results, new = filled(size, args.new)
            results.chunk_done[new] = False
            results.clear_undone()
            results.write(out, attrs, LIMITS, {"ranks": 1, "seconds_io": 0.0})
            del results
        comm.Barrier()
        t0 = time.perf_counter()
        results = chunks.run(grid, Sleeper(Results(grid, 2).schema, args.sample_ms / 1e3),
                             out, dict(attrs), LIMITS, comm=comm, resume=True,
                             new_results=lambda: Results(grid, 2), checkpoint_seconds=0.0)
        wall = time.perf_counter() - t0
        if comm.rank == 0:
            assert results.chunk_done.all()
            log = results.checkpoints
            places = [s for kind, _, s in log if kind == "in place"]
            fulls = [s for kind, _, s in log if kind == "full"]
            per = [n for kind, n, _ in log if kind == "in place"]
            rows.append((size, len(places), statistics.median(places or [np.nan]),
                         max(places or [np.nan]), statistics.median(per or [0]), fulls, wall))
    if comm.rank == 0:
        import shutil
        shutil.rmtree(tmp)
        print(f"{comm.size} ranks; {args.new} new samples per run, {args.sample_ms} ms each; "
              f"a checkpoint after every stored chunk; load average {os.getloadavg()[0]:.1f}\n")
        print("| samples in file | in-place checkpoints | median (max) | samples per "
              "checkpoint, median | full writes (first, last) | run wall | median / smallest |")
        print("|---|---|---|---|---|---|---|")
        base = rows[0][2]
        for size, count, med, top, per, fulls, wall in rows:
            print(f"| {size:.0e} | {count} | {1e3 * med:.2f} ms ({1e3 * top:.1f} ms) | "
                  f"{per:.0f} | {', '.join(f'{s:.2f} s' for s in fulls)} | {wall:.1f} s | "
                  f"{med / base:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[1e3, 1e4, 1e5, 1e6])
    parser.add_argument("--new", type=int, default=1000, help="new samples per checkpoint")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--full-repeats", type=int, default=3)
    parser.add_argument("--engine", action="store_true", help="the chunk engine over MPI")
    parser.add_argument("--sample-ms", type=float, default=1.0)
    args = parser.parse_args()
    args.sizes = [int(s) for s in args.sizes]
    import petsc4py
    petsc4py.init([])
    engine(args) if args.engine else writers(args)


if __name__ == "__main__":
    main()
