"""Length-controlled equilibria as crossings of curves on the equilibrium manifold.

With two tendons the load-controlled equilibria form a 2-dimensional manifold
M = {(u, p) : F(u, p) = 0} (Eq. (9); :mod:`elastica_petsc.solvers.continuation`).
The equilibria with prescribed cable lengths L* (Sec. 4.6, Eq. (23), both cables
taut) are the points of M whose cable chords L(u) equal L*.  Take a line in
length space through L* with unit direction d and normal nu: its preimage

    C_d = {(u, p) in M : nu . (L(u) - L*) = 0}

is a curve on M (one scalar equation more), and the length-controlled
equilibria are the points of C_d where the along-line coordinate
a(w) = d . (L(u) - L*) changes sign.  Following C_d by pseudo-arclength
continuation (:class:`~elastica_petsc.solvers.continuation.CurveTracer`) goes
around every fold of the length path, so every equilibrium on the connected
piece of C_d through a seed is found, whatever the step sizes: that is what
makes the search systematic rather than a matter of lucky Newton starts.

Seeds (:meth:`CurveSearch.run`): the straight arm (the only state at p = 0) on
the line through its own chords L0 and L*; each loading order (cable i first:
the line L_j = L0_j from the straight arm to its crossings of L_i = L*_i, then
the line L_i = L*_i through L*); the faces p_i = 0 of M from the straight arm
(slack states: a cable with p_i = 0 no longer than L*_i); then every
equilibrium found, on lines through L* in several directions (a found
equilibrium lies on every such line; the piece through it may carry others;
on a line L_i = L*_i a crossing of p_j = 0 is a slack state too), until no new
equilibrium appears (:meth:`CurveSearch.close`).  A curve ends when it closes,
leaves the tension box |p_i| <= margin p_max (wider than the box of reported
states, 0 <= p_i <= p_max, so that a piece that leaves it and comes back is
not lost), when a cable collapses onto its routing point, or after
``max_points``; tensions may be negative on the way (the manifold does not
stop at p = 0), only crossings with p >= 0 count.

Load control (``control="load"``) uses the same machinery with lines through
p* in tension space: the curves are load paths followed through their folds.

What this proves: nothing about pieces of M that no seed touches (isolas).
It is a list, not a proof, but it no longer depends on a continuation step count.
Non-dimensional throughout (lengths / l, p = P l^2 / B).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..solvers.continuation import (Constraint, CurvePoint, CurveTracer, Manifold, TensionBound,
                                    TraceCounts)

# a cable within this distance (units of l) of its routing point ends a curve
COLLAPSE = 1e-3


# PETSc options of the search's corrector (prefix ``curve_``) unless the user sets them:
# the full Newton step (the predictor is close; a corrector that wanders is rejected
# by the tracer's jump test and the step halved)
CURVE_OPTIONS = {"snes_linesearch_type": "basic"}


class SearchTracer(CurveTracer):
    """A :class:`CurveTracer` (options prefix ``curve_``) without the test
    functions a search does not use: no determinant sign (branch points) and
    no inertia count per point, which cost a third of each step."""

    def __init__(self, disc, **kw):
        super().__init__(disc, options_prefix="curve_", petsc_options=CURVE_OPTIONS, **kw)
        self.A.pattern.determinant_sign = lambda lu: 1.0       # det sign unused

    def point(self, w, t, det_sign, iterations, tip_det: float = np.nan,
              tip_inward=None) -> CurvePoint:
        return CurvePoint(w=w.copy(), t=t.copy(), tip=self.mf.tip(w),
                          tip_velocity=self.mf.tip_velocity(w, t),
                          unstable_modes=-1, det_sign=det_sign, iterations=iterations)


class LengthLine(Constraint):
    """c(w) = nu . (L(w) - L*) (with ``along``: d . (L(w) - L*)) for the line
    through L* with direction d in cable-length space (two tendons)."""

    def __init__(self, manifold: Manifold, target, direction, along: bool = False):
        d = np.asarray(direction, float)
        d = d / np.linalg.norm(d)
        self.mf, self.target = manifold, np.asarray(target, float)
        self.vector = d if along else np.array([-d[1], d[0]])
        self.name = "along" if along else "line"

    def quantity(self, w) -> np.ndarray:
        return self._chords(w)[0]

    def _chords(self, w):
        disc = self.mf.disc
        y = disc.split(self.mf.split(w)[0])[1]
        return disc.cables(y)

    def value(self, w):
        return float(self.vector @ (self._chords(w)[0] - self.target))

    def gradient(self, w):
        """d|r_i - y_i|/dy_i = -d_i (Eq. (3); through guides, docs/model.md §11),
        weighted by the line's vector."""
        disc = self.mf.disc
        y = disc.split(self.mf.split(w)[0])[1]
        g = np.zeros(self.mf.m)
        g[disc.n_elements:disc.size] = self.vector @ disc.length_gradients(y)
        return g


class TensionLine(LengthLine):
    """The same for a line through p* in tension space (load control): c(w) =
    nu . (p - p*), linear in w; its curves are load paths followed through folds."""

    def quantity(self, w) -> np.ndarray:
        return self.mf.split(w)[1]

    def value(self, w):
        return float(self.vector @ (self.quantity(w) - self.target))

    def gradient(self, w):
        g = np.zeros(self.mf.m)
        g[self.mf.size:] = self.vector
        return g


class FaceChord(Constraint):
    """L_j(w) - L*_j: the along-curve coordinate on the face p_i = 0 (slack cable i)."""

    def __init__(self, manifold: Manifold, target, j: int):
        self.mf, self.target, self.j = manifold, np.asarray(target, float), int(j)
        self.name = f"L{j + 1}=L*"

    def value(self, w):
        disc = self.mf.disc
        return float(disc.cables(disc.split(self.mf.split(w)[0])[1])[0][self.j]
                     - self.target[self.j])

    def gradient(self, w):
        disc = self.mf.disc
        y = disc.split(self.mf.split(w)[0])[1]
        g = np.zeros(self.mf.m)
        g[disc.n_elements:disc.size] = disc.length_gradients(y)[self.j]
        return g


@dataclass
class Trace:
    """One followed curve: where it started, the crossings it found, why it ended."""

    curve: str                                          # e.g. "line (1, 0)" or "face P1=0"
    crossings: list = field(default_factory=list)      # states w on the curve with a(w) = 0
    points: int = 0
    end: str = ""


def _closes(mf: Manifold, start, a, b) -> bool:
    """True if the step a -> b passes within a quarter of its length of ``start``."""
    seg = b - a
    length2 = float(np.sum(mf.metric * seg * seg))
    if length2 <= 0.0:
        return False
    frac = min(max(float(np.sum(mf.metric * seg * (start - a))) / length2, 0.0), 1.0)
    return mf.norm(a + frac * seg - start) < 0.25 * np.sqrt(length2)


def follow_curve(tracer: CurveTracer, w0, constraint: Constraint, events, name: str, *,
                 p_max: float, counts: TraceCounts, ds0: float = 0.1, ds_min: float = 1e-5,
                 max_points: int = 400) -> list[Trace]:
    """Follow the curve {F = 0, constraint = 0} from its point w0 in both
    orientations, by pseudo-arclength continuation; every sign change of an
    ``events`` function (Constraints) on the way is located by a Newton solve
    of {F = 0, constraint = 0, event = 0}: a crossing (w, event index).  A
    branch ends when it closes on itself (the other orientation is then
    skipped), leaves the box max |p_i| <= p_max, pulls a cable onto its
    routing point, cannot be followed with steps above ``ds_min`` ("lost")
    or after ``max_points`` points.  Its solves are counted in ``counts``."""
    mf = tracer.mf
    out = []
    t0 = tracer.tangent(w0, constraint, np.ones(mf.m))[0]
    for orient in (t0, -t0):
        trace = Trace(name)
        t, sign = tracer.tangent(w0, constraint, orient)[:2]
        pt = tracer.point(w0, t, sign, 0)
        ds = ds0
        while True:
            if trace.points >= max_points:
                trace.end = "max_points"
                break
            new, its = tracer.step(pt, constraint, ds, counts)
            if new is None:
                ds *= 0.5
                if ds < ds_min:
                    trace.end = "lost"
                    break
                continue
            trace.points += 1
            trace.crossings += _crossings(tracer, constraint, events, pt.w, new.w,
                                          counts, first=trace.points == 1)
            closed = trace.points > 2 and _closes(mf, w0, pt.w, new.w)
            pt = new
            if its <= 3:
                ds = min(2.0 * ds, tracer.ds_max)
            trace.end = ("closed" if closed else
                         "p_max" if np.max(np.abs(mf.split(pt.w)[1])) > p_max else
                         "collapse" if np.min(mf.disc.cables(mf.disc.split(
                             mf.split(pt.w)[0])[1])[0]) < COLLAPSE else "")
            if trace.end:
                break
        out.append(trace)
        if trace.end == "closed":
            break                       # the other orientation walks the same loop
    return out


def _crossings(tracer: CurveTracer, constraint, events, wa, wb, counts: TraceCounts,
               first: bool) -> list:
    """(w, k) for each event k that changes sign between the points wa and wb of
    a curve, located by Newton; an event vanishing at the curve's start
    (``first`` step from a crossing) is not a crossing again."""
    out = []
    for k, event in enumerate(events):
        a0, a1 = event.value(wa), event.value(wb)
        if first and abs(a0) < 1e-10:
            continue
        if a0 < 0.0 <= a1 or a1 < 0.0 <= a0:
            frac = a0 / (a0 - a1) if a0 != a1 else 1.0
            w, ok = tracer.correct(wa + frac * (wb - wa), [constraint, event], counts)
            if ok:
                out.append((w, k))
    return out


def line_directions(count: int) -> list[np.ndarray]:
    """``count`` unit directions in the (L_1, L_2) plane, evenly spread over
    half a turn from (1, 0) (a line and its reverse are the same line)."""
    return [np.array([np.cos(a), np.sin(a)]) for a in np.pi * np.arange(count) / count]


class CurveSearch:
    """Length-controlled equilibria at cable lengths ``target`` (units of l,
    two tendons) as crossings of curves on M (module docstring), found with
    ``tracer``; :meth:`run` follows the curves from the straight arm, then
    :meth:`close`; :meth:`add` and :meth:`close` again continue the search
    from equilibria found by other means.

    ``states`` are the distinct crossings (w, label) in discovery order (max
    nodal angle difference > ``tol``), negative tensions and p_i > p_max
    included (the caller filters); ``traces`` every curve followed.  Lines
    through an equilibrium are followed in ``directions`` directions
    (:func:`line_directions`); curves in the box |p_i| <= ``margin`` p_max, so
    that a piece of a curve that leaves the box of reported states (0 <= p_i
    <= p_max) and comes back into it is not lost."""

    def __init__(self, tracer: CurveTracer, target, *, control: str = "length",
                 directions: int = 4, p_max: float = 200.0, margin: float = 1.5,
                 tol: float = 1e-4, ds0: float = 0.1, max_points: int = 400,
                 on_curve=None):
        if control not in ("length", "load"):
            raise ValueError(f"control must be 'length' or 'load', got {control!r}")
        self.tracer, self.mf, self.control = tracer, tracer.mf, control
        self.Line = LengthLine if control == "length" else TensionLine
        self.L = np.asarray(target, float)
        self.directions, self.p_max, self.margin, self.tol = directions, p_max, margin, tol
        self.ds0, self.max_points = ds0, max_points
        self.on_curve = on_curve                # called with each curve's label (progress)
        self.states: list[tuple[np.ndarray, str]] = []
        self.traces: list[Trace] = []
        self.queue: list[int] = []              # indices into states, to be followed
        self.done: set = set()                  # (index, direction) curves already followed
        self.whole = True
        self.counts = TraceCounts()             # the corrector solves of every curve followed

    @property
    def in_box(self) -> list[tuple[np.ndarray, str]]:
        """The crossings with 0 <= p_i <= p_max (slack states included)."""
        return [(w, label) for w, label in self.states
                if np.all(self.mf.split(w)[1] >= -1e-9)
                and np.all(self.mf.split(w)[1] <= self.p_max)]

    def ends(self) -> dict:
        out: dict[str, int] = {}
        for t in self.traces:
            out[t.end] = out.get(t.end, 0) + 1
        return out

    def _chords(self, w):
        disc = self.mf.disc
        return disc.cables(disc.split(self.mf.split(w)[0])[1])[0]

    def quantity(self, w):
        """The controlled quantity of w: cable chords (length) or tensions (load)."""
        return self._chords(w) if self.control == "length" else self.mf.split(w)[1]

    def add(self, w, label: str, slack: int | None = None) -> int | None:
        """Keep a new equilibrium; ``slack``: the cable on a face p = 0 (its
        chord must not exceed its length).  Taut ones in the box are queued
        for :meth:`close`.  Returns its index in ``states`` (new or already
        known), None if rejected."""
        w = np.asarray(w, float)
        if slack is not None and self._chords(w)[slack] > self.L[slack] + 1e-12:
            return None
        n_ang = self.mf.disc.n_elements
        for k, f in enumerate(self.states):
            if np.max(np.abs(w[:n_ang] - f[0][:n_ang])) <= self.tol:
                return k
        self.states.append((w.copy(), label))
        p = self.mf.split(w)[1]
        if slack is None and np.all(p >= -1e-9) and np.all(p <= self.p_max):
            self.queue.append(len(self.states) - 1)
        return len(self.states) - 1

    def _follow(self, w, constraint, events, label) -> list:
        """Crossings (w, event, label) of the curve through w; ``self.whole``
        says whether the curve was followed to its ends both ways (closed,
        box, collapse) rather than given up ("lost", "max_points")."""
        out = []
        self.whole = True
        for tr in follow_curve(self.tracer, w, constraint, events, label,
                               p_max=self.margin * self.p_max, counts=self.counts, ds0=self.ds0,
                               max_points=self.max_points):
            self.traces.append(tr)
            if self.on_curve is not None:
                self.on_curve(label)
            self.whole &= tr.end in ("closed", "p_max", "collapse")
            out += [(x, k, f"{label} ({tr.end})") for x, k in tr.crossings]
        return out

    def line(self, w, direction, label, through=None, offered: bool = True) -> list:
        """Follow the line through ``through`` (default L*) with ``direction``
        from w; its crossings of L* (and, on a line L_i = L*_i, of p_j = 0)
        are added unless ``offered`` is False; returns the crossings of
        ``through``.  A curve followed to its ends both ways through L* is the
        same curve from each of its crossings: (crossing, direction) is
        recorded as done, so :meth:`close` does not follow it again."""
        through = self.L if through is None else through
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        events = [self.Line(self.mf, through, d, along=True)]
        axis = [j for j in range(2) if abs(abs(d[j]) - 1.0) < 1e-12 and self.control == "length"]
        events += [TensionBound(self.mf, j, 0.0) for j in axis]   # slack cable j
        out = self._follow(w, self.Line(self.mf, through, d), events, label)
        for x, k, how in out if offered else ():
            index = self.add(x, how, slack=None if k == 0 else axis[0])
            if index is not None and k == 0 and self.whole and through is self.L:
                self.done.add((index, tuple(np.round(d, 12))))
        return [x for x, k, _ in out if k == 0]

    def run(self, seeds=(), close: bool = True) -> "CurveSearch":
        """From the straight arm (p = 0): the line through its chords L0 and
        L*; each loading order (cable i first: the line L_j = L0_j to its
        crossings with L_i = L*_i, then from each of those the line L_i = L*_i
        through L*); the faces p_i = 0 (slack states: crossings of L_j =
        L*_j).  For every ``seeds`` state (w, label): the line through its
        chords and L*.  Then (with ``close``) :meth:`close`."""
        disc, L = self.mf.disc, self.L
        straight = np.concatenate((disc.straight(), np.zeros(disc.n_tendons)))
        L0 = self.quantity(straight)
        if np.linalg.norm(L - L0) > 1e-12:       # else the straight arm is the target's state
            self.line(straight, L - L0, "line from the straight arm")
        else:
            self.add(straight, "the straight arm")
        for i, j in ((0, 1), (1, 0)):
            corner = L0.copy()
            corner[i] = L[i]
            for w in self.line(straight, np.eye(2)[i], f"cable {i + 1} first", through=corner,
                               offered=False):
                self.line(w, np.eye(2)[j], f"cable {i + 1} then cable {j + 1}")
        for i in range(2 if self.control == "length" else 0):
            for x, _, how in self._follow(straight, TensionBound(self.mf, i, 0.0),
                                          [FaceChord(self.mf, L, 1 - i)],
                                          f"face P{i + 1}=0 from the straight arm"):
                self.add(x, how, slack=i)
        for w, label in seeds:
            if np.linalg.norm(L - self.quantity(w)) > 1e-9:
                self.line(w, L - self.quantity(w), f"line from {label}")
        return self.close() if close else self

    def close(self) -> "CurveSearch":
        """Follow the lines through L* in every direction from every queued
        equilibrium, until no new one appears."""
        while self.queue:
            k = self.queue.pop(0)
            for d in line_directions(self.directions):
                if (k, tuple(np.round(d, 12))) in self.done:
                    continue
                self.line(self.states[k][0], d,
                          f"line ({d[0]:.3g}, {d[1]:.3g}) through crossing {k + 1}")
        return self
