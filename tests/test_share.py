"""Redundant tendons (issue 11): tension sharing on a 3-tendon arm, checked
against the KKT conditions and a brute-force search over the one-parameter
family of tension sets that put the tip on the target."""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.core.errors import InputError
from elastica_petsc.solvers.control import TipController
from elastica_petsc.solvers.reach import Reacher
from elastica_petsc.solvers.share import TensionSharer, family, kkt_residual, objective

from test_reach import three_tendon_arm

ELEMENTS = 60


@pytest.fixture(scope="module")
def shared():
    """The target of p = (8, 10, 3), reached, then shared both ways."""
    arm3 = three_tendon_arm(load_config())
    with TipController(arm3, n_elements=ELEMENTS) as ctl:
        target = ctl.forward([8.0, 10.0, 3.0]).tip
        reached = Reacher(ctl).reach(target)
        out = {}
        for share in ("min-norm", "min-energy"):
            res = TensionSharer(ctl, share).solve(reached)
            ev = ctl.evaluate(res.p, start=res.equilibrium)
            fam = family(ctl, ev, target, 1, np.linspace(res.p[1] - 0.5, res.p[1] + 0.5, 11))
            out[share] = (res, ev, fam, target)
        floor = TensionSharer(ctl, "min-norm", min_tension=1.0 / arm3.force_scale_N)
        out["floor"] = floor.solve(reached)
        with pytest.raises(InputError, match="sharing"):
            TensionSharer(ctl, "max-norm")
    return out


@pytest.mark.parametrize("share", ["min-norm", "min-energy"])
def test_sharing_is_optimal_on_the_family(shared, share):
    res, ev, fam, target = shared[share]
    assert res.converged and res.tip_error_mm < 1e-5 and np.min(res.p) >= 0.0
    assert kkt_residual(share, ev) < 1e-7
    f_star = objective(share, ev)[0]
    on_target = [e for e in fam if np.all(e.p >= 0)
                 and np.linalg.norm(e.equilibrium.tip - target) < 1e-10]
    assert len(on_target) >= 5                       # the family was followed
    assert all(objective(share, e)[0] >= f_star - 1e-9 * abs(f_star) for e in on_target)


def test_min_norm_is_interior_here(shared):
    """All three tensions free at the min-norm optimum: the KKT test is not trivial
    (3 stationarity equations, 2 multipliers)."""
    res = shared["min-norm"][0]
    assert np.all(res.p > 1e-6)


def test_min_energy_gradient_taylor(shared):
    """grad U = -(dL/dp) p (docs: stationarity of the potential): Taylor remainder O(t^2)."""
    arm3 = three_tendon_arm(load_config())
    with TipController(arm3, n_elements=ELEMENTS) as ctl:
        ev = ctl.evaluate([8.0, 10.0, 3.0])
        f0, g = objective("min-energy", ev)
        v = np.array([0.6, -0.3, 0.74])
        rem = []
        for t in (0.2, 0.1, 0.05):
            e = ctl.evaluate(ev.p + t * v, start=ev.equilibrium)
            rem.append(abs(objective("min-energy", e)[0] - f0 - t * g @ v))
    rates = np.log2(np.array(rem[:-1]) / np.array(rem[1:]))
    assert np.all(rates > 1.8), rates


def test_pretension_floor(shared):
    res = shared["floor"]
    arm3 = three_tendon_arm(load_config())
    assert res.converged and np.min(res.tensions_N) >= 1.0 - 1e-9



@pytest.mark.parametrize("share", ["min-norm", "min-energy"])
def test_tao_almm_agrees_with_the_sqp(shared, share):
    """The first sharer, TAO ALMM (method="almm", kept for comparison: docs/model.md
    §4.4), is an independent solver of the same problem: from the same reached
    state it ends on the target with the SQP's tensions and satisfies the KKT
    conditions."""
    sqp = shared[share][0]
    arm3 = three_tendon_arm(load_config())
    with TipController(arm3, n_elements=ELEMENTS) as ctl:
        reached = Reacher(ctl).reach(shared[share][3])
        almm = TensionSharer(ctl, share, method="almm").solve(reached)
        ev = ctl.evaluate(almm.p, start=almm.equilibrium)
    assert almm.converged and almm.tip_error_mm < 1e-5
    assert kkt_residual(share, ev) < 1e-7
    np.testing.assert_allclose(almm.p, sqp.p, atol=1e-6)
