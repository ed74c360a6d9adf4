"""Answers within a budget (issue 25): ``max_seconds`` / ``--max-seconds`` stop
tip control, the length and load searches and the design optimiser with the
verdict TIME_LIMIT; and proof first: a target the traced boundary proves
outside W_0 (a hole of it) is answered without the global search.

The budgets here are tiny (1e-9 s), so the stop is forced at the first
question: nothing depends on the machine's speed except that the search
stopped and said so."""
from __future__ import annotations

import numpy as np
import pytest

import elastica_petsc as ep
from elastica_petsc.core.budget import (TIME_LIMIT, TimeBudget, TimeLimitReached,
                                        check_max_seconds)
from elastica_petsc.core.errors import InputError
from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.control import TipController
from elastica_petsc.solvers.reach import OUTSIDE_BOUNDARY, Reacher, SeedLibrary
from elastica_petsc.studies.boundary import TraceCache, boundary_proof
from elastica_petsc.studies.search import search_lengths, search_tensions

ELEMENTS = 60          # the paper's arm on a coarse mesh (as tests/test_boundary.py): fast
TINY = 1e-9            # spent before the first question


@pytest.fixture(scope="module")
def arm():
    return load_config()


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), "1", True])
def test_bad_budgets_are_one_line_input_errors(arm, bad):
    with pytest.raises(InputError, match="max_seconds"):
        check_max_seconds(bad)
    with pytest.raises(InputError, match="max_seconds"):
        ep.control(arm, (400.0, 100.0), elements=30, max_seconds=bad)
    assert check_max_seconds(None) is None and check_max_seconds(2) == 2.0


def test_time_budget_raises_once_spent():
    now = [0.0]
    budget = TimeBudget(1.0, clock=lambda: now[0])   # started at t = 0
    now[0] = 0.5
    budget.check("first step")
    assert not budget.reached and budget.remaining_s == pytest.approx(0.5)
    now[0] = 2.0
    with pytest.raises(TimeLimitReached, match="TIME_LIMIT.*at second step"):
        budget.check("second step")
    assert budget.reached and budget.expired()
    assert TimeBudget(None).remaining_s == np.inf


def test_control_stops_and_says_so(arm):
    res = ep.control(arm, (380.0, -100.0), elements=30, max_seconds=TINY)
    assert not res.converged and res.reachable is None
    assert res.reason == TIME_LIMIT and "undecided" in res.message
    assert res.equilibrium.converged          # the closest tip so far is a computed state


def test_length_search_stops_and_says_so(arm):
    res = search_lengths(arm, (147.1, 472.5), elements=30, max_seconds=TINY)
    assert res.outcome == TIME_LIMIT and res.stopped.startswith(TIME_LIMIT)
    assert "may be incomplete" in res.report()
    assert res.summary()["outcome"] == TIME_LIMIT


def test_load_search_stops_and_keeps_what_it_found(arm):
    res = search_tensions(arm, (25.2, 10.8), elements=30, max_seconds=TINY)
    assert res.outcome == TIME_LIMIT
    assert len(res.states) >= 1             # the first loading path's state is kept


def test_design_stops_without_claiming_a_gain(arm):
    res = ep.design_area(arm, vary=("tendon2.route",), elements=30, max_seconds=TINY,
                         resample_cells=2)
    assert res.reason == TIME_LIMIT and res.iterations == 0
    assert res.resampled_after is None and not res.confirmed


class CountingLibrary(SeedLibrary):
    """A seed library that counts how often the global search asks for it."""

    calls = 0

    def seeds(self):
        CountingLibrary.calls += 1
        return super().seeds()


def test_hole_target_is_answered_by_the_proof_without_the_search(arm):
    """The hole of W_0 around r_1 (a face of winding number 0 with no
    preimage): OUTSIDE_BOUNDARY by the boundary proof, without a seed library
    or any global solve, whether the boundary is traced on the way (the local
    solve failed first) or was traced before (the proof comes first)."""
    cache = TraceCache()
    with TipController(arm, n_elements=ELEMENTS, max_it=30) as ctl:     # a short local solve
        proof = boundary_proof(arm, ctl.disc, cache)
        assert proof(np.zeros(2), trace=False) == ("", pytest.approx(np.nan, nan_ok=True))
        CountingLibrary.calls = 0
        reacher = Reacher(ctl, boundary=proof, seeds=CountingLibrary(ctl))
        hole_mm = np.array([100.0, -200.0])           # README: the face around r_1
        cold = reacher.reach(hole_mm / arm.length_mm)
        assert cache.holds(arm, ctl.disc)
        hole = [f for f in cache.get(arm, ctl.disc).faces
                if f["winding"] == 0 and f["preimages"] == 0]
        assert hole and cache.get(arm, ctl.disc).outside_map.label(hole_mm[None])[0] == \
            hole[0]["label"]
        steps_cold = reacher.steps
        warm = reacher.reach(hole_mm / arm.length_mm)
        assert CountingLibrary.calls == 0
    for res in (cold, warm):
        assert res.reachable is False and res.reason == OUTSIDE_BOUNDARY
        assert res.strategy == "boundary proof" and "hole" in res.evidence
    assert reacher.steps - steps_cold == 1        # warm: the proof alone, before the local solve


def test_a_reached_target_costs_no_trace_and_keeps_its_result(arm):
    """Before the boundary is traced the local solve runs cut short (the probe);
    a target it reaches (Fig. 2) has the full local solve's result, and no
    boundary is traced for it."""
    cache = TraceCache()
    with TipController(arm, n_elements=ELEMENTS) as ctl:
        reacher = Reacher(ctl, boundary=boundary_proof(arm, ctl.disc, cache))
        target = np.array([535.8, 222.6]) / arm.length_mm
        probed = reacher.reach(target)
        full = ctl.solve(target)
    assert probed.converged and not cache.holds(arm, ctl.disc)
    assert probed.iterations == full.iterations and np.array_equal(probed.p, full.p)


def test_length_continuation_stops_and_says_so(arm):
    state = ep.lengths(arm, (147.1, 472.5), elements=30, max_seconds=TINY)
    assert not state.converged and state.reason == TIME_LIMIT
    assert "time budget" in state.message
