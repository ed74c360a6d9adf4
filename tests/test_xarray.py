"""Named dimensions in the HDF5 outputs (io/dims.py): tools that read netCDF-4
(xarray with the h5netcdf engine, from Debian's python3-xarray and
python3-h5netcdf) see named dimensions and coordinates, not phony_dim_*."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from elastica_petsc.io.dims import label

xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")


def test_label_gives_named_dimensions_shared_by_name(tmp_path):
    path = tmp_path / "d.h5"
    with h5py.File(path, "w") as fh:
        g = fh.create_group("path")
        label(g.create_dataset("tip", data=np.zeros((4, 2))), ("point", "component"))
        label(g.create_dataset("tensions", data=np.ones((4, 3))), ("point", "tendon"))
        grid = fh.create_group("grid")
        label(grid.create_dataset("W0", data=np.zeros((2, 3), bool)), ("y", "x"),
              coords={"x": (np.array([0.0, 10.0, 20.0]), "mm", "target x"),
                      "y": (np.array([0.0, 10.0]), "mm", "target y")})
        with pytest.raises(ValueError, match="length"):       # "point" has length 4 here
            label(g.create_dataset("bad", data=np.zeros(5)), ("point",))
        del g["bad"]
    ds = xr.open_dataset(path, engine="h5netcdf", group="path")
    assert ds["tip"].dims == ("point", "component") and ds["tensions"].dims == ("point", "tendon")
    assert list(ds["component"].values) == ["x", "y"] and list(ds["tendon"].values) == [1, 2, 3]
    grid = xr.open_dataset(path, engine="h5netcdf", group="grid")
    assert grid["W0"].dims == ("y", "x") and grid["x"].attrs["units"] == "mm"
    np.testing.assert_array_equal(grid["x"].values, [0.0, 10.0, 20.0])


def run_cli(tmp_path, *args):
    import os
    import subprocess
    import sys

    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *args, "--elements", "30",
                          "--quiet"], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr


@pytest.mark.slow
def test_workspace_file_opens_as_named_y_x_grids_with_cf_units(tmp_path):
    run_cli(tmp_path, "workspace", "--spacing", "100", "--box", "300", "500", "100", "300",
            "--out", "w.h5")
    ds = xr.open_dataset(tmp_path / "w.h5", engine="h5netcdf", group="map")
    for name in ("W0", "WS", "status", "kappa_max", "strain_energy"):
        assert ds[name].dims == ("y", "x"), name
    assert ds["tensions_N"].dims == ("y", "x", "tendon") and ds["tensions_N"].attrs["units"] == "N"
    # non-dimensional quantities: CF units "1", the meaning in long_name
    assert ds["tensions"].attrs["units"] == "1" and "P l^2/B" in ds["tensions"].attrs["long_name"]
    assert ds["strain_energy"].attrs["units"] == "1"
    assert "SE_0" in ds["strain_energy"].attrs["long_name"]
    np.testing.assert_allclose(ds["x"].values, [300.0, 400.0, 500.0])
    np.testing.assert_allclose(ds["y"].values, [100.0, 200.0, 300.0])
    assert ds["x"].attrs["units"] == "mm"
    # the grid holds the same samples as the flat arrays
    flat = xr.open_dataset(tmp_path / "w.h5", engine="h5netcdf", group="samples")
    masks = xr.open_dataset(tmp_path / "w.h5", engine="h5netcdf", group="masks")
    assert int(ds["W0"].sum()) == int(masks["W0"].sum())
    reached = masks["W0"].values
    tips = flat["target"].values[reached]
    for (x, y), P in zip(tips, flat["tensions_N"].values[reached]):
        np.testing.assert_array_equal(ds["tensions_N"].sel(x=x, y=y).values, P)


@pytest.mark.slow
def test_trace_file_opens_with_point_and_tendon_dimensions(tmp_path):
    run_cli(tmp_path, "trace", "--shape", "line", "--center", "420", "200", "--end", "440",
            "220", "--step", "10", "--speed-mm-s", "5", "--out", "t.h5")
    path = xr.open_dataset(tmp_path / "t.h5", engine="h5netcdf", group="path")
    assert path["tensions_N"].dims == ("point", "tendon")
    assert path["tip"].dims == ("point", "component")
    assert path["tip_sensitivity"].dims == ("point", "tendon", "component")
    assert path["theta"].dims == ("point", "node")
    sched = xr.open_dataset(tmp_path / "t.h5", engine="h5netcdf", group="schedule")
    assert sched["steps"].dims == ("row", "tendon")
    assert set(sched["phase"].values) == {"approach", "path"}       # variable-length UTF-8
    assert sched["time"].attrs["units"] == "s" and sched["revolutions"].attrs["units"] == "1"


@pytest.mark.slow
def test_results_to_xarray_as_in_the_files(tmp_path):
    """``to_xarray()`` of a traced path and of a workspace map: the same dimension
    names, values and CF units as the files."""
    from elastica_petsc.core.model import load_config
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.studies.trace import densify, line, trace
    from elastica_petsc.studies.workspace import read_map

    with TipController(load_config(), n_elements=30) as controller:
        traced = trace(controller, densify(line((420.0, 200.0), (440.0, 220.0)), 10.0))
    ds = traced.to_xarray()
    assert ds["tensions_N"].dims == ("point", "tendon") and ds["tip"].dims == ("point", "component")
    np.testing.assert_array_equal(ds["tensions_N"].values, traced.tensions_N)
    assert ds["tensions"].attrs["units"] == "1" and "P l^2/B" in ds["tensions"].attrs["long_name"]
    run_cli(tmp_path, "workspace", "--spacing", "100", "--box", "300", "500", "100", "300",
            "--out", "w.h5")
    mapped = read_map(tmp_path / "w.h5").to_xarray()
    stored = xr.open_dataset(tmp_path / "w.h5", engine="h5netcdf", group="samples")
    assert mapped["tensions_N"].dims == stored["tensions_N"].dims == ("sample", "tendon")
    np.testing.assert_array_equal(mapped["tensions_N"].values, stored["tensions_N"].values)
    assert mapped["lambda_min"].attrs["units"] == stored["lambda_min"].attrs["units"] == "1"
    assert int(mapped["W0"].sum()) == int((mapped["status"] == 1).sum())
