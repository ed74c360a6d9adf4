"""Searches for several equilibria at the same tensions or cable lengths
(Fig. 8: states 1 and 2 share the cable lengths, states 1 and 3 the tensions).

Starts come from loading paths (:func:`tension_starts`); from each start a
search continues (in the cable lengths) or loads (in the tensions) to the
target, then runs deflated Newton solves (Farrell et al. 2015,
:mod:`elastica_petsc.core.deflation`) that cannot return to the states
already found.  With two tendons the searches are built around the curve
search of :mod:`elastica_petsc.studies.preimage` (curves of equilibria whose
cable lengths or tensions move on lines through the target, followed through
folds), which does not depend on a step count.  A search reports what it
found and from where, never that nothing else exists.  Non-dimensional
(lengths / l, p = P l^2 / B).
"""
from __future__ import annotations

import itertools

import numpy as np

from ..core.budget import TimeBudget
from ..core.deflation import Deflation
from ..core.errors import InputError
from ..solvers.equilibrium import Equilibrium, EquilibriumSolver, check_tensions
from ..solvers.lengths import (DEFLATED_DIVERGENCE_FACTOR, DEFLATION_OPTIONS, SAME_SHAPE_TOL,
                               AugmentedSystem,
                               LengthEquilibrium, LengthInertia, LengthSolver, check_lengths)
from .search_methods import (Collector, deflated_continuation, deflation_of, homotopy_paths,
                             loading_paths, phased_search, search_phases, tension_starts,
                             with_curves)
from .search_result import (DEFAULT_P_MAX, DEFLATED_MAX_IT, FIG8_STATES, FoundState,
                            SearchResult, effort_settings, search_box, state_numbers)

__all__ = ["DEFAULT_P_MAX", "FIG8_STATES", "FoundState", "LoadSolves", "SearchResult",
           "deflated_continuation", "effort_settings", "equilibria", "follow_lengths",
           "homotopy_paths", "length_equilibria", "loading_paths", "search_box",
           "search_lengths", "search_tensions", "snap_targets", "state_numbers",
           "tension_starts"]


def length_equilibria(solver: LengthSolver, lengths, starts=None, *,
                      eq_solver: EquilibriumSolver | None = None, continuation: bool = True,
                      effort: int = 1, levels=None, deflation_rounds: int | None = None,
                      passes: int = 2, steps: int | None = None,
                      tol: float = SAME_SHAPE_TOL, curves: bool | None = None,
                      p_max: float = DEFAULT_P_MAX, progress=None,
                      budget: TimeBudget | None = None) -> SearchResult:
    """Distinct equilibria with cable lengths ``lengths`` (units of l) and
    tensions 0 <= p_i <= ``p_max``.

    (0) With two tendons (``curves``, default on): the systematic search of
    :class:`~elastica_petsc.studies.preimage.CurveSearch`: pseudo-arclength
    continuation, through every fold, of curves of the equilibrium manifold
    whose cable lengths move on a line through L* (from the straight arm,
    along each loading order, on the faces p_i = 0, then through every
    equilibrium found in 4 ``effort`` directions); every crossing of L* is an
    equilibrium.  Its result does not depend on a step count.
    Then in phases k = 1..``effort`` (:func:`effort_settings`, a higher effort
    repeats the lower ones first, so it never finds fewer states): (1)
    :func:`deflated_continuation` in the cable lengths from the straight arm
    along every loading order (``steps`` points per segment, default 12 k);
    (2) from every new start (phase 1: ``starts`` or :func:`tension_starts`
    at ``levels``, default 5, 10, 20; later phases add doubled levels):
    continuation in the cable lengths from the start's own lengths
    (:meth:`LengthSolver.follow`, unstable states allowed), then up to
    ``deflation_rounds`` (default 2 k) deflated VI Newton solves from the
    start, each deflating every state found so far (Farrell et al. 2015, l2
    line search, :data:`DEFLATION_OPTIONS`), repeated over the phase's starts
    while a sweep finds new states (at most ``passes`` sweeps).  (3) With
    ``curves``: the curves through every state (1)-(2) found that (0) had not.
    States are distinct if some nodal angle differs by more than ``tol`` rad.
    Each state reports its stability under load and length control.  What is
    returned is what these methods reached, never a claim that no other
    equilibrium exists.  ``progress(steps, note)``, if given, is called after
    every search step (a continuation point or an attempt from a start; the
    number of steps is not known in advance).  ``budget`` (a
    :class:`~elastica_petsc.core.budget.TimeBudget`): once spent, the search
    stops at its next step and returns the states found so far, with
    ``stopped`` saying so (outcome TIME_LIMIT: the list may be incomplete).
    """
    L = check_lengths(lengths, solver.disc.n_tendons)
    disc = solver.disc
    found = Collector(tol, progress, budget)
    deflation = Deflation(disc.h)
    curves = disc.n_tendons == 2 if curves is None else bool(curves)
    if curves and disc.n_tendons != 2:
        raise InputError("the curve search of length control needs exactly two tendons")

    def continue_paths(k_steps: int) -> list:
        straight = solver.solve(solver.lengths_of(disc.straight()))
        return deflated_continuation(
            lambda target, start, deflate=None, max_it=None:
                solver.solve(target, start, deflate=deflate, max_it=max_it),
            homotopy_paths(straight.cable_lengths, L, k_steps), straight, found,
            "cable lengths")

    def multistart(phase_starts, rounds: int) -> None:
        for sweep in range(max(1, passes)):
            before = len(found.found)
            for label, start in phase_starts:
                if continuation and sweep == 0:
                    state = solver.follow(L, start, keep_stable=False,
                                          label=f"{label}; continuation")
                    found.offer(state, label, "continuation")
                for _ in range(rounds):
                    state = solver.solve(L, start, deflate=deflation_of(found, deflation),
                                         label=f"{label}; deflation", max_it=DEFLATED_MAX_IT)
                    if not found.offer(state, label, "deflation"):
                        break
            if len(found.found) == before:
                break

    own = eq_solver is None
    eq_solver = EquilibriumSolver(disc) if own else eq_solver

    def rest():
        return phased_search(found, search_phases(effort, levels, steps, deflation_rounds),
                             starts, lambda lv: tension_starts(eq_solver, levels=lv),
                             continue_paths, multistart)

    try:
        search = None
        if curves:
            search, used = with_curves(
                disc, L, "length", p_max, effort, found,
                lambda u, p, label: solver.solve(L, (u, p), label=label), rest)
        else:
            used = found.attempt(rest) or []
    finally:
        if own:
            eq_solver.destroy()
    return found.result("length", L, used, curves=search)


class LoadSolves:
    """Newton solves at fixed tensions on the plain residual F(u; p), deflated
    on request (an SNES VI with unbounded p, options prefix ``prefix``, l2
    line search by default); every converged state is returned as a
    :class:`LengthEquilibrium` held at its own cable chords, with its
    stability under load and under length control."""

    def __init__(self, eq_solver: EquilibriumSolver, prefix: str = "defl_",
                 length_mm: float | None = None):
        self.eq_solver, self.disc, self.length_mm = eq_solver, eq_solver.disc, length_mm
        self.system = AugmentedSystem(self.disc, "load", prefix, Deflation(self.disc.h),
                                      petsc_options=DEFLATION_OPTIONS,
                                      divergence_factor=DEFLATED_DIVERGENCE_FACTOR)
        self.length_inertia = LengthInertia(self.disc)

    def examined(self, eq: Equilibrium | None, label: str = ""):
        """A converged load-controlled state as a LengthEquilibrium (else as is)."""
        if eq is None or not eq.converged:
            return eq
        lengths = self.disc.cables(self.disc.split(eq.u)[1])[0]
        return LengthEquilibrium(
            self.disc, np.asarray(eq.p, float).copy(), np.asarray(eq.u, float).copy(), True,
            eq.reason, eq.iterations, eq.load_steps, message=eq.message,
            unstable_modes=eq.unstable_modes, snaps=eq.snaps, bifurcations=eq.bifurcations,
            p_requested=np.asarray(eq.p, float), lengths_requested=lengths,
            length_unstable_modes=self.length_inertia.negative_eigenvalues(eq.u, eq.p),
            length_mm=self.length_mm, label=label)

    def solve(self, p, start, deflate=None, max_it=None, label: str = ""):
        """One (deflated) Newton solve at tensions ``p`` from ``start`` (an
        Equilibrium or (u, p)); None if it does not converge."""
        u0 = start.u if isinstance(start, Equilibrium) else start[0]
        p = np.asarray(p, float)
        self.system.deflation = deflate if deflate is not None else Deflation(self.disc.h)
        z, its, reason, ok = self.system.newton(self.system.augment(u0, p), p, max_it)
        if not ok:
            return None
        u = z[: self.system.nu]
        return self.examined(Equilibrium(
            self.disc, p.copy(), u.copy(), True, reason, its, 0,
            unstable_modes=self.eq_solver.inertia.negative_eigenvalues(u, p),
            p_requested=p), label)

    def destroy(self) -> None:
        self.system.destroy()
        self.length_inertia.destroy()


def equilibria(eq_solver: EquilibriumSolver, p, starts=None, *, effort: int = 1, levels=None,
               deflation_rounds: int | None = None, passes: int = 2, steps: int | None = None,
               tol: float = SAME_SHAPE_TOL, prefix: str = "defl_",
               length_mm: float | None = None, curves: bool | None = None,
               p_max: float = DEFAULT_P_MAX, progress=None,
               budget: TimeBudget | None = None) -> SearchResult:
    """Distinct load-controlled equilibria at fixed tensions ``p``.

    (0) Loading paths from the straight arm: proportional and every order
    (:meth:`EquilibriumSolver.solve`, both sides of every bifurcation
    crossed, :func:`loading_paths`); with two tendons (``curves``, default
    on) the curve search of :class:`~elastica_petsc.studies.preimage.CurveSearch`
    in tension space: load paths followed through their folds by
    pseudo-arclength continuation (the line from p = 0 to ``p``, each loading
    order, then lines through ``p`` in 4 ``effort`` directions through every
    state found, tensions within |p_i| <= 1.5 max(p_max, max p)); then in
    phases k = 1..``effort`` as in
    :func:`length_equilibria`: (1) :func:`deflated_continuation` in the
    tensions from the straight arm (the only equilibrium at p = 0) along
    every loading order, unstable branches included (``steps`` points per
    segment, default 12 k); (2) from every new start (``starts`` or
    :func:`tension_starts`): the loading path from the start's tensions to
    ``p``, then up to ``deflation_rounds`` (default 2 k) deflated Newton
    solves (:class:`LoadSolves`) from the start, deflating every state found
    so far, repeated while a sweep finds new states (at most ``passes``
    sweeps).  Each state is a :class:`LengthEquilibrium` whose prescribed
    lengths are its own cable chords, with ``unstable_modes`` (load control)
    and ``length_unstable_modes`` (the same state held at its cable
    lengths).  After (1)-(2) the curves through every state they added.  Not
    a proof of completeness.  ``progress``, ``budget``: as for
    :func:`length_equilibria`.
    """
    disc = eq_solver.disc
    p = check_tensions(p, disc.n_tendons)
    n = disc.n_tendons
    found = Collector(tol, progress, budget)
    deflation = Deflation(disc.h)
    solves = LoadSolves(eq_solver, prefix, length_mm)

    def continue_paths(k_steps: int) -> list:
        straight = solves.solve(np.zeros(n), (disc.straight(), np.zeros(n)))
        return deflated_continuation(solves.solve, homotopy_paths(np.zeros(n), p, k_steps),
                                     straight, found, "tensions")

    def multistart(phase_starts, rounds: int) -> None:
        for sweep in range(max(1, passes)):
            before = len(found.found)
            for label, start in phase_starts:
                if sweep == 0 and np.any(start.p != p):
                    for eq, side in loading_paths(eq_solver, p, start=start):
                        found.offer(solves.examined(eq, label + side), label + side,
                                    "loading path")
                for _ in range(rounds):
                    state = solves.solve(p, start, deflate=deflation_of(found, deflation),
                                         max_it=DEFLATED_MAX_IT, label=label)
                    if not found.offer(state, label, "deflation"):
                        break
            if len(found.found) == before:
                break

    def rest():
        return phased_search(found, search_phases(effort, levels, steps, deflation_rounds),
                             starts, lambda lv: tension_starts(eq_solver, levels=lv),
                             continue_paths, multistart)

    curves = n == 2 if curves is None else bool(curves)
    if curves and n != 2:
        raise InputError("the curve search needs exactly two tendons")
    def straight_paths() -> None:
        for order in [None] + list(itertools.permutations(range(1, n + 1))):
            how = "proportional" if order is None else "order " + ",".join(map(str, order))
            for eq, side in loading_paths(eq_solver, p, order=order):
                label = f"straight arm, {how}{side}"
                found.offer(solves.examined(eq, label), label, "loading path")

    search, used = None, []
    try:
        found.attempt(straight_paths)
        if curves and not found.stopped:
            search, used = with_curves(
                disc, p, "load", max(p_max, float(np.max(p))), effort, found,
                lambda u, q, label: solves.solve(p, (u, p), label=label), rest)
        else:
            used = found.attempt(rest) or []
    finally:
        solves.destroy()
    return found.result("load", p, used, curves=search)


# --- one call each, from an arm (for the command line and the Python API) -------------
def search_lengths(arm, lengths_mm, *, elements: int | None = None, effort: int = 1,
                   levels=None, deflation_rounds: int | None = None,
                   steps: int | None = None, progress=None,
                   max_seconds: float | None = None) -> SearchResult:
    """Every equilibrium this search finds with the cable lengths ``lengths_mm``
    (mm, one per tendon) under length control (Sec. 4.6, Eq. (23)) and
    tensions 0 <= P_i <= the motor limit P_crit of Eq. (22) (p <= 200 without
    one, :func:`search_box`): :func:`length_equilibria` on ``arm``
    (``elements``: mesh, default the arm's).  States are non-dimensional
    (``*_mm`` properties in mm).  ``progress(steps, note)``: see
    :func:`length_equilibria`; ``max_seconds``: its time budget (None: none)."""
    from ..core.fem import Discretisation

    disc = Discretisation.from_arm(arm, elements)
    L = check_lengths(np.asarray(lengths_mm, float) / arm.length_mm, disc.n_tendons)
    with LengthSolver(disc, length_mm=arm.length_mm) as solver, \
            EquilibriumSolver(disc) as eq_solver:
        return length_equilibria(solver, L, eq_solver=eq_solver, effort=effort, levels=levels,
                                 deflation_rounds=deflation_rounds, steps=steps,
                                 p_max=search_box(arm), progress=progress,
                                 budget=TimeBudget(max_seconds))


def search_tensions(arm, p, *, elements: int | None = None, effort: int = 1, levels=None,
                    deflation_rounds: int | None = None, progress=None,
                    max_seconds: float | None = None) -> SearchResult:
    """Every equilibrium this search finds at the tensions ``p`` (non-dimensional,
    p = P l^2/B; ``arm.tensions_from_N`` converts newtons) under load control
    (Eq. (9)): :func:`equilibria` on ``arm``.  ``progress(steps, note)``,
    ``max_seconds``: see :func:`search_lengths`."""
    from ..core.fem import Discretisation

    disc = Discretisation.from_arm(arm, elements)
    with EquilibriumSolver(disc) as eq_solver:
        return equilibria(eq_solver, p, effort=effort, levels=levels,
                          deflation_rounds=deflation_rounds, length_mm=arm.length_mm,
                          p_max=search_box(arm), progress=progress,
                          budget=TimeBudget(max_seconds))


# --- length continuation with a global search at its critical points ------------------
def snap_targets(solver: LengthSolver, p_max: float = DEFAULT_P_MAX):
    """A ``post_critical`` callback for :meth:`LengthSolver.follow` (two
    tendons): at the critical lengths, every equilibrium the curve search of
    :class:`~elastica_petsc.studies.preimage.CurveSearch` reaches from the
    straight arm (0 <= p_i <= ``p_max``), the stable ones under length
    control (Sec. 4.6), nearest in shape (max nodal angle difference) to the
    critical state first: where the arm can snap to when the mode
    perturbation finds no stable state nearby."""
    from .preimage import CurveSearch, SearchTracer

    def targets(lengths, u_c, p_c) -> list:
        with SearchTracer(solver.disc) as tracer:
            search = CurveSearch(tracer, lengths, p_max=p_max).run()
            crossings = [search.mf.split(w) for w, _ in search.in_box]
        states = [solver.solve(lengths, (u, np.maximum(p, 0.0))) for u, p in crossings]
        stable = [s for s in states if s.converged and s.length_unstable_modes == 0]
        theta_c = solver.disc.split(np.asarray(u_c))[0]
        stable.sort(key=lambda s: float(np.max(np.abs(s.theta - theta_c))))
        return [(s.u, s.p) for s in stable]

    return targets


def follow_lengths(arm, lengths_mm, *, elements: int | None = None,
                   max_seconds: float | None = None):
    """The equilibrium with cable lengths ``lengths_mm`` (mm) reached from the
    straight arm by length continuation (Sec. 4.6; :meth:`LengthSolver.follow`:
    a stable path, snaps and buckling recorded).  With two tendons, where the
    buckling mode finds no stable state past a critical point, the arm snaps
    to the nearest stable state the curve search finds there
    (:func:`snap_targets`, tensions up to the motor limit of Eq. (22)).
    ``max_seconds``: a time budget (:meth:`LengthSolver.follow`'s ``budget``)."""
    budget = TimeBudget(max_seconds)
    with LengthSolver.from_arm(arm, elements) as solver:
        post = snap_targets(solver, search_box(arm)) if solver.disc.n_tendons == 2 else None
        return solver.follow(solver.to_l(lengths_mm), post_critical=post, budget=budget)
