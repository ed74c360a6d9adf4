"""Named dimensions (HDF5 dimension scales, io/dims.py) in the replay, boundary,
design-sweep and calibration files (issue 26): xarray opens each group with
named dims instead of phony_dim_*."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")

ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")


def run_cli(tmp_path, *args):
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *map(str, args),
                          "--quiet"], cwd=tmp_path, env=ENV, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr


def no_phony(ds):
    assert not [d for d in ds.dims if str(d).startswith("phony_dim")], ds.dims


@pytest.mark.slow
def test_replay_file_has_named_dimensions(tmp_path):
    run_cli(tmp_path, "trace", "--shape", "line", "--center", "420", "200", "--end", "440",
            "220", "--step", "10", "--elements", "30", "--out", "t.h5")
    run_cli(tmp_path, "replay", "t.h5", "--out", "r.h5")
    planned = xr.open_dataset(tmp_path / "r.h5", engine="h5netcdf", group="planned")
    assert planned["cable_lengths"].dims == ("point", "tendon")
    replay = xr.open_dataset(tmp_path / "r.h5", engine="h5netcdf", group="replay")
    assert replay["tip"].dims == ("point", "component") and replay["theta"].dims[0] == "point"
    assert replay["tensions_N"].attrs["units"] == "N"
    for group in ("planned", "replay", "jumps", "instabilities"):
        no_phony(xr.open_dataset(tmp_path / "r.h5", engine="h5netcdf", group=group))


@pytest.mark.slow
def test_boundary_file_has_named_dimensions(tmp_path):
    run_cli(tmp_path, "boundary", "--elements", "30", "--no-restricted", "--out", "b.h5")
    w0 = xr.open_dataset(tmp_path / "b.h5", engine="h5netcdf", group="W0")
    assert w0["polygon"].dims == ("vertex", "component") and w0["polygon"].attrs["units"] == "mm"
    nodes = xr.open_dataset(tmp_path / "b.h5", engine="h5netcdf", group="W0/nodes")
    assert nodes["tensions_N"].dims == ("node", "tendon")
    no_phony(xr.open_dataset(tmp_path / "b.h5", engine="h5netcdf"))
    from elastica_petsc.io.boundary import read_boundary
    assert read_boundary(tmp_path / "b.h5")["regions"]["W0"]["polygon"].shape[1] == 2


def test_sweep_file_has_named_dimensions(tmp_path):
    run_cli(tmp_path, "design", "--sweep", "tendon2.route.y=40:50:10", "--elements", "30",
            "--tension-max-N", "3", "--out", "s.h5")
    grid = xr.open_dataset(tmp_path / "s.h5", engine="h5netcdf", group="grid")
    assert grid["points"].dims == ("design", "axis")
    assert list(grid["axis"].values) == ["tendon2.route.y"]
    samples = xr.open_dataset(tmp_path / "s.h5", engine="h5netcdf", group="samples")
    assert samples["area"].dims == ("design",) and samples["area"].attrs["units"] == "mm^2"
    assert samples.sizes["design"] == 2


def test_calibration_file_has_named_dimensions(tmp_path):
    import dataclasses

    from elastica_petsc.core.calibration_data import write_calibration_csv
    from elastica_petsc.core.calibration_params import ParameterModel
    from elastica_petsc.core.model import Arm
    from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize

    arm = dataclasses.replace(Arm.paper(), elements=30)
    rng = np.random.default_rng(5)
    P = np.column_stack((rng.uniform(1, 9, 6), rng.uniform(0.5, 5, 6)))
    truth = ParameterModel(arm, ["tendon1.route"]).start() + [2.0, -1.0]
    data = synthesize(arm, ["tendon1.route"], truth, command_rows(arm, P, "tension"),
                      noise_mm=0.1, marker_s_mm=(300.0,))
    write_calibration_csv(tmp_path / "d.csv", data, ["SYNTHETIC"])
    run_cli(tmp_path, "calibrate", "--elements", "30", "--data", "d.csv", "--vary",
            "tendon1.route", "--folds", "0", "--h5", "c.h5")
    params = xr.open_dataset(tmp_path / "c.h5", engine="h5netcdf", group="parameters")
    assert params["value"].dims == ("parameter",)
    assert list(params["parameter"].values) == ["tendon1.route.x", "tendon1.route.y"]
    assert params["covariance"].dims == ("parameter", "parameter_j")
    rows = xr.open_dataset(tmp_path / "c.h5", engine="h5netcdf", group="rows")
    assert rows["measured_mm"].dims == ("row", "measured_point", "component")
    assert rows["inputs"].dims == ("row", "tendon") and rows.sizes["row"] == 6
    assert list(rows["kind"].values) == ["tension"] * 6
