"""What one workspace sample computes (paper Sec. 4.3, Figs. 4-5).

``TargetSampler`` (mode ``targets``, Fig. 4): tip control to each target,
warm-started from the previous sample of the chunk; classified as reached
(P >= 0, E < eps), needing a negative tension (the optimiser stops on the
bound P_i = 0 with E > eps: the paper's red points), or not converged.
``TensionSampler`` (mode ``tensions``): the forward solve on a grid of
tensions, each warm-started (continued) from the previous one.
Both fill the same fields (:func:`elastica_petsc.studies.workspace.fields`) and add
the smallest stiffness eigenvalue (SLEPc) of every equilibrium reached.
"""
from __future__ import annotations

import time

import numpy as np

from ..core.clearance import state_cable_clear
from ..solvers.equilibrium import Equilibrium, EquilibriumSolver
from ..core.fem import Discretisation
from ..core.model import Arm
from ..solvers.stability import StabilityError, StabilitySolver
from .workspace import NEEDS_NEGATIVE, NOT_CONVERGED, REACHED, empty_fields, fields


class _Sampler:
    def __init__(self, arm: Arm, disc: Discretisation):
        self.arm, self.disc = arm, disc
        self.solver = EquilibriumSolver(disc)
        self.stability = StabilitySolver(disc, nev=1)
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
            result = self.stability.solve(eq.u, eq.p)
            out["lambda_min"][k] = result.lambda_min
            out["lambda_min_raw"][k] = result.raw_min
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
                out["status"][k] = REACHED
                self._record(out, k, eq)
                previous = eq
            else:
                out["status"][k] = NOT_CONVERGED
        return out


class TargetSampler(_Sampler):
    """Tip control over a chunk of targets (mm), Algorithm 1 with TAO BLMVM.

    Warm starts inside a chunk (the next target is a grid neighbour):

    * after a reached target: from its equilibrium (tensions and state);
    * after a target outside W_0 (``NEEDS_NEGATIVE``): from that solve's
      end state, the tip on the boundary P_1 = 0 closest to the target, so
      a run of outside targets slides along the boundary instead of
      restarting from afar (measured on the paper's half-disc, 4202 targets,
      180 elements: 66 -> 12 ms per outside target).  If that start does not
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
      failed equilibria (the retries that fail run into snaps and collapses
      at 0.1 s per failed equilibrium; with the solve's default budget of 25
      they cost 50 s on the paper's half-disc).  Measured there (4202
      targets, 180 elements): 5 more targets reached, 4.2 s of work.

    ``stationary_rtol`` (passed to :class:`~elastica_petsc.solvers.control.TipController`)
    is looser than the controller's default 1e-7: a target is classified as
    outside once the projected gradient is 1e-5 of |x_t - x_d| |S|; pinning
    the closest boundary point to 1e-7 cost ~8 more iterations per outside
    target and changed no classification (measured on a 30 mm grid, 649
    targets).  Reached targets are unaffected (they stop on E < eps).
    """

    head_guess = 2.0
    stationary_rtol = 1e-5
    retry_failures = 1

    def __init__(self, arm: Arm, disc: Discretisation):
        from ..solvers.control import TipController

        super().__init__(arm, disc)
        self.controller = TipController(arm, solver=self.solver,
                                        stationary_rtol=self.stationary_rtol)

    def _classify(self, result) -> int:
        if result.converged:
            return REACHED
        # local evidence only (a stationary point of E with a tension on P = 0 and the
        # gradient pushing through it): the class is 'needs a negative tension from
        # here', not a proof about W_0 (solvers/reach.py: reachable stays None)
        lower = any(side == "lower" for _, side in result.on_bound)
        local_end = result.reason in ("STATIONARY", "STALLED")
        return NEEDS_NEGATIVE if (local_end and lower) else NOT_CONVERGED

    def solve_chunk(self, points: np.ndarray, stop) -> dict | None:
        out = self._empty(len(points))
        out["target"][:] = points
        head = np.full(self.disc.n_tendons, self.head_guess)
        reached = boundary = None          # last reached state; state after an outside target
        states = {}                        # sample -> equilibrium, reached samples
        for k, target in enumerate(points):
            if stop():
                return None
            t0 = time.perf_counter()
            result = status = None
            if boundary is not None:
                result = self.controller.solve_mm(target, start=boundary)
                status = self._classify(result)
                if status == NOT_CONVERGED:
                    result = None
            if result is None:
                result = self.controller.solve_mm(
                    target, p0=None if reached is not None else head, start=reached)
                status = self._classify(result)
            self._store(out, k, result, status, time.perf_counter() - t0)
            boundary = result.equilibrium if status == NEEDS_NEGATIVE else None
            if status == REACHED:
                reached = states[k] = result.equilibrium
        # backward sweep: a target not converged before a reached one is solved
        # again from its reached neighbour on the other side
        reached = None
        for k in reversed(range(len(points))):
            if k in states:
                reached = states[k]
                continue
            if out["status"][k] != NOT_CONVERGED or reached is None:
                continue
            if stop():
                return None
            t0 = time.perf_counter()
            result = self.controller.solve_mm(points[k], start=reached,
                                              max_failures=self.retry_failures)
            status = self._classify(result)
            seconds = out["seconds_control"][k] + time.perf_counter() - t0
            if status == NOT_CONVERGED:
                out["seconds_control"][k] = seconds
                continue
            self._store(out, k, result, status, seconds)
            if status == REACHED:
                reached = result.equilibrium
        return out

    def _store(self, out: dict, k: int, result, status: int, seconds: float) -> None:
        out["seconds_control"][k] = seconds
        out["iterations"][k] = result.iterations
        out["reason"][k] = result.reason.encode()[:48]
        out["tip_error"][k] = result.tip_error_mm
        out["status"][k] = status
        if status == REACHED:
            self._record(out, k, result.equilibrium)
        else:
            out["tip"][k] = result.tip * self.arm.length_mm
            out["tensions"][k] = result.p
            out["tensions_N"][k] = self.arm.tensions_to_N(result.p)    # N wherever p is

    def destroy(self) -> None:
        self.controller.destroy()
        super().destroy()
