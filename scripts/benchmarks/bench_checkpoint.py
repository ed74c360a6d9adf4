"""Cost of one workspace checkpoint (issue 15): the whole file built in memory and
written with one synced write (``io.hdf5.atomic_h5``, what the code does), against
HDF5 writing the temporary file on disk itself (the previous way, which a full
disk turned into HDF5 errors at close).  The paper's grid: 4202 targets.

Usage: .venv/bin/python scripts/benchmarks/bench_checkpoint.py [--repeats 7]
Prints a Markdown table (medians, interleaved) and the ratio.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import median_time  # noqa: E402


@contextlib.contextmanager
def h5_on_disk(path, overwrite=False):
    """The previous writer: h5py writes the temporary file, then a rename."""
    import h5py

    tmp = Path(path).with_name(f".{Path(path).name}.tmp-{os.getpid()}")
    with h5py.File(tmp, "w") as fh:
        yield fh
    os.replace(tmp, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    import petsc4py
    petsc4py.init([])
    from elastica_petsc.core.model import load_config
    from elastica_petsc.io import hdf5
    from elastica_petsc.io.workspace import write_results
    from elastica_petsc.studies.workspace import driver
    from elastica_petsc.studies.workspace.grids import target_grid
    from elastica_petsc.studies.workspace.schema import Results, limits_of

    arm = load_config(None)
    grid = target_grid(arm.length_mm, 11.67)
    results = Results(grid, 2)
    rng = np.random.default_rng(1)
    for c in range(len(grid.chunks)):
        n = len(grid.chunks[c])
        results.store(c, {name: rng.random((n,) + shape).astype(dtype) if dtype[0] == "f"
                          else np.ones((n,) + shape, dtype)
                          for name, (shape, dtype, _, _) in results.schema.items()})
    attrs = driver.map_attrs(arm, type("D", (), {"n_elements": 180, "n_tendons": 2})(), grid, None)
    limits = limits_of(arm)
    timing = {"ranks": 1, "seconds_io": 0.0, "seconds_wall": 1.0}
    with tempfile.TemporaryDirectory(dir=".") as tmp:
        out = Path(tmp) / "ws.h5"
        memory, disk = [], []
        for _ in range(args.repeats):                   # interleaved
            memory.append(median_time(lambda: write_results(out, results, attrs, limits,
                                                            timing), 1))
            real = hdf5.atomic_h5
            hdf5.atomic_h5 = h5_on_disk
            try:
                disk.append(median_time(lambda: write_results(out, results, attrs, limits,
                                                              timing), 1))
            finally:
                hdf5.atomic_h5 = real
        size = out.stat().st_size
    m, d = float(np.median(memory)), float(np.median(disk))
    print(f"grid: {grid.size} samples; file {size / 1e6:.2f} MB; {args.repeats} repeats, "
          f"interleaved; load average {os.getloadavg()[0]:.1f}\n")
    print("| writer | checkpoint, median | min-max |\n|---|---|---|")
    print(f"| in memory, one synced write (current) | {1e3 * m:.1f} ms | "
          f"{1e3 * min(memory):.1f}-{1e3 * max(memory):.1f} ms |")
    print(f"| HDF5 writes the file itself (previous) | {1e3 * d:.1f} ms | "
          f"{1e3 * min(disk):.1f}-{1e3 * max(disk):.1f} ms |")
    print(f"\nratio current / previous: {m / d:.2f}")


if __name__ == "__main__":
    main()
