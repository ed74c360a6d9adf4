"""The smallest eigenvalues of a sequence of neighbouring equilibria, with SLEPc
(workspace maps; docs/model.md §2, §3 and "SLEPc along a sweep", §29).

A workspace map records, for every state reached, the two numbers of
:class:`~.stability.StabilitySolver` that it keeps: lambda_min of
K v = lambda M v (lumped mass, Sec. 4.3 (ii)) and the raw lambda_min(K) / (B/l)
(Fig. 5b, M = I).  :class:`SweepStability` computes the same two eigenvalues
with the same pencil (the bordered SNES Jacobian A = [[T, B], [C, I]] against
diag(M, 0)), the same Krylov-Schur solver with shift-and-invert and the same
tolerance, and differs in how it gets there cheaply, one state after the other:

* one EPS per mass for the whole sweep (``setOperators`` on the reassembled
  matrix, no re-creation) and one shared KSP/LU: both spectral transforms
  invert the same A - sigma Mb, so the second solve reuses the first one's
  factorisation;
* the shift sigma = 0 when the LDL^T inertia of H (:class:`InertiaCounter`)
  finds K positive definite: every eigenvalue is then > 0 and the one closest
  to 0 is the smallest.  (:class:`StabilitySolver` shifts to -1 and -h; the raw
  pencil's eigenvalues are O(h), so its shift at -h separates them poorly.)
  With negative eigenvalues, the Gershgorin lower bound of (T, M) minus one
  unit, as there;
* a warm start: each solve starts from the eigenvector of the previous one
  (a grid neighbour), so one Krylov-Schur restart with ``ncv`` = 6 basis
  vectors converges (``restart`` goes back to the fixed start vector of
  :class:`StabilitySolver`: a map's results depend on its chunk alone);
* no eigenvectors, modes, asymmetry estimate or result object, and no
  options lookup per solve (the options under the prefix are read once).

The eigenvalues agree with :meth:`StabilitySolver.solve` within the solver
tolerance (relative differences about 2e-11, tests/test_sweep_stability.py).
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc
from slepc4py import SLEPc

from ..core.fem import Discretisation
from .inertia import InertiaCounter
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm
from .reasons import eps_reasons, reason_name
from .stability import StabilityError, diagonal_matrix, gershgorin_lower_bound


class SweepStability:
    """(lambda_min, raw lambda_min) of K(u, p) along a sweep of neighbouring
    states (module doc), on ``PETSc.COMM_SELF``.

    ``tol``: SLEPc's relative residual tolerance (that of
    :class:`StabilitySolver`); ``ncv``: Krylov basis size (``-<prefix>eps_ncv``
    overrides).  Options prefix ``stab_`` (``-stab_eps_view``), the raw solve
    ``stab_raw_``; options are read at construction.
    """

    def __init__(self, disc: Discretisation, *, tol: float = 1e-12, ncv: int = 6,
                 comm=None, options_prefix: str = "stab_", petsc_options=None):
        self.disc = disc
        self.options = SolverOptions(options_prefix, petsc_options)
        self.comm = check_comm(comm)
        N = disc.n_elements
        self._csr = disc.pattern[:2]
        size = disc.size
        n_border = size - N
        self.mass = np.full(N, disc.h)
        self.mass[-1] *= 0.5                              # lumped: h, ..., h, h/2
        self._ones = np.ones(N)                           # the raw pencil's weights
        # A keeps this array (no copy): each solve writes the Jacobian's values in place
        self._values = disc.jacobian_values(disc.straight(), np.zeros(disc.n_tendons))
        self.A = PETSc.Mat().createAIJWithArrays((size, size), (*self._csr, self._values),
                                                 comm=self.comm)
        self.B = diagonal_matrix(np.concatenate((self.mass, np.zeros(n_border))))
        self.B_raw = diagonal_matrix(np.concatenate((np.ones(N), np.zeros(n_border))))
        self.options.label(self.A, self.B)
        self._v0 = np.random.default_rng(2019).standard_normal(size)   # as StabilitySolver
        self.eps = self._make_eps(self.B, tol, ncv, "", None)
        self.eps_raw = self._make_eps(self.B_raw, tol, ncv, "raw_", self.eps.getST().getKSP())
        self._warm = [self.A.createVecRight(), self.A.createVecRight()]
        self.restart()
        self.inertia = InertiaCounter(disc, comm=self.comm,
                                      options_prefix=self.options.name("inertia_"))

    def _make_eps(self, B, tol, ncv, part, ksp):
        eps = SLEPc.EPS().create(self.comm)
        eps.setOptionsPrefix(self.options.name(part))
        eps.setOperators(self.A, B)
        eps.setProblemType(SLEPc.EPS.ProblemType.GNHEP)
        eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_REAL)
        eps.setTarget(0.0)
        eps.setDimensions(1, ncv)
        eps.setTolerances(tol, 500)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        st.setMatStructure(PETSc.Mat.Structure.SUBSET)   # diag(M, 0) lies on A's diagonal
        if ksp is None:
            use_bordered_lu(st.getKSP())
        else:
            st.setKSP(ksp)                                 # one LU of A - sigma Mb for both
        self.options.apply(eps)
        return eps

    def restart(self) -> None:
        """Forget the warm start: the next solve starts from the fixed vector."""
        for vec in self._warm:
            vec.setArray(self._v0)

    def solve(self, u, p) -> tuple[float, float]:
        """(lambda_min l^2/B, lambda_min(K)/(B/l)) at the bordered state ``u`` and
        tensions ``p``; StabilityError if SLEPc does not converge."""
        disc = self.disc
        u = np.asarray(u, float)
        p = np.asarray(p, float)
        negatives = self.inertia.negative_eigenvalues(u, p)
        self._values[:] = disc.jacobian_values(u, p)
        self.A.assemble()                  # raises the matrix state: SLEPc refactors
        return (self._smallest(self.eps, self.B, 0, u, p, negatives, self.mass),
                self._smallest(self.eps_raw, self.B_raw, 1, u, p, negatives, self._ones))

    def _smallest(self, eps, B, which: int, u, p, negatives: int, weights) -> float:
        """One solve (module doc): shift, warm start, the eigenvalue."""
        target = 0.0
        if negatives > 0:        # below the spectrum, in units of the weights (StabilitySolver)
            unit = self.disc.h / float(np.max(weights))
            target = gershgorin_lower_bound(self.disc, u, p, weights) - unit
        eps.setTarget(target)
        eps.setOperators(self.A, B)          # A was reassembled
        warm = self._warm[which]
        eps.setInitialSpace([warm])
        eps.solve()
        reason = eps.getConvergedReason()
        if reason < 0 or eps.getConverged() < 1:
            self.restart()
            raise StabilityError(
                f"SLEPc EPS ({eps.getOptionsPrefix()}) did not converge: "
                f"{reason_name(eps_reasons(), reason)}, {eps.getConverged()} eigenpairs converged")
        return float(eps.getEigenpair(0, warm).real)

    def destroy(self) -> None:
        self.inertia.destroy()
        for obj in (self.eps, self.eps_raw, self.A, self.B, self.B_raw, *self._warm):
            obj.destroy()

    def __enter__(self) -> "SweepStability":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()
