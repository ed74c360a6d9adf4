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

# the project's unit notation -> (UDUNITS/CF units, what the number means, for long_name)
CF_UNITS = {
    "P l^2/B": ("1", "non-dimensional tension p = P l^2/B"),
    "B/(2l)": ("1", "in units of SE_0 = B/(2l)"),
    "B/l^2": ("1", "in units of B/l^2"),
    "B/l": ("1", "in units of B/l"),
    "mm per (P l^2/B)": ("mm", "mm per unit of p = P l^2/B"),
    "microsteps": ("1", "motor microsteps"),
    "rev": ("1", "spool revolutions"),
}
DIMENSION_TEXT = {"tendon": "tendon number", "component": "vector component (x, y)",
                  "node": "mesh node index (arc length s = node l / N)",
                  "element": "finite element index", "point": "path point index",
                  "row": "schedule row", "sample": "workspace sample index",
                  "iteration": "optimiser iteration", "x": "target x", "y": "target y",
                  "vertex": "polygon vertex", "fold_point": "point where the tip map folds",
                  "event": "event index", "jump": "jump index",
                  "singular_value": "singular value index"}


def cf_attrs(units: str, description: str) -> dict:
    """``units`` as a UDUNITS/CF string and ``long_name`` with the description
    and, for a non-dimensional quantity, what it is measured in."""
    cf, meaning = CF_UNITS.get(units, (units, None))
    return {"units": cf, "long_name": description if meaning is None
            else f"{description} [{meaning}]"}


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
    text = long_name or DIMENSION_TEXT.get(name, f"index along {name}")
    scale.attrs.update({"units": units or "1", "long_name": text, "description": text})
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


def put(group, name: str, data, units: str, description: str, dims=None, coords=None):
    """A dataset with its units (UDUNITS/CF: ``1`` for a non-dimensional one, its
    meaning in ``long_name``), description and, with ``dims``, one named
    dimension per axis (io/dims.py; ``coords`` their values)."""
    data = np.asarray(data)
    if data.dtype.kind == "U":                  # text: variable-length UTF-8 strings
        import h5py
        data = data.astype(object).astype(h5py.string_dtype("utf-8"))
    dset = group.create_dataset(name, data=data)
    dset.attrs.update(cf_attrs(units, description))
    dset.attrs["description"] = description
    if dims is not None:
        label(dset, dims, coords)
    return dset


def fields(group) -> dict:
    """{name: values} of a group's datasets, its dimension scales left out."""
    import h5py

    return {name: d[()] for name, d in group.items()
            if isinstance(d, h5py.Dataset) and not h5py.h5ds.is_scale(d.id)}


def xarray_dataset(variables: dict, coords: dict | None = None, attrs: dict | None = None):
    """An ``xarray.Dataset`` (xarray is optional: InputError without it) from
    {name: (dims, values, units, description)} in the project's units, with the
    same dimension names, CF units and long names as the HDF5 files."""
    from ..core.errors import InputError

    try:
        import xarray as xr
    except ImportError:
        raise InputError("to_xarray needs xarray (Debian: python3-xarray)") from None
    data = {name: (dims, np.asarray(values), {**cf_attrs(units, text), "description": text})
            for name, (dims, values, units, text) in variables.items()}
    lengths = {d: np.shape(v[1])[k] for v in variables.values() for k, d in enumerate(v[0])}
    coords = dict(coords or {})
    if "tendon" in lengths and "tendon" not in coords:
        coords["tendon"] = ("tendon", np.arange(1, lengths["tendon"] + 1),
                            {"long_name": DIMENSION_TEXT["tendon"], "units": "1"})
    if "component" in lengths and "component" not in coords:
        coords["component"] = ("component", list(COMPONENTS[:lengths["component"]]),
                               {"long_name": DIMENSION_TEXT["component"]})
    return xr.Dataset(data, coords=coords, attrs=attrs or {})
