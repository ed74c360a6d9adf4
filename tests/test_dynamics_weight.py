"""The arm in motion under its weight and a tip mass (issue 22, docs/model.md §16.4, §16.5):
the preconditioner's weight stiffness, the hanging equilibrium as a fixed point, its
vibration against SLEPc and the energy with the weight's potential."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from elastica_petsc.core.drive import TensionDrive
from elastica_petsc.core.dynamics import Inertia
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import Arm
from elastica_petsc.solvers.dynamics import FORCE, DynamicsSolver, _Principal
from elastica_petsc.solvers.equilibrium import solve_equilibrium
from elastica_petsc.solvers.stability import StabilitySolver
from elastica_petsc.studies.simulate import simulate

TENSIONS_N = [2.0, 4.0]


@pytest.fixture(scope="module")
def arm():
    """configs/paper_vertical.toml (gravity -9.81 m/s^2 across the arm) with a 20 g tip mass."""
    from importlib.resources import files

    vertical = Arm.from_toml(files("elastica_petsc") / "configs" / "paper_vertical.toml")
    return dataclasses.replace(vertical, tip_mass_kg=0.02)


def _tip_mass(arm):
    return arm.tip_mass_kg / (arm.mass_per_length_kg_m * arm.length_mm * 1e-3)


def _hanging(arm, N):
    disc = Discretisation.from_arm(arm, N)
    eq = solve_equilibrium(disc, arm.tensions_from_N(TENSIONS_N))
    assert eq.converged
    return disc, eq


def test_principal_pc_carries_the_weights_stiffness(arm):
    """At rest (no acceleration, no velocity) the PC is the exact inverse of the Jacobian:
    the weight's stiffness (h/4) t_e . G_e is in T (§11.5); without it the PC is off by
    7e-3 at small shifts (a Newton contraction that slow)."""
    disc, eq = _hanging(arm, 30)
    errors = {}
    for with_weight in (True, False):
        sim = DynamicsSolver(disc, Inertia.build(disc, tip_mass=_tip_mass(arm)))
        if not with_weight:
            sim.weight = np.zeros_like(sim.weight)
        sim.modes, sim.drive = np.full(2, FORCE), TensionDrive.constant(eq.p)
        sim.pc_ctx = _Principal(sim)
        rng = np.random.default_rng(3)
        U = np.concatenate((eq.theta[1:] + 1e-2 * rng.standard_normal(30), np.zeros(2)))
        V, A = np.concatenate((np.zeros(30), eq.p)), np.zeros(32)
        sv, sa = 1e-3, 1e-3
        sim._factor(U, V, sv, sa)
        x, e = rng.standard_normal(32), 1e-6
        Jx = (sim.residual(0.3, U + e * x, V + sv * e * x, A + sa * e * x)
              - sim.residual(0.3, U - e * x, V - sv * e * x, A - sa * e * x)) / (2 * e)
        errors[with_weight] = np.linalg.norm(sim.pc_ctx.apply_fn(Jx) - x) / np.linalg.norm(x)
    assert errors[True] < 1e-6 and errors[False] > 1e-3, errors


@pytest.mark.parametrize("tensions_N", [TENSIONS_N, [0.0, 0.0]])
def test_hanging_equilibrium_is_a_fixed_point(arm, tensions_N):
    """Released at rest from its static equilibrium under its weight and the tensions (at
    zero tension: the arm sagging under its weight, §11.5), the arm stays there: the
    dynamics' residual carries the same weight as the static model."""
    r = simulate(arm, elements=30, initial_tensions_N=tensions_N, tensions_N=tensions_N,
                 duration_s=3.5, steps_per_period=100)
    assert r.completed and r.time_s[-1] * r.f1_hz > 3          # three periods
    motion = np.max(np.linalg.norm(r.tip_mm - r.tip_mm[0], axis=1)) / arm.length_mm
    assert motion < 1e-9, motion
    assert r.tip_mm[0, 1] < -20.0                      # it sags under its weight
    assert r.energy_J.shape[1] == 4 and np.all(r.energy_J[:, 3] < 0)


def _first_mode(disc, arm, eq, nev=1):
    with StabilitySolver(disc) as st:
        return st.frequencies(disc.consistent_state(eq.theta), eq.p, arm, nev=nev,
                              tip_mass_kg=arm.tip_mass_kg)


def test_vibration_about_hanging_equilibrium_matches_slepc(arm):
    """A small first-mode vibration (N = 30, 800 fixed steps per period, load control):
    the frequency from the zero crossings agrees with SLEPc's `frequencies` to 1e-4."""
    from tests.test_dynamics import _crossings

    disc, eq = _hanging(arm, 30)
    fr = _first_mode(disc, arm, eq)
    omega = math.sqrt(fr.omega2[0])
    mode = fr.modes[0]
    sim = DynamicsSolver(disc, Inertia.build(disc, tip_mass=_tip_mass(arm)),
                         dt0=2 * math.pi / omega / 800, adaptive=False)
    tr = sim.run(eq.theta + 1e-4 * mode, np.zeros(30), eq.p, TensionDrive.constant(eq.p), None,
                 2 * 2 * math.pi / omega)
    k = int(np.argmax(np.abs(mode)))
    q = np.array([th[k] for th in tr.theta]) - eq.theta[k]
    qd = np.array([w[k - 1] for w in tr.omega])
    measured = math.pi / np.mean(np.diff(_crossings(np.array(tr.time), q, qd)))
    assert tr.completed and abs(measured / omega - 1) < 1e-4, (measured, omega)


def test_energy_with_weight_conserved_without_damping(arm):
    """No damping, rho_inf = 1, 5 periods of a two-mode vibration about the hanging
    equilibrium (N = 24): kinetic + strain - work + the weight's potential stays within
    1e-6 of the vibration's energy (the potential above the equilibrium's) at 400 steps per
    first period, and the error is the midpoint rule's O(dt^2) (bounded, not a drift): 4
    times larger at 200 steps (1.0e-6 there; 3e-10 about the straight unweighted arm,
    whose potential has no cubic term)."""
    disc, eq = _hanging(arm, 24)
    fr = _first_mode(disc, arm, eq, nev=2)
    period = 2 * math.pi / math.sqrt(fr.omega2[0])
    start = eq.theta + 1e-3 * fr.modes[0] + 2e-4 * fr.modes[1]
    # the potential of §11.5 at the start less at rest (tensions held: p . L is theirs)
    vibration = disc.potential(start, eq.p) - disc.potential(eq.theta, eq.p)
    errors = []
    for steps in (200, 400):
        sim = DynamicsSolver(disc, Inertia.build(disc, tip_mass=_tip_mass(arm)),
                             dt0=period / steps, adaptive=False)
        tr = sim.run(start, np.zeros(24), eq.p, TensionDrive.constant(eq.p), None, 5 * period)
        E = (np.array(tr.kinetic) + np.array(tr.strain) - np.array(tr.work)
             + np.array(tr.gravity))
        assert tr.completed
        errors.append(np.max(np.abs(E - E[0])) / vibration)
    assert errors[1] < 1e-6 and errors[0] / errors[1] > 3.5, errors


def test_weighted_motion_residual_is_force_plus_static_residual(arm):
    """The compiled residual of the cables plus the weight's rows equals the inertial force
    plus §11's static residual (core/guided.py) at a bent, moving state with tensions."""
    disc, _ = _hanging(arm, 30)
    rng = np.random.default_rng(4)
    theta = np.concatenate(([0.0], np.cumsum(0.05 * rng.standard_normal(30))))
    v, a, p = rng.standard_normal(30), rng.standard_normal(30), np.array([2.0, 5.0])
    inert = Inertia.build(disc, tip_mass=_tip_mass(arm), rotary=0.01, damping_ratio=0.1)
    expected = inert.force(theta, v, a) + disc.residual(disc.consistent_state(theta), p)[:30]
    np.testing.assert_allclose(inert.residual(theta, v, a, p), expected, rtol=1e-12,
                               atol=1e-12 * np.abs(expected).max())


def test_cli_simulates_a_vertical_arm(tmp_path):
    """`simulate` on configs/paper_vertical.toml (accepted since §34): released from 1 N on
    cable 2 the arm swings under its weight; energy_J's columns are labelled."""
    import subprocess
    import sys
    from importlib.resources import files

    import h5py

    config = files("elastica_petsc") / "configs" / "paper_vertical.toml"
    r = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "simulate", "--config",
                        str(config), "--elements", "30", "--initial-tensions-N", "0", "1",
                        "--tensions-N", "0", "0", "--duration", "0.5", "--out", "v.h5"],
                       capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "v.h5") as fh:
        labels = [x.decode() for x in fh["energy_J"].dims[1][0][:]]
        gravity = fh["energy_J"][:, 3]
    assert labels == ["kinetic", "strain", "work", "gravity"]
    assert np.ptp(gravity) > 1e-3          # J: the tip falls by centimetres
