"""Direct Gauss-Newton steps and the path predictor of tip control (docs/model.md §25)."""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.solvers.control import TipController
from elastica_petsc.solvers.tip_problem import TARGET_REACHED, spectral_norm
from elastica_petsc.studies import trace as paths

TOL_MM = 1e-5


@pytest.fixture(scope="module")
def arm():
    return load_config()


def test_spectral_norm_closed_form():
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 5):
        S = rng.standard_normal((n, 2))
        assert spectral_norm(S) == pytest.approx(np.linalg.norm(S, 2), rel=1e-13)
    S = np.array([[1.0, 2.0], [2.0, 4.0]])                 # rank one
    assert spectral_norm(S) == pytest.approx(5.0, rel=1e-14)


def test_direct_steps_are_the_tao_steps(arm):
    """From a warm start the direct steps take BLMVM's steps: same iterates,
    iterations, evaluations and reason as TAO run on the same problem."""
    with TipController(arm, n_elements=90) as ctl:
        first = ctl.solve_mm((450.0, 250.0))
        direct = ctl.solve_mm((452.0, 249.0), start=first.equilibrium)
        ctl._solve_blmvm = ctl._solve_tao               # TAO only, for comparison
        tao = ctl.solve_mm((452.0, 249.0), start=first.equilibrium)
    assert direct.converged and tao.converged and direct.reason == TARGET_REACHED
    assert direct.tao_reason == tao.tao_reason == "CONVERGED_USER"
    assert direct.iterations == tao.iterations >= 2
    assert direct.evaluations == tao.evaluations
    np.testing.assert_allclose(direct.history_p, tao.history_p, rtol=0, atol=1e-11)
    np.testing.assert_allclose(direct.history_E, tao.history_E, rtol=1e-6, atol=1e-24)


def test_path_predictor_one_step_per_point_on_a_line(arm):
    """Equally spaced points on a line: after two chained points the corrected
    first step lands within the tolerance (one iteration), at the same
    tensions as the plain iteration within what the tolerance allows."""
    targets = paths.line((430.0, 240.0), (442.0, 236.0), 13)
    with TipController(arm, n_elements=90) as ctl:
        first = ctl.solve_mm(targets[0])
        fast = paths.trace(ctl, targets[1:], p0=first.p, start=first.equilibrium)
        ctl.predictor.correction = lambda start, target: None     # plain Gauss-Newton
        plain = paths.trace(ctl, targets[1:], p0=first.p, start=first.equilibrium)
    assert fast.all_converged and plain.all_converged
    assert np.all(fast.tip_errors_mm < TOL_MM)
    assert np.all(plain.iterations == 2)
    assert np.all(fast.iterations[2:] == 1) and fast.iterations.sum() < plain.iterations.sum()
    # both tips within 1e-5 mm of the same targets: tensions within |S^+| 2e-5 mm / l
    np.testing.assert_allclose(fast.p, plain.p, rtol=0, atol=1e-3)


def test_path_predictor_only_for_a_chained_similar_step(arm):
    """No correction from another start than the last point reached, nor
    across a corner (the next step differs from the last by more than 25 %)."""
    with TipController(arm, n_elements=90) as ctl:
        a = ctl.solve_mm((430.0, 240.0))
        b = ctl.solve_mm((431.0, 240.0), start=a.equilibrium)
        c = ctl.solve_mm((432.0, 240.0), start=b.equilibrium)
        pred = ctl.predictor
        assert pred.correction(c.equilibrium, np.array([433.0, 240.0]) / ctl.length_mm) \
            is not None
        assert pred.correction(b.equilibrium, np.array([433.0, 240.0]) / ctl.length_mm) is None
        assert pred.correction(c.equilibrium, np.array([432.0, 241.0]) / ctl.length_mm) is None


def test_path_from_the_straight_arm(arm):
    """A path out of the straight arm's tip and back (S of rank one at p = 0,
    cond(S^T S) ~ 1e10 at the last point): every point reached within the
    tolerance, the predictor's corrected steps included."""
    with TipController(arm, n_elements=90) as ctl:
        straight = ctl.forward([0.0, 0.0]).tip * ctl.length_mm
        off = straight + np.array([-6.0, 3.0])
        targets = np.vstack((paths.line(straight, off, 7), paths.line(off, straight, 7)[1:]))
        res = paths.trace(ctl, targets)
    assert res.all_converged and np.all(res.tip_errors_mm < TOL_MM)


def test_path_predictor_turns_with_the_step_at_polygon_vertices(arm):
    """Arc of the 73-gon circle of Fig. 3a, chords cut into 1 mm steps: the
    step turns by 5 degrees at every vertex.  With the turned defect most
    points take one step; without it every vertex costs two."""
    targets = paths.densify(paths.circle((400.0, 200.0), 40.0, 73)[:16], 1.0)
    with TipController(arm, n_elements=90) as ctl:
        first = ctl.solve_mm(targets[0])
        turned = paths.trace(ctl, targets[1:], p0=first.p, start=first.equilibrium)
        ctl.predictor._turn = lambda v: 0.0 * v                  # the defect not turned
        straight = paths.trace(ctl, targets[1:], p0=first.p, start=first.equilibrium)
    assert turned.all_converged and np.all(turned.tip_errors_mm < TOL_MM)
    assert np.mean(turned.iterations[2:] == 1) >= 0.75
    assert turned.iterations.sum() < straight.iterations.sum()
