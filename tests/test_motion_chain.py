"""Re-timing as a chain (core/motion_chain.py): where a short move sits between
long ones (a corner of the path), slowing it gives both its accelerations more
time, so the schedule can be shorter than the forward/backward passes make it.
The chain's timing is checked for playability, against the passes alone, and
against the best of 20 SLSQP runs on the same discrete constraints."""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core import motion
from elastica_petsc.core.motion import MotorLimits, check, rates_and_accelerations, retime

LIMITS = MotorLimits(np.array([1000.0, 800.0]), np.array([2000.0, 3000.0]))
# two motors; the move into row 3 is short (2 and 10 steps) between long ones
Q = np.array([[0, 0], [300, -100], [600, -250], [602, -240], [900, -100], [1200, 0],
              [1300, 20]], float)


def best_feasible(q, limits, start):
    """The shortest of 20 SLSQP schedules under check's constraints (scipy)."""
    from scipy.optimize import minimize

    def margins(d):
        r, a = rates_and_accelerations(q, d)
        return np.concatenate([(limits.accel_steps_s2 - np.abs(a)).ravel(),
                               (limits.speed_steps_s - np.abs(r)).ravel()])

    best = np.inf
    for seed in range(20):
        x0 = start * np.random.default_rng(seed).uniform(1.0, 3.0, len(start))
        res = minimize(lambda d: d.sum(), x0, method="SLSQP", bounds=[(1e-6, None)] * len(x0),
                       constraints=[{"type": "ineq", "fun": margins}],
                       options={"maxiter": 500, "ftol": 1e-12})
        if res.success and margins(res.x).min() > -1e-6:
            best = min(best, res.x.sum())
    return best


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_chain_timing_is_playable_shorter_than_the_passes_and_near_the_optimum(monkeypatch):
    timing = retime(Q, LIMITS)
    assert not check(Q, timing.durations_s, LIMITS)
    assert set(timing.limited_by) <= {"speed_1", "speed_2", "accel_1", "accel_2"}
    total = timing.durations_s.sum()
    best = best_feasible(Q, LIMITS, timing.durations_s)
    assert best <= total <= 1.01 * best, (total, best)
    monkeypatch.setattr(motion, "chain_speeds", lambda dq, caps, passes, accel: passes)
    passes = retime(Q, LIMITS).durations_s.sum()
    assert not check(Q, retime(Q, LIMITS).durations_s, LIMITS)
    assert total < 0.98 * passes, (total, passes)            # the passes alone: 3 % longer
