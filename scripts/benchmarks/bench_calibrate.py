"""Benchmarks of calibrate (issue 23): the 40-row fit of the perturbed paper arm,
the cost of one Gauss-Newton evaluation (residuals + exact Jacobian, warm rows)
against the number of rows, and a large fit on 1 or more MPI ranks.

    .venv/bin/python scripts/benchmarks/bench_calibrate.py fit40 [elements] [repeats]
    .venv/bin/python scripts/benchmarks/bench_calibrate.py scaling [elements]
    .venv/bin/python scripts/benchmarks/bench_calibrate.py iterations [elements] [repeats]
    mpiexec -n R .venv/bin/python scripts/benchmarks/bench_calibrate.py large [rows] [elements]

Synthetic data (0.5 mm noise) as in tests/test_calibrate.py; medians of repeats.
"""
from __future__ import annotations

import dataclasses
import statistics
import sys
import time

import numpy as np

from elastica_petsc.core.calibration_params import ParameterModel
from elastica_petsc.core.model import Arm
from elastica_petsc.studies.calibrate import CalibrationProblem, fit
from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize

VARY = ["bending_stiffness", "tendon1.route", "tendon2.route", "motor1.offset", "motor2.offset"]


def dataset(rows: int, elements: int, seed: int = 1):
    arm = dataclasses.replace(Arm.paper(), elements=elements)
    model = ParameterModel(arm, VARY)
    truth = model.start().copy()
    truth[0] *= 1.15
    truth[1:5] += [3.0, -4.0, -3.5, 4.5]
    truth[5:7] = 2.0
    rng = np.random.default_rng(seed)
    P = np.column_stack((rng.uniform(1, 9, rows), rng.uniform(0.5, 5, rows)))
    kinds = ["tension"] * (rows // 2) + ["length"] * (rows - rows // 2)
    data = synthesize(arm, VARY, truth, command_rows(arm, P, kinds), noise_mm=0.5, seed=3)
    return model, data


def fit40(elements: int = 180, repeats: int = 3) -> None:
    model, data = dataset(40, elements)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fit(CalibrationProblem(model, data))
        times.append(time.perf_counter() - t0)
    print(f"40 rows, {elements} elements: median {statistics.median(times):.2f} s of "
          f"{repeats} ({result.iterations} GN iterations, {result.evaluations} evaluations, "
          f"{result.reason})")


def scaling(elements: int = 180) -> None:
    base = None
    for rows in (25, 50, 100, 200, 400):
        model, data = dataset(rows, elements)
        problem = CalibrationProblem(model, data)
        problem.match_branches(model.start())
        theta = model.start() * (1 + 1e-3)
        problem.evaluate(theta)                       # states at the first point
        times = []
        for k in range(3):
            t0 = time.perf_counter()
            problem.evaluate(theta * (1 + 1e-4 * (k + 1)))   # warm, as in a GN iteration
            times.append(time.perf_counter() - t0)
        t = statistics.median(times)
        base = base or t / rows
        print(f"{rows:4d} rows: {t:.3f} s per evaluation, {1e3 * t / rows:.2f} ms per row "
              f"(x {t / rows / base:.2f} of the 25-row cost per row)")


def iterations(elements: int = 60, repeats: int = 3) -> None:
    """Whole fits (branch matching, TAO BRGN to convergence) against the rows: the
    cost of one Gauss-Newton iteration, fit time / iterations, wall and CPU
    (median of ``repeats``), and the evaluations each iteration needs."""
    base = None
    for rows in (25, 50, 100, 200, 400):
        model, data = dataset(rows, elements)
        walls, cpus = [], []
        for _ in range(repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            result = fit(CalibrationProblem(model, data))
            walls.append((time.perf_counter() - t0) / result.iterations)
            cpus.append((time.process_time() - c0) / result.iterations)
        cpu = statistics.median(cpus)
        base = base or cpu / rows
        print(f"{rows:4d} rows: {result.iterations} GN iterations, {result.evaluations} "
              f"evaluations; per iteration {statistics.median(walls):.3f} s wall, {cpu:.3f} s "
              f"CPU, {1e3 * cpu / rows:.2f} ms CPU per row (x {cpu / rows / base:.2f} of the "
              f"25-row cost per row)")


def large(rows: int = 2000, elements: int = 60) -> None:
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    model, data = dataset(rows, elements)
    comm.Barrier()
    t0, c0 = time.perf_counter(), time.process_time()
    result = fit(CalibrationProblem(model, data, comm=comm if comm.size > 1 else None))
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    cpus = comm.gather(cpu)
    if comm.rank == 0:
        print(f"{rows} rows, {elements} elements, {comm.size} rank(s): {seconds:.1f} s wall, "
              f"CPU per rank " + ", ".join(f"{c:.1f}" for c in cpus) + " s "
              f"({result.iterations} GN iterations, {result.evaluations} evaluations)")


if __name__ == "__main__":
    what, rest = sys.argv[1], [int(v) for v in sys.argv[2:]]
    {"fit40": fit40, "scaling": scaling, "iterations": iterations, "large": large}[what](*rest)
