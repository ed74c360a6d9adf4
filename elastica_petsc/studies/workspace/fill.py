"""The workspace map filled from the traced boundary (sampler "boundary-fill",
the default of mode targets; docs/model.md, "Maps filled from the traced
boundary").

Each chunk of targets is classed in three passes:

1. by the traced boundary of W_0 (:meth:`~elastica_petsc.studies.boundary.BoundaryResult.preimage_counts`,
   docs/model.md §9.1): a target beyond reach is ``BEYOND_REACH`` and one with
   no preimage in D (the unbounded face or a hole) ``OUTSIDE_BOUNDARY``, both
   proven and without a solve;
2. a target with exactly one preimage in D (N = 1) is reached by Newton's
   method on the tip (:class:`~.tip_newton.TipNewton`), swept along the chunk
   from the previous reached sample (the grid neighbour), or, with none, from
   the nearest nodes of the traced loop on the faces P_i = 0
   (:class:`~.tip_newton.Anchors`) by a homotopy in target space; the state
   is kept if it is stable (its smallest eigenvalue, recorded anyway, is > 0);
3. every other target (N >= 2 or undecided by the boundary, targets near
   the traced curves, arms with other than two tendons) and every target the
   sweep missed goes through the global-search sampler's passes
   (:class:`~.samplers.TargetSampler`: local tip control warm-started from
   the chunk's reached samples, the backward sweep, the global search), and
   is REACHED or UNDECIDED as there.

With N = 1 the tensions are unique, so a sample reached by the sweep has the
tensions of the global-search map within the tip tolerance (both stop with
|x_t - x_d| < 1e-5 mm); the classes are those of the global-search map where
the two samplers' local searches agree on the samples of pass 3
(tests/test_workspace_fill.py, BENCHMARKS.md).  Every result depends on its
chunk alone (the boundary and the anchors are fixed functions of the arm), so
maps are equal on any number of ranks.
"""
from __future__ import annotations

import time

import numpy as np

from ...core.errors import InputError
from .schema import Status
from .samplers import TargetSampler
from .tip_newton import Anchors, TipNewton


class BoundaryFillSampler(TargetSampler):
    """Tip control over a chunk of targets filled from the traced boundary
    (module doc); the global search only for what the sweep misses."""

    anchor_tries = 2               # nearest loop nodes tried for a target with no start
    start_reach_l = 0.15           # a reached sample farther than this (units of l) is no start

    def __init__(self, arm, disc, share: str = "none", min_tension: float = 0.0):
        super().__init__(arm, disc, global_search=True, share=share, min_tension=min_tension)
        self.newton = TipNewton(self.controller)
        self._boundary = self._anchors = None
        self._traced = False

    def boundary(self):
        """The traced W_0 boundary (traced once; None where it cannot be traced)."""
        if not self._traced:
            if self.disc.n_tendons == 2:
                from ..boundary import traced_w0
                try:
                    self._boundary = traced_w0(self.arm, self.disc, self._trace_cache())
                except InputError:
                    self._boundary = None
                if self._boundary is not None:
                    self._anchors = Anchors(self.newton, self._boundary)
            self._traced = True
        return self._boundary

    def adopt_boundary(self, boundary) -> None:
        """Use ``boundary``, this arm's W_0 boundary traced by another rank (a
        :func:`~.shared_setup.plain_boundary`; None: it cannot be traced)."""
        from .shared_setup import AdoptedTraces

        if boundary is None:
            self._boundary, self._traced = None, True
            return
        self._traces = AdoptedTraces(self.arm, self.disc, boundary)
        self.boundary()

    def solve_chunk(self, points: np.ndarray, stop) -> dict | None:
        out, states, runs = self._start_chunk(points)
        counts = self._classify_by_boundary(points, out)
        if not (self._sweep(points, out, counts, states, stop)
                and self._forward(points, out, states, runs, stop)
                and self._backward(points, out, states, runs, stop)
                and self._search(points, out, states, runs, stop)):
            return None
        self._mark_undecided(out)
        return self._shared(points, out, stop)

    def _classify_by_boundary(self, points, out: dict) -> list:
        """Pass 1 (module doc): BEYOND_REACH and OUTSIDE_BOUNDARY, no solve;
        returns each target's preimage count N (None: undecided)."""
        from ...solvers.reach import beyond_reach

        l_mm = self.arm.length_mm
        boundary = self.boundary()
        counts = ([None] * len(points) if boundary is None
                  else boundary.preimage_counts(points))
        for k, target in enumerate(points):
            if beyond_reach(target / l_mm):
                out["status"][k], out["reason"][k] = Status.BEYOND_REACH, b"BEYOND_REACH"
                counts[k] = None
            elif counts[k] == 0:
                out["status"][k], out["reason"][k] = Status.OUTSIDE_BOUNDARY, b"OUTSIDE_BOUNDARY"
        return counts

    def _sweep(self, points, out: dict, counts: list, states: dict, stop) -> bool:
        """Pass 2 (module doc); False if stopped.  Forward along the chunk: a
        target with N = 1 from the previous reached sample, else from the
        nearest anchors; a target undecided by the boundary (None) from the
        previous reached sample only.  Then backward: a target still not
        reached from the next reached sample."""
        if self._boundary is None:         # no trace (e.g. not two tendons): no sweep
            return True
        pairs = {}                         # sample -> (equilibrium, sensitivity) reached
        previous = None
        for k in range(len(points)):
            if counts[k] not in (1, None) or out["status"][k] != Status.NOT_COMPUTED:
                continue
            if stop():
                return False
            anchors = self.anchor_tries if counts[k] == 1 else 0
            previous = self._reach(points, out, k, previous, anchors, pairs) or previous
        following = None
        for k in reversed(range(len(points))):
            if k in pairs:
                following = pairs[k]
                continue
            if following is None or counts[k] not in (1, None) or \
                    out["status"][k] != Status.NOT_COMPUTED:
                continue
            if stop():
                return False
            following = self._reach(points, out, k, following, 0, pairs) or following
        states.update({k: pair[0] for k, pair in pairs.items()})
        return True

    def _reach(self, points, out: dict, k: int, start, anchors: int, pairs: dict):
        """Newton on the tip to target ``k`` from ``start`` (None, or farther than
        ``start_reach_l``: none), then from its ``anchors`` nearest anchors; the
        state kept (:meth:`_keep`), or None."""
        t0 = time.perf_counter()
        target = points[k] / self.arm.length_mm
        near = start is not None and \
            np.linalg.norm(start[0].tip - target) <= self.start_reach_l
        starts = ([start] if near else []) + \
            (self._anchors.nearest(target, anchors) if anchors else [])
        for begin in starts:
            state = self.newton.reach(target, begin)
            if state is not None and self._keep(out, k, state[0], t0):
                pairs[k] = state
                return state
        return None

    def _keep(self, out: dict, k: int, eq, t0: float) -> bool:
        """Record the state reached by the sweep at sample ``k`` if it is stable
        (smallest eigenvalue > 0, Eq. (20)); else clear the sample (False)."""
        seconds = time.perf_counter() - t0
        self._record(out, k, eq)
        if not out["lambda_min"][k] > 0.0:
            for name, values in self._empty(1).items():
                if name != "target":
                    out[name][k] = values[0]
            return False
        out["seconds_control"][k] = seconds
        out["strategy"][k] = b"boundary fill"
        out["iterations"][k] = self.newton.iterations
        out["reason"][k] = b"TARGET_REACHED"
        out["tip_error"][k] = np.linalg.norm(eq.tip * self.arm.length_mm - out["target"][k])
        out["status"][k] = Status.REACHED
        self._reached[k] = eq
        return True
