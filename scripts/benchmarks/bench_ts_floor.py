"""The floor of a `simulate` step (issue 22): PETSc TS `alpha2` driven from Python with the
solver's own configuration (SNES newtonls, basic line search, KSP preonly, a Python PC,
lagged Jacobian, a monitor) on a problem whose callbacks do almost nothing.

The problem is linear (a' + u = 0 per unknown, N + n = 182 unknowns as for the paper's arm
at 180 elements), so Newton converges in one iteration: a step is two residual calls, one
PC application and one monitor call, each a Python callback from C that builds its Vec
wrappers and numpy views.  Prints the median CPU time per step; the arm's own step needs two
Newton iterations (three residuals, two PC applications) plus the kernels' work.

    python scripts/benchmarks/bench_ts_floor.py [--repeats 5] [--steps 2000]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from petsc4py import PETSc

SIZE = 182


class _Scaling:
    """PC: divides by the shift of the (diagonal) Jacobian."""

    shift, calls = 1.0, 0

    def setUp(self, pc):
        pass

    def apply(self, pc, x, y):
        self.calls += 1
        y.setArray(x.getArray(readonly=True) / self.shift)


class _Unused:
    def mult(self, mat, x, y):                   # pragma: no cover - KSP preonly
        raise RuntimeError


def step_cpu_s(steps: int) -> float:
    pc_ctx, calls = _Scaling(), [0]
    ts = PETSc.TS().create()
    ts.setType(PETSc.TS.Type.ALPHA2)
    F = PETSc.Vec().createSeq(SIZE)

    def residual(ts_, t, U, V, A, Fv):
        calls[0] += 1
        Fv.setArray(A.getArray(readonly=True) + U.getArray(readonly=True))

    def jacobian(ts_, t, U, V, A, shift_v, shift_a, J, P):
        pc_ctx.shift = shift_a + 1.0

    J = PETSc.Mat().createPython([SIZE, SIZE], _Unused())
    J.setUp()
    ts.setI2Function(residual, F)
    ts.setI2Jacobian(jacobian, J, J)
    U, V = PETSc.Vec().createSeq(SIZE), PETSc.Vec().createSeq(SIZE)
    U.set(0.1)
    V.set(0.0)
    ts.setSolution2(U, V)
    ts.setTimeStep(0.01)
    ts.setMaxSteps(steps)
    ts.setMaxTime(1e9)
    ts.setExactFinalTime(PETSc.TS.ExactFinalTime.STEPOVER)
    ts.setOptionsPrefix("floor_")
    options = PETSc.Options("floor_")
    for key, value in (("ts_adapt_type", "none"), ("snes_type", "newtonls"),
                       ("snes_linesearch_type", "basic"), ("snes_lag_jacobian", 10),
                       ("snes_lag_jacobian_persists", True)):
        options[key] = value
    ts.setFromOptions()
    snes = ts.getSNES()
    snes.setTolerances(rtol=1e-12, atol=1e-14, stol=1e-14, max_it=30)
    ksp = snes.getKSP()
    ksp.setType("preonly")
    ksp.getPC().setType("python")
    ksp.getPC().setPythonContext(pc_ctx)
    ts.setMonitor(lambda ts_, k, t, u: None)
    start = time.process_time()
    ts.solve(U)
    cpu = time.process_time() - start
    done = ts.getStepNumber()
    ts.destroy()
    return cpu / done, calls[0] / done, pc_ctx.calls / done


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--steps", type=int, default=2000)
    args = ap.parse_args()
    step_cpu_s(100)
    runs = [step_cpu_s(args.steps) for _ in range(args.repeats)]
    per_step = statistics.median(r[0] for r in runs)
    print(f"TS alpha2 step with trivial Python callbacks, {SIZE} unknowns, {runs[0][1]:.2f} "
          f"residual calls and {runs[0][2]:.2f} PC applications per step: "
          f"{1e6 * per_step:.1f} us CPU (median of {args.repeats} x {args.steps} steps); "
          f"at 366 steps per simulated second (200 per first period) the real-time factor "
          f"cannot exceed {1 / (366 * per_step):.0f}")


if __name__ == "__main__":
    main()
