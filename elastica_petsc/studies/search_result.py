"""What a search for several equilibria returns (:class:`SearchResult`),
the paper's numbering of Fig. 8's states, the search settings per effort and
the tension box a search covers (split from :mod:`.search`).  Non-dimensional
(lengths / l, p = P l^2 / B)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.budget import TIME_LIMIT
from ..core.errors import InputError
from ..core.model import Arm
from ..core.results import Result
from ..solvers.equilibrium import Equilibrium


SEARCH_FINISHED = "SEARCH_FINISHED"      # outcome of a search that ran every phase


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
    stopped: str = ""             # why the time budget stopped it ('' : it ran every phase)
    arm: Arm | None = None        # the arm (ep.equilibria's results; saved as provenance)

    def __len__(self) -> int:
        return len(self.states)

    @property
    def outcome(self) -> str:
        """SEARCH_FINISHED (every phase ran) or TIME_LIMIT (stopped by its
        budget: the states found so far, the list may be incomplete)."""
        return TIME_LIMIT if self.stopped else SEARCH_FINISHED

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
        if self.stopped:
            lines.append(f"  {self.stopped}: the states found so far; the list may be "
                         "incomplete (the search did not finish)")
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


# Tension box of a complete length search when the arm has no motor limit (p = P l^2/B).
DEFAULT_P_MAX = 200.0
# Directions of the lines through each equilibrium (studies.preimage) at effort 1.
DEFAULT_DIRECTIONS = 4


def search_box(disc_or_arm) -> float:
    """p_max of the tension box 0 <= p_i <= p_max a length search covers: the
    motor limit P_crit of Eq. (22) if the arm has one, else DEFAULT_P_MAX."""
    limit = getattr(disc_or_arm, "max_tension", None)
    return float(limit) if limit is not None else DEFAULT_P_MAX
