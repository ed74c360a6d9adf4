"""Stability indicator and eigenfrequencies of an equilibrium, with SLEPc.

Stability (Sec. 4.3 (ii), docs/model.md §2, §3)
--------------------------------------
The paper's indicator is the smallest eigenvalue of the generalized problem

    K v = lambda M v                                                    (Sec. 4.3 (ii))

with K the consistent tangent of Eq. (9) and M a lumped mass.  K = T - B C is
dense (one rank-2 term per tendon), so it is never formed.  The eigen solve
works on the *bordered* pencil

    A = [[T, B], [C, I_2n]]  (the SNES Jacobian, :attr:`Discretisation.pattern`)
    Mb = diag(M, 0_2n)

(or, with ``operator="symmetric"``, A = H = [[T, W], [W^T, -I_n]] of
:meth:`Discretisation.stability_values`, Mb = diag(M, 0_n)).  For a finite
eigenvalue the border rows give w = -C v, and the theta rows become
(T - B C) v = lambda M v: the finite eigenvalues of the pencil are exactly
those of (K, M).  Mb is singular; its null space (the 2n border unknowns)
carries infinite eigenvalues, and because the border block of A is
nonsingular the pencil has index 1, so shift-and-invert, whose operator
(A - sigma Mb)^{-1} Mb maps them to the eigenvalue 0, never returns them
(checked in the tests).  (A - sigma Mb) is factored by LU in the natural
order, where only the border fills: O(N) per solve.

The problem is solved as a general non-Hermitian GNHEP (as the paper does),
with eigenvalues of smallest real part (TARGET_REAL at a target below the
spectrum).  Because the discrete residual is the gradient of a discrete
potential (docs/model.md §2), K is symmetric to round-off; the measured asymmetry
||K - K^T||_F / ||K||_F of the Jacobian's Schur complement is reported.

Target.  When the LDL^T inertia of H (:class:`InertiaCounter`) finds K
positive definite, the target is -1 (all eigenvalues lie to its right); when
K has negative eigenvalues the target is a Gershgorin lower bound of (T, M),
which bounds the spectrum of (K, M) from below because K - T = W W^T is
positive semidefinite (Weyl).  With the target below the spectrum, the
eigenvalues closest to it are the smallest ones.  The number of negative
eigenvalues found is cross-checked against the inertia count.

Mass: decision.  The paper lumps M = h I (its footnote: the tip node gets
twice its share, "crudely justified" by the pen holder) so that the spectrum
of K itself is the indicator.  Here the default ``mass="lumped"`` is the
row-sum lumped P1 mass, M = h diag(1, ..., 1, 1/2): the discrete problem is
then the standard second-order finite-difference discretisation of
theta'' + lambda theta = 0 and lambda l^2/B converges at O(h^2) to the
continuous value (the paper's doubled tip mass perturbs it by O(h): at
N = 180 the unloaded arm gives 2.4538 instead of 2.4674).  ``mass="paper"``
reproduces the paper's pencil.  The sign of the eigenvalues (stability) does
not depend on M.  Reported values (docs/model.md §3):

* ``eigenvalues``: lambda l^2 / B, mesh independent (pi^2/4 for the unloaded
  arm).
* ``raw_min``: the paper's Fig. 5b number, lambda_min(K) / (B/l) at the mesh
  used (code units B = l = 1; scales with h: ~ 2.4674 h unloaded).  With
  ``mass="paper"`` it is exactly h * eigenvalues[0]; otherwise it is a second,
  one-eigenvalue solve with Mb = diag(I, 0) (options prefix ``<prefix>raw_``).

Eigenfrequencies (beyond the paper, Sec. 4.5 (vi))
---------------------------------------------------
Small vibrations of the inextensible, unshearable rod about an equilibrium
theta*: the angles are the generalized coordinates; the potential is Pi of
docs/model.md §2 (prescribed tensions: conservative), so the stiffness is K; the
kinetic energy is (1/2) rho_A int |x_dot|^2 ds with x_dot(s) = int_0^s n
theta_dot ds (Eq. (2) differentiated; rotary inertia rho I theta_dot^2 is
neglected: (t^2/12) / l^2 ~ 2e-6 for the paper's strip).  With the same
midpoint quadrature as the positions and trapezoidal (nodal) masses h, ..., h,
h/2 (+ an optional tip mass), M_phys = rho_A l^3 G^T D G, G = dx_nodes/dtheta.
M_phys is dense, but G is a cumulative sum, so M_phys v costs O(N) (forward
cumulative sum, reverse cumulative sum).  The lowest eigenpairs of
K v = Omega M_phys v are found as the largest of the standard problem
K^{-1} M_phys (a shell operator; K^{-1} through the bordered LU), so no dense
matrix appears.  omega^2 = Omega B / (rho_A l^4), f = sqrt(omega^2) / (2 pi).
Straight and unloaded, this is the clamped-free Euler-Bernoulli beam:
Omega_1 = 1.8751^4.

``control="load"``: tensions stay fixed during the vibration (force-controlled
motors).  ``control="length"``: the cable lengths stay fixed (the paper's
steppers hold L_i; its cables are ~ rigid, Sec. 3): the motion is
constrained to grad L_i . v = 0, with the same K (the Hessian of the
Lagrangian U + sum p_i (L_i - Lbar_i) is K).  By interlacing, the
length-controlled frequencies are >= the load-controlled ones: the
load-controlled f_1 is a conservative (lower) bound.

Tracing speed.  Model the tip near the fundamental mode as an undamped
oscillator x'' = -omega_1^2 (x - x_s(t)) dragged by its static position x_s.
Moving x_s at constant speed v leaves the tip in step; each abrupt change of
the tip velocity by dv (start, stop, a corner of a polygon) starts a free
vibration of amplitude |dv| / omega_1.  Keeping it below a tolerated amplitude
delta gives v_max = omega_1 delta = 2 pi f_1 delta
(:func:`max_tracing_speed_mm_s`).  A corner of turning angle a has
|dv| = 2 v sin(a/2) (sqrt(3) v for the triangle of Fig. 3a).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc
from slepc4py import SLEPc

from ..core.results import Result
from ..core.errors import SolverError
from ..core.dynamics import EB_BETA1, mass_apply, node_masses
from ..core.fem import Discretisation
from .inertia import InertiaCounter
from ..core.model import Arm
from .linalg import use_bordered_lu
from .options import SolverOptions, check_comm
from .reasons import KSP_REASONS, eps_reasons, reason_name

MASS_MODELS = ("lumped", "paper")
OPERATORS = ("jacobian", "symmetric")
CONTROLS = ("load", "length")


class StabilityError(SolverError):
    """An eigen solve that did not converge."""


# --- results -------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class Stability(Result):
    """Smallest eigenvalues of K v = lambda M v at one equilibrium (Sec. 4.3 (ii)).

    ``eigenvalues`` are real parts of lambda l^2 / B, ascending (``max_imag``
    is the largest |Im lambda| found: 0 or round-off, K being symmetric);
    ``raw_min`` is lambda_min(K) / (B/l) at the mesh used (Fig. 5b);
    ``modes[k]`` are the nodal angles theta_0..theta_N (theta_0 = 0) of
    eigenvector k, scaled to max |theta| = 1 with that entry positive.
    """

    eigenvalues: np.ndarray
    raw_min: float
    modes: np.ndarray
    converged: int                # eigenpairs SLEPc reports converged
    stable: bool                  # smallest real part > 0
    asymmetry: float              # ||K - K^T||_F / ||K||_F, random-probe estimate
    negative: int                 # computed eigenvalues with negative real part
    inertia_negative: int         # negative eigenvalues of K by LDL^T inertia of H
    max_imag: float
    mass: str
    operator: str
    target: float
    iterations: int
    reason: str

    @property
    def lambda_min(self) -> float:
        """Smallest real part, lambda l^2 / B."""
        return float(self.eigenvalues[0])

    @property
    def inertia_agrees(self) -> bool:
        """The eigen solve and the Sylvester inertia count the same negatives."""
        return self.negative == self.inertia_negative


@dataclass(frozen=True, repr=False)
class Frequencies(Result):
    """Lowest small-vibration eigenpairs about an equilibrium.

    ``omega2`` = omega^2 rho_A l^4 / B (non-dimensional, ascending; negative:
    unstable, the motion grows); ``hz`` = sqrt(omega2 B/(rho_A l^4)) / (2 pi)
    (NaN where omega2 <= 0), or None without a mass per length.
    """

    omega2: np.ndarray
    hz: np.ndarray | None
    modes: np.ndarray
    control: str
    converged: int
    iterations: int
    reason: str

    @property
    def f1_hz(self) -> float | None:
        return None if self.hz is None else float(self.hz[0])


# --- units and rules -------------------------------------------------------------
def frequency_scale_hz(arm: Arm) -> float:
    """sqrt(B / (rho_A l^4)) / (2 pi) in Hz: f = sqrt(omega2) * this."""
    if arm.mass_per_length_kg_m is None:
        raise ValueError("arm.mass_per_length_kg_m is not set: cannot give frequencies in Hz")
    length_m = arm.length_mm * 1e-3
    return float(np.sqrt(arm.bending_stiffness_Nm2 / (arm.mass_per_length_kg_m * length_m**4))
                 / (2.0 * np.pi))


def euler_bernoulli_f1_hz(arm: Arm) -> float:
    """Fundamental frequency of the clamped-free Euler-Bernoulli beam,
    f_1 = (1.8751^2 / (2 pi)) sqrt(B / (rho_A l^4)) [Hz]."""
    return EB_BETA1**2 * frequency_scale_hz(arm)


def max_tracing_speed_mm_s(f1_hz: float, amplitude_mm: float) -> float:
    """v_max = 2 pi f_1 delta [mm/s]: an abrupt tip-velocity change dv excites a
    vibration of amplitude dv / omega_1; keep it below ``amplitude_mm``."""
    return 2.0 * np.pi * f1_hz * amplitude_mm


# --- O(N) kinetic mass --------------------------------------------------------------
def kinetic_mass_apply(disc: Discretisation, theta: np.ndarray, v: np.ndarray,
                       weights: np.ndarray) -> np.ndarray:
    """M_phys v / (rho_A l^3) = G^T D G v in O(N) (:func:`core.dynamics.mass_apply`):
    G v are the nodal velocities x_dot_k = sum_{e<k} h n_e (v_e + v_{e+1})/2
    (Eq. (2) differentiated with the midpoint rule; v_0 = 0), D = diag(weights)."""
    return mass_apply(disc, theta, v, weights)


# --- helpers -------------------------------------------------------------------------
def schur_asymmetry(T, B, C, rng: np.random.Generator, probes: int = 4) -> float:
    """Estimate ||K - K^T||_F / ||K||_F for K = T - B C (bordered corner I)
    from matrix-vector products only, O(nnz): with Gaussian probes V,
    E||X V||_F^2 = probes ||X||_F^2, and K V = T V - B (C V),
    K^T V = T^T V - C^T (B^T V)."""
    V = rng.standard_normal((T.shape[0], probes))
    KV = T @ V - B @ (C @ V)
    KTV = T.T @ V - C.T @ (B.T @ V)
    return float(np.linalg.norm(KV - KTV) / np.linalg.norm(KV))


def gershgorin_lower_bound(disc: Discretisation, u, p, weights: np.ndarray) -> float:
    """Gershgorin lower bound of the spectrum of (T, diag(weights)), hence of
    (K, diag(weights)) since K - T = W W^T >= 0."""
    theta, y = disc.split(np.asarray(u, float))
    _, d = disc.cables(y)
    band = disc.band(theta, d, np.asarray(p, float))
    s = 1.0 / np.sqrt(weights)
    lower = np.abs(band[1:, 0]) * s[1:] * s[:-1]      # |T[r, r-1]|, r >= 1
    upper = np.abs(band[:-1, 2]) * s[:-1] * s[1:]     # |T[r, r+1]|, r < N-1
    radius = np.append(0.0, lower) + np.append(upper, 0.0)
    return float(np.min(band[:, 1] * s * s - radius))


def diagonal_matrix(values: np.ndarray) -> PETSc.Mat:
    """A diagonal AIJ matrix on COMM_SELF."""
    n = len(values)
    idx = np.arange(n + 1, dtype=np.int32)
    return PETSc.Mat().createAIJ(size=(n, n), csr=(idx, idx[:-1].copy(), values),
                                 comm=PETSc.COMM_SELF)


def _full_from_upper(disc: Discretisation):
    """CSR of the full symmetric H from its upper-triangle pattern, and the map
    from stored upper values to full entries."""
    indptr, indices, _ = disc.stability_pattern
    n = len(indptr) - 1
    rows = np.repeat(np.arange(n), np.diff(indptr))
    strict = indices > rows
    nnz = np.arange(len(indices))
    r = np.concatenate((rows, indices[strict]))
    c = np.concatenate((indices, rows[strict]))
    src = np.concatenate((nnz, nnz[strict]))
    order = np.lexsort((c, r))
    full_ptr = np.searchsorted(r[order], np.arange(n + 1)).astype(np.int32)
    return full_ptr, c[order].astype(np.int32), src[order]


def _real_eigenpairs(eps, A, n_theta: int, wanted: int):
    """(values, imag, modes) of the first ``wanted`` converged eigenpairs (the
    closest to the target, in SLEPc's order), sorted by real part."""
    nconv = min(eps.getConverged(), wanted)
    vr, vi = A.createVecs()
    vals, modes = [], []
    for i in range(nconv):
        lam = eps.getEigenpair(i, vr, vi)
        v = vr.getArray()[:n_theta]
        theta = np.concatenate(([0.0], v))
        k = int(np.argmax(np.abs(theta)))
        if theta[k] != 0.0:
            theta = theta / theta[k]
        vals.append(complex(lam))
        modes.append(theta)
    vr.destroy()
    vi.destroy()
    if not vals:
        return np.zeros(0), 0.0, np.zeros((0, n_theta + 1))
    vals = np.array(vals)
    order = np.argsort(vals.real, kind="stable")
    return vals.real[order], float(np.max(np.abs(vals.imag))), np.array(modes)[order]


class _ShellOperator:
    """Python context of the shell matrix x -> K^{-1} M_phys x (frequencies)."""

    def __init__(self, apply):
        self.apply = apply

    def mult(self, mat, x, y):
        y.setArray(self.apply(x.getArray(readonly=True)))


# --- the solver context ----------------------------------------------------------------
class StabilitySolver:
    """SLEPc eigen solves on the bordered tangent of one discretised arm
    (on ``PETSc.COMM_SELF``, like :class:`EquilibriumSolver`).

    Parameters
    ----------
    disc : the discretised arm.
    nev : number of smallest eigenvalues wanted (``-<prefix>eps_nev`` overrides),
        at most N: K has N eigenvalues, and asking the bordered pencil for more
        would return its infinite ones (the border unknowns) as huge numbers of
        either sign.  Larger requests are clamped to N.
    mass : ``"lumped"`` (default; h at interior nodes, h/2 at the tip) or
        ``"paper"`` (M = h I, the paper's footnote).
    operator : ``"jacobian"`` (default; the SNES bordered Jacobian
        [[T, B], [C, I]], non-symmetric storage) or ``"symmetric"``
        (H = [[T, W], [W^T, -I]] stored in full as AIJ).
    comm, options_prefix, petsc_options : the contract of :mod:`.options`
        (one process; ``-stab_eps_view``, ``-stab_eps_target``; the raw-K
        solve ``<prefix>raw_``, the frequency solve ``<prefix>freq_``).
    """

    def __init__(self, disc: Discretisation, *, nev: int = 4, mass: str = "lumped",
                 operator: str = "jacobian", tol: float = 1e-12, comm=None,
                 options_prefix: str = "stab_", petsc_options=None):
        if mass not in MASS_MODELS:
            raise ValueError(f"mass must be one of {MASS_MODELS}, got {mass!r}")
        if operator not in OPERATORS:
            raise ValueError(f"operator must be one of {OPERATORS}, got {operator!r}")
        self.disc = disc
        self.mass = mass
        self.operator = operator
        self.options = SolverOptions(options_prefix, petsc_options)
        self.prefix = prefix = self.options.prefix
        self.comm = check_comm(comm)     # one arm is a small problem (parallel: across arms)
        N, n = disc.n_elements, disc.n_tendons
        self.m = np.full(N, disc.h)
        if mass == "lumped":
            self.m[-1] *= 0.5
        u0, p0 = disc.straight(), np.zeros(n)
        if operator == "jacobian":
            indptr, indices, _ = disc.pattern
            self._csr = (indptr, indices)
            values = disc.jacobian_values(u0, p0)
        else:
            indptr, indices, self._full_src = _full_from_upper(disc)
            self._csr = (indptr, indices)
            values = disc.stability_values(u0, p0)[self._full_src]
        size = len(indptr) - 1
        self.n_border = size - N
        self.A = PETSc.Mat().createAIJ(size=(size, size), csr=(indptr, indices, values),
                                       comm=self.comm)
        self.B = diagonal_matrix(np.concatenate((self.m, np.zeros(self.n_border))))
        self.options.label(self.A, self.B)
        # a fixed initial vector: each eigen solve is reproducible bit for bit,
        # whatever solves the process did before (workspace results must not
        # depend on how samples are spread over ranks)
        self._v0 = self.A.createVecRight()
        self._v0.setArray(np.random.default_rng(2019).standard_normal(size))
        self.eps = self._make_eps(self.A, self.B, min(int(nev), N), tol, prefix)
        self.nev = self.eps.getDimensions()[0]
        self.eps_raw = None
        if mass != "paper":
            self.B_raw = diagonal_matrix(np.concatenate((np.ones(N), np.zeros(self.n_border))))
            self.eps_raw = self._make_eps(self.A, self.B_raw, 1, tol, prefix + "raw_")
        self.inertia = InertiaCounter(disc, comm=self.comm,
                                      options_prefix=self.options.name("inertia_"))

    def _target_given(self, part: str) -> bool:
        """Whether the user set ``-<prefix><part>eps_target`` (command line or code)."""
        return (PETSc.Options(self.prefix + part).hasName("eps_target")
                or part + "eps_target" in self.options.options)

    def _make_eps(self, A, B, nev, tol, prefix):
        eps = SLEPc.EPS().create(self.comm)
        eps.setOptionsPrefix(prefix)
        eps.setOperators(A, B)
        eps.setProblemType(SLEPc.EPS.ProblemType.GNHEP)
        eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_REAL)
        eps.setTarget(-1.0)
        eps.setDimensions(nev)
        eps.setTolerances(tol, 500)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        st.setMatStructure(PETSc.Mat.Structure.SUBSET)   # diag(M, 0) lies on A's diagonal
        use_bordered_lu(st.getKSP())
        self.options.apply(eps)
        n_theta = self.disc.n_elements
        if eps.getDimensions()[0] > n_theta:          # -<prefix>eps_nev beyond N: clamp
            eps.setDimensions(n_theta)
        return eps

    # --- assembly -------------------------------------------------------------------
    def _assemble(self, u, p) -> None:
        if self.operator == "jacobian":
            values = self.disc.jacobian_values(u, p)
        else:
            values = self.disc.stability_values(u, p)[self._full_src]
        self.A.setValuesCSR(*self._csr, values)
        self.A.assemble()

    def lower_bound(self, u, p, weights=None) -> float:
        """:func:`gershgorin_lower_bound` (default weights: the mass)."""
        return gershgorin_lower_bound(self.disc, u, p, self.m if weights is None else weights)

    # --- asymmetry ----------------------------------------------------------------------
    def asymmetry(self, u, p, probes: int = 4) -> float:
        """||K - K^T||_F / ||K||_F of K = T - B C, the Schur complement of the
        assembled bordered SNES Jacobian [[T, B], [C, I]], estimated in O(N) with
        Gaussian probes (E||X v||^2 = ||X||_F^2): K v = T v - B (C v),
        K^T v = T^T v - C^T (B^T v)."""
        disc = self.disc
        N = disc.n_elements
        indptr, indices, _ = disc.pattern
        J = sp.csr_matrix((disc.jacobian_values(u, p), indices, indptr),
                          shape=(disc.size, disc.size))
        return schur_asymmetry(J[:N, :N], J[:N, N:], J[N:, :N], np.random.default_rng(20190406),
                               probes)

    # --- stability ------------------------------------------------------------------------
    def _run(self, eps, B, u, p, nev: int, negatives: int, part: str,
             weights) -> tuple[float, int]:
        """Set the target (module docstring) unless the user set it for this
        ``part`` of the prefix ("" or "raw_"), solve, check convergence."""
        if not self._target_given(part):
            # -1 in units of lambda l^2/B, whatever the weights' scale
            target = -self.disc.h / float(np.max(weights))
            if negatives > 0:
                target = min(target, self.lower_bound(u, p, weights) - abs(target))
            eps.setTarget(target)
        nev = min(nev, self.disc.n_elements)           # K has N eigenvalues (see nev)
        if eps.getDimensions()[0] < nev:
            eps.setDimensions(nev)
        eps.setOperators(self.A, B)     # SLEPc must be told that A was reassembled
        eps.setInitialSpace([self._v0])
        eps.solve()
        reason = eps.getConvergedReason()
        if reason < 0 or eps.getConverged() < 1:
            raise StabilityError(
                f"SLEPc EPS ({eps.getOptionsPrefix()}) did not converge: "
                f"{reason_name(eps_reasons(), reason)}, {eps.getConverged()} eigenpairs converged")
        return eps.getTarget(), reason

    def solve(self, u, p, *, raw: bool = True) -> Stability:
        """Smallest eigenvalues of K(u, p) v = lambda M v at the state ``u`` (a
        bordered vector, e.g. ``Equilibrium.u``) and tensions ``p`` (= P l^2/B).

        ``raw=False`` skips the extra solve for ``raw_min`` (NaN then, unless
        ``mass="paper"``).
        """
        disc = self.disc
        self.options.refresh(*filter(None, (self.eps, self.eps_raw)))
        u = np.asarray(u, float)
        p = np.asarray(p, float)
        negatives = self.inertia.negative_eigenvalues(u, p)
        self._assemble(u, p)
        nev = min(max(self.nev, negatives + 1), disc.n_elements)
        target, reason = self._run(self.eps, self.B, u, p, nev, negatives, "",
                                   self.m)
        values, imag, modes = _real_eigenpairs(self.eps, self.A, disc.n_elements, nev)
        if self.mass == "paper":
            raw_min = disc.h * float(values[0])
        elif raw:
            self._run(self.eps_raw, self.B_raw, u, p, 1, negatives, "raw_",
                      np.ones(disc.n_elements))
            raw_values, _, _ = _real_eigenpairs(self.eps_raw, self.A, disc.n_elements, 1)
            raw_min = float(raw_values[0])
        else:
            raw_min = float("nan")
        negative = int(np.sum(values < 0.0))
        return Stability(eigenvalues=values, raw_min=raw_min, modes=modes,
                         converged=self.eps.getConverged(), stable=bool(values[0] > 0.0),
                         asymmetry=self.asymmetry(u, p), negative=negative,
                         inertia_negative=negatives, max_imag=imag, mass=self.mass,
                         operator=self.operator, target=float(target),
                         iterations=self.eps.getIterationNumber(),
                         reason=reason_name(eps_reasons(), reason))

    # --- eigenfrequencies --------------------------------------------------------------------
    def _constrained_matrix(self, u, p, control: str) -> sp.csr_matrix:
        """Bordered Jacobian, plus for length control one constraint row and
        column grad L_i per tendon (zero corner stored explicitly)."""
        disc = self.disc
        indptr, indices, _ = disc.pattern
        J = sp.csr_matrix((disc.jacobian_values(u, p), indices, indptr),
                          shape=(disc.size, disc.size))
        if control == "load":
            return J
        grad_L = disc.load_derivative(u)            # row i: dF/dp_i = grad_theta L_i
        n, size = disc.n_tendons, disc.size
        Jc = J.tocoo()
        r, c = np.nonzero(grad_L)
        rows = np.concatenate((Jc.row, c, size + r, size + np.arange(n)))
        cols = np.concatenate((Jc.col, size + r, c, size + np.arange(n)))
        vals = np.concatenate((Jc.data, grad_L[r, c], grad_L[r, c], np.zeros(n)))
        return sp.csr_matrix((vals, (rows, cols)), shape=(size + n, size + n))

    def frequencies(self, u, p, arm: Arm | None = None, *, nev: int = 3,
                    control: str = "load", tip_mass_kg: float = 0.0,
                    tol: float = 1e-10) -> Frequencies:
        """Lowest small-vibration eigenpairs K v = Omega M_phys v about the
        equilibrium ``u`` at tensions ``p`` (module docstring).

        ``arm`` gives B, l and rho_A for Hz (``arm.mass_per_length_kg_m``); a
        ``tip_mass_kg`` (e.g. the pen holder) is added to the tip node.
        ``control``: ``"load"`` (tensions fixed) or ``"length"`` (cable lengths
        fixed).  Options prefix ``<prefix>freq_``.
        """
        if control not in CONTROLS:
            raise ValueError(f"control must be one of {CONTROLS}, got {control!r}")
        disc = self.disc
        N = disc.n_elements
        u = np.asarray(u, float)
        p = np.asarray(p, float)
        theta = disc.split(u)[0]
        tip_mass = 0.0
        if tip_mass_kg:
            if arm is None or arm.mass_per_length_kg_m is None:
                raise ValueError("a tip mass needs the arm's mass per length")
            tip_mass = tip_mass_kg / (arm.mass_per_length_kg_m * arm.length_mm * 1e-3)
        weights = node_masses(disc, tip_mass)
        Ac = self._constrained_matrix(u, p, control)
        size = Ac.shape[0]
        A = PETSc.Mat().createAIJ(size=(size, size), comm=self.comm,
                                  csr=(Ac.indptr.astype(np.int32), Ac.indices.astype(np.int32),
                                       Ac.data))
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOptionsPrefix(self.prefix + "freq_inv_")
        A.setOptionsPrefix(self.prefix + "freq_")
        ksp.setOperators(A)
        use_bordered_lu(ksp)
        self.options.apply(ksp)
        rhs, sol = A.createVecs()
        buf = np.zeros(size)

        def apply(x):                       # K^{-1} M_phys x (constrained if length control)
            buf[:N] = kinetic_mass_apply(disc, theta, x, weights)
            rhs.setArray(buf)
            ksp.solve(rhs, sol)
            if ksp.getConvergedReason() < 0:
                raise StabilityError("bordered solve failed: KSP reason "
                                     + reason_name(KSP_REASONS, ksp.getConvergedReason()))
            return sol.getArray(readonly=True)[:N].copy()

        op = PETSc.Mat().createPython([N, N], _ShellOperator(apply), comm=self.comm)
        op.setUp()
        eps = SLEPc.EPS().create(self.comm)
        try:
            eps.setOptionsPrefix(self.prefix + "freq_")
            eps.setOperators(op)
            eps.setProblemType(SLEPc.EPS.ProblemType.NHEP)
            eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
            eps.setDimensions(nev)
            eps.setTolerances(tol, 500)
            self.options.apply(eps)
            eps.solve()
            reason = eps.getConvergedReason()
            if reason < 0 or eps.getConverged() < 1:
                raise StabilityError(f"frequency solve did not converge: "
                                     f"{reason_name(eps_reasons(), reason)}")
            nu, _, modes = _real_eigenpairs(eps, op, N, nev)   # nu = 1 / Omega
            keep = np.abs(nu) > 0
            omega2 = 1.0 / nu[keep]
            order = np.argsort(omega2)
            omega2, modes = omega2[order], modes[keep][order]
            hz = None
            if arm is not None and arm.mass_per_length_kg_m is not None:
                with np.errstate(invalid="ignore"):
                    hz = np.where(omega2 > 0, np.sqrt(np.abs(omega2)), np.nan) \
                        * frequency_scale_hz(arm)
            return Frequencies(omega2=omega2, hz=hz, modes=modes, control=control,
                               converged=eps.getConverged(),
                               iterations=eps.getIterationNumber(),
                               reason=reason_name(eps_reasons(), reason))
        finally:
            for obj in (eps, op, ksp, A, rhs, sol):
                obj.destroy()

    # --- lifetime ----------------------------------------------------------------------------
    def destroy(self) -> None:
        self.inertia.destroy()
        objs = [self.eps, self.A, self.B]
        if self.eps_raw is not None:
            objs += [self.eps_raw, self.B_raw]
        for obj in objs:
            obj.destroy()

    def __enter__(self) -> "StabilitySolver":
        return self

    def __exit__(self, *exc) -> None:
        self.destroy()
