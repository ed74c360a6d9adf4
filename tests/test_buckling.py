"""Fig. 7 as a library function (paper Sec. 4.6; :mod:`elastica_petsc.studies.buckling`).

The physics of the scenario is asserted in tests/test_lengths.py (its fig7
fixture calls this module's critical_configuration and aligned_family); here
the top-level :func:`fig7` result is checked for consistency with those
assertions, for the quantities only it computes (continuation event,
post-buckling states, the L_1-held experiment), and the figure is drawn.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from elastica_petsc.plots.buckling import plot_fig7
from elastica_petsc.studies.buckling import (BucklingError, Fig7Result, clamped_column_estimate,
                                             critical_configuration, fig7, segment_geometry,
                                             segment_profile)
from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.core.errors import InputError
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.lengths import LengthSolver
from elastica_petsc.core.model import Arm, Tendon


@pytest.fixture(scope="module")
def arm():
    return load_config()


@pytest.fixture(scope="module")
def solvers(arm):
    eqs = EquilibriumSolver(Discretisation.from_arm(arm))
    ls = LengthSolver.from_arm(arm)
    yield eqs, ls
    eqs.destroy()
    ls.destroy()


@pytest.fixture(scope="module")
def result(solvers):
    return fig7(*solvers)


@pytest.mark.slow
def test_fig7_result_on_the_paper_arm(result):
    """The numbers of test_lengths.py's Fig. 7 tests, from the one call."""
    r = result
    assert isinstance(r, Fig7Result)
    disc = r.critical.disc
    m1 = disc.attach_nodes[0]
    # critical configuration: p_2 = 0, segment straight and its line through r_2
    assert 22.0 < r.p1_star < 25.0
    align, dev = segment_geometry(disc, r.critical.u, m1)
    assert abs(align) < 1e-12 and abs(dev) * r.length_mm < 1e-9
    np.testing.assert_allclose(r.L0_mm, r.critical.cable_lengths * 600.0)
    # aligned family: stable before the crossing, unstable after
    np.testing.assert_allclose(r.aligned_shortenings_mm, [0.0, 0.5, 1.0, 1.5, 2.0])
    assert [s.length_unstable_modes for s in r.aligned] == [0, 0, 0, 0, 1]
    assert np.all(np.diff(r.aligned_lambda) < 0) and r.bracket == (3, 4)
    np.testing.assert_allclose(r.L0_mm[1] - r.aligned_L_mm[:, 1], r.aligned_shortenings_mm,
                               atol=1e-9)
    assert np.all(np.diff(r.aligned_L_mm[:, 0]) > 0)           # L_1 let out
    # critical point and the clamped-column estimate
    assert 1.5 < r.dL2_cr_mm < 1.7 and 10.5 < r.p2_cr < 11.5
    assert r.p_clamped == pytest.approx(11.73, abs=0.01)
    assert 0.85 < r.load_ratio < 1.0
    # the continuation reports the event within 0.02 mm and jumps
    assert abs(r.event_dL2_mm - r.dL2_cr_mm) < 0.02
    assert r.event_kind == "bifurcation"                          # buckling, not a fold
    assert np.max(np.abs(r.event_L_mm - r.L_cr_mm)) < 0.05
    assert r.jump_L_mm is not None and r.jumped is r.path[-1]
    assert abs(r.path_deviation_mm[-1]) > 1.0 and np.all(np.abs(r.path_deviation_mm[:-1]) < 1e-6)
    # post-buckling: two stable states to either side, lower p_2 than the straight column
    assert r.post_dL2_mm == pytest.approx(1.8)
    assert len(r.post_buckling) == 2
    assert r.post_deviation_mm[0] < -0.5 and r.post_deviation_mm[1] > 0.5
    np.testing.assert_allclose(r.post_deviation_mm, [-1.21, 3.72], atol=0.01)
    for s in r.post_buckling:
        assert s.converged and s.length_unstable_modes == 0 and s.taut.all()
        assert s.p[1] < r.straight_p2
        np.testing.assert_allclose(s.lengths_requested * r.length_mm, r.post_L_mm)
    assert abs(r.straight_deviation_mm) < 0.01 and r.straight.length_unstable_modes == 1
    # the paper's experiment: bows continuously, p_2 levels off below p_2,cr, stable
    assert len(r.experiment) == len(r.experiment_shortenings_mm) == 24
    dev = np.abs(r.experiment_deviation_mm)
    assert np.all(np.diff(dev) > 0) and dev[-1] > 10.0
    assert np.all(np.diff(r.experiment_p2) > 0) and r.experiment_p2[-1] < r.p2_cr
    assert all(s.length_unstable_modes == 0 and not s.jumps for s in r.experiment)
    assert r.experiment[-1].unstable_modes == 1
    assert r.seconds < 30.0


@pytest.mark.slow
def test_summary_and_report(arm, result):
    data = result.summary(arm)
    json.dumps(data)
    assert data["critical_dL2_mm"] == pytest.approx(result.dL2_cr_mm, abs=1e-6)
    assert data["critical_p2_N"] == pytest.approx(result.p2_cr * arm.force_scale_N, abs=1e-6)
    assert len(data["aligned"]) == 5 and len(data["post_buckling"]) == 2
    text = result.report()
    assert "p1* = " in text and "post-buckling" in text and "Sec. 4.6" in text


@pytest.mark.slow
def test_segment_profile_matches_geometry(result):
    disc = result.critical.disc
    m1 = disc.attach_nodes[0]
    for s in result.post_buckling:
        xi, w = segment_profile(disc, s.u, m1)
        assert xi[0] == 0.0 and w[0] == 0.0 and abs(w[-1]) < 1e-12
        assert w[np.argmax(np.abs(w))] == pytest.approx(segment_geometry(disc, s.u, m1)[1])


def test_clamped_column_limits():
    """c -> infinity: the dead-load cantilever (k a = pi/2); c -> a: k a -> pi."""
    ka, p = clamped_column_estimate(1.0, 1e9)
    assert ka == pytest.approx(math.pi / 2, abs=1e-6) and p == pytest.approx(ka ** 2)
    assert clamped_column_estimate(1.0, 1.0 + 1e-6)[0] == pytest.approx(math.pi, abs=1e-5)
    ka, _ = clamped_column_estimate(2.0 / 3.0, 1.0)
    assert math.tan(ka) == pytest.approx(-(1.0 - 2.0 / 3.0) * ka / (2.0 / 3.0), rel=1e-9)


@pytest.mark.slow
def test_coarse_mesh_extends_the_family_past_the_crossing(arm):
    """With shortenings that stop before the crossing, the family is extended
    (here 1.6 mm lies within 0.01 mm of the crossing, where Newton on the
    straight column fails, and is moved on); results agree with 180 elements."""
    with EquilibriumSolver(Discretisation.from_arm(arm, 60)) as eqs, \
            LengthSolver.from_arm(arm, 60) as ls:
        r = fig7(eqs, ls, shortenings_mm=(0.4,), experiment_shortenings_mm=(1.0, 3.0))
    assert r.aligned_shortenings_mm[-1] > r.dL2_cr_mm > r.aligned_shortenings_mm[-2]
    assert r.dL2_cr_mm == pytest.approx(1.61, abs=0.02)
    assert r.p2_cr == pytest.approx(10.96, abs=0.05)
    assert len(r.post_buckling) == 2 and len(r.experiment) == 2


def test_bad_input(arm):
    one = Arm(length_mm=600.0, bending_stiffness_Nm2=0.2, elements=30,
              tendons=(Tendon(600.0, (26.1, 51.1)),))
    with EquilibriumSolver(Discretisation.from_arm(one)) as eqs, LengthSolver.from_arm(one) as ls:
        with pytest.raises(InputError, match="two tendons"):
            fig7(eqs, ls)
    disc = Discretisation.from_arm(arm, 30)
    with EquilibriumSolver(disc) as eqs, LengthSolver(disc) as ls:
        with pytest.raises(InputError, match="arm length"):
            fig7(eqs, ls)
        with pytest.raises(BucklingError, match="does not change sign"):
            critical_configuration(eqs, bracket=(5.0, 10.0))


@pytest.mark.slow
def test_plot_fig7(arm, result, tmp_path):
    png = tmp_path / "fig7.png"
    plot_fig7(arm, result, png)
    assert png.stat().st_size > 50_000
