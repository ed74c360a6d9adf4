"""Output of ``elastica-petsc design``: the designed arm as a TOML config
(readable by ``--config``), with the optimisation history in its header."""
from __future__ import annotations

from pathlib import Path

from ..core.config import SCHEMA, arm_to_dict
from .hdf5 import check_output_path


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):                                 # a guide: an inline table
        return "{" + ", ".join(f"{k} = {_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def config_toml(arm, header_lines=()) -> str:
    """TOML text of an Arm in the schema of :mod:`elastica_petsc.core.config`
    (keys whose value is None are left out: their defaults apply)."""
    data = arm_to_dict(arm)
    lines = [f"# {line}" for line in header_lines]
    for section in ("arm", "motor", "limits"):
        lines += ["", f"[{section}]"]
        lines += [f"{k} = {_value(data[section][k])}" for k in SCHEMA[section]
                  if data[section].get(k) is not None]
    for tendon in data["tendon"]:
        lines += ["", "[[tendon]]"]
        lines += [f"{k} = {_value(tendon[k])}" for k in SCHEMA["tendon"] if k in tendon]
    return "\n".join(lines) + "\n"


def write_config(path, arm, header_lines=(), overwrite: bool = False) -> Path:
    """Write ``arm`` as TOML to ``path`` (refuses to clobber unless ``overwrite``)."""
    from .exclusive import replace_file

    path = check_output_path(path, overwrite)
    replace_file(path, config_toml(arm, header_lines).encode())
    return path


def write_sweep(path, results, attrs: dict, timing: dict):
    """One checkpoint of ``design --sweep`` written in full (aside, renamed into
    place; returns its :class:`~.inplace.Layout` for in-place checkpoints)::

        grid/points      (D, k)  mm   the designs (one row each; axes in grid/names)
        grid/names       (k,)         the swept parameters, e.g. tendon2.route.y
        grid/axis_j      (m_j,)  mm   the values along axis j
        grid/chunk_done  (D,)         design evaluated and stored (resume)
        samples/FIELD    (D, ...)     per design: area [mm^2], area_converged,
                                      cables_clear, det_sign_changes, path_misfit
                                      [mm^2], path_reached, error, seconds, done
    Root attributes: provenance, ``complete``, ``tension_max`` inside
    ``grid_json``; group ``timing``: ranks, seconds_wall, seconds_io."""
    import json

    import numpy as np

    from .hdf5 import put, write_attrs
    from .inplace import FullWrite
    from .workspace import write_timing

    grid = results.grid
    with FullWrite(path) as full:
        fh = full.file
        write_attrs(fh, attrs)
        fh.attrs["complete"] = bool(results.chunk_done.all())
        full.mark(fh, "samples_done", results.samples_done, "i8")
        fh.attrs["samples_total"] = grid.size
        g = fh.create_group("grid")
        axes = json.loads(attrs["grid_json"])["axes"]
        names = np.array([a["name"] for a in axes], dtype=str)
        coords = {"axis": (names, "1", "swept parameter"),
                  "design": (None, "1", "design index (a row of grid/points)")}
        put(g, "points", grid.points, "mm", "the designs, one per row (columns: grid/names)",
            ("design", "axis"), coords)
        put(g, "names", names, "1", "swept parameters", ("axis",), coords)
        for j, a in enumerate(axes):
            put(g, f"axis_{j}", np.array(a["values"]), "mm", f"values of {a['name']}",
                (f"value_{j}",), {f"value_{j}": (None, "1", f"index along {a['name']}")})
        put(g, "chunk_done", results.chunk_done, "1", "design evaluated and stored", ("chunk",))
        samples = fh.create_group("samples")
        done = np.zeros(grid.size, bool)
        for c in np.flatnonzero(results.chunk_done):
            done[grid.chunks[c]] = True
        put(samples, "done", done, "1", "design evaluated and stored", ("design",), coords)
        for name, (_, _, units, description) in results.schema.items():
            put(samples, name, results.data[name], units, description, ("design",), coords)
        write_timing(full, fh.create_group("timing"), timing)
    return full.layout
