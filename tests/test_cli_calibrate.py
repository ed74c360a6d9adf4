"""``elastica-petsc calibrate`` as a user meets it (issue 23): outputs, and bad
input reported in one line with exit status 2 and nothing written."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from elastica_petsc.core.calibration_data import write_calibration_csv
from elastica_petsc.core.model import load_config

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "paper.toml"
GOOD_HEADER = "tension_1_N,tension_2_N,tip_x_mm,tip_y_mm"


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "calibrate",
                           *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=120)


@pytest.fixture(scope="module")
def data_csv(tmp_path_factory):
    """12 synthetic rows of the paper arm with tendon 1's routing point moved 3 mm."""
    import dataclasses

    from elastica_petsc.core.calibration_params import ParameterModel
    from elastica_petsc.core.model import Arm
    from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize

    arm = dataclasses.replace(Arm.paper(), elements=30)
    rng = np.random.default_rng(5)
    P = np.column_stack((rng.uniform(1, 9, 12), rng.uniform(0.5, 5, 12)))
    model = ParameterModel(arm, ["tendon1.route"])
    truth = model.start() + [3.0, -2.0]
    data = synthesize(arm, ["tendon1.route"], truth, command_rows(arm, P, "tension"),
                      noise_mm=0.2, seed=1, marker_s_mm=(300.0,))
    path = tmp_path_factory.mktemp("calib") / "data.csv"
    write_calibration_csv(path, data, ["SYNTHETIC: paper arm, tendon1.route + (3, -2) mm"])
    return path, truth


@pytest.mark.slow
def test_calibrate_writes_loadable_toml_h5_plot_json(data_csv, tmp_path):
    path, truth = data_csv
    out, h5, png = tmp_path / "fit.toml", tmp_path / "fit.h5", tmp_path / "fit.png"
    run = cli("--config", CONFIG, "--elements", 30, "--data", path, "--vary", "tendon1.route",
              "--folds", 2, "--out", out, "--h5", h5, "--plot", png, "--json", "--quiet",
              cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    values = [p["value"] for p in summary["parameters"]]
    sigmas = [p["sigma"] for p in summary["parameters"]]
    assert np.all(np.abs(np.array(values) - truth) < 4 * np.array(sigmas))
    assert summary["cross_validation"]["folds"] == 2
    arm = load_config(out)                            # ready for every other command
    np.testing.assert_allclose(arm.tendons[0].route_mm, values, rtol=1e-7)
    import h5py
    with h5py.File(h5) as fh:
        assert fh["rows/measured_mm"].attrs["units"] == "mm"
        assert fh.attrs["kind"] == "calibration"
        assert fh["parameters/sigma"].shape == (2,)
    assert png.stat().st_size > 10_000


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="needs mpiexec")
def test_rows_over_two_ranks_give_the_same_fit(data_csv, tmp_path):
    path, _ = data_csv
    from mpi_env import mpi_env
    env = mpi_env()
    runs = []
    for launch in ([], ["mpiexec", "-n", "2"]):
        done = subprocess.run(launch + [sys.executable, "-m", "elastica_petsc.cli", "calibrate",
                                        "--elements", "30", "--data", str(path), "--vary",
                                        "tendon1.route", "--folds", "0", "--json", "--quiet"],
                              capture_output=True, text=True, timeout=300, env=env,
                              cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        runs.append(json.loads(done.stdout))
    assert [r["ranks"] for r in runs] == [1, 2]
    for a, b in zip(runs[0]["parameters"], runs[1]["parameters"]):
        assert abs(a["value"] - b["value"]) < 1e-9 and abs(a["sigma"] - b["sigma"]) < 1e-9


def _csv(tmp_path, text):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    return path


BAD = {
    "missing column": (GOOD_HEADER.replace(",tip_y_mm", "") + "\n1,2,500\n" * 4,
                       "missing column tip_y_mm"),
    "tendon the arm lacks": (GOOD_HEADER + ",tension_3_N\n1,2,500,10,1\n",
                             "column tension_3_N: the arm has tendons 1..2"),
    "NaN": (GOOD_HEADER + "\n1,2,500,10\n1,nan,500,10\n", "line 3, column tension_2_N"),
    "text": (GOOD_HEADER + "\n1,2,500,10\n1,two,500,10\n", "not a number: 'two'"),
    "too few rows": (GOOD_HEADER + "\n1,2,500,10\n", "need more coordinates than parameters"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_data_one_line_exit_2_nothing_written(case, tmp_path):
    text, message = BAD[case]
    out = tmp_path / "fit.toml"
    run = cli("--data", _csv(tmp_path, text), "--vary", "bending_stiffness", "tendon1.route",
              "--out", out, "--h5", tmp_path / "fit.h5", cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("elastica-petsc: error:"), run.stderr
    assert message in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv"]


@pytest.mark.parametrize("args, message", [
    (["--vary", "stiffness"], "unknown parameter"),
    (["--vary", "tendon3.route"], "the arm has tendons 1..2"),
    (["--vary", "tendon1.route", "--bounds", "tendon1.route.x=50:60"],
     "excludes the start value 46.3"),
])
def test_bad_parameters_exit_2(args, message, data_csv, tmp_path):
    path, _ = data_csv
    run = cli("--data", path, *args, "--out", tmp_path / "fit.toml", cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    assert message in run.stderr and len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert not (tmp_path / "fit.toml").exists()


def test_a_schedule_csv_reads_with_input_steps(tmp_path):
    """The schedule CSV of `trace --schedule` carries all three input groups: --input
    picks one; its other columns are ignored; without --input a row is ambiguous."""
    from elastica_petsc.core.calibration_data import DataError, read_calibration_csv
    from elastica_petsc.core.model import Motor
    from elastica_petsc.core.schedule import motor_schedule

    lengths = [[150.0, 560.0], [148.0, 555.0], [146.5, 552.0]]
    sched = motor_schedule(lengths, Motor(), tips_mm=[[590, -50], [580, -80], [570, -100]],
                           tensions_N=[[1, 1], [2, 1], [3, 1]])
    path = sched.write_csv(tmp_path / "s.csv")
    data = read_calibration_csv(path, 2, kind="steps")
    assert list(data.kinds) == ["steps"] * 3
    np.testing.assert_array_equal(data.inputs, sched.steps)
    np.testing.assert_allclose(data.tips_mm, [[590, -50], [580, -80], [570, -100]])
    with pytest.raises(DataError, match="inputs of several kinds"):
        read_calibration_csv(path, 2)


def test_heavy_arm_with_clamp_angle_is_refused_naming_the_flag(data_csv, tmp_path):
    """Guided and weighted arms calibrate (tests/test_calibrate_guided.py); turning the
    clamp of an arm with weight is refused by name, the CLI naming its flag."""
    path, _ = data_csv
    run = cli("--config", ROOT / "configs" / "paper_vertical.toml", "--data", path,
              "--vary", "clamp.angle", "--out", tmp_path / "fit.toml", cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    assert "--vary 'clamp.angle': not supported for an arm with weight" in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "fit.toml").exists()
