"""Bounded nonlinear least squares with PETSc TAO, for the calibration
(docs/model.md §14): minimise |r(X)|^2 / 2 over lo <= X <= hi.

``method`` "brgn": TAO BRGN (bounded regularised Gauss-Newton) with the exact
Jacobian, converged (CONVERGED_USER) when an iteration of its subsolver moves
no variable by more than ``step_tol`` or lowers the objective by less than
:data:`F_RTOL` of itself (the gradient cannot fall below the round-off of the
residuals).  "pounders": TAO POUNDERS, derivative-free (residuals only),
converged on its model gradient.  A trial point the caller cannot evaluate
(it raises one of ``failures``) gets residuals of :data:`FAILED_RESIDUAL`, so
the step is refused.  The contract of :mod:`.options`: one process
(``COMM_SELF``), TAO's options under ``prefix`` (BRGN's subsolver under
``prefix + "brgn_"``).
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from .reasons import TAO_REASONS, reason_name

# BRGN: converged once the objective fell by less than this fraction of itself.
F_RTOL = 1e-10
# Residual reported for a trial point that cannot be evaluated.
FAILED_RESIDUAL = 1e6
# POUNDERS: stop on this gradient of its model ...
POUNDERS_GATOL = 1e-9
POUNDERS_GRTOL = 1e-10           # ... or on |g| / f (residuals that do not vanish)
# ... or after max_iterations x this x variables iterations.
POUNDERS_ITERATIONS_PER_PARAMETER = 4
METHODS = ("brgn", "pounders")


def bounded_least_squares(evaluate, size: int, n_residuals: int, lo, hi, *,
                          method: str = "brgn", max_iterations: int = 50,
                          step_tol: float = 1e-7, failures: tuple = (),
                          on_failure=None, prefix: str = "calib_"):
    """Minimise |r(X)|^2 / 2 from X = 0 within [lo, hi] (module docstring).

    ``evaluate(X, jacobian)`` returns (r, J) (J None unless ``jacobian``);
    it is called once per distinct trial point.  ``on_failure()`` is called
    for each trial point that raised one of ``failures``.  Returns (X, TAO's
    reason name, iterations)."""
    M, P_ = n_residuals, size
    cache: dict = {}

    def at(X):
        key = X.getArray(readonly=True).tobytes()
        if cache.get("key") != key:
            r, J = evaluate(X.getArray(readonly=True).copy(), method == "brgn")
            cache.update(key=key, r=r, J=J)
        return cache

    def residual(tao, X, R):
        try:
            R.setArray(at(X)["r"])
        except failures:                     # a trial step too far: make it look bad
            if on_failure is not None:
                on_failure()
            R.setArray(np.full(M, FAILED_RESIDUAL))

    def jacobian(tao, X, J, P):
        try:
            values = at(X)["J"].ravel()
        except failures:                     # the failed trial point of residual()
            values = np.zeros(M * P_)
        J.setValues(range(M), range(P_), values)
        J.assemble()

    previous = {}

    def monitor(t) -> None:
        X = t.getSolution().getArray(readonly=True)
        f, step = t.getObjectiveValue(), t.getSolutionStatus()[4]
        if "X" in previous and step > 0 and (np.max(np.abs(X - previous["X"])) <= step_tol
                                             or previous["f"] - f <= F_RTOL * previous["f"]):
            t.setConvergedReason(PETSc.TAO.Reason.CONVERGED_USER)
        previous.update(X=X.copy(), f=f)

    x = PETSc.Vec().createSeq(P_, comm=PETSc.COMM_SELF)
    x.set(0.0)
    R = PETSc.Vec().createSeq(M, comm=PETSc.COMM_SELF)
    Jm = PETSc.Mat().createDense((M, P_), comm=PETSc.COMM_SELF)
    Jm.setUp()
    xl, xu = x.duplicate(), x.duplicate()
    xl.setArray(lo)
    xu.setArray(hi)
    tao = PETSc.TAO().create(PETSc.COMM_SELF)
    tao.setOptionsPrefix(prefix)
    tao.setType(method)
    tao.setResidual(residual, R)
    if method == "brgn":
        tao.setJacobianResidual(jacobian, Jm, Jm)
    tao.setVariableBounds(xl, xu)
    tao.setFromOptions()
    inner = tao.getBRGNSubsolver() if method == "brgn" else tao   # BRGN iterates inside
    if method == "brgn":
        inner.setOptionsPrefix(prefix + "brgn_")      # PETSc 3.18 gives it no prefix of ours
        inner.setFromOptions()
        inner.setTolerances(gatol=1e-12, grtol=1e-14, gttol=0.0)
        inner.setMaximumIterations(max_iterations)
        inner.setMonitor(monitor)
    else:
        tao.setTolerances(gatol=POUNDERS_GATOL, grtol=POUNDERS_GRTOL, gttol=0.0)
        tao.setMaximumIterations(POUNDERS_ITERATIONS_PER_PARAMETER * P_ * max_iterations)
    try:
        tao.solve(x)
        X = x.getArray(readonly=True).copy()
        reason = inner.getConvergedReason()
        return X, reason_name(TAO_REASONS, reason), inner.getIterationNumber()
    finally:
        for obj in (tao, x, R, Jm, xl, xu):
            obj.destroy()
