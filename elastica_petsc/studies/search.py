"""Searches for several equilibria at the same tensions or cable lengths
(Fig. 8: states 1 and 2 share the cable lengths, states 1 and 3 the tensions).

Starts come from loading paths (:func:`tension_starts`); from each start a
search continues (in the cable lengths) or loads (in the tensions) to the
target, then runs deflated Newton solves (Farrell et al. 2015,
:mod:`elastica_petsc.core.deflation`) that cannot return to the states
already found.  A search reports what it found and from where, never that
nothing else exists.  Non-dimensional (lengths / l, p = P l^2 / B).
"""
from __future__ import annotations

from dataclasses import dataclass
import itertools

import numpy as np

from ..core.deflation import Deflation
from ..solvers.equilibrium import Equilibrium, EquilibriumSolver, check_order, check_tensions
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


def is_paper_arm(disc) -> bool:
    """True if ``disc`` discretises the arm of the paper's Fig. 1 (same routing
    points and attachments in units of l; any mesh)."""
    from ..core.config import load_config

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


@dataclass(frozen=True)
class SearchResult:
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

    def __len__(self) -> int:
        return len(self.states)

    def closest(self, p=None, lengths=None) -> FoundState:
        """The found state nearest to given tensions or cable lengths (units of l)."""
        if (p is None) == (lengths is None):
            raise ValueError("give exactly one of p, lengths")
        ref = np.asarray(p if p is not None else lengths, float)
        key = (lambda f: np.max(np.abs(f.state.p - ref))) if p is not None else \
            (lambda f: np.max(np.abs(f.state.cable_lengths - ref)))
        return min(self.states, key=key)

    def summary(self) -> str:
        what = "cable lengths L/l" if self.control == "length" else "tensions p"
        lines = [f"{len(self.states)} distinct equilibria at {what} = "
                 + ", ".join(f"{v:.6g}" for v in self.target)
                 + f" from {len(self.starts)} starts ({self.attempts} attempts, "
                 f"{self.failures} failed, {self.duplicates} re-found a known state); "
                 "not a proof that there are no others"]
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
            nxt = eq_solver.solve(target, start=state)
            if not nxt.converged:
                break
            keep(nxt, "order " + ",".join(map(str, order)))
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
                    nxt = eq_solver.solve(p, start=state)
                    if not nxt.converged:
                        break
                    keep(nxt, "proportional")
                    state = nxt
        else:
            ordered(order, 0, straight)
    return out


class _Collector:
    """Distinct states in order of discovery, compared by shape, and a log of
    every attempt: (start, method, outcome) with outcome "new k", "again k"
    (k: 1-based state number) or PETSc's reason of the failure."""

    def __init__(self, tol: float):
        self.tol = tol
        self.found: list[list] = []          # [state, start, method, hits]
        self.log: list[tuple[str, str, str]] = []
        self.attempts = self.failures = self.duplicates = 0

    def offer(self, state, start: str, method: str) -> bool:
        self.attempts += 1
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

    def result(self, control, target, starts) -> SearchResult:
        numbers = state_numbers([e[0] for e in self.found])
        found = sorted((FoundState(*e, number=k) for e, k in zip(self.found, numbers)),
                       key=lambda f: f.number)
        return SearchResult(control, np.asarray(target, float), tuple(found), tuple(starts),
                            self.attempts, self.failures, self.duplicates, tuple(self.log))


def length_equilibria(solver: LengthSolver, lengths, starts=None, *,
                      eq_solver: EquilibriumSolver | None = None, continuation: bool = True,
                      deflation_rounds: int = 2, passes: int = 2,
                      tol: float = SAME_SHAPE_TOL) -> SearchResult:
    """Distinct equilibria with cable lengths ``lengths`` (units of l).

    From every start (default :func:`tension_starts`): (1) continuation in
    the cable lengths from the start's own lengths (:meth:`LengthSolver.follow`,
    unstable states allowed), then (2) up to ``deflation_rounds`` deflated VI
    Newton solves from the start itself, each deflating every state found so
    far (Farrell et al. 2015, whose deflated solves here use the l2 line
    search, :data:`DEFLATION_OPTIONS`).  While a sweep over the starts finds
    new states, the deflated solves are repeated from every start (at most
    ``passes`` sweeps), so early starts also see the roots found later.
    States are distinct if some nodal angle
    differs by more than ``tol`` rad.  Each state reports its stability under
    load and length control.  What is returned is what these starts reached,
    never a claim that no other equilibrium exists.
    """
    L = check_lengths(lengths, solver.disc.n_tendons)
    if starts is None:
        own = eq_solver is None
        eq_solver = EquilibriumSolver(solver.disc) if own else eq_solver
        try:
            starts = tension_starts(eq_solver)
        finally:
            if own:
                eq_solver.destroy()
    found = _Collector(tol)
    deflation = Deflation(solver.disc.h)
    for sweep in range(max(1, passes)):
        before = len(found.found)
        for label, start in starts:
            if continuation and sweep == 0:
                state = solver.follow(L, start, keep_stable=False, label=f"{label}; continuation")
                if found.offer(state, label, "continuation"):
                    deflation.add(state.theta[1:])
            for _ in range(deflation_rounds):
                state = solver.solve(L, start, deflate=deflation, label=f"{label}; deflation")
                if not found.offer(state, label, "deflation"):
                    break
                deflation.add(state.theta[1:])
        if len(found.found) == before:
            break
    return found.result("length", L, [s[0] for s in starts])


def equilibria(eq_solver: EquilibriumSolver, p, starts=None, *, deflation_rounds: int = 2,
               passes: int = 2, tol: float = SAME_SHAPE_TOL, prefix: str = "defl_",
               length_mm: float | None = None) -> SearchResult:
    """Distinct load-controlled equilibria at fixed tensions ``p``.

    (1) Loading paths from the straight arm: proportional and every order
    (:meth:`EquilibriumSolver.solve`); (2) from every start (default
    :func:`tension_starts`): the loading path from the start's tensions to
    ``p``, then up to ``deflation_rounds`` deflated Newton solves on the
    plain residual F(u; p) from the start, deflating every state found so
    far (own SNES VI with unbounded p, options prefix ``defl_``, l2 line
    search by default), repeated over all starts while a sweep finds new
    states (at most ``passes`` sweeps).  Each state
    is a :class:`LengthEquilibrium` whose prescribed lengths are its own
    cable chords, with ``unstable_modes`` (load control) and
    ``length_unstable_modes`` (the same state held at its cable lengths).
    Not a proof of completeness.
    """
    disc = eq_solver.disc
    p = check_tensions(p, disc.n_tendons)
    found = _Collector(tol)
    n = disc.n_tendons
    length_inertia = LengthInertia(disc)

    def examined(eq: Equilibrium | None, label: str):
        if eq is None or not eq.converged:
            return eq
        lengths = disc.cables(disc.split(eq.u)[1])[0]
        return LengthEquilibrium(
            disc, np.asarray(eq.p, float).copy(), np.asarray(eq.u, float).copy(), True,
            eq.reason, eq.iterations, eq.load_steps, unstable_modes=eq.unstable_modes,
            snaps=eq.snaps, p_requested=p, lengths_requested=lengths,
            length_unstable_modes=length_inertia.negative_eigenvalues(eq.u, eq.p),
            length_mm=length_mm, label=label)

    deflation = Deflation(disc.h)
    system = AugmentedSystem(disc, "load", prefix, deflation, options=DEFLATION_OPTIONS)
    try:
        for order in [None] + list(itertools.permutations(range(1, n + 1))):
            how = "proportional" if order is None else "order " + ",".join(map(str, order))
            label = f"straight arm, {how}"
            if found.offer(examined(eq_solver.solve(p, order=order), label), label,
                           "loading path"):
                deflation.add(found.found[-1][0].theta[1:])
        if starts is None:
            starts = tension_starts(eq_solver)
        for sweep in range(max(1, passes)):
            before = len(found.found)
            for label, start in starts:
                if sweep == 0 and np.any(start.p != p):
                    state = examined(eq_solver.solve(p, start=start), label)
                    if found.offer(state, label, "loading path"):
                        deflation.add(state.theta[1:])
                for _ in range(deflation_rounds):
                    z, its, reason, ok = system.newton(system.augment(start.u, p), p)
                    state = None
                    if ok:
                        u = z[: system.nu]
                        state = examined(Equilibrium(
                            disc, p.copy(), u.copy(), True, reason, its, 0,
                            unstable_modes=eq_solver.inertia.negative_eigenvalues(u, p),
                            p_requested=p), label)
                    if not found.offer(state, label, "deflation"):
                        break
                    deflation.add(state.theta[1:])
            if len(found.found) == before:
                break
    finally:
        system.destroy()
        length_inertia.destroy()
    return found.result("load", p, [s[0] for s in starts])
