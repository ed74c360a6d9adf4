"""What one workspace sample computes (paper Sec. 4.3, Figs. 4-5).

``TargetSampler`` (mode ``targets``, Fig. 4): tip control to each target,
warm-started from the previous sample of the chunk; a target that local tip
control does not reach then goes through the global search (seeds over every
loading order, :class:`~elastica_petsc.solvers.reach.SeedLibrary`, and the
chunk's reached neighbours) before it is classed: reached (P >= 0, E < eps),
not reached after the global search (undecided: no proof either way),
beyond reach |x_d| > l (proven), or outside the traced boundary of W_0
(proven, docs/model.md §9.1).  With ``global_search=False`` the old local
classes are kept: reached, tip control ended on P_i = 0 (a local verdict), or
not converged.
``TensionSampler`` (mode ``tensions``): the forward solve on a grid of
tensions, each warm-started (continued) from the previous one.
Both fill the same fields (:func:`elastica_petsc.studies.workspace.schema.fields`) and add
the smallest stiffness eigenvalue (SLEPc, :class:`~elastica_petsc.solvers.sweep_stability.SweepStability`,
warm-started along each chunk) of every equilibrium reached.
"""
from __future__ import annotations

import time

import numpy as np

from ...core.clearance import state_cable_clear
from ...core.fem import Discretisation
from ...core.model import Arm
from ...solvers.equilibrium import Equilibrium, EquilibriumSolver
from ...solvers.stability import StabilityError
from ...solvers.sweep_stability import SweepStability
from ..chunks import empty_fields
from .schema import Status, fields


class _Sampler:
    def __init__(self, arm: Arm, disc: Discretisation):
        self.arm, self.disc = arm, disc
        self.solver = EquilibriumSolver(disc)
        self.stability = SweepStability(disc)     # warm-started along a chunk
        self.schema = fields(disc.n_tendons)

    def _empty(self, count: int) -> dict:
        return empty_fields(self.schema, count)

    def _record(self, out: dict, k: int, eq: Equilibrium) -> None:
        """Fields of a solved state, with its smallest eigenvalue (Eq. (20))."""
        l_mm = self.arm.length_mm
        out["tip"][k] = eq.tip * l_mm
        out["tensions"][k] = eq.p
        out["tensions_N"][k] = self.arm.tensions_to_N(eq.p)
        out["cable_lengths"][k] = eq.cable_lengths * l_mm
        out["kappa_max"][k] = eq.kappa_max
        out["strain_energy"][k] = eq.strain_energy
        out["cable_clear"][k] = state_cable_clear(eq)
        t0 = time.perf_counter()
        try:
            out["lambda_min"][k], out["lambda_min_raw"][k] = self.stability.solve(eq.u, eq.p)
        except StabilityError:
            pass                                        # NaN: eigen solve failed
        out["seconds_eigen"][k] = time.perf_counter() - t0

    def destroy(self) -> None:
        self.stability.destroy()
        self.solver.destroy()


class TensionSampler(_Sampler):
    """Forward solves over a chunk of tension points (non-dimensional p)."""

    def solve_chunk(self, points: np.ndarray, stop) -> dict | None:
        out = self._empty(len(points))
        self.stability.restart()           # results depend on the chunk alone
        previous = None
        for k, p in enumerate(points):
            if stop():
                return None
            t0 = time.perf_counter()
            eq = self.solver.solve(p, start=previous)
            out["seconds_control"][k] = time.perf_counter() - t0
            out["iterations"][k] = eq.iterations
            out["reason"][k] = eq.reason.encode()[:48]
            if eq.converged:
                out["status"][k] = Status.REACHED
                self._record(out, k, eq)
                previous = eq
            else:
                out["status"][k] = Status.NOT_CONVERGED
        return out


class TargetSampler(_Sampler):
    """Tip control over a chunk of targets (mm), Algorithm 1 with TAO BLMVM.

    Warm starts inside a chunk (the next target is a grid neighbour):

    * after a reached target: from its equilibrium (tensions and state);
    * after a target outside W_0 (``NEEDS_NEGATIVE``): from that solve's
      end state, the tip on the boundary P_1 = 0 closest to the target, so
      a run of outside targets slides along the boundary instead of
      restarting from afar (timing: BENCHMARKS.md, "Timing notes from the
      docstrings").  If that start does not
      end reached or outside, the target is solved again from the last
      reached state of the chunk (or the head guess): a boundary state can
      have a cable pulled almost onto its routing point, a poor start for a
      target back inside W_0;
    * otherwise, and for the first target of a chunk: from the last reached
      state of the chunk, else from ``head_guess`` in every tension, not from
      zero: at p = 0 the arm is straight, its tip sensitivities have no x
      component, and every target on the x axis is a stationary point of E
      (Eq. (12)) — the optimiser would not move;
    * then, backwards through the chunk: a target that ended not converged
      before a reached one (a chunk that starts outside W_0, where the head
      guess leads the optimiser to a cable collapse) is solved again from
      its reached neighbour, with a failure budget of ``retry_failures``
      failed equilibria (the retries that fail run into snaps and collapses;
      with the solve's default budget of 25 they cost far more than they
      reach: BENCHMARKS.md, "Timing notes from the docstrings").

    ``stationary_rtol`` (passed to :class:`~elastica_petsc.solvers.control.TipController`)
    is looser than the controller's default 1e-7: a target is classified as
    outside once the projected gradient is 1e-5 of |x_t - x_d| |S|; pinning
    the closest boundary point to 1e-7 costs more iterations per outside
    target and changed no classification (BENCHMARKS.md, "Timing notes from
    the docstrings").  Reached targets are unaffected (they stop on E < eps).

    Global search (``global_search=True``, the default; the theme: a local run
    gives no global verdict).  After both passes, every target of the chunk
    still not reached, whether tip control stalled, ended on a bound P_i = 0
    or hit a cable collapse, is solved again (:meth:`_search`):

    * by local tip control from its reached chunk neighbours (the samples
      just before and after it; the forward pass tried only the one before,
      the backward sweep only for targets not converged);
    * by local tip control from each of the ``search_seeds`` equilibria of
      the seed library (forward solves over a coarse tension grid reached by
      every loading order and by proportional loading, Fig. 8; built once per
      process, on first need) whose tips lie nearest the target.  A seed
      already tried in this chunk starts from where its last try ended (the
      closest tip of its branch to the previous target, slid along like the
      forward pass's outside targets), and from the seed itself only if that
      start ends neither reached nor on a local end (on a bound, or a cable
      collapse);
    * once one is reached, its state is carried to its not-reached chunk
      neighbours on both sides by local solves (:meth:`_spread`), as the
      forward pass would have done.

    A start in the same state as one already solved for the target (the
    forward pass's, or another seed's track that slid onto the same edge)
    is not solved again (:meth:`_seek`).  Neighbours in other rows, homotopies
    in target space and the other strategies of
    :class:`~elastica_petsc.solvers.reach.Reacher` are not used: rows are
    solved independently (results may not depend on the rank count), and
    the homotopies cost about 1 s per target outside W_0.

    Before the search, a target not reached by the passes that lies outside
    the traced boundary of W_0 (:func:`~elastica_petsc.studies.boundary.boundary_proof`:
    the unbounded component of the plane minus the images of the tension
    region's boundary and of the tip map's folds, farther than 3 cells from
    them; docs/model.md §9.1) is classed ``OUTSIDE_BOUNDARY`` and not
    searched: a proof, paid once per process (one boundary trace, about 1 s
    on the paper's arm), which spares the search its most expensive
    samples.  Arms with other than two tendons give no such proof.
    The samples still not reached are classed ``UNDECIDED``; a target beyond
    reach, |x_d| > l, is ``BEYOND_REACH`` without any solve (a proof: the
    inextensible arm's tip is never farther than l from the clamp, Eq. (2)).
    Every result still depends on the chunk alone (the seeds are a fixed
    function of the arm), so maps stay equal on any number of ranks.  The
    extra cost is paid only by samples that local control did not reach.

    Tension sharing (``share`` 'min-norm'/'min-energy', floor ``min_tension``
    p_min; docs/model.md §9.3), after all of the above, so the rule changes
    which tensions are stored, never which targets are reached
    (:meth:`_share_chunk`): with n >= 3 tendons each reached sample's tensions
    are replaced by the sharing rule's (SQP on the KKT conditions,
    :class:`~elastica_petsc.solvers.share.TensionSharer`), warm-started from the
    chunk's previous shared sample, else from the sample's own reached state,
    and a sample still not shared is tried again from the next shared sample
    (backwards, like the backward sweep).  With two tendons there is no
    redundancy: the tensions of the state reached are kept and checked against
    the floor; one below it is ``UNIQUE_BELOW_FLOOR`` (proven) where the traced
    boundary shows the target has no other preimage (:meth:`_unique`).  A
    sample reached with P >= 0 whose sharing fails is ``BELOW_FLOOR`` with a
    floor (reason: how the sharer stopped; its P >= 0 state is kept: it is in
    W_0, undecided for W_0(p_min)), and stays
    ``REACHED`` without one (``shared`` False).  No sharing, no floor: nothing
    of this runs (the maps are those of before).
    """

    head_guess = 2.0
    stationary_rtol = 1e-5
    retry_failures = 1
    search_seeds = 3           # seeds tried per not-reached target (nearest tips first)
    search_its = 15            # iteration limit of a search solve (a reached one needs < 10)
    search_failures = 3        # failure budget of a search solve

    def __init__(self, arm: Arm, disc: Discretisation, global_search: bool = True,
                 share: str = "none", min_tension: float = 0.0):
        from ...solvers.control import TipController

        super().__init__(arm, disc)
        self.controller = TipController(arm, solver=self.solver,
                                        stationary_rtol=self.stationary_rtol)
        self.global_search = global_search
        self._library = None
        self._traces = None            # the W_0 boundary of this arm, traced on first need
        self.share, self.min_tension = share, float(min_tension)
        self.sharer = None
        if share != "none" and disc.n_tendons >= 3:
            from ...solvers.share import TensionSharer
            self.sharer = TensionSharer(self.controller, share, self.min_tension)
        self._reached = {}                 # sample -> ControlResult that reached it (a chunk)

    @property
    def library(self):
        """The seed library of :mod:`~elastica_petsc.solvers.reach` (built on first use)."""
        if self._library is None:
            from ...solvers.reach import SeedLibrary
            self._library = SeedLibrary(self.controller)
        return self._library

    def _classify(self, result) -> int:
        if result.converged:
            return Status.REACHED
        # local evidence only (a stationary point of E with a tension on P = 0 and the
        # gradient pushing through it): the class is 'needs a negative tension from
        # here', not a proof about W_0 (solvers/reach.py: reachable stays None)
        return Status.NEEDS_NEGATIVE if _on_lower_bound(result) else Status.NOT_CONVERGED

    def solve_chunk(self, points: np.ndarray, stop) -> dict | None:
        out, states, runs = self._start_chunk(points)
        if self.global_search:
            from ...solvers.reach import beyond_reach
            for k, target in enumerate(points):
                if beyond_reach(target / self.arm.length_mm):
                    out["status"][k] = Status.BEYOND_REACH
                    out["reason"][k] = b"BEYOND_REACH"
        if not (self._forward(points, out, states, runs, stop)
                and self._backward(points, out, states, runs, stop)):
            return None
        if self.global_search:
            self._prove_outside(points, out)
            if not self._search(points, out, states, runs, stop):
                return None
            self._mark_undecided(out)
        return self._shared(points, out, stop)

    def _start_chunk(self, points: np.ndarray) -> tuple[dict, dict, dict]:
        """The empty result of a chunk of ``points`` and its records: ``states``
        (sample -> equilibrium, reached samples) and ``runs`` (sample ->
        [(start, result)] of its local solves)."""
        out = self._empty(len(points))
        out["target"][:] = points
        self._reached = {}
        self.stability.restart()           # results depend on the chunk alone
        return out, {}, {}

    @staticmethod
    def _mark_undecided(out: dict) -> None:
        """After the global search, a local verdict is no class: UNDECIDED."""
        out["status"][(out["status"] == Status.NEEDS_NEGATIVE)
                      | (out["status"] == Status.NOT_CONVERGED)] = Status.UNDECIDED

    def _shared(self, points: np.ndarray, out: dict, stop) -> dict | None:
        """``out`` with the reached samples' tensions shared (if asked); None if stopped."""
        if self.share != "none" and not self._share_chunk(points, out, stop):
            return None
        return out

    def _forward(self, points, out: dict, states: dict, runs: dict, stop) -> bool:
        """The forward pass (class doc); False if stopped.  ``runs[k]``: the
        (start, result) pairs of sample k's local solves (start None: head guess)."""
        head = np.full(self.disc.n_tendons, self.head_guess)
        reached = boundary = None          # last reached state; state after an outside target
        for k, target in enumerate(points):
            if k in states:                # reached before this pass (boundary fill)
                reached, boundary = states[k], None
                continue
            if out["status"][k] != Status.NOT_COMPUTED:
                continue
            if stop():
                return False
            t0 = time.perf_counter()
            result = status = None
            runs[k] = []
            if boundary is not None:
                result = self.controller.solve_mm(target, start=boundary)
                runs[k].append((boundary, result))
                status = self._classify(result)
                if status == Status.NOT_CONVERGED:
                    result = None
            if result is None:
                result = self.controller.solve_mm(
                    target, p0=None if reached is not None else head, start=reached)
                runs[k].append((reached, result))
                status = self._classify(result)
            self._store(out, k, result, status, time.perf_counter() - t0)
            boundary = result.equilibrium if status == Status.NEEDS_NEGATIVE else None
            if status == Status.REACHED:
                reached = states[k] = result.equilibrium
        return True

    def _backward(self, points, out: dict, states: dict, runs: dict, stop) -> bool:
        """Backward sweep: a target not converged before a reached one is solved
        again from its reached neighbour on the other side; False if stopped."""
        reached = None
        for k in reversed(range(len(points))):
            if k in states:
                reached = states[k]
                continue
            if out["status"][k] != Status.NOT_CONVERGED or reached is None:
                continue
            if stop():
                return False
            t0 = time.perf_counter()
            result = self.controller.solve_mm(points[k], start=reached,
                                              max_failures=self.retry_failures)
            runs[k].append((reached, result))
            status = self._classify(result)
            seconds = out["seconds_control"][k] + time.perf_counter() - t0
            if status == Status.NOT_CONVERGED:
                out["seconds_control"][k] = seconds
                continue
            self._store(out, k, result, status, seconds)
            if status == Status.REACHED:
                reached = states[k] = result.equilibrium
        return True

    def _prove_outside(self, points, out: dict) -> None:
        """Class ``OUTSIDE_BOUNDARY`` the not-reached samples the traced boundary
        of W_0 proves outside (class doc); the boundary is traced on first need."""
        from ..boundary import boundary_proof

        outside = boundary_proof(self.arm, self.disc, self._trace_cache())
        for k, target in enumerate(points):
            if out["status"][k] in (Status.REACHED, Status.BEYOND_REACH):
                continue
            if outside(target / self.arm.length_mm)[0]:
                out["status"][k] = Status.OUTSIDE_BOUNDARY     # reason: how its local solve ended

    def _search(self, points, out: dict, states: dict, runs: dict, stop) -> bool:
        """The global search of the class doc over the chunk's not-reached
        samples, in chunk order; False if stopped."""
        tracks = {}                        # seed index -> where its last try ended
        for k in range(len(points)):
            if out["status"][k] in (Status.REACHED, Status.BEYOND_REACH, Status.OUTSIDE_BOUNDARY):
                continue
            if stop():
                return False
            t0 = time.perf_counter()
            result, label = self._neighbours(points[k] / self.arm.length_mm, k, states, runs[k])
            if result is None:
                result, label = self._seek(points[k] / self.arm.length_mm, tracks, runs[k])
            seconds = out["seconds_control"][k] + time.perf_counter() - t0
            if result is None:
                out["seconds_control"][k] = seconds
                out["strategy"][k] = b"global search: not reached"
                continue
            self._store(out, k, result, Status.REACHED, seconds, label)
            states[k] = result.equilibrium
            if not self._spread(points, out, states, k, stop):
                return False
        return True

    def _neighbours(self, target: np.ndarray, k: int, states: dict, runs: list):
        """(result, label) of a local solve to ``target`` (units of l) from a reached
        chunk neighbour of sample ``k`` that reaches it, else (None, '')."""
        for j in (k - 1, k + 1):
            if j in states:
                result = self._search_solve(target, states[j], runs)
                if result.converged:
                    return result, f"neighbour of sample {j} (global search)"
        return None, ""

    def _seek(self, target: np.ndarray, tracks: dict, runs: list):
        """(result, label) of the first seed start that reaches ``target``
        (units of l), else (None, '').  ``runs``: the (start, result) pairs
        already solved for this target; a start in the same state as one of
        them (same tensions and tip to 1e-9) is not solved again (the same
        start gives the same local solve: in a region outside the local
        picture the seeds' tracks and the forward pass soon slide along the
        same edge, and each costs one solve per target instead of one per seed)."""
        seeds = self.library.seeds()
        if not seeds:
            return None, ""
        tips = np.array([s.equilibrium.tip for s in seeds])
        order = np.argsort(np.linalg.norm(tips - target, axis=1), kind="stable")
        for i in order[:self.search_seeds]:
            result = None
            if i in tracks:
                result = self._search_solve(target, tracks[i], runs)
                if not (result.converged or _local_end(result)):
                    result = None
            if result is None:
                result = self._search_solve(target, seeds[i].equilibrium, runs)
            if result.converged:
                return result, f"seed {seeds[i].label}"
            if _local_end(result):
                tracks[i] = result.equilibrium
        return None, ""

    def _search_solve(self, target: np.ndarray, start, runs: list):
        """Local tip control to ``target`` from ``start``, or the result of a run
        from the same state (:meth:`_seek`)."""
        for done, result in runs:
            if done is not None and _same_state(done, start):
                return result
        result = self.controller.solve(target, start=start, max_failures=self.search_failures,
                                       max_it=self.search_its)
        runs.append((start, result))
        return result

    def _spread(self, points, out: dict, states: dict, k: int, stop) -> bool:
        """Carry the state reached at sample ``k`` by the search to its
        not-reached neighbours on both sides (local solves, each from the last
        one reached) until one is not reached; False if stopped."""
        for step in (1, -1):
            j, start = k + step, states[k]
            while 0 <= j < len(points) and out["status"][j] not in (Status.REACHED,
                                                                     Status.BEYOND_REACH,
                                                                     Status.OUTSIDE_BOUNDARY):
                if stop():
                    return False
                t0 = time.perf_counter()
                result = self.controller.solve_mm(points[j], start=start,
                                                  max_failures=self.retry_failures)
                seconds = out["seconds_control"][j] + time.perf_counter() - t0
                if not result.converged:
                    out["seconds_control"][j] = seconds
                    break
                self._store(out, j, result, Status.REACHED, seconds, f"neighbour of sample {k} "
                            "(global search)")
                start = states[j] = result.equilibrium
                j += step
        return True

    def _store(self, out: dict, k: int, result, status: int, seconds: float,
               strategy: str = "local") -> None:
        out["seconds_control"][k] = seconds
        out["strategy"][k] = strategy.encode()[:48] if status == Status.REACHED else b""
        out["iterations"][k] = result.iterations
        out["reason"][k] = result.reason.encode()[:48]
        out["tip_error"][k] = result.tip_error_mm
        out["status"][k] = status
        if status == Status.REACHED:
            self._reached[k] = result
            self._record(out, k, result.equilibrium)
        else:
            out["tip"][k] = result.tip * self.arm.length_mm
            out["tensions"][k] = result.p
            out["tensions_N"][k] = self.arm.tensions_to_N(result.p)    # N wherever p is

    # --- tension sharing (class doc) -----------------------------------------------
    def _share_chunk(self, points, out: dict, stop) -> bool:
        """Share the tensions of every reached sample of the chunk (class doc);
        False if stopped."""
        if self.sharer is None:                     # two tendons: the floor is a check
            for k in self._reached:
                if np.min(out["tensions"][k]) >= self.min_tension - 1e-12:
                    out["shared"][k] = True
                elif self._unique(points[k]):
                    out["status"][k] = Status.UNIQUE_BELOW_FLOOR
                    out["reason"][k] = b"UNIQUE_BELOW_FLOOR"
                else:
                    out["status"][k], out["reason"][k] = Status.BELOW_FLOOR, b"BELOW_FLOOR"
            return True
        shared, last = {}, None                     # sample -> shared Evaluation
        for k in sorted(self._reached):
            if stop():
                return False
            result = self._share_one(points[k], k, out, (last, "own"))
            if result is not None:
                last = shared[k] = result
        for k in sorted(set(self._reached) - set(shared), reverse=True):
            later = [j for j in shared if j > k]
            if later:
                if stop():
                    return False
                result = self._share_one(points[k], k, out, (shared[min(later)],))
                if result is not None:
                    shared[k] = result
        for k in set(self._reached) - set(shared):
            if self.min_tension > 0:
                out["status"][k] = Status.BELOW_FLOOR
        return True

    def _unique(self, target_mm) -> bool:
        """Two tendons: whether ``target_mm`` has one preimage in the region D of the
        traced boundary of W_0 (:meth:`~elastica_petsc.studies.boundary.BoundaryResult.preimages`
        is 1: docs/model.md §9.1), so that the state reached is its only one (§9.3).
        The boundary is the sampler's one trace (:func:`~elastica_petsc.studies.boundary.traced_w0`)."""
        from ..boundary import traced_w0

        return traced_w0(self.arm, self.disc, self._trace_cache()).preimages(target_mm)[0] == 1

    def _trace_cache(self):
        """The sampler's own cache of its arm's W_0 boundary (one entry)."""
        if self._traces is None:
            from ..boundary import TraceCache
            self._traces = TraceCache(size=1)
        return self._traces

    def _share_one(self, target_mm, k: int, out: dict, starts: tuple):
        """Track the shared tensions at sample ``k`` from each of ``starts`` (an
        Evaluation, None: skip, 'own': the sample's reached state) until one
        succeeds; store it and return its Evaluation, else store the sharer's
        stopping reason and return None."""
        from ...solvers.control import Evaluation

        t0 = time.perf_counter()
        target, reached, result = target_mm / self.arm.length_mm, self._reached[k], None
        for start in starts:
            if start is None:
                continue
            if isinstance(start, str):              # "own"
                start = Evaluation(reached.p.copy(), reached.equilibrium, reached.sensitivity,
                                   reached.loading)
            self.controller.forget()                # evaluations cached for another branch
            result = self.sharer.track(target, start)
            if result.converged:
                break
        out["seconds_control"][k] += time.perf_counter() - t0
        if result is None:
            return None
        out["reason"][k] = result.reason.encode()[:48]
        if not result.converged:
            return None
        out["shared"][k] = True
        out["tip_error"][k] = result.tip_error_mm
        self._record(out, k, result.equilibrium)
        return Evaluation(result.p, result.equilibrium, result.sensitivity, result.loading)

    def destroy(self) -> None:
        self.controller.destroy()
        super().destroy()


def _on_lower_bound(result) -> bool:
    """A local end (STATIONARY or STALLED) with a tension on its lower bound P_i = 0
    and the gradient pushing through it: local evidence only."""
    return (result.reason in ("STATIONARY", "STALLED")
            and any(side == "lower" for _, side in result.on_bound))


def _local_end(result) -> bool:
    """Ended on a bound P_i = 0 or on a cable collapse: a state worth sliding from."""
    return _on_lower_bound(result) or result.reason == "CABLE_COLLAPSE"


def _same_state(a, b, tol: float = 1e-9) -> bool:
    """Two equilibria with the same tensions and tip (to ``tol``, units of l and
    p = P l^2/B): for a local solve, the same start."""
    return a is b or (np.allclose(a.p, b.p, rtol=tol, atol=tol)
                      and np.allclose(a.tip, b.tip, rtol=0.0, atol=tol))
