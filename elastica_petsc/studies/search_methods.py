"""The methods of the searches of :mod:`.search` (split from it): load-controlled
starts (:func:`tension_starts`), the collector of distinct states
(:class:`Collector`), deflated continuation along homotopies of the control
parameters (:func:`deflated_continuation`), the phases of a search of some
effort (:func:`phased_search`) and the curve search around them
(:func:`with_curves`).  Non-dimensional (lengths / l, p = P l^2 / B)."""
from __future__ import annotations

import contextlib
import itertools

import numpy as np

from ..core.budget import TimeBudget, TimeLimitReached
from ..core.deflation import Deflation
from ..solvers.equilibrium import Equilibrium, EquilibriumSolver, check_order, loading_path
from ..solvers.lengths import same_shape
from .search_result import (DEFAULT_DIRECTIONS, DEFLATED_MAX_IT, FoundState, SearchResult,
                            effort_settings, state_numbers)

def loading_paths(eq_solver: EquilibriumSolver, p, *, order=None,
                  start: Equilibrium | None = None) -> list[tuple[Equilibrium, str]]:
    """The load-controlled states at ``p`` reached along one loading path
    (:meth:`EquilibriumSolver.solve`), with a label suffix: one state, or two
    when the path crossed a symmetric bifurcation (the default branch, then the
    other side's, :mod:`elastica_petsc.solvers.bifurcation`)."""
    eq = eq_solver.solve(p, order=order, start=start)
    out = [(eq, "")]
    if eq.converged and eq.bifurcations:
        side = eq.bifurcations[0].side
        other = "right" if side == "left" else "left"
        out = [(eq, f", {side} branch at the bifurcation"),
               (eq_solver.solve(p, order=order, start=start, side=other),
                f", {other} branch at the bifurcation")]
    return out


def tension_starts(eq_solver: EquilibriumSolver, levels=(5.0, 10.0, 20.0), orders="all",
                   include_straight: bool = True) -> list[tuple[str, Equilibrium]]:
    """A spread of initial states: the straight arm and the load-controlled
    equilibria at every combination of ``levels`` (one per tendon) reached
    along every loading order (``orders="all"``: proportional and each
    permutation), plus the intermediate states of the ordered paths (the
    first tendons loaded, the others idle).  Paths that share a beginning
    share its solves (warm starts); states reached several ways are kept
    once (same shape, :data:`SAME_SHAPE_TOL`)."""
    disc = eq_solver.disc
    n = disc.n_tendons
    levels = sorted(float(v) for v in levels if v > 0)
    if orders == "all":
        orders = [None] + list(itertools.permutations(range(1, n + 1)))
    out: list[tuple[str, Equilibrium]] = []
    straight = Equilibrium(disc, np.zeros(n), disc.straight(), True, "STRAIGHT", 0, 0,
                           p_requested=np.zeros(n))
    if include_straight:
        out.append(("straight arm", straight))

    def keep(eq, how):
        if eq.converged and not any(same_shape(eq, s) for _, s in out):
            out.append(("load p=(" + ", ".join(f"{v:g}" for v in eq.p) + f") {how}", eq))

    def ordered(order, depth, state):
        if depth == n:
            return
        k = order[depth] - 1
        for level in levels:                  # raise tendon k through the levels, warm
            target = np.array(state.p, float)
            target[k] = level
            (nxt, how), *others = loading_paths(eq_solver, target, start=state)
            if not nxt.converged:
                break
            for eq, side in [(nxt, how)] + others:
                keep(eq, "order " + ",".join(map(str, order)) + side)
            ordered(order, depth + 1, nxt)
            state = nxt

    for order in orders:
        order = check_order(order, n)
        if order is None:
            rays: dict[tuple, list[np.ndarray]] = {}
            for p in itertools.product(levels, repeat=n):
                p = np.array(p)
                rays.setdefault(tuple(np.round(p / np.max(p), 12)), []).append(p)
            for ps in rays.values():
                state = straight
                for p in sorted(ps, key=np.max):
                    (nxt, how), *others = loading_paths(eq_solver, p, start=state)
                    if not nxt.converged:
                        break
                    for eq, side in [(nxt, how)] + others:
                        keep(eq, "proportional" + side)
                    state = nxt
        else:
            ordered(order, 0, straight)
    return out


class Collector:
    """Distinct states in order of discovery, compared by shape, and a log of
    every attempt: (start, method, outcome) with outcome "new k", "again k"
    (k: 1-based state number) or PETSc's reason of the failure.  ``progress``
    (optional) is called as ``progress(steps, note)`` after every search step
    (:meth:`step`: a continuation point or an attempt from a start).

    ``budget`` (a :class:`~elastica_petsc.core.budget.TimeBudget`): once it is
    spent, every step raises TimeLimitReached; :meth:`attempt` runs a phase
    and turns that into ``stopped`` (the note kept in the result), and
    :meth:`wrapping_up` lets the search polish what it holds without asking."""

    def __init__(self, tol: float, progress=None, budget: TimeBudget | None = None):
        self.tol, self.progress, self.steps = tol, progress, 0
        self.budget, self.stopped, self._wrapping = budget, "", False
        self.found: list[list] = []          # [state, start, method, hits]
        self.log: list[tuple[str, str, str]] = []
        self.attempts = self.failures = self.duplicates = 0

    def step(self, what: str) -> None:
        self.steps += 1
        if self.progress is not None:
            self.progress(self.steps, f"{len(self.found)} found; {what}")
        if self.budget is not None and not self._wrapping:
            self.budget.check(what)

    def attempt(self, phase):
        """``phase()``, or None if the time budget stops it (``stopped`` says
        where); a phase is not started once the search is stopped."""
        if self.stopped:
            return None
        try:
            return phase()
        except TimeLimitReached as stop:
            self.stopped = str(stop)
            return None

    @contextlib.contextmanager
    def wrapping_up(self):
        """Context: steps inside do not ask the budget (polishing found states)."""
        self._wrapping = True
        try:
            yield
        finally:
            self._wrapping = False

    def offer(self, state, start: str, method: str) -> bool:
        """Record an attempt's state; True if it is new.  The step (and the
        budget's question) comes after the state is kept."""
        self.attempts += 1
        new = False
        if state is None or not state.converged:
            self.failures += 1
            self.log.append((start, method, "failed" if state is None else
                             f"failed ({state.reason})"))
        else:
            for k, entry in enumerate(self.found, 1):
                if same_shape(entry[0], state, self.tol):
                    entry[3] += 1
                    self.duplicates += 1
                    self.log.append((start, method, f"again {k}"))
                    break
            else:
                self.found.append([state, start, method, 1])
                self.log.append((start, method, f"new {len(self.found)}"))
                new = True
        self.step(f"{method} from {start}")
        return new

    def result(self, control, target, starts, curves=None) -> SearchResult:
        """The search's result; its starts are ``starts`` and every other start
        of an attempt (the straight arm of each homotopy path).  With ``curves``
        (a :class:`~elastica_petsc.studies.preimage.CurveSearch`) only the
        states in its tension box are kept (the others are counted) and the
        curves are summarised in ``coverage``."""
        starts = list(starts)
        for label, _, _ in self.log:
            if label not in starts:
                starts.append(label)
        kept, coverage = self.found, {}
        if curves is not None:
            kept = [e for e in self.found if np.all(e[0].p <= curves.p_max)]
            coverage = {"p_max": float(curves.p_max), "directions": int(curves.directions),
                        "curves_followed": len(curves.traces), "curve_ends": curves.ends(),
                        "corrector_solves": int(curves.counts.solves),
                        "outside_the_box": len(self.found) - len(kept)}
        numbers = state_numbers([e[0] for e in kept])
        found = sorted((FoundState(*e, number=k) for e, k in zip(kept, numbers)),
                       key=lambda f: f.number)
        return SearchResult(control, np.asarray(target, float), tuple(found), tuple(starts),
                            self.attempts, self.failures, self.duplicates, tuple(self.log),
                            coverage, stopped=self.stopped)


def homotopy_paths(start, end, steps: int, orders="all") -> list[tuple[str, np.ndarray]]:
    """Straight homotopies of the control parameters (cable lengths or
    tensions) from ``start`` to ``end``, one per loading order (None: all
    together, proportionally; a permutation: one tendon after another;
    ``"all"``: both kinds, every permutation), each an array (k, n) of
    ``steps`` points per segment, the end included."""
    n = len(start)
    out = []
    if orders == "all":
        orders = [None] + list(itertools.permutations(range(1, n + 1)))
    for order in orders:
        how = "proportional" if order is None else "order " + ",".join(map(str, order))
        corners = [np.asarray(start, float)] + [b for _, b in loading_path(start, end, order)]
        t = np.linspace(0.0, 1.0, steps + 1)[1:, None]
        points = [a + t * (b - a) for a, b in zip(corners[:-1], corners[1:])
                  if np.any(a != b)]
        out.append((how, np.vstack(points)))
    return out


def deflated_continuation(solve, paths, start, found: "Collector", what: str, *,
                          discovery_rounds: int = 1,
                          discovery_max_it: int = DEFLATED_MAX_IT) -> list:
    """Deflated continuation (Farrell, Beentjes & Birkisson 2016) along each
    homotopy ``paths`` (:func:`homotopy_paths`) from the equilibrium
    ``start`` (the straight arm: the only equilibrium at p = 0, and at its
    own cable lengths).  ``solve(target, start, deflate=None, max_it=None)``
    is one (deflated) Newton solve at the path's parameter ``target``.  At
    every point each known branch is continued by one solve from its
    previous state, then up to ``discovery_rounds`` deflated solves from each
    previous state, with every branch known at this point deflated, look
    for branches born since (at folds: next to the known ones); each gets at
    most ``discovery_max_it`` Newton iterations.  The branches that reach
    the end are offered to ``found`` (method "deflated continuation").
    Returns the last states of the branches lost on the way (at folds), as
    labelled starts for other methods."""
    h = start.disc.h
    lost = []
    for how, points in paths:
        branches, current = [start], [start]
        for k, target in enumerate(points):
            found.step(f"continuation in {what}, {how}: {k + 1}/{len(points)}")
            current = []
            for previous in branches:
                state = solve(target, previous)
                if is_new(state, current):
                    current.append(state)
                elif state is None or not state.converged:
                    lost.append((f"branch lost at point {k + 1} of the {what} {how} path",
                                 previous))
            deflation = Deflation(h)
            for c in current:
                deflation.add(c.theta[1:])
            for previous in branches:
                for _ in range(discovery_rounds):
                    state = solve(target, previous, deflate=deflation, max_it=discovery_max_it)
                    if not is_new(state, current):
                        break
                    current.append(state)
                    deflation.add(state.theta[1:])
            branches = current
        for state in current:
            found.offer(state, f"straight arm, {what} {how}", "deflated continuation")
    return lost


def is_new(state, known) -> bool:
    return state is not None and state.converged and not any(same_shape(state, k)
                                                              for k in known)


def search_phases(effort: int, levels, steps, deflation_rounds) -> list[dict]:
    """Settings of the phases of a search: phase k does the work of effort k
    (:func:`effort_settings`); ``steps`` and ``deflation_rounds``, if given,
    replace those of every phase."""
    out = []
    for k in range(1, int(effort) + 1):
        settings = effort_settings(k, levels)
        if steps is not None:
            settings["steps"] = int(steps)
        if deflation_rounds is not None:
            settings["deflation_rounds"] = int(deflation_rounds)
        out.append(settings)
    return out


def phased_search(found: "Collector", phases, starts, make_starts, continue_paths,
                   multistart) -> list[str]:
    """Run the phases in order on one collector, so that a search of higher
    effort finds every state of a lower one (it repeats it first).  Phase k:
    ``continue_paths(steps)`` (deflated continuation, skipped for a number
    of steps already done; it returns the branches it lost), then
    ``multistart(new_starts, rounds)`` on the starts ``make_starts(levels)``
    (``starts``, if given, are phase 1's) and the lost branches, each start
    once over all phases.  Returns the labels of every start used."""
    used: list[str] = []
    done_steps: set[int] = set()
    for k, settings in enumerate(phases):
        lost = []
        if settings["steps"] > 0 and settings["steps"] not in done_steps:
            done_steps.add(settings["steps"])
            lost = continue_paths(settings["steps"])
        phase = starts if (k == 0 and starts is not None) else make_starts(settings["levels"])
        phase = [(label, st) for label, st in list(phase) + lost if label not in used]
        used += [label for label, _ in phase]
        multistart(phase, settings["deflation_rounds"])
    return used


def deflation_of(found: "Collector", deflation: Deflation) -> Deflation:
    """``deflation`` extended by the states of ``found`` it does not hold yet."""
    for entry in found.found[len(deflation):]:
        deflation.add(entry[0].theta[1:])
    return deflation



def offer_crossings(search, found: "Collector", polish, start: int) -> None:
    """Offer the crossings ``search.states[start:]`` inside the tension box to
    ``found``, each polished by ``polish(u, p, label)`` (one Newton solve,
    which also judges its stability under load and length control)."""
    box = {id(w) for w, _ in search.in_box}
    for w, label in search.states[start:]:
        if id(w) in box:
            u, p = search.mf.split(w)
            found.offer(polish(u, np.maximum(p, 0.0), label), label, "curve continuation")


def with_curves(disc, target, control: str, p_max: float, effort: int,
                 found: "Collector", polish, rest):
    """The curve search (:class:`~elastica_petsc.studies.preimage.CurveSearch`)
    around the other methods ``rest()``: first the curves from the straight
    arm and through every equilibrium they meet, then ``rest()``, then the
    curves through every state ``rest`` added.  Returns (the CurveSearch,
    what ``rest`` returned, [] if it did not run).  Each part runs under
    ``found``'s time budget (:meth:`Collector.attempt`); the crossings found
    before a stop are still polished and offered."""
    from .preimage import CurveSearch, SearchTracer

    with SearchTracer(disc) as tracer:
        search = CurveSearch(tracer, target, control=control, p_max=p_max,
                             directions=DEFAULT_DIRECTIONS * int(effort),
                             on_curve=lambda label: found.step(f"curve {label}"))
        found.attempt(search.run)
        with found.wrapping_up():
            offer_crossings(search, found, polish, 0)
        before = len(found.found)
        out = found.attempt(rest) or []
        start = len(search.states)
        if not found.stopped:
            for state, label, method, _ in found.found[before:]:
                w = np.concatenate((state.u, state.p))
                # only states on the lines through the target (a slack cable's chord is short)
                if np.all(state.p <= p_max) and np.allclose(search.quantity(w), target,
                                                            atol=1e-8):
                    search.add(w, f"{label} ({method})")
            found.attempt(search.close)
        with found.wrapping_up():
            offer_crossings(search, found, polish, start)
    return search, out
