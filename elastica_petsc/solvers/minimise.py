"""Bounded minimisation of a smooth objective with TAO BLMVM, for design
studies (:mod:`elastica_petsc.studies.design`, ``design_area``).

The design vector q (mm) is scaled, q = q0 + scale_mm * X, so that TAO
works on X of order one; the bounds lo <= q <= hi become bounds on X.
The contract of :mod:`.options`: ``comm`` (one process),
``options_prefix`` (``design_``: ``-design_tao_monitor``) and
``petsc_options``.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from .options import SolverOptions, check_comm
from .reasons import converged_reason


class BoundedMinimiser:
    """TAO BLMVM and its vectors for design vectors of ``size`` entries.

    ``line_search``: TAO's line search type (as ``petsc_options``
    ``{"tao_ls_type": ...}``; ``-<prefix>tao_ls_type`` wins)."""

    def __init__(self, size: int, *, max_iterations: int, comm=None,
                 options_prefix: str = "design_", petsc_options=None,
                 line_search: str | None = None):
        defaults = {} if line_search is None else {"tao_ls_type": line_search}
        self.options = SolverOptions(options_prefix, petsc_options, defaults)
        self.comm = comm = check_comm(comm)
        self.x = PETSc.Vec().createSeq(size, comm=comm)
        self.xl, self.xu = self.x.duplicate(), self.x.duplicate()
        self.tao = PETSc.TAO().create(comm)
        self.options.label(self.tao, self.x, self.xl, self.xu)
        self.tao.setType(PETSc.TAO.Type.BLMVM)
        self.tao.setTolerances(gatol=0.0, grtol=0.0, gttol=0.0)
        self.tao.setMaximumIterations(max_iterations)     # -<prefix>tao_max_it wins
        self.tao.setMonitor(self._monitor)
        self.options.apply(self.tao)

    @staticmethod
    def _monitor(tao) -> None:
        run = tao.getAppCtx()
        run["status"]["iteration"] = tao.getIterationNumber()
        if run["done"]():
            tao.setConvergedReason(PETSc.TAO.Reason.CONVERGED_USER)

    def minimise(self, objective, q0, lo, hi, *, scale_mm: float, done=lambda: False,
                 status: dict | None = None) -> tuple[str, int]:
        """Minimise ``objective(q) -> (f, df/dq)`` from ``q0`` within lo <= q <= hi
        (mm); ``done()`` true stops it (CONVERGED_USER); ``status["iteration"]``
        follows TAO's iteration number.  Returns (TAO's reason, iterations)."""
        def form(tao, X, G) -> float:
            f, g = objective(q0 + scale_mm * X.getArray(readonly=True))
            G.setArray(np.asarray(g, float) * scale_mm)
            return float(f)

        self.options.refresh(self.tao)
        self.x.set(0.0)
        self.xl.setArray((lo - q0) / scale_mm)
        self.xu.setArray((hi - q0) / scale_mm)
        self.tao.setObjectiveGradient(form, None)
        self.tao.setVariableBounds(self.xl, self.xu)
        self.tao.setAppCtx({"status": {} if status is None else status, "done": done})
        try:
            self.tao.solve(self.x)
        finally:
            self.tao.setAppCtx(None)
        return converged_reason(self.tao), self.tao.getIterationNumber()

    def destroy(self) -> None:
        for obj in (self.tao, self.x, self.xl, self.xu):
            obj.destroy()

    def __enter__(self) -> "BoundedMinimiser":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()


def minimise_bounded(objective, q0, lo, hi, *, scale_mm: float, max_iterations: int,
                     options_prefix: str = "design_", done=lambda: False,
                     line_search: str | None = None, status: dict | None = None,
                     petsc_options=None) -> tuple[str, int]:
    """One :meth:`BoundedMinimiser.minimise` with a minimiser made and
    destroyed for it."""
    with BoundedMinimiser(len(q0), max_iterations=max_iterations, options_prefix=options_prefix,
                          petsc_options=petsc_options, line_search=line_search) as minimiser:
        return minimiser.minimise(objective, q0, lo, hi, scale_mm=scale_mm, done=done,
                                  status=status)
