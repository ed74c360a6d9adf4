"""Load paths with capstan friction at the guides (studies/friction.py, docs/model.md §27):

- mu = 0 gives the frictionless equilibria of the same tensions to round-off;
- the capstan closed form: a cable through n guides at offset d along the arm, loaded
  in slip toward the motor, bends the arm to theta(l) = ln(1 + mu p d)/mu and, unloaded
  in slip toward the end, to -ln(1 - mu p d)/mu (tension P e^{-+mu theta(s)} along the
  backbone), converging at rate n^-2; the segment tensions are P e^{-mu sum beta};
- a load-unload cycle of configs/guided3.toml: hysteresis of the tip against the motor
  tension, with the guides sticking at the reversal, and none with mu = 0;
- the energy balance of a cycle: the motor's work -oint P_1 dL_1 equals the dissipation
  sum_a oint (P_{a+1} - P_a) dS_a at the guides (O(step^2) in the increments), and every
  guide dissipates >= 0 in every increment (maximal dissipation, the second law).
"""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core.errors import InputError
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.friction import SLIP_IN, SLIP_OUT, STICK, CapstanKernel
from elastica_petsc.core.model import Arm, Guide, Tendon, load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.studies.friction import friction_path
from conftest import REPO

MU = 0.3
OFFSET = 0.05            # d / l
P_MAX, P_BACK = 20.0, 10.0


def cycle(p_max: float, steps: int) -> np.ndarray:
    up = np.linspace(0.0, p_max, steps + 1)
    return np.concatenate((up, up[::-1][1:]))


@pytest.fixture(scope="module")
def guided3():
    return Discretisation.from_arm(load_config(REPO / "configs" / "guided3.toml"), 48)


def test_mu_zero_is_the_frictionless_model(guided3):
    history = np.column_stack((np.linspace(0.0, 30.0, 7), np.linspace(0.0, 12.0, 7)))
    path = friction_path(guided3, 0.0, history)
    assert path.converged
    # every segment carries its motor's tension exactly
    motor = path.p_motor[:, guided3.point_tendon]
    np.testing.assert_array_equal(path.tensions, motor)
    with EquilibriumSolver(guided3) as solver:
        for k in (2, 6):
            eq = solver.solve(history[k])
            theta = guided3.split(path.states[k][:guided3.size])[0]
            assert np.max(np.abs(theta - eq.theta)) < 1e-11
            assert np.max(np.abs(path.tip[k] - eq.tip)) < 1e-11


def guided_column(n_guides: int) -> Arm:
    """l = 1000 mm, B = 1 N m^2; one cable from its motor 500 mm behind the clamp on
    the line y = d (so it reaches the first guide along the backbone's tangent), through
    n - 1 guides at s = j l / n and offset d to the tip, offset d."""
    d_mm = 1000.0 * OFFSET
    guides = tuple(Guide(1000.0 * j / n_guides, d_mm) for j in range(1, n_guides))
    return Arm(length_mm=1000.0, bending_stiffness_Nm2=1.0, guide_radius_mm=d_mm, elements=480,
               tendons=(Tendon(1000.0, (-500.0, d_mm), attach_offset_mm=d_mm, guides=guides),))


def test_capstan_closed_form_loading_and_unloading():
    """B theta' = P(s) d with P(s) = P e^{-mu theta(s)} (slip toward the motor) or
    e^{+mu theta(s)} (toward the end): theta(l) = +-ln(1 +- mu p d)/mu."""
    load = np.log(1.0 + MU * P_MAX * OFFSET) / MU
    unload = -np.log(1.0 - MU * P_BACK * OFFSET) / MU
    history = np.concatenate((np.linspace(0.0, P_MAX, 6), np.linspace(P_MAX, P_BACK, 6)[1:]))
    errors = []
    for n in (8, 16, 32):
        path = friction_path(Discretisation.from_arm(guided_column(n)), MU, history[:, None],
                             max_step=4.0)
        assert path.converged, path.message
        top = 5
        assert np.all(path.modes[1:top + 1] == SLIP_IN)
        assert np.all(path.modes[-1] == SLIP_OUT)
        errors.append((path.tip_angle[top] - load, path.tip_angle[-1] - unload))
        # the segment tensions are the motor's times e^{-+mu (the angles turned so far)},
        # to Newton's tolerance (absolute 1e-10 on every equation)
        for k, sign in ((top, -1.0), (-1, 1.0)):
            turned = np.concatenate(([0.0], np.cumsum(path.wrap[k])))
            np.testing.assert_allclose(path.tensions[k], path.p_motor[k, 0] *
                                       np.exp(sign * MU * turned), rtol=0, atol=1e-10)
    errors = np.array(errors)
    orders = np.log2(errors[:-1] / errors[1:])
    assert np.all(errors[-1] > 0) and np.all(np.abs(errors[-1]) < [2e-3, 5e-4]), errors
    assert np.all(orders[-1] > 1.9) and np.all(orders > 1.8), orders
    # hysteresis: the tip angles of loading and unloading differ at the same tension
    assert -np.log(1.0 - MU * P_BACK * OFFSET) / MU - np.log(1.0 + MU * P_BACK * OFFSET) / MU > 0.07


def test_load_unload_cycle_shows_hysteresis(guided3):
    p1 = cycle(40.0, 20)
    history = np.column_stack((p1, np.zeros_like(p1)))
    paths = {mu: friction_path(guided3, mu, history) for mu in (0.0, MU)}
    assert all(path.converged for path in paths.values())
    top = 20
    for mu, path in paths.items():
        up, down = path.tip_angle[:top + 1], path.tip_angle[top:][::-1]
        gap = down - up
        if mu == 0.0:
            assert np.max(np.abs(gap)) < 1e-10                 # no loop without friction
            continue
        # unloading bends the arm more at every tension between the ends of the cycle (the
        # gap grows like p^2 near p = 0: 6.6e-4 rad at p = 2, far above Newton's 1e-10)
        assert np.all(gap[1:-1] > 1e-4) and gap.max() > 0.15, gap
        assert abs(gap[0]) < 1e-10 and abs(gap[-1]) < 1e-10  # the loop closes at p = 0
        # loading: tendon 1's guides slip toward the motor; tension falls along the cable
        cable1 = guided3.point_tendon == 0
        guides1 = np.flatnonzero(cable1[:-1] & cable1[1:])
        assert np.all(path.modes[1:top + 1][:, guides1] == SLIP_IN)
        assert np.all(np.diff(path.tensions[top][cable1]) < 0)
        # the reversal: the first guide sticks and the tension beyond it stays at its peak
        assert path.modes[top + 1, guides1[0]] == STICK
        assert path.tensions[top + 1, 1] == pytest.approx(path.tensions[top, 1], rel=1e-12)
        # unloading, once it slips back: toward the end, tension rising along the cable
        assert np.all(path.modes[-2][guides1] == SLIP_OUT)
        assert np.all(np.diff(path.tensions[-2][cable1]) > 0)


def test_a_cycle_dissipates_the_motor_work_at_the_guides(guided3):
    """-P_1 dL_1 - dU = sum_a (P_{a+1} - P_a) dS_a exactly (docs/model.md §27.4): over a closed
    cycle U returns, so the motor's work is the guides' dissipation.  Both by the trapezoid
    rule over the increments (one per history step); the gap falls at order 2."""
    kernel = CapstanKernel.of(guided3, MU)
    gaps = []
    for steps in (20, 40):
        up = np.linspace(0.0, 40.0, steps + 1)
        p1 = np.r_[up, up[::-1][1:]]
        path = friction_path(guided3, MU, np.column_stack((p1, 0 * p1)), max_step=40.0 / steps)
        assert path.converged and path.increments == 2 * steps
        beyond = np.array([kernel.beyond(w) for w in path.states])
        jump = path.tensions[:, kernel.guides + 1] - path.tensions[:, kernel.guides]
        slip = np.diff(beyond, axis=0)
        # backward Euler: the end-of-increment tensions dissipate >= 0 at every guide
        assert np.min(jump[1:] * slip) > -1e-11
        dissipated = np.sum(0.5 * (jump[1:] + jump[:-1]) * slip)
        work = -np.sum(0.5 * (path.p_motor[1:, 0] + path.p_motor[:-1, 0])
                       * np.diff(path.cable_lengths[:, 0]))
        assert dissipated > 0.08                      # 0.090 B/l: 15 mJ per cycle
        gaps.append(abs(work - dissipated) / dissipated)
    assert gaps[1] < 1e-3 and np.log2(gaps[0] / gaps[1]) > 1.8, gaps


def test_length_control_follows_the_force_controlled_path(guided3):
    """Reeling cable 1 in by its motor length (the paths meet on monotone loading: every
    guide slips toward the motor and the state is a function of the motor tension), then
    paying it out again: the motor tension falls while the guides stick."""
    start = np.array([4.0, 0.0])
    lengths = friction_path(guided3, MU, [[0.0, 0.0]], start_tensions=start).cable_lengths[0, 0]
    pull = lengths - np.linspace(0.0, 0.02, 5)[1:]                 # reel in 0.02 l = 6 mm
    history = np.column_stack((np.r_[pull, pull[-1] + 5e-4], np.zeros(5)))
    by_length = friction_path(guided3, MU, history, length_control=(True, False),
                              start_tensions=start)
    assert by_length.converged, by_length.message
    np.testing.assert_allclose(by_length.cable_lengths[1:, 0], history[:, 0], atol=1e-10)
    assert np.all(np.diff(by_length.p_motor[:5, 0]) > 0)            # reeling in pulls harder
    by_force = friction_path(guided3, MU, np.column_stack((by_length.p_motor[:5, 0], np.zeros(5))))
    np.testing.assert_allclose(by_force.states[:, :guided3.size],
                               by_length.states[:5, :guided3.size], atol=1e-8)
    # paying out 5e-4 l = 0.15 mm of cable again: the first guide sticks (the cable beyond
    # it keeps its length) and the motor tension drops by 6 % (28.28 to 26.51)
    assert by_length.modes[-1, 0] == STICK
    assert by_length.tensions[-1, 1] == pytest.approx(by_length.tensions[-2, 1], rel=1e-12)
    assert by_length.p_motor[-1, 0] < 0.95 * by_length.p_motor[-2, 0]


def test_elastic_cables_tend_to_the_inextensible_path():
    """configs/guided.toml, cable 2 cycled against cable 1 at 5 N, mu = 0.6: guides of both
    cables stick over shared spans (statically indeterminate with inextensible cables, see
    test_friction_kernel.py).  With a cable compliance B/(EA l^2) the path converges to the
    inextensible one at order 1 (tip and tensions)."""
    arm = load_config(REPO / "configs" / "guided.toml")
    disc = Discretisation.from_arm(arm, 48)
    up = np.linspace(0.0, 30.0, 16)
    cycle = np.r_[up, up[::-1][1:]]
    history = np.column_stack((np.full(cycle.size, 5.0), cycle)) / arm.force_scale_N
    base = friction_path(disc, 0.6, history)
    assert base.converged and np.any(base.modes[:, :5] == STICK)
    tips, tensions = [], []
    for compliance in (1e-4, 1e-5, 1e-6):
        path = friction_path(disc, 0.6, history, compliance=compliance)
        assert path.converged
        tips.append(np.abs(path.tip - base.tip).max())
        tensions.append(np.abs(path.tensions - base.tensions).max())
    for gaps in (tips, tensions):
        orders = np.log10(np.array(gaps[:-1]) / np.array(gaps[1:]))
        assert np.all(orders > 0.8), (gaps, orders)


def test_a_start_that_cannot_be_reached_is_a_result(guided3):
    """No frictionless equilibrium at the first tensions (cable 1 collapses onto a guide long
    before p = 2000): converged False with the reason, no rows, not an exception."""
    path = friction_path(guided3, MU, [[2000.0, 0.0], [10.0, 0.0]])
    assert not path.converged and "no frictionless equilibrium" in path.message
    assert path.tip.shape == (0, 2) and path.modes.shape == (0, 6)


def test_bad_history(guided3):
    with pytest.raises(InputError, match="motor values with 2 values"):
        friction_path(guided3, MU, [[1.0, 2.0, 3.0]])
    with pytest.raises(InputError, match="negative"):
        friction_path(guided3, MU, [[1.0, 0.0], [-1.0, 0.0]])
    with pytest.raises(InputError, match="start_tensions"):
        friction_path(guided3, MU, [[1.0, 0.0]], length_control=(True, False))
