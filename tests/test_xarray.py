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
