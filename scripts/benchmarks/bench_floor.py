"""The warm forward solve against the bare petsc4py SNES floor (issue 25), same process.

    .venv/bin/python scripts/benchmarks/bench_floor.py [--repeats 7] [--calls 200]

The floor: a nonlinear tridiagonal system of the same size as the paper's arm
(N = 180 unknowns), F_k = (2 x_k - x_{k-1} - x_{k+1}) / h + h sin x_k - h f_k
(x_0 = 0, a free end like the arm's), solved by the same SNES (Newton line
search, LU in the natural order, the equilibrium solver's tolerances) with
Python callbacks that assemble a CSR Jacobian, from a nearby solution so that
Newton takes 3 iterations like the warm solve.  That is the least any Python
driver of PETSc pays for such a solve.

The forward solve: :meth:`EquilibriumSolver.solve` of the paper's arm at 180
elements, p = (25.2, 10.8), warm-started from the equilibrium at p + 0.1 (3
Newton iterations, 1 load step, plus the inertia check); and the cold solve
from the straight arm.  Each round times ``--calls`` single calls of each and
keeps their median (a shared machine preempts some calls; the median is the
undisturbed solve); the report is the median over ``--repeats`` rounds, and
the ratio is taken within each round (the floor and the solve alternate, so
they run under the same load).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np
from petsc4py import PETSc

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.linalg import use_bordered_lu

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from timing import median_time  # noqa: E402

P = np.array([25.2, 10.8])
N = 180


class Floor:
    """The bare SNES solve of the tridiagonal system above."""

    def __init__(self, n: int = N, load: float = 30.0):
        self.h = 1.0 / n
        self.f = np.full(n, load)
        k = np.arange(n)
        cols = np.concatenate((k[k > 0] - 1, k, k[k < n - 1] + 1))
        rows = np.concatenate((k[k > 0], k, k[k < n - 1]))
        order = np.lexsort((cols, rows))
        self.rows, self.cols = rows[order], cols[order]
        self.indptr = np.searchsorted(self.rows, np.arange(n + 1)).astype(np.int32)
        self.indices = self.cols.astype(np.int32)
        self.diag = self.rows == self.cols
        self.offdiag = np.where(self.diag, 0.0, -1.0 / self.h)
        self.stiff = np.full(n, 2.0 / self.h)
        self.stiff[-1] = 1.0 / self.h                  # free end
        self.J = PETSc.Mat().createAIJ(size=(n, n), csr=(self.indptr, self.indices,
                                                          self.values(np.zeros(n))))
        self.x = PETSc.Vec().createSeq(n)
        self.r = self.x.duplicate()
        snes = PETSc.SNES().create(PETSc.COMM_SELF)
        snes.setType(PETSc.SNES.Type.NEWTONLS)
        snes.setFunction(self.function, self.r)
        snes.setJacobian(self.jacobian, self.J, self.J)
        snes.setTolerances(rtol=1e-10, atol=1e-10, stol=1e-14, max_it=40)
        snes.setForceIteration(True)
        use_bordered_lu(snes.getKSP())
        self.snes = snes

    def residual(self, x):
        lap = self.stiff * x
        lap[1:] -= x[:-1] / self.h
        lap[:-1] -= x[1:] / self.h
        return lap + self.h * (np.sin(x) - self.f)

    def values(self, x):
        v = self.offdiag.copy()
        v[self.diag] = self.stiff + self.h * np.cos(x)
        return v

    def function(self, snes, X, F):
        F.setArray(self.residual(X.getArray(readonly=True)))

    def jacobian(self, snes, X, J, P):
        P.setValuesCSR(self.indptr, self.indices, self.values(X.getArray(readonly=True)))
        P.assemble()

    def solve(self, x0, load):
        self.f[:] = load
        self.x.setArray(x0)
        self.snes.solve(None, self.x)
        return self.x.getArray().copy(), self.snes.getIterationNumber()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--calls", type=int, default=200)
    args = parser.parse_args()
    floor = Floor()
    near, _ = floor.solve(np.zeros(N), 30.3)
    x, floor_its = floor.solve(near, 30.0)
    with EquilibriumSolver(Discretisation.from_arm(load_config())) as solver:
        start = solver.solve(P + 0.1)
        warm = solver.solve(P, start=start)
        cold = solver.solve(P)
        assert warm.converged and cold.converged
        t_floor, t_warm, t_cold, cpu_cold = [], [], [], []
        for _ in range(args.repeats):
            t_floor.append(median_time(lambda: floor.solve(near, 30.0), args.calls))
            t_warm.append(median_time(lambda: solver.solve(P, start=start), args.calls))
            t_cold.append(median_time(lambda: solver.solve(P), max(3, args.calls // 20)))
            cpu_cold.append(median_time(lambda: solver.solve(P), max(3, args.calls // 20),
                                        clock=time.process_time))
    floor_ms, warm_ms, cold_ms = (statistics.median(t) * 1e3 for t in (t_floor, t_warm, t_cold))
    ratios = [w / f for w, f in zip(t_warm, t_floor)]
    print(f"load average {os.getloadavg()[0]:.2f}; median of {args.repeats} rounds of "
          f"{args.calls} calls each (cold: {max(3, args.calls // 20)})")
    print("| solve | median time | Newton iterations |")
    print("|---|---|---|")
    print(f"| floor: bare SNES, {N} unknowns, tridiagonal | {floor_ms:.3f} ms | {floor_its} |")
    print(f"| warm forward solve (N = 180, from p + 0.1, with the inertia check) | "
          f"{warm_ms:.3f} ms | {warm.iterations} |")
    print(f"| cold forward solve (from the straight arm) | {cold_ms:.3f} ms | "
          f"{cold.iterations} ({cold.load_steps} load steps); CPU time "
          f"{statistics.median(cpu_cold) * 1e3:.3f} ms |")
    print(f"\nwarm / floor = {statistics.median(ratios):.2f} (median of the per-round ratios; "
          f"range {min(ratios):.2f}-{max(ratios):.2f}; target <= 2)")


if __name__ == "__main__":
    main()
