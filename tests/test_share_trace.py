"""Tension sharing along a traced path (issue 11): a circle traced on a 3-tendon
arm closes in cable space; the floor holds; minimum norm and minimum strain
energy are checked at every point by the KKT conditions (least-squares
multipliers, independent of the solver's) and at a few points by brute force
over the one-parameter family of tension sets that put the tip on the target.
Coarse mesh, few points: the full study is scripts/studies/share_study.py."""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.core.qp import LOWER, closest_in_box, solve_box_qp
from elastica_petsc.solvers.control import Evaluation, TipController
from elastica_petsc.solvers.share import (SHARE_INFEASIBLE, SHARE_STALLED, TensionSharer,
                                          family, kkt_residual, objective)
from elastica_petsc.studies import trace as paths

pytestmark = pytest.mark.slow          # left out by scripts/test.sh --fast

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "three_tendon.toml"
ELEMENTS = 30
CENTER, RADIUS, POINTS = (450.0, 290.0), 40.0, 25      # ~10.5 mm between targets


@pytest.fixture(scope="module")
def traced():
    """The circle traced plainly, shared min-norm, min-energy, and min-norm with P >= 1 N."""
    arm = load_config(CONFIG)
    pts = paths.circle(CENTER, RADIUS, POINTS)
    out = {"arm": arm}
    with TipController(arm, n_elements=ELEMENTS) as ctl:
        out["plain"] = paths.trace(ctl, pts)
        for key, share, floor_N in (("min-norm", "min-norm", 0.0),
                                    ("min-energy", "min-energy", 0.0),
                                    ("floor", "min-norm", 1.0)):
            sharer = TensionSharer(ctl, share, floor_N / arm.force_scale_N)
            res = paths.trace(ctl, pts, sharer=sharer, keep_results=True)
            out[key] = (res, sharer)
        out["family"] = {key: brute_force(ctl, *out[key], picks=(3, 12, 20))
                         for key in ("min-norm", "min-energy", "floor")}
    return out


def brute_force(ctl, result, sharer, picks):
    """Per picked point: (f at the shared state, f over the family with p >= floor)."""
    out = []
    for k in picks:
        r = result.results[k]
        ev = Evaluation(r.p, r.equilibrium, r.sensitivity)
        on_floor = np.flatnonzero(r.p <= sharer.min_tension + 1e-9)
        j = int(on_floor[0]) if on_floor.size else 1
        t0 = r.p[j]
        up = family(ctl, ev, r.target, j, t0 + np.linspace(0.02, 0.6, 8))
        down = family(ctl, ev, r.target, j, t0 - np.linspace(0.02, 0.6, 8))
        fam = [e for e in up + down if np.min(e.p) >= sharer.min_tension - 1e-12]
        out.append((objective(sharer.share, ev)[0],
                    [objective(sharer.share, e)[0] for e in fam], bool(on_floor.size)))
    return out


def test_plain_trace_does_not_close(traced):
    """Without sharing the redundant arm drifts along the family: the problem is real."""
    plain = traced["plain"]
    assert plain.all_converged
    assert np.max(np.abs(plain.cable_lengths_mm[-1] - plain.cable_lengths_mm[0])) > 1e-2


@pytest.mark.parametrize("key", ["min-norm", "min-energy", "floor"])
def test_shared_circle_closes_in_cable_space(traced, key):
    res, _ = traced[key]
    assert res.all_converged and np.max(res.tip_errors_mm) < 1e-5
    assert np.max(np.abs(res.cable_lengths_mm[-1] - res.cable_lengths_mm[0])) < 1e-3


@pytest.mark.parametrize("key", ["min-norm", "min-energy", "floor"])
def test_kkt_conditions_at_every_point(traced, key):
    res, sharer = traced[key]
    for r in res.results:
        ev = Evaluation(r.p, r.equilibrium, r.sensitivity)
        assert kkt_residual(sharer.share, ev, sharer.min_tension) < 1e-8


def test_rules_differ_and_min_norm_is_interior_somewhere(traced):
    """Not a trivial check: min-norm has all three tensions free at some points
    (3 stationarity equations, 2 multipliers), and there the rules differ."""
    norm, energy = traced["min-norm"][0].p, traced["min-energy"][0].p
    interior = np.all(norm > 1e-6, axis=1)
    assert interior.sum() >= 3
    assert np.max(np.abs(norm - energy)[interior]) > 0.1


@pytest.mark.parametrize("key", ["min-norm", "min-energy", "floor"])
def test_brute_force_over_the_family(traced, key):
    for f_star, fam, _ in traced["family"][key]:
        assert len(fam) >= 6                             # the family was followed
        assert min(fam) > f_star - 1e-9 * abs(f_star)


def test_floor_holds_and_binds(traced):
    res, _ = traced["floor"]
    assert np.min(res.tensions_N) >= 1.0 - 1e-9
    assert np.sum(np.isclose(res.tensions_N.min(axis=1), 1.0, atol=1e-9)) >= 5
    assert any(on_floor for _, _, on_floor in traced["family"]["floor"])


def test_unshareable_target_stops_promptly():
    """(590, 20) mm, just off the straight arm, with every P >= 10 N: not found,
    a clear local reason, no hang."""
    arm = load_config(CONFIG)
    with TipController(arm, n_elements=ELEMENTS) as ctl:
        reached = ctl.solve_mm([590.0, 20.0])
        assert reached.converged
        sharer = TensionSharer(ctl, "min-norm", 10.0 / arm.force_scale_N)
        t0 = time.perf_counter()
        res = sharer.solve(reached)
        seconds = time.perf_counter() - t0
    assert not res.converged and res.reachable is None
    assert res.reason in (SHARE_INFEASIBLE, SHARE_STALLED)
    assert "not a proof" in res.message and "10 N" in res.message
    assert res.iterations <= sharer.max_it and seconds < 30


# --- the QP (numpy only) -------------------------------------------------------------
def test_box_qp_against_projected_brute_force():
    """Random strictly convex QPs with 2 equality constraints and a box: the
    enumerated KKT point beats every feasible point of a dense sample of the
    feasible set (a line for n = 3), and warm starts give the same answer."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        M = rng.normal(size=(3, 3))
        W = M @ M.T + 0.1 * np.eye(3)
        g, A = rng.normal(size=3), rng.normal(size=(3, 2))
        d0 = rng.uniform(-0.5, 0.5, 3)
        c = -A.T @ d0                                    # d0 is feasible
        lo, hi = np.full(3, -0.6), np.full(3, 0.6)
        sol = solve_box_qp(W, g, A, c, lo, hi)
        assert sol is not None
        z = np.cross(A[:, 0], A[:, 1])                   # the null space of A^T
        ts = np.linspace(-3, 3, 20001)
        line = d0 + ts[:, None] * z / np.linalg.norm(z)
        ok = np.all((line >= lo) & (line <= hi), axis=1)
        q = line[ok] @ g + 0.5 * np.einsum("ki,ij,kj->k", line[ok], W, line[ok])
        q_star = g @ sol.d + 0.5 * sol.d @ W @ sol.d
        assert q_star <= q.min() + 1e-9
        np.testing.assert_allclose(A.T @ sol.d, -c, atol=1e-12)
        again = solve_box_qp(W, g, A, c, lo, hi, guess=sol.active)
        np.testing.assert_allclose(again.d, sol.d, atol=1e-12)


def test_box_qp_infeasible_and_closest_step():
    A = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    c = np.array([-5.0, 0.0])                 # needs d_1 + d_2 = 5 within |d| <= 1
    lo, hi = -np.ones(3), np.ones(3)
    assert solve_box_qp(np.eye(3), np.zeros(3), A, c, lo, hi) is None
    d, resid = closest_in_box(A, c, lo, np.array([1.0, 1.0, -1.0]))   # lo == hi on one
    np.testing.assert_allclose(d, [1.0, 1.0, -1.0])
    assert resid == pytest.approx(np.hypot(3.0, 1.0))
    sol = solve_box_qp(np.eye(3), np.array([2.0, 0.0, 0.0]), A, np.array([-1.0, 0.0]),
                       np.array([0.0, -1.0, -1.0]), 2.0 * hi)
    assert sol.active[0] == LOWER and sol.mu[0] > 0 and sol.d[1] == pytest.approx(1.0)


def test_cli_trace_share_json(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "elastica_petsc.cli", "trace", "--config", str(CONFIG),
         "--elements", str(ELEMENTS), "--shape", "circle", "--center", *map(str, CENTER),
         "--radius", str(RADIUS), "--step", "12", "--no-approach", "--share", "min-energy",
         "--min-tension-N", "1", "--json"], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert data["share"] == "min-energy" and data["min_tension_floor_N"] == 1.0
    assert data["all_reached"] and min(data["min_tension_N"]) >= 1.0 - 1e-6
    assert data["closure_cable_length_change_mm"] < 1e-3


def test_api_trace_share_and_bad_input():
    import elastica_petsc as ep
    from elastica_petsc.core.errors import InputError

    arm = load_config(CONFIG)
    pts = paths.circle(CENTER, RADIUS, 7)
    res = ep.trace(arm, pts, min_tension_N=1.0, elements=ELEMENTS)     # implies min-norm
    assert res.all_converged and np.min(res.tensions_N) >= 1.0 - 1e-9
    assert np.max(np.abs(res.cable_lengths_mm[-1] - res.cable_lengths_mm[0])) < 1e-3
    with pytest.raises(InputError, match="sharing"):
        ep.trace(arm, pts, share="max-norm", elements=ELEMENTS)
    with pytest.raises(InputError, match="minimum tension"):
        ep.trace(arm, pts, share="min-norm", min_tension_N=-1.0, elements=ELEMENTS)
