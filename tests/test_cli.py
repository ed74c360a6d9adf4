"""The command line as a user meets it: run as a subprocess (issue 2)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "configs" / "paper.toml"


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=120)


def test_solve_text_summary():
    run = cli("solve", "--tensions", 25.2, 10.8, "--order", "2,1")
    assert run.returncode == 0, run.stderr
    assert "converged: yes" in run.stdout
    assert "147.2" in run.stdout and "472.4" in run.stdout     # Fig. 8 state 1 cable lengths


def test_solve_json_keys_and_units():
    run = cli("solve", "--config", PAPER, "--tensions", 25.2, 10.8, "--order", "1,2", "--json")
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    for key in ("converged", "reason", "iterations", "tensions", "tensions_N", "tip_mm",
                "attachments_mm", "cable_lengths_mm", "strain_energy", "kappa_max"):
        assert key in data
    assert data["converged"] is True
    np.testing.assert_allclose(data["cable_lengths_mm"], [96.2, 454.3], atol=0.5)  # Fig. 8 state 3
    # B/l^2 = 0.2 N m^2 / (0.6 m)^2: p = 25.2 is 14 N
    np.testing.assert_allclose(data["tensions_N"], [14.0, 6.0], rtol=1e-12)


def test_tensions_in_newtons_equal_nondimensional():
    a = json.loads(cli("solve", "--tensions-N", 14.0, 6.0, "--json").stdout)
    b = json.loads(cli("solve", "--tensions", 25.2, 10.8, "--json").stdout)
    np.testing.assert_allclose(a["tip_mm"], b["tip_mm"], atol=1e-9)


@pytest.mark.parametrize("args, message", [
    (["--tensions", -1, 2], "negative"),
    (["--tensions", 1], "expected 2 tensions"),
    (["--tensions", 1, 2, 3], "expected 2 tensions"),
    (["--tensions", 1, 2, "--order", "1,1"], "not a permutation"),
    (["--tensions", 1, 2, "--order", "2,1,3"], "not a permutation"),
    (["--tensions", 1, 2, "--order", "a,b"], "--order"),
    (["--tensions", 1, 2, "--elements", 7], "not on a node"),
    (["--tensions", 1, 2, "--elements", 1], "--elements"),
    (["--tensions", 1, 2, "--config", "missing.toml"], "no such config file"),
    (["--tensions", 1, 2, "--no-such-flag"], "unrecognized argument"),
])
def test_bad_command_lines_one_line_exit_2(args, message):
    run = cli("solve", *args)
    assert run.returncode == 2
    assert message in run.stderr
    assert "Traceback" not in run.stderr
    assert len([l for l in run.stderr.splitlines() if "error" in l]) == 1


GOOD = {"arm": "[arm]\nlength_mm = 600\nbending_stiffness_Nm2 = 0.2\n",
        "tendon": "[[tendon]]\nattach_mm = 600\nroute_mm = [26.1, 51.1]\n"}


@pytest.mark.parametrize("text, message", [
    (GOOD["arm"] + "colour = 1\n" + GOOD["tendon"], "arm.colour: unknown key"),
    (GOOD["arm"] + GOOD["tendon"] + "[extra]\n", "extra: unknown section"),
    ("[arm]\nlength_mm = 600\n" + GOOD["tendon"], "arm.bending_stiffness_Nm2: missing"),
    (GOOD["arm"], "tendon: missing"),
    ("[arm]\nlength_mm = -600\nbending_stiffness_Nm2 = 0.2\n" + GOOD["tendon"],
     "arm.length_mm must be a positive number"),
    ("[arm]\nlength_mm = 0\nbending_stiffness_Nm2 = 0.2\n" + GOOD["tendon"],
     "arm.length_mm must be a positive number"),
    (GOOD["arm"] + "[[tendon]]\nattach_mm = 700\nroute_mm = [0, 50]\n", "tendon[1].attach_mm"),
    (GOOD["arm"] + "[[tendon]]\nattach_mm = 0\nroute_mm = [0, 50]\n", "tendon[1].attach_mm"),
    (GOOD["arm"] + "[[tendon]]\nattach_mm = 300\nroute_mm = [300, 0]\n", "zero length"),
    (GOOD["arm"] + "[[tendon]]\nattach_mm = 300\nroute_mm = [1, 2, 3]\n", "tendon[1].route_mm"),
    ("[arm]\nlength_mm = \"600\"\nbending_stiffness_Nm2 = 0.2\n" + GOOD["tendon"],
     "arm.length_mm: expected float"),
    (GOOD["arm"] + GOOD["tendon"] + "[motor]\nsteps_per_rev = 1.5\n", "motor.steps_per_rev"),
    ("[arm\n", "not valid TOML"),
])
def test_bad_configs_one_line_exit_2(tmp_path, text, message):
    path = tmp_path / "arm.toml"
    path.write_text(text)
    run = cli("solve", "--config", path, "--tensions", 1)
    assert run.returncode == 2, run.stdout
    assert message in run.stderr, run.stderr
    assert "Traceback" not in run.stderr


def test_failed_solve_says_why_exit_1():
    """Tendon 2 alone drags the tip onto r_2 beyond p_2 ~ 23 (issue 2)."""
    run = cli("solve", "--tensions", 0, 30, "--json")
    assert run.returncode == 1
    data = json.loads(run.stdout)
    assert data["converged"] is False
    assert "tendon 2 pulled its attachment point onto its routing point" in data["message"]
    assert "solve failed" in run.stderr


def test_petsc_options_reach_the_solver():
    run = cli("solve", "--tensions", 1, 2, "-eq_snes_monitor")
    assert run.returncode == 0, run.stderr
    assert "SNES Function norm" in run.stdout


@pytest.mark.slow
def test_hdf5_round_trip_units_and_provenance(tmp_path):
    out, png = tmp_path / "state3.h5", tmp_path / "state3.png"
    run = cli("solve", "--tensions", 25.2, 10.8, "--order", "1,2", "--json", "--out", out,
              "--plot", png)
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert png.stat().st_size > 10_000
    with h5py.File(out, "r") as fh:
        assert fh.attrs["kind"] == "equilibrium"
        assert json.loads(fh.attrs["config_json"])["arm"]["length_mm"] == 600.0
        for key in ("petsc_version", "elastica_petsc_version", "command_line", "created_utc"):
            assert fh.attrs[key]
        # UDUNITS/CF units; a non-dimensional quantity has "1", its scale in long_name
        expected_units = {"mesh/s": "mm", "state/theta": "rad", "state/x": "mm",
                          "state/tip": "mm", "state/strain_energy": "1",
                          "tendons/cable_lengths": "mm", "tendons/tensions": "1",
                          "tendons/tensions_N": "N", "tendons/attachments": "mm"}
        for name, units in expected_units.items():
            assert fh[name].attrs["units"] == units
        without_units = []
        fh.visititems(lambda n, o: isinstance(o, h5py.Dataset) and "units" not in o.attrs
                      and without_units.append(n))
        assert without_units == []
        np.testing.assert_allclose(fh["tendons/cable_lengths"][()], data["cable_lengths_mm"],
                                   atol=1e-5)
        np.testing.assert_allclose(fh["state/x"][-1], data["tip_mm"], atol=1e-5)
        assert fh["state/x"].shape == (181, 2)
        assert fh["solver"].attrs["converged"]
        assert fh.attrs["loading_order"] == "1,2"
    # refuse to overwrite; nothing else is left in the folder
    again = cli("solve", "--tensions", 1, 2, "--out", out)
    assert again.returncode == 2 and "--overwrite" in again.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["state3.h5", "state3.png"]


def test_help_lists_commands():
    run = cli("--help")
    assert run.returncode == 0 and "solve" in run.stdout and "PETSc options" in run.stdout


def test_stability_command_json_and_hdf5(tmp_path):
    """Issue 4: both Fig. 8 states stable, asymmetry at round-off, modes in HDF5."""
    out = tmp_path / "stab.h5"
    run = cli("stability", "--tensions", 25.2, 10.8, "--order", "2,1", "--modes", 3, "--json",
              "--out", out)
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert data["stable"] is True and data["negative_eigenvalues"] == 0
    assert len(data["eigenvalues"]) >= 3 and data["eigenvalues"][0] > 0
    assert data["asymmetry"] < 1e-10
    # the raw eigenvalue of K scales like h * lambda (paper Fig. 5b normalisation)
    assert 0.5 < data["lambda_min_raw"] * 180 / data["lambda_min"] < 1.5
    assert data["frequencies_hz"]["load"][0] > 0 and data["max_tracing_speed_mm_s"] > 0
    with h5py.File(out, "r") as fh:
        assert fh.attrs["kind"] == "stability"
        assert fh["stability/modes"].shape[1] == 181
        assert fh["stability/eigenvalues"].attrs["units"] == "1"
        assert "B/l^2" in fh["stability/eigenvalues"].attrs["long_name"]


def test_stability_bad_modes():
    run = cli("stability", "--tensions", 1, 1, "--modes", 0)
    assert run.returncode == 2 and "--modes" in run.stderr
