"""One increment of a load path with capstan friction at the guides: semismooth
Newton on PETSc SNES (docs/model.md §27).

:class:`CapstanSolver` owns a SNES (Newton with line search, prefix ``fric_``)
on the system of :class:`~elastica_petsc.core.friction.CapstanKernel`: the
guided equilibrium with one tension per segment and one complementarity
equation Phi per guide.  The residual evaluates Phi in the modes (stick, slip
either way) of the current iterate, the Jacobian is the derivative in those
modes (an element of the generalised Jacobian: an active-set Newton, no
smoothing).  The angle unknowns come first, so LU in the natural order fills
only the border (solvers/linalg.py).
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..core.friction import CapstanKernel, IncrementStart
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm
from .reasons import SNES_REASONS


# Full Newton steps: a backtracking line search on |F| (not smooth across a change of
# mode) stalled the path on configs/guided3.toml and on the closed form's arm (4-6x
# more iterations); the load increments keep the predictor within reach.
DEFAULTS = {"snes_linesearch_type": "basic"}


class CapstanSolver:
    """SNES on the friction system of one arm, reused across increments.

    Parameters
    ----------
    kernel : the arm with its friction coefficients.
    comm : one process (default ``PETSc.COMM_SELF``).
    options_prefix : PETSc options prefix of the SNES, its Jacobian and
        vectors; e.g. ``-fric_snes_monitor``.
    petsc_options : options without the prefix (nested dicts flatten); the
        command line wins.

    The motor values and the start of the current increment (``_p``, ``_start``)
    are the context of the SNES callbacks.
    """

    def __init__(self, kernel: CapstanKernel, *, comm=None, options_prefix: str = "fric_",
                 petsc_options=None):
        self.options = SolverOptions(options_prefix, petsc_options, DEFAULTS)
        self.comm = comm = check_comm(comm)
        self.kernel = kernel
        n = kernel.size
        self._p = np.zeros(kernel.disc.n_tendons)
        self._start = None
        indptr, indices = kernel.pattern
        # J keeps these arrays (no copy): the Jacobian callback writes in place
        self._values = np.zeros(len(indices))
        self.J = PETSc.Mat().createAIJWithArrays((n, n), (indptr, indices, self._values),
                                                  comm=comm)
        self.x = PETSc.Vec().createSeq(n, comm=comm)
        self.f = self.x.duplicate()
        snes = PETSc.SNES().create(comm)
        self.options.label(snes, self.J, self.x, self.f)
        snes.setType(PETSc.SNES.Type.NEWTONLS)
        snes.setFunction(self._form_function, self.f)
        snes.setJacobian(self._form_jacobian, self.J, self.J)
        self.atol = max(1e-10, 1e-14 * kernel.disc.n_elements ** 1.5)
        snes.setTolerances(rtol=1e-10, atol=self.atol, stol=1e-14, max_it=60)
        snes.setForceIteration(True)
        use_bordered_lu(snes.getKSP())
        self.options.apply(snes)
        self.snes = snes

    def _form_function(self, snes, X, F) -> None:
        F.setArray(self.kernel.residual(X.getArray(readonly=True), self._p, self._start))

    def _form_jacobian(self, snes, X, J, P) -> None:
        w = X.getArray(readonly=True)
        modes = self.kernel.modes(w, self._p, self._start)
        self._values[:] = self.kernel.jacobian_values(w, self._p, self._start, modes)
        P.assemble()

    def increment(self, w0: np.ndarray, motor, start: IncrementStart
                  ) -> tuple[np.ndarray, int, str, bool]:
        """The state at the motor values ``motor`` from the guess ``w0``, the slip at
        each guide measured from ``start`` (:meth:`CapstanKernel.start_of` the last
        state): (w, iterations, PETSc's reason, converged)."""
        self.options.refresh(self.snes)
        self._p = np.asarray(motor, float)
        self._start = start
        self.x.setArray(w0)
        self.snes.solve(None, self.x)
        reason = self.snes.getConvergedReason()
        converged = reason > 0 or self.snes.getFunctionNorm() <= self.atol
        w = self.x.getArray().copy()
        return w, self.snes.getIterationNumber(), SNES_REASONS.get(reason, str(reason)), converged

    def destroy(self) -> None:
        for obj in (self.snes, self.J, self.x, self.f):
            obj.destroy()

    def __enter__(self) -> "CapstanSolver":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()
