"""``elastica-petsc friction`` (docs/model.md §27): a load-unload cycle on
configs/guided3.toml with its table, the hysteresis line, --out read back and
--plot, and bad input in one line with exit status 2."""
from __future__ import annotations

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest

import elastica_petsc as ep
from conftest import REPO

GUIDED3 = str(REPO / "configs" / "guided3.toml")


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=120)


@pytest.mark.slow                 # a subprocess that plots and computes two cycles
def test_cycle_table_hysteresis_out_and_plot(tmp_path):
    out, png = tmp_path / "f.h5", tmp_path / "f.png"
    run = cli("friction", "--config", GUIDED3, "--mu", 0.3, "--peak-N", 22, "--steps", 4,
              "--elements", 48, "--out", out, "--plot", png)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert len(lines) == 1 + 9 + 1                       # header, 2 x 4 + 1 rows, hysteresis
    assert lines[1].split()[0] == "0.000" and lines[5].split()[0] == "22.000"
    assert lines[5].split()[4] == "<<<>>>"              # loading: cable 1 slips toward its motor
    assert "=" in lines[6].split()[4]                    # the reversal: a guide sticks
    gap = float(lines[-1].split("up to ")[1].split()[0])
    assert gap > 5.0
    with h5py.File(out, "r") as fh:                      # units and provenance (io/friction.py)
        assert fh.attrs["kind"] == "friction" and "config_json" in fh.attrs
        assert fh["tip_mm"].attrs["units"] == "mm" and fh["modes"].shape == (9, 6)
        np.testing.assert_array_equal(fh["modes"][4, :3], [-1, -1, -1])
    result = ep.read(out)
    assert isinstance(result, ep.FrictionResult) and result.converged
    np.testing.assert_allclose(result.motor_tensions_N[:, 0],
                               [0, 5.5, 11, 16.5, 22, 16.5, 11, 5.5, 0], atol=1e-12)
    assert png.stat().st_size > 10_000


def test_a_history_of_both_motors(tmp_path):
    """--history: the rows of a tension-history CSV (as simulate --history) in order."""
    csv = tmp_path / "h.csv"
    csv.write_text("time_s,tension_1_N,tension_2_N\n0,0,0\n1,10,0\n2,10,8\n")
    run = cli("friction", "--config", GUIDED3, "--mu", 0.3, "--history", csv, "--elements", 48,
              "--json")
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    assert data["motor_tensions_N"] == [[0.0, 0.0], [10.0, 0.0], [10.0, 8.0]]
    assert "largest_gap_mm" not in data and data["converged"]
    assert data["modes"][1][:3] == [-1, -1, -1]          # cable 1 reeled in: slip toward it
    assert 0 in data["modes"][2][:3]                     # cable 2 pulls back: a guide sticks


@pytest.mark.slow                 # seven subprocesses
def test_bad_input_is_one_line_and_status_2():
    cases = ((["--mu", -0.1], "friction coefficient"), (["--mu", 0.1, 0.2], "one per guide"),
             (["--peak-N", 0], "--peak-N"), (["--tendon", 3], "--tendon"),
             (["--cable-stiffness-kN", -1], "--cable-stiffness-kN"))
    for extra, words in cases:
        args = ["--config", GUIDED3, "--mu", 0.1, "--peak-N", 5] + extra      # the last wins
        run = cli("friction", *args)
        assert run.returncode == 2, (args, run.stderr)
        assert run.stderr.count("\n") == 1 and words in run.stderr, run.stderr
    for args, words in ((["friction", "--mu", 0.1, "--peak-N", 5], "guides"),
                        (["solve", "--config", REPO / "configs" / "guided3_friction.toml",
                          "--tensions", 1, 1], "models frictionless guides")):
        run = cli(*args)
        assert run.returncode == 2, (args, run.stderr)
        assert run.stderr.count("\n") == 1 and words in run.stderr, run.stderr


@pytest.mark.slow                 # plans a trace first
def test_replay_of_a_traced_schedule(tmp_path):
    """--replay: the motors hold the cable lengths of a `trace --schedule` file.  With
    mu = 0 and inextensible cables the tip follows the plan; elastic cables (EA = 39 kN,
    needed with friction here: the antagonists hold their lengths over one span,
    docs/model.md §27.6) leave it by their stretch, and friction by several times more."""
    plan = cli("trace", "--config", GUIDED3, "--shape", "line", "--center", 250, 100, "--end",
               250, 110, "--step", 2, "--schedule", "plan.csv", "--elements", 48, "--quiet",
               cwd=tmp_path)
    assert plan.returncode == 0, plan.stderr
    deviation = {}
    for mu, elastic in ((0.0, []), (0.0, ["--cable-stiffness-kN", 39]),
                        (0.3, ["--cable-stiffness-kN", 39])):
        run = cli("friction", "--config", GUIDED3, "--mu", mu, "--replay", "plan.csv",
                  "--elements", 48, "--json", *elastic, cwd=tmp_path)
        assert run.returncode == 0, run.stderr
        deviation[mu, bool(elastic)] = json.loads(run.stdout)["plan_deviation_mm"]
    assert deviation[0.0, False] < 1e-6, deviation
    assert deviation[0.3, True] > 3 * deviation[0.0, True] > 0, deviation
