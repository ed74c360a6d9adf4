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

from dataclasses import dataclass, field
import itertools

import numpy as np

from ..core.results import Result
from ..core.deflation import Deflation
from ..core.errors import InputError
from ..solvers.equilibrium import (Equilibrium, EquilibriumSolver, check_order, check_tensions,
                                   loading_path)
from ..solvers.lengths import (DEFLATION_OPTIONS, SAME_SHAPE_TOL, AugmentedSystem,
                               LengthEquilibrium, LengthInertia, LengthSolver, check_lengths,
                               same_shape)


@dataclass(frozen=True)
class FoundState:
    """One distinct equilibrium of a search and how it was found."""

    state: Equilibrium            # LengthEquilibrium for length control
    start: str                    # label of the first start that reached it
    method: str                   # "loading path", "continuation" or "deflation"
    hits: int                     # how many (start, method) attempts reached it
    number: int = 0               # the state's number (the paper's for Fig. 8's states)


# Fig. 8 of the paper (its arm, Fig. 1): (state number, p = P l^2/B, cable lengths in mm of
# the 600-mm arm).  The paper rounds tensions to 0.1 and lengths to 0.1 mm.
FIG8_STATES = ((1, (25.2, 10.8), (147.1, 472.5)),
               (2, (9.7, 12.6), (147.1, 472.5)),
               (3, (25.2, 10.8), (96.2, 454.3)))
FIG8_LENGTH_MM = 600.0


# Newton iterations allowed to a deflated solve of a search: on the paper's arm the
# successful ones take 18 on average (at most 34 of 234 measured), the failures run
# to any limit, so a lower cap makes a search cheaper (the cost of a failure).
DEFLATED_MAX_IT = 25


# Search settings at effort 1 (the defaults of the command line).
DEFAULT_LEVELS = (5.0, 10.0, 20.0)
DEFAULT_STEPS = 12
DEFAULT_DEFLATION_ROUNDS = 2


MAX_EFFORT = 16


def effort_settings(effort: int = 1, levels=None, name: str = "the search effort") -> dict:
    """Search settings that spend ``effort`` (>= 1) times the default work:
    ``steps`` (deflated continuation points per path segment) and
    ``deflation_rounds`` scale with it, and the tension levels of the starts
    (``levels``, default :data:`DEFAULT_LEVELS`) gain effort - 1 doublings
    of the largest."""
    effort = int(effort)
    if not 1 <= effort <= MAX_EFFORT:
        raise InputError(f"{name} must be an integer >= 1 and <= {MAX_EFFORT} (each "
                         f"doubles the top tension level once more), got {effort}")
    levels = sorted(float(v) for v in (DEFAULT_LEVELS if levels is None else levels))
    levels += [levels[-1] * 2.0 ** k for k in range(1, effort)]
    return {"steps": DEFAULT_STEPS * effort, "levels": tuple(levels),
            "deflation_rounds": DEFAULT_DEFLATION_ROUNDS * effort}


def is_paper_arm(disc) -> bool:
    """True if ``disc`` discretises the arm of the paper's Fig. 1 (same routing
    points and attachments in units of l; any mesh)."""
    from ..core.model import load_config

    paper = load_config()
    return (disc.n_tendons == paper.n_tendons
            and np.allclose(disc.routes, paper.routes(), rtol=0.0, atol=1e-9)
            and np.allclose(np.asarray(disc.attach_nodes) / disc.n_elements,
                            paper.attachments(), rtol=0.0, atol=1e-9))


def state_numbers(states) -> list[int]:
    """Numbers of found states in the paper's numbering: on the paper's arm a
    state matching one of Fig. 8's states (tensions within 0.1, the paper's
    rounding, and cable lengths within 0.5 mm) takes its number (1, 2 or 3);
    every other state is numbered after those (from 4 on the paper's arm when
    one matched, else from 1), in the order of discovery."""
    numbers: list[int | None] = [None] * len(states)
    if states and is_paper_arm(states[0].disc):
        for k, s in enumerate(states):
            for number, p, L_mm in FIG8_STATES:
                if (np.max(np.abs(s.p - p)) <= 0.1 + 1e-9 and number not in numbers and
                        np.max(np.abs(s.cable_lengths * FIG8_LENGTH_MM - L_mm)) <= 0.5):
                    numbers[k] = number
                    break
    nxt = len(FIG8_STATES) + 1 if any(v is not None for v in numbers) else 1
    for k, v in enumerate(numbers):
        if v is None:
            numbers[k], nxt = nxt, nxt + 1
    return numbers


@dataclass(frozen=True, repr=False)
class SearchResult(Result):
    """Distinct equilibria found from a set of starts.  Not a proof that no
    other equilibrium exists: only what these starts and methods reached."""

    control: str                  # "length" or "load"
    target: np.ndarray            # L / l (length) or p (load)
    states: tuple                 # FoundState, by number (:func:`state_numbers`)
    starts: tuple                 # labels of every start tried
    attempts: int                 # solves attempted (starts x methods)
    failures: int                 # attempts that did not converge
    duplicates: int               # converged attempts that re-found a known state
    log: tuple = ()               # (start, method, outcome) per attempt
    curves: dict = field(default_factory=dict)   # the curve search's coverage ({}: none)

    def __len__(self) -> int:
        return len(self.states)

    @property
    def last_new_attempt(self) -> int:
        """1-based number of the attempt that found the last new state (0:
        none): attempts after it found nothing new, a measure of coverage."""
        new = [k for k, (_, _, outcome) in enumerate(self.log, 1) if outcome.startswith("new")]
        return new[-1] if new else 0

    def methods(self) -> dict:
        """Attempts per method: {method: (attempts, new states found)}."""
        out: dict[str, list[int]] = {}
        for _, method, outcome in self.log:
            entry = out.setdefault(method, [0, 0])
            entry[0] += 1
            entry[1] += outcome.startswith("new")
        return {k: tuple(v) for k, v in out.items()}

    def closest(self, p=None, lengths=None) -> FoundState:
        """The found state nearest to given tensions or cable lengths (units of l)."""
        if (p is None) == (lengths is None):
            raise ValueError("give exactly one of p, lengths")
        ref = np.asarray(p if p is not None else lengths, float)
        key = (lambda f: np.max(np.abs(f.state.p - ref))) if p is not None else \
            (lambda f: np.max(np.abs(f.state.cable_lengths - ref)))
        return min(self.states, key=key)

    def curve_method(self) -> str:
        """One sentence on the curve search and its box ('' without one)."""
        c = self.curves
        if not c:
            return ""
        what = "cable lengths" if self.control == "length" else "tensions"
        return (f"curve search: equilibrium curves whose {what} move on a line through the "
                f"target, followed by pseudo-arclength continuation through every fold, from "
                f"the straight arm (its line and every loading order"
                + (", the faces P_i = 0" if self.control == "length" else "")
                + f") and through every state found ({c['directions']} directions); "
                f"{c['curves_followed']} curves, {c['corrector_solves']} corrector solves; "
                f"states with 0 <= p_i <= p_max = {c['p_max']:.6g} (the motor limit P_crit "
                f"of Eq. (22) if the arm sets one, else {DEFAULT_P_MAX:g})"
                + ("" if not c["outside_the_box"] else
                   f", {c['outside_the_box']} found beyond it not listed"))

    def summary(self) -> dict:
        """The search's coverage (what ``lengths --all``/``equilibria --json`` print as
        ``search``) and the states found (``states``: p, L/l, tip in units of l)."""
        from ..io.summaries import search_summary

        return dict(search_summary(self), states=[
            {"number": f.number, "p": f.state.p.tolist(),
             "cable_lengths": f.state.cable_lengths.tolist(), "tip": f.state.tip.tolist(),
             "unstable_modes": int(f.state.unstable_modes)} for f in self.states])

    def report(self) -> str:
        """The search in a few lines of text (a list, not a proof)."""
        what = "cable lengths L/l" if self.control == "length" else "tensions p"
        lines = [f"{len(self.states)} distinct equilibria at {what} = "
                 + ", ".join(f"{v:.6g}" for v in self.target)
                 + f" from {len(self.starts)} starts ({self.attempts} attempts, "
                 f"{self.failures} failed, {self.duplicates} re-found a known state); "
                 "a list, not a proof that there are no others"]
        if self.curves:
            lines.append("  " + self.curve_method())
        for f in self.states:
            s = f.state
            lm = getattr(s, "length_unstable_modes", -1)
            lines.append(
                f"  {f.number}: p = (" + ", ".join(f"{v:.4f}" for v in s.p) + "), L/l = ("
                + ", ".join(f"{v:.6f}" for v in s.cable_lengths) + f"), tip = ({s.tip[0]:.6f}, "
                f"{s.tip[1]:.6f}), unstable modes load/length = {s.unstable_modes}/{lm}; "
                f"first from '{f.start}' by {f.method}, reached {f.hits}x")
        return "\n".join(lines)


# --- several equilibria: starts, continuation, deflation -----------------------------------
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


class _Collector:
    """Distinct states in order of discovery, compared by shape, and a log of
    every attempt: (start, method, outcome) with outcome "new k", "again k"
    (k: 1-based state number) or PETSc's reason of the failure.  ``progress``
    (optional) is called as ``progress(steps, note)`` after every search step
    (:meth:`step`: a continuation point or an attempt from a start)."""

    def __init__(self, tol: float, progress=None):
        self.tol, self.progress, self.steps = tol, progress, 0
        self.found: list[list] = []          # [state, start, method, hits]
        self.log: list[tuple[str, str, str]] = []
        self.attempts = self.failures = self.duplicates = 0

    def step(self, what: str) -> None:
        self.steps += 1
        if self.progress is not None:
            self.progress(self.steps, f"{len(self.found)} found; {what}")

    def offer(self, state, start: str, method: str) -> bool:
        self.attempts += 1
        self.step(f"{method} from {start}")
        if state is None or not state.converged:
            self.failures += 1
            self.log.append((start, method, "failed" if state is None else
                             f"failed ({state.reason})"))
            return False
        for k, entry in enumerate(self.found, 1):
            if same_shape(entry[0], state, self.tol):
                entry[3] += 1
                self.duplicates += 1
                self.log.append((start, method, f"again {k}"))
                return False
        self.found.append([state, start, method, 1])
        self.log.append((start, method, f"new {len(self.found)}"))
        return True

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
                        "corrector_solves": int(curves.solves),
                        "outside_the_box": len(self.found) - len(kept)}
        numbers = state_numbers([e[0] for e in kept])
        found = sorted((FoundState(*e, number=k) for e, k in zip(kept, numbers)),
                       key=lambda f: f.number)
        return SearchResult(control, np.asarray(target, float), tuple(found), tuple(starts),
                            self.attempts, self.failures, self.duplicates, tuple(self.log),
                            coverage)


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


def deflated_continuation(solve, paths, start, found: "_Collector", what: str, *,
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
                if _is_new(state, current):
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
                    if not _is_new(state, current):
                        break
                    current.append(state)
                    deflation.add(state.theta[1:])
            branches = current
        for state in current:
            found.offer(state, f"straight arm, {what} {how}", "deflated continuation")
    return lost


def _is_new(state, known) -> bool:
    return state is not None and state.converged and not any(same_shape(state, k)
                                                              for k in known)


def _phases(effort: int, levels, steps, deflation_rounds) -> list[dict]:
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


def _phased_search(found: "_Collector", phases, starts, make_starts, continue_paths,
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


def _deflation_of(found: "_Collector", deflation: Deflation) -> Deflation:
    """``deflation`` extended by the states of ``found`` it does not hold yet."""
    for entry in found.found[len(deflation):]:
        deflation.add(entry[0].theta[1:])
    return deflation


# Tension box of a complete length search when the arm has no motor limit (p = P l^2/B).
DEFAULT_P_MAX = 200.0
# Directions of the lines through each equilibrium (studies.preimage) at effort 1.
DEFAULT_DIRECTIONS = 4


def search_box(disc_or_arm) -> float:
    """p_max of the tension box 0 <= p_i <= p_max a length search covers: the
    motor limit P_crit of Eq. (22) if the arm has one, else DEFAULT_P_MAX."""
    limit = getattr(disc_or_arm, "max_tension", None)
    return float(limit) if limit is not None else DEFAULT_P_MAX


def _offer_crossings(search, found: "_Collector", polish, start: int) -> None:
    """Offer the crossings ``search.states[start:]`` inside the tension box to
    ``found``, each polished by ``polish(u, p, label)`` (one Newton solve,
    which also judges its stability under load and length control)."""
    box = {id(w) for w, _ in search.in_box}
    for w, label in search.states[start:]:
        if id(w) in box:
            u, p = search.mf.split(w)
            found.offer(polish(u, np.maximum(p, 0.0), label), label, "curve continuation")


def _with_curves(disc, target, control: str, p_max: float, effort: int,
                 found: "_Collector", polish, rest):
    """The curve search (:class:`~elastica_petsc.studies.preimage.CurveSearch`)
    around the other methods ``rest()``: first the curves from the straight
    arm and through every equilibrium they meet, then ``rest()``, then the
    curves through every state ``rest`` added.  Returns (the CurveSearch,
    what ``rest`` returned)."""
    from .preimage import CurveSearch, SearchTracer

    with SearchTracer(disc) as tracer:
        search = CurveSearch(tracer, target, control=control, p_max=p_max,
                             directions=DEFAULT_DIRECTIONS * int(effort),
                             on_curve=lambda label: found.step(f"curve {label}")).run()
        _offer_crossings(search, found, polish, 0)
        before = len(found.found)
        out = rest()
        start = len(search.states)
        for state, label, method, _ in found.found[before:]:
            w = np.concatenate((state.u, state.p))
            # only states on the lines through the target (a slack cable's chord is short)
            if np.all(state.p <= p_max) and np.allclose(search.quantity(w), target, atol=1e-8):
                search.add(w, f"{label} ({method})")
        _offer_crossings(search.close(), found, polish, start)
    return search, out


def length_equilibria(solver: LengthSolver, lengths, starts=None, *,
                      eq_solver: EquilibriumSolver | None = None, continuation: bool = True,
                      effort: int = 1, levels=None, deflation_rounds: int | None = None,
                      passes: int = 2, steps: int | None = None,
                      tol: float = SAME_SHAPE_TOL, curves: bool | None = None,
                      p_max: float = DEFAULT_P_MAX, progress=None) -> SearchResult:
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
    number of steps is not known in advance).
    """
    L = check_lengths(lengths, solver.disc.n_tendons)
    disc = solver.disc
    found = _Collector(tol, progress)
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
                    state = solver.solve(L, start, deflate=_deflation_of(found, deflation),
                                         label=f"{label}; deflation", max_it=DEFLATED_MAX_IT)
                    if not found.offer(state, label, "deflation"):
                        break
            if len(found.found) == before:
                break

    own = eq_solver is None
    eq_solver = EquilibriumSolver(disc) if own else eq_solver

    def rest():
        return _phased_search(found, _phases(effort, levels, steps, deflation_rounds), starts,
                              lambda lv: tension_starts(eq_solver, levels=lv), continue_paths,
                              multistart)

    try:
        search = None
        if curves:
            search, used = _with_curves(
                disc, L, "length", p_max, effort, found,
                lambda u, p, label: solver.solve(L, (u, p), label=label), rest)
        else:
            used = rest()
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
                                      petsc_options=DEFLATION_OPTIONS)
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
               p_max: float = DEFAULT_P_MAX, progress=None) -> SearchResult:
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
    a proof of completeness.  ``progress``: as for :func:`length_equilibria`.
    """
    disc = eq_solver.disc
    p = check_tensions(p, disc.n_tendons)
    n = disc.n_tendons
    found = _Collector(tol, progress)
    deflation = Deflation(disc.h)
    solves = LoadSolves(eq_solver, prefix, length_mm)

    def continue_paths(k_steps: int) -> list:
        straight = solves.solve(np.zeros(n), (disc.straight(), np.zeros(n)))
        return deflated_continuation(solves.solve, homotopy_paths(np.zeros(n), p, k_steps), straight,
                              found, "tensions")

    def multistart(phase_starts, rounds: int) -> None:
        for sweep in range(max(1, passes)):
            before = len(found.found)
            for label, start in phase_starts:
                if sweep == 0 and np.any(start.p != p):
                    for eq, side in loading_paths(eq_solver, p, start=start):
                        found.offer(solves.examined(eq, label + side), label + side,
                                    "loading path")
                for _ in range(rounds):
                    state = solves.solve(p, start, deflate=_deflation_of(found, deflation),
                                         max_it=DEFLATED_MAX_IT, label=label)
                    if not found.offer(state, label, "deflation"):
                        break
            if len(found.found) == before:
                break

    def rest():
        return _phased_search(found, _phases(effort, levels, steps, deflation_rounds), starts,
                              lambda lv: tension_starts(eq_solver, levels=lv), continue_paths,
                              multistart)

    curves = n == 2 if curves is None else bool(curves)
    if curves and n != 2:
        raise InputError("the curve search needs exactly two tendons")
    search = None
    try:
        for order in [None] + list(itertools.permutations(range(1, n + 1))):
            how = "proportional" if order is None else "order " + ",".join(map(str, order))
            for eq, side in loading_paths(eq_solver, p, order=order):
                label = f"straight arm, {how}{side}"
                found.offer(solves.examined(eq, label), label, "loading path")
        if curves:
            search, used = _with_curves(
                disc, p, "load", max(p_max, float(np.max(p))), effort, found,
                lambda u, q, label: solves.solve(p, (u, p), label=label), rest)
        else:
            used = rest()
    finally:
        solves.destroy()
    return found.result("load", p, used, curves=search)


# --- one call each, from an arm (for the command line and the Python API) -------------
def search_lengths(arm, lengths_mm, *, elements: int | None = None, effort: int = 1,
                   levels=None, deflation_rounds: int | None = None,
                   steps: int | None = None, progress=None) -> SearchResult:
    """Every equilibrium this search finds with the cable lengths ``lengths_mm``
    (mm, one per tendon) under length control (Sec. 4.6, Eq. (23)) and
    tensions 0 <= P_i <= the motor limit P_crit of Eq. (22) (p <= 200 without
    one, :func:`search_box`): :func:`length_equilibria` on ``arm``
    (``elements``: mesh, default the arm's).  States are non-dimensional
    (``*_mm`` properties in mm).  ``progress(steps, note)``: see
    :func:`length_equilibria`."""
    from ..core.fem import Discretisation

    disc = Discretisation.from_arm(arm, elements)
    L = check_lengths(np.asarray(lengths_mm, float) / arm.length_mm, disc.n_tendons)
    with LengthSolver(disc, length_mm=arm.length_mm) as solver, \
            EquilibriumSolver(disc) as eq_solver:
        return length_equilibria(solver, L, eq_solver=eq_solver, effort=effort, levels=levels,
                                 deflation_rounds=deflation_rounds, steps=steps,
                                 p_max=search_box(arm), progress=progress)


def search_tensions(arm, p, *, elements: int | None = None, effort: int = 1, levels=None,
                    deflation_rounds: int | None = None, progress=None) -> SearchResult:
    """Every equilibrium this search finds at the tensions ``p`` (non-dimensional,
    p = P l^2/B; ``arm.tensions_from_N`` converts newtons) under load control
    (Eq. (9)): :func:`equilibria` on ``arm``.  ``progress(steps, note)``: see
    :func:`length_equilibria`."""
    from ..core.fem import Discretisation

    disc = Discretisation.from_arm(arm, elements)
    with EquilibriumSolver(disc) as eq_solver:
        return equilibria(eq_solver, p, effort=effort, levels=levels,
                          deflation_rounds=deflation_rounds, length_mm=arm.length_mm,
                          p_max=search_box(arm), progress=progress)


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


def follow_lengths(arm, lengths_mm, *, elements: int | None = None):
    """The equilibrium with cable lengths ``lengths_mm`` (mm) reached from the
    straight arm by length continuation (Sec. 4.6; :meth:`LengthSolver.follow`:
    a stable path, snaps and buckling recorded).  With two tendons, where the
    buckling mode finds no stable state past a critical point, the arm snaps
    to the nearest stable state the curve search finds there
    (:func:`snap_targets`, tensions up to the motor limit of Eq. (22))."""
    with LengthSolver.from_arm(arm, elements) as solver:
        post = snap_targets(solver, search_box(arm)) if solver.disc.n_tendons == 2 else None
        return solver.follow(solver.to_l(lengths_mm), post_critical=post)
