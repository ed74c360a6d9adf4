"""Global tip control: reach a target when the local iteration stalls, and say
honestly when it cannot be decided.

:meth:`TipController.solve` is a local method (Eqs. (10)-(12)): it can stop at
a stationary point of E with the tip away from a target that other tensions,
or the same tensions on another branch, do reach (measured before this module:
7.3 % of targets made as tips of random admissible tensions on the paper's
arm ended STATIONARY from the default start).  :func:`reach` runs the local
solve and, only when it fails, continues with

1. **homotopy in target space** from the state the local solve started from:
   the target moves on the straight line from that tip to x_d in steps
   (doubled after a success, halved after a failure), each sub-target
   solved by the local method warm-started from the previous one, as path
   tracing does (Sec. 4.5 (v)): the equilibrium stays on its branch;
2. **neighbours**: equilibria given by the caller (e.g. reached grid
   neighbours in a workspace map), each as a local start and a homotopy start;
3. **seeds**: forward equilibria over a coarse set of tensions reached by
   proportional loading and by every loading order (Fig. 8: other branches),
   built once per :class:`Reacher`; the ``max_seeds`` seeds whose tips are
   nearest x_d are tried as local and homotopy starts.

Every path in tension space is followed by continuation with P >= 0 from the
straight arm, so a reached target lies in W_0 (the tips of stable equilibria
connected to the straight arm by quasi-static loading with all P_i >= 0) and
the result's ``loading`` reproduces it.

Verdicts (``ControlResult.reachable``):

* True: reached (E < eps).
* False: only with a proof about all of W_0, named in ``evidence``.  Proven
  here: ``|x_d| > l`` (``BEYOND_REACH``): the arm is inextensible, so
  |x_t| = |int_0^l t ds| <= l (Eq. (2)) for every state.  With a
  ``boundary`` (a callable, e.g. :func:`elastica_petsc.studies.boundary.boundary_proof`),
  before any global strategy (proof first: before the local solve when the
  boundary is traced already, else after a short local solve, the probe,
  has failed): ``OUTSIDE_BOUNDARY``, the target lies in the unbounded
  component of the plane minus the traced boundary curves of W_0, or in a
  hole of W_0 (faces and tip-map folds, docs/model.md §9), with its distance
  to them; the result is then the local solve's closest tip.
* None (reason ``SEARCH_EXHAUSTED``): not reached and not proven
  unreachable; the result is the closest tip found (a stationary point with
  a tension on its lower bound is *local* evidence that the target needs
  P_i < 0, see ``on_bound``).
* None (reason ``TIME_LIMIT``): the :class:`~elastica_petsc.core.budget.TimeBudget`
  was spent before a verdict: the closest tip found so far, reachability
  undecided (the strategies not run are named in ``evidence``).

Cables through the arm (:mod:`elastica_petsc.core.clearance`): with
``cables="prefer"`` a reached state whose cable crosses the arm starts a
search (local solves and homotopies from the seeds whose cables are clear)
for a state with clear cables, returned if found, else the crossing state
(flagged); ``"require"`` returns not converged, reason CABLE_CROSSES_ARM,
``reachable`` None; ``"ignore"`` (the default of :func:`Reacher.reach`)
does not look.
"""
from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np

from ..core.budget import TIME_LIMIT, TimeLimitReached
from ..core.clearance import state_cable_clear
from ..core.loading import Loading
from .control import ControlResult, StartFailed, TipController
from .equilibrium import COLLAPSE_LENGTH, Equilibrium

BEYOND_REACH = "BEYOND_REACH"            # reason and evidence: |x_d| > l
OUTSIDE_BOUNDARY = "OUTSIDE_BOUNDARY"    # reason and evidence: outside the traced boundary
#                                          of W_0 (faces and tip-map folds, docs/model.md §9)
SEARCH_EXHAUSTED = "SEARCH_EXHAUSTED"    # reason: global strategies tried, undecided
CABLE_CROSSES_ARM = "CABLE_CROSSES_ARM"  # reason (cables="require"): reached only with a
#                                          cable through the arm
CABLE_POLICIES = ("ignore", "prefer", "require")
CLOSEST_STALL = (2, 1e-3)                # the local solve beside an OUTSIDE_BOUNDARY proof
#                                          stops once E falls by < 0.1 % over 2 iterations:
#                                          the closest tip is then known to ~0.05 % of its
#                                          distance (measured: 5 s -> 0.04 s on the hole of
#                                          the paper's arm at (387.4, -261.1) mm)
MAX_SEED_SOLVES = 2000                   # budget of a seed library, equilibrium solves (the
#                                          full library of n <= 3 tendons fits: 1566 for n = 3)


@dataclasses.dataclass(frozen=True)
class Start:
    """An equilibrium to start from, with the loading path that reached it."""

    equilibrium: Equilibrium
    loading: Loading | None
    label: str = ""


def beyond_reach(target: np.ndarray) -> str:
    """The evidence string if ``target`` (units of l) is farther than l from
    the clamp, else ''.  |x_t| <= l for any state of the inextensible arm (Eq. (2))."""
    r = float(np.linalg.norm(target))
    if r > 1.0 + 1e-12:
        return (f"{BEYOND_REACH}: |x_d| = {r:.6g} l > l, and the inextensible arm's tip is "
                "never farther than l from the clamp (|x_t| = |int_0^l t ds| <= l, Eq. (2))")
    return ""


class SeedLibrary:
    """Forward equilibria on a grid of tension levels, reached by every loading
    order (Fig. 8: the order selects the branch) and by proportional loading.

    For each order (a permutation of the tendons) the first tendon is swept
    through ``levels`` by continuation; from each of its states the next
    tendon is swept likewise, and so on: every recorded state's loading path
    raises the tendons one after another in that order.  Proportional rays
    along simplex-grid directions are added.  Kept: converged, stable, no
    cable shorter than 5 COLLAPSE_LENGTH.  Built on first use (a few hundred
    warm continuation solves; about 1-2 s at 180 elements on an idle core).

    Budget (``max_solves`` equilibrium solves, default :data:`MAX_SEED_SOLVES`):
    the full library takes up to n! sum_{k=1}^{n} L^k sweep solves (L levels)
    plus L per ray, which grows like n! 6^n (about 37,000 solves for n = 4:
    minutes).  The rule: all levels and all n! loading orders while they fit
    (every arm with n <= 3 tendons); else the largest number of levels L that
    fits (spread over the range, the smallest and largest kept; L = 1: the
    middle level), then as many loading orders as fit (each tendon first
    once before the others), and a hard stop at the budget (rays included).
    :attr:`cap_note` says what was cut ('' when nothing was)."""

    def __init__(self, controller: TipController, levels=(2.0, 6.0, 14.0, 28.0, 50.0, 80.0),
                 divisions: int = 4, max_solves: int = MAX_SEED_SOLVES):
        self.controller = controller
        upper = np.inf if controller.upper is None else controller.upper
        full = tuple(v for v in levels if v <= upper)
        self.divisions = divisions if controller.n <= 2 else 2
        self.max_solves, self.solves, self.stopped = int(max_solves), 0, False
        self.full_count = self._count(len(full), math.factorial(controller.n))
        self.levels, self.orders = self._budget(full)
        self._seeds: list[Start] | None = None
        self.on_seed = None            # called with the number of seeds kept so far (progress)
        self._full_levels = len(full)

    def _count(self, levels: int, orders: int) -> int:
        """Upper bound of the solves of ``orders`` sweeps over ``levels`` levels, and the rays."""
        n = self.controller.n
        rays = sum(1 for c in itertools.product(range(self.divisions + 1), repeat=n)
                   if sum(c) == self.divisions and max(c) < self.divisions)
        return orders * sum(levels ** k for k in range(1, n + 1)) + rays * levels

    def _budget(self, full: tuple) -> tuple[tuple, list]:
        """(levels, loading orders) that fit the budget (class doc)."""
        n = self.controller.n
        orders = list(itertools.permutations(range(n)))
        L = len(full)
        while L > 1 and self._count(L, len(orders)) > self.max_solves:
            L -= 1
        if L < len(full):
            pick = ([len(full) // 2] if L == 1 else
                    np.round(np.linspace(0, len(full) - 1, L)).astype(int).tolist())
            full = tuple(full[i] for i in pick)
        if self._count(L, len(orders)) > self.max_solves:      # each tendon first once, first
            first = [tuple((i + j) % n for j in range(n)) for i in range(n)]
            orders = first + [o for o in orders if o not in first]
            while len(orders) > 1 and self._count(L, len(orders)) > self.max_solves:
                orders.pop()
        return full, orders

    @property
    def cap_note(self) -> str:
        """What the budget cut from the library ('' if nothing)."""
        n_orders = math.factorial(self.controller.n)
        if (len(self.levels) == self._full_levels and len(self.orders) == n_orders
                and not self.stopped):
            return ""
        return (f"seed library capped by its budget of {self.max_solves} equilibrium solves, "
                f"the full library needing up to {self.full_count}: {len(self.levels)} of "
                f"{self._full_levels} tension levels, {len(self.orders)} of {n_orders} loading "
                f"orders" + (", stopped at the budget" if self.stopped else ""))

    def _solve(self, p: np.ndarray, start: Equilibrium | None) -> Equilibrium | None:
        """One counted solve; None once the budget is spent."""
        if self.solves >= self.max_solves:
            self.stopped = True
            return None
        self.solves += 1
        return self.controller.solver.solve(p, start=start)

    def seeds(self) -> list[Start]:
        if self._seeds is None:
            self._seeds = []
            n = self.controller.n
            root = Start(None, Loading.straight(n), "")
            try:
                for order in self.orders:
                    self._sweep(root, order)
                self._rays()
            except BaseException:          # e.g. a time limit: never keep half a library
                self._seeds = None
                raise
        return self._seeds

    def adopt(self, seeds: list[Start], solves: int, stopped: bool, disc=None) -> None:
        """Use the ``seeds`` of another library of the same arm and controller
        (e.g. built on another rank: a fixed function of the arm), with its
        count of ``solves`` and whether it ``stopped`` at the budget.  Their
        equilibria are bound to ``disc`` (default the controller's: they may
        come with a copy of it)."""
        disc = self.controller.disc if disc is None else disc
        self._seeds = [Start(dataclasses.replace(s.equilibrium, disc=disc), s.loading, s.label)
                       for s in seeds]
        self.solves, self.stopped = int(solves), bool(stopped)

    def _keep(self, eq: Equilibrium, loading: Loading, label: str) -> bool:
        ok = eq.converged and eq.stable and np.min(eq.cable_lengths) > 5 * COLLAPSE_LENGTH
        if ok:
            self._seeds.append(Start(eq, loading, label))
            if self.on_seed is not None:
                self.on_seed(len(self._seeds))
        return ok

    def _sweep(self, parent: Start, order: tuple) -> None:
        """Raise tendon order[0] through the levels from ``parent``, recursing
        into the remaining tendons from each state (continuation throughout)."""
        if not order:
            return
        i = order[0]
        eq, loading = parent.equilibrium, parent.loading
        for level in self.levels:
            p = (np.zeros(self.controller.n) if eq is None else eq.p).copy()
            p[i] = level
            eq = self._solve(p, eq)
            if eq is None:
                return
            loading = loading.then(p)
            label = f"p={np.round(p, 3).tolist()} {loading.describe()}"
            if not self._keep(eq, loading, label):
                break
            start = Start(eq, loading, label)
            if len(order) > 1:
                self._sweep(start, order[1:])

    def _rays(self) -> None:
        n, k = self.controller.n, self.divisions
        for combo in itertools.product(range(k + 1), repeat=n):
            if sum(combo) != k or max(combo) == k:
                continue                      # one-tendon rays are in the sweeps
            direction = np.array(combo, float) / max(combo)
            eq, loading = None, Loading.straight(n)
            for level in self.levels:
                eq = self._solve(level * direction, eq)
                if eq is None:
                    return
                loading = loading.then(level * direction)
                if not self._keep(eq, loading, f"p={np.round(level * direction, 3).tolist()} "
                                               "proportional from zero"):
                    break

    def nearest(self, target: np.ndarray, k: int) -> list[Start]:
        seeds = self.seeds()
        d = [float(np.linalg.norm(s.equilibrium.tip - target)) for s in seeds]
        return [seeds[i] for i in np.argsort(d)[:k]]


def replay(solver, loading: Loading, start: Equilibrium | None = None) -> Equilibrium | None:
    """The equilibrium at the end of ``loading``, each segment followed by
    continuation (:meth:`EquilibriumSolver.solve`); None if a segment fails."""
    eq = start
    for vertex in loading.vertices():
        eq = solver.solve(vertex, start=eq)
        if not eq.converged:
            return None
    if eq is None:
        eq = solver.solve(np.zeros(loading.p.size))
    return eq


class Reacher:
    """Local tip control plus the global strategies of the module doc.

    controller : the :class:`TipController` doing the local solves.
    homotopy_step : first and largest sub-target step, units of l.
    min_step : give a homotopy up when its step falls below this (units of l).
    max_seeds : seeds tried per target (nearest tips first).
    max_substeps : sub-target solves per homotopy.
    max_homotopies : homotopies per target (from the initial state, the
        neighbours, then the nearest seeds).
    local_its : iteration limit of the local solves of the global phase (a
        reached target needs < 10 from a good start; a solve that stalls
        would otherwise spend its full budget on penalised evaluations).
    boundary : None, or a callable ``boundary(target, trace=True)`` (target in
        units of l) -> (evidence, distance in units of l), evidence '' unless
        the target is proven outside W_0 (``OUTSIDE_BOUNDARY``); with
        ``trace=False`` it may answer only from a boundary already traced
        (:func:`~elastica_petsc.studies.boundary.boundary_proof`; distance
        nan: not traced).  Asked before the local solve (``trace=False``),
        and after a failed probe (:meth:`_probe`) when it was not traced.
    budget : None, or a :class:`~elastica_petsc.core.budget.TimeBudget`:
        once spent, the search stops at its next step and returns the
        closest tip so far with reason ``TIME_LIMIT`` (the first local solve
        always yields a state; a proof is then taken only from a boundary
        already traced).
    progress : None, or a callable ``progress(steps, note)`` told of every
        search step of :meth:`reach` (a local solve, a homotopy sub-target,
        building the seed library, the boundary proof) with what it is doing
        (ui/progress.py: ``control`` shows it while the global search runs).
    """

    def __init__(self, controller: TipController, *, homotopy_step: float = 0.08,
                 min_step: float = 2e-3, max_seeds: int = 6, max_substeps: int = 25,
                 local_its: int = 30, max_homotopies: int = 4, seeds: SeedLibrary | None = None,
                 boundary=None, progress=None, budget=None):
        self.controller = controller
        self.budget = budget
        self.progress, self.steps = progress, 0
        self.boundary = boundary
        self.max_homotopies = max_homotopies
        self.local_its = local_its
        self.homotopy_step = homotopy_step
        self.min_step = min_step
        self.max_seeds = max_seeds
        self.max_substeps = max_substeps
        self.library = seeds if seeds is not None else SeedLibrary(controller)

    def step(self, note: str, check: bool = True) -> None:
        """One search step done or starting (``progress``); with ``check``,
        raises TimeLimitReached once the budget is spent."""
        self.steps += 1
        if self.progress is not None:
            self.progress(self.steps, note)
        if check and self.budget is not None:
            self.budget.check(note)

    def _on_seed(self, count: int) -> None:
        """Progress of the seed library, which also stops at the time budget."""
        if self.progress is not None:
            self.progress(self.steps, f"global search: seed library, {count} equilibria"
                          + (f" (capped: budget of {self.library.max_solves} solves)"
                             if self.library.cap_note else ""))
        if self.budget is not None:
            self.budget.check("the seed library")

    def _solve(self, target, **kw) -> ControlResult:
        """One local solve (:meth:`TipController.solve`) under the budget."""
        return self.controller.solve(target, budget=self.budget, **kw)

    # --- strategies --------------------------------------------------------------
    def homotopy(self, target: np.ndarray, start: Start) -> ControlResult | None:
        """Move the target from ``start``'s tip to ``target`` in warm-started
        steps; the last converged sub-result (its target may fall short)."""
        tip0 = start.equilibrium.tip.copy()
        d = target - tip0
        dist = float(np.linalg.norm(d))
        if dist == 0.0:
            return None
        t, h = 0.0, min(1.0, self.homotopy_step / dist)
        eq, loading, last = start.equilibrium, start.loading, None
        for _ in range(self.max_substeps):
            t_new = 1.0 if t + h >= 1.0 - 1e-12 else t + h
            self.step(f"homotopy in target space from {start.label or 'a state'}: "
                       f"{100 * t_new:.0f} % of the way")
            res = self._solve(tip0 + t_new * d, start=eq, start_loading=loading,
                              max_failures=2, max_it=self.local_its)
            if res.converged:
                t, eq, loading, last = t_new, res.equilibrium, res.loading, res
                if t >= 1.0:
                    break
                h = min(2.0 * h, self.homotopy_step / dist)
            else:
                h *= 0.5
                if h * dist < self.min_step:
                    break
        return last

    def _local(self, target, start: Start, tried: list) -> ControlResult | None:
        self.step(f"local solve from {start.label or 'a state'}")
        res = self._solve(target, start=start.equilibrium, start_loading=start.loading,
                          max_failures=3, max_it=self.local_its)
        tried.append(res)
        return res if res.converged else None

    def _homotopy(self, target, start: Start, tried: list) -> ControlResult | None:
        last = self.homotopy(target, start)
        if last is not None:
            tried.append(last)
            if last.converged and np.array_equal(last.target, target):
                return last
        return None

    # --- public --------------------------------------------------------------------
    def reach(self, target, p0=None, start: Equilibrium | None = None,
              start_loading: Loading | None = None, neighbours=(),
              global_search: bool = True, cables: str = "ignore") -> ControlResult:
        """Tensions putting the tip on ``target`` (units of l): the local solve
        (:meth:`TipController.solve`, same arguments), then if needed the
        global strategies of the module doc: local solves from the
        ``neighbours`` (extra :class:`Start` s, e.g. reached nearby states)
        and from the nearest seeds, then homotopies from the initial state,
        the neighbours and the seeds.  ``cables``: ignore, prefer or
        require cables clear of the arm (module doc)."""
        if cables not in CABLE_POLICIES:
            raise ValueError(f"cables must be one of {CABLE_POLICIES}, got {cables!r}")
        target = np.asarray(target, dtype=float).ravel()
        evidence, reason, traced = beyond_reach(target), BEYOND_REACH, True
        if not evidence and global_search and self.boundary is not None:
            self.step("boundary proof from the boundary already traced", check=False)
            evidence, distance = self.boundary(target, trace=False)
            reason, traced = OUTSIDE_BOUNDARY, not math.isnan(distance)
        if evidence:                 # the closest tip from a short local solve
            first = self._solve(target, p0=p0, start=start, start_loading=start_loading,
                                max_failures=3, max_it=self.local_its,
                                stall=CLOSEST_STALL if reason == OUTSIDE_BOUNDARY else None)
            return dataclasses.replace(first, reachable=False, reason=reason,
                                       local_reason=first.reason, evidence=evidence,
                                       message=evidence,
                                       strategy="boundary proof" if reason == OUTSIDE_BOUNDARY
                                       else first.strategy)
        self.step("local tip control", check=False)
        if not traced:                   # a short local solve before tracing the boundary
            probe = self._probe(target, p0, start, start_loading)
            if probe is not None and probe.converged:
                return self._clear(target, probe, cables)
            proven = None if probe is None else self._outside(target, probe)
            if proven is not None and proven.reachable is False:
                return proven
        first = self._first(target, p0, start, start_loading)
        if first.converged:
            return self._clear(target, first, cables)
        if not global_search:
            return first
        proven = self._outside(target, first)
        if proven.reachable is False:
            return proven
        tried = [first]
        try:
            return self._global(target, first, tried, start, start_loading, neighbours, cables)
        except TimeLimitReached as stop:
            return self._stopped(target, tried, str(stop))

    def _global(self, target, first, tried, start, start_loading, neighbours, cables):
        """The global strategies of the module doc after a failed local solve."""
        origin = self._origin(first, start, start_loading)
        self.step("global search: seed library (equilibria over every loading order)")
        self.library.on_seed = self._on_seed
        seeds = self.library.nearest(target, self.max_seeds)
        plan = ([("neighbour", s, self._local) for s in neighbours]
                + [("seed", s, self._local) for s in seeds]
                + [("homotopy", s, self._homotopy)
                   for s in (origin + list(neighbours) + seeds)[:self.max_homotopies]])
        for kind, s, run in plan:
            res = run(target, s, tried)
            if res is not None:
                res = dataclasses.replace(res, strategy=f"{kind} from {s.label}")
                return self._clear(target, res, cables)
        return self._closest(target, tried)

    def _probe(self, target, p0, start, start_loading) -> ControlResult | None:
        """The local solve cut short (``local_its`` iterations, 3 failures,
        stopped when E stalls: ``CLOSEST_STALL``), before the boundary is
        traced: a target it reaches has exactly the full solve's result (the
        same iterations, none of the limits met); one it does not reach is
        asked of the boundary before the full local solve runs.  None if the
        start fails."""
        try:
            return self._solve(target, p0=p0, start=start, start_loading=start_loading,
                               max_failures=3, max_it=self.local_its, stall=CLOSEST_STALL)
        except StartFailed:
            return None

    def _first(self, target, p0, start, start_loading) -> ControlResult:
        """The local solve from the given start; a start at which no equilibrium
        can be computed (a guess that collapses a cable) is a failed start like
        any other: the local solve from the straight arm follows."""
        try:
            return self._solve(target, p0=p0, start=start, start_loading=start_loading)
        except StartFailed as failed:
            if p0 is None and start is None:
                raise
            self.step("the initial tensions failed: local tip control from the straight arm",
                      check=False)
            res = self._solve(target)
            return dataclasses.replace(res, strategy=f"local from the straight arm ({failed})")

    def _outside(self, target: np.ndarray, res: ControlResult) -> ControlResult:
        """Proof first: an undecided local result becomes ``reachable=False``
        (OUTSIDE_BOUNDARY, strategy "boundary proof") when ``self.boundary``
        proves the target outside W_0, without any global search.  With the
        budget spent only a boundary already traced is asked."""
        if res.converged or res.reachable is not None or self.boundary is None:
            return res
        self.step("boundary proof: the traced boundary of W_0", check=False)
        trace = self.budget is None or not self.budget.expired()
        evidence, _ = self.boundary(target) if trace else self.boundary(target, trace=False)
        if not evidence:
            return res
        return dataclasses.replace(res, reachable=False, reason=OUTSIDE_BOUNDARY,
                                   local_reason=res.reason, evidence=evidence,
                                   message=evidence, strategy="boundary proof")

    def _stopped(self, target: np.ndarray, tried: list, stop: str) -> ControlResult:
        """The closest tip found before the budget was spent, undecided (TIME_LIMIT)."""
        best = min(tried, key=lambda r: float(np.linalg.norm(r.tip - target)))
        mm = self.controller.length_mm
        proof = ("; the traced boundary of W_0 does not prove it outside" if self.boundary
                 is not None else "")
        note = (f"{stop}: not reached in time by {len(tried)} local solve(s); reachability "
                f"undecided (the global search was not finished{proof}). Closest tip so far "
                f"{best.tip_error * mm:.4g} mm away, local end {best.reason}")
        return dataclasses.replace(best, converged=False, reachable=None, reason=TIME_LIMIT,
                                   local_reason=best.reason, message=note, evidence=note)

    def _clear(self, target, res: ControlResult, cables: str) -> ControlResult:
        """Apply the cable policy to a reached state (module doc)."""
        if cables == "ignore" or np.all(state_cable_clear(res.equilibrium)):
            return res
        stopped = ""
        try:
            self.step("a cable crosses the arm: searching for clear cables")
            tried = []
            seeds = [s for s in self.library.nearest(target, 4 * self.max_seeds)
                     if np.all(state_cable_clear(s.equilibrium))]
            plan = ([(s, self._local) for s in seeds[:2 * self.max_seeds]]
                    + [(s, self._homotopy) for s in seeds[:self.max_homotopies]])
            for s, run in plan:
                found = run(target, s, tried)
                if found is not None and np.all(state_cable_clear(found.equilibrium)):
                    return dataclasses.replace(found, strategy=f"clear cables: from {s.label}")
        except TimeLimitReached as stop:
            stopped = str(stop)
        if cables == "prefer":
            return res
        crossing = [i + 1 for i, c in enumerate(state_cable_clear(res.equilibrium)) if not c]
        note = (f"{CABLE_CROSSES_ARM}: the target is reached only with the cable of tendon(s) "
                f"{crossing} through the arm; no state with clear cables found"
                + (f" before the time limit ({stopped})" if stopped else ""))
        return dataclasses.replace(res, converged=False, reachable=None,
                                   reason=TIME_LIMIT if stopped else CABLE_CROSSES_ARM,
                                   local_reason=res.reason, message=note, evidence=note)

    def _origin(self, first: ControlResult, start, start_loading) -> list:
        """The state the local solve started from, for the homotopy."""
        if start is not None:
            return [Start(start, start_loading, "the given start")]
        ev = self.controller.evaluate(first.history_p[0])
        return [] if ev is None else [Start(ev.equilibrium, ev.loading, "the initial tensions")]

    def _closest(self, target: np.ndarray, tried: list) -> ControlResult:
        """The closest tip found, re-solved towards ``target`` from its state,
        reported undecided (SEARCH_EXHAUSTED)."""
        best = min(tried, key=lambda r: float(np.linalg.norm(r.tip - target)))
        if not np.array_equal(best.target, target):
            self.step("local solve from the closest tip found")
            tried.append(self._solve(target, start=best.equilibrium,
                                     start_loading=best.loading, max_failures=3))
            best = tried[-1]
        if best.converged:
            return dataclasses.replace(best, strategy="closest state")
        if best.reason == TIME_LIMIT:
            raise TimeLimitReached(f"{TIME_LIMIT}: during the local solve from the closest tip")
        mm = self.controller.length_mm
        capped = self.library.cap_note
        note = (f"{SEARCH_EXHAUSTED}: not reached by the local solve, a homotopy in target "
                f"space, {len(tried)} solves from neighbours and seeds (other loading orders"
                + (f"; {capped}" if capped else "") + "); not proven unreachable. Closest tip "
                f"{best.tip_error * mm:.4g} mm away, local end {best.reason}")
        return dataclasses.replace(best, reachable=None, reason=SEARCH_EXHAUSTED,
                                   local_reason=best.reason,
                                   message=note + "; " + best.message, evidence=note)




def simplest_loading(solver, equilibrium: Equilibrium, loading: Loading | None,
                     tol: float = 1e-8) -> Loading | None:
    """A simpler loading path reaching the same state, if there is one:
    proportional loading, else each loading order (Fig. 8), replayed from the
    straight arm; accepted when every nodal angle agrees within ``tol`` rad.
    Otherwise ``loading`` unchanged (the recorded path always reproduces it)."""
    p = np.asarray(equilibrium.p, float)
    n = p.size
    candidates = [Loading.proportional(p)]
    if n > 1:
        candidates += [Loading.ordered(p, [i + 1 for i in perm])
                       for perm in itertools.permutations(range(n))]
    for candidate in candidates:
        if loading is not None and len(candidate) >= len(loading):
            break
        eq = replay(solver, candidate)
        if eq is not None and np.max(np.abs(eq.theta - equilibrium.theta)) < tol:
            return candidate
    return loading
