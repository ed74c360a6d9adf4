#!/usr/bin/env python3
"""Cost of the workspace boundary by continuation against the sampled map (issue 13).

Runs :func:`elastica_petsc.studies.boundary.trace_boundary` on the paper's arm
(180 elements, one rank) ``--repeat`` times for W_0 alone and for W_0 plus
the restricted workspace; prints the median wall time (min, max) and the
number of continuation solves, and their ratio to the 4,202 targets of the
sampled Fig. 4 map.  With ``--samples WS.h5`` (from ``mpiexec -n 2
elastica-petsc workspace --spacing 11.67 --out WS.h5``) also the agreement of
the W_0 polygon with the map and the map's own wall time and optimiser
iterations (each iteration solves at least one equilibrium).

Usage: bench_boundary.py [--repeat R] [--samples WS.h5]
"""
from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--samples", metavar="H5")
    args = parser.parse_args()
    import petsc4py
    petsc4py.init([])
    from elastica_petsc.core.config import load_config
    from elastica_petsc.studies.boundary import compare_with_samples, trace_boundary

    arm = load_config()
    rows = []
    for restricted in (False, True):
        times, result = [], None
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            result = trace_boundary(arm, restricted=restricted, tip_folds=False)
            times.append(time.perf_counter() - t0)
        rows.append((restricted, statistics.median(times), min(times), max(times), result))
    print("| regions | wall time, median (min-max) | continuation solves | solves / 4202 |")
    print("|---|---|---|---|")
    for restricted, med, lo, hi, result in rows:
        name = "W_0 + restricted" if restricted else "W_0"
        print(f"| {name} | {med:.2f} s ({lo:.2f}-{hi:.2f}) | {result.solves} | "
              f"{result.solves / 4202:.1%} |")
    result = rows[-1][-1]
    print(f"\nareas: W_0 {result.areas_mm2['W0']:.0f} mm^2, restricted "
          f"{result.areas_mm2['restricted']:.0f} mm^2; loops: "
          + "; ".join(f"{k}: " + " -> ".join(c.constraint for c in r.curves)
                      for k, r in result.regions.items()))
    if args.samples:
        import h5py
        with h5py.File(args.samples, "r") as fh:
            status = fh["samples/status"][()]
            targets = fh["samples/target"][()]
            spacing = json.loads(fh.attrs["grid_json"])["spacing"]
            iterations = int(np.sum(fh["samples/iterations"][()]))
            wall = float(fh["timing"].attrs.get("seconds_wall", np.nan))
            ranks = int(fh["timing"].attrs.get("ranks", 0))
        agreement = compare_with_samples(result.polygons_mm["W0"][0], targets, status, spacing)
        print(f"\nsampled map: {len(status)} targets, {iterations} optimiser iterations, "
              f"{wall:.1f} s on {ranks} rank(s)")
        print(json.dumps(agreement, indent=1))


if __name__ == "__main__":
    main()
