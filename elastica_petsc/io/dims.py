"""Named dimensions for the HDF5 outputs: netCDF-4 style dimension scales.

Every array a writer stores gets one named dimension per axis (``point``,
``tendon``, ``node``, ``element``, ``sample``, ``x``, ``y``, ``row``,
``component``, ...), a dimension scale dataset of that name in the same group
(its values the coordinate: 0, 1, ... unless given, e.g. the lattice's x and
y in mm, tendons numbered from 1, components "x" and "y").  Tools that read
netCDF-4 then see named dimensions instead of ``phony_dim_*``:
``xarray.open_dataset(file, engine="h5netcdf", group="path")`` opens a group
as a Dataset (tests/test_xarray.py).
"""
from __future__ import annotations

import numpy as np

# coordinates every writer shares: tendon numbers and vector components
COMPONENTS = ("x", "y")


def dimension(group, name: str, length: int, values=None, units: str | None = None,
              long_name: str | None = None):
    """The dimension scale ``name`` of ``group``, created on first use with
    ``values`` (default 0..length-1) as its coordinate; a later use must agree
    on the length."""
    import h5py

    if name in group:
        scale = group[name]
        if scale.shape != (length,):
            raise ValueError(f"dimension {name!r} of {group.name} has length {scale.shape}, "
                             f"not {length}")
        return scale
    if values is None:
        values = np.arange(length)
    values = np.asarray(values)
    if values.dtype.kind in "US":
        values = np.array([str(v) for v in values], dtype=h5py.string_dtype("utf-8"))
    scale = group.create_dataset(name, data=values)
    scale.make_scale(name)
    if units is not None:
        scale.attrs["units"] = units
    if long_name is not None:
        scale.attrs["long_name"] = long_name
    return scale


def label(dset, dims, coords: dict | None = None) -> None:
    """Attach the dimension scales ``dims`` (one name per axis of ``dset``),
    created in ``dset``'s group when missing; ``coords`` maps a name to its
    values (and optionally ``(values, units, long_name)``)."""
    if len(dims) != dset.ndim:
        raise ValueError(f"{dset.name}: {dset.ndim} axes but dimensions {dims}")
    coords = coords or {}
    for axis, name in enumerate(dims):
        spec = coords.get(name)
        if spec is None and name == "component":
            spec = list(COMPONENTS[:dset.shape[axis]])
        if spec is None and name == "tendon":
            spec = (np.arange(1, dset.shape[axis] + 1), "1", "tendon number")
        values, units, long_name = spec if isinstance(spec, tuple) else (spec, None, None)
        scale = dimension(dset.parent, name, dset.shape[axis], values, units, long_name)
        dset.dims[axis].attach_scale(scale)
