"""The HDF5 layout of a workspace map (``workspace --out``, paper Figs. 4-5) and
what the chunk engine (:mod:`elastica_petsc.studies.chunks`) needs of any
chunked file (also ``design --sweep``'s, io/design.py): the root attributes a
resume must match, the samples read back, the provenance of resumed runs.

Layout: root attributes (provenance, ``mode``, ``sampler``, ``share``,
``min_tension_N``, ``config_json``, ``grid_json``, ``complete``, ...);
``grid/`` (points, chunk_order, chunk_bounds, chunk_done, lattice index and
axes); ``samples/`` (one dataset per field of
:func:`~elastica_petsc.studies.workspace.schema.fields`, and ``done``);
``masks/`` (W0, WY, WS, WE, WP, WC and the limits as attributes);
``timing`` (attributes).  Units are in each dataset's ``units`` attribute.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..core import jsontext
from ..core.errors import InputError

# the sampler attribute of a file (part of what a resume must match); files
# written before it existed were made by the local sampler (targets) or by
# forward solves (tensions)
SAMPLERS = {"targets": ("global-search", "boundary-fill", "local"), "tensions": ("forward",),
            "design-sweep": ("design-sweep",)}

# what must be equal for a resume: everything that changes a sample's result
GRID_ATTRS = ("mode", "config_json", "elements", "grid_json", "petsc_options",
              "elastica_petsc_version", "sampler", "share", "min_tension_N")
OPTIONAL_FIELDS = ("strategy", "shared")   # absent from files written before the global
#                                            search / before tension sharing
# attributes of files written before they existed (and of other studies' files)
ATTR_DEFAULTS = {"share": "none", "min_tension_N": 0.0}


def share_of(attrs) -> tuple[str, float]:
    """(share, min_tension_N) of a file's root ``attrs``: the tension sharing of a
    target map ('none', 0.0 for files written before sharing existed)."""
    share = attrs.get("share", ATTR_DEFAULTS["share"])
    share = share.decode() if isinstance(share, bytes) else str(share)
    return share, float(attrs.get("min_tension_N", ATTR_DEFAULTS["min_tension_N"]))


def sampler_of(attrs, mode: str) -> str:
    """The ``sampler`` attribute of a file's root ``attrs`` (:data:`SAMPLERS`);
    files written before it existed: the local sampler (the only one then)."""
    stored = attrs.get("sampler")
    if isinstance(stored, bytes):
        stored = stored.decode()
    return str(stored) if stored else SAMPLERS[mode][-1]


def read_samples(fh, results) -> None:
    """Every per-sample field of ``results`` from an open file; the optional ones
    an older file lacks keep their empty values."""
    for name in results.schema:
        if name in OPTIONAL_FIELDS and name not in fh["samples"]:
            continue
        results.data[name][...] = fh["samples"][name][()]
    results.clear_undone()          # rows of chunks not done may hold an unfinished update


def lattice_index(grid) -> tuple[np.ndarray, list[np.ndarray]]:
    """Integer lattice coordinates (S, d) of the samples along each coordinate
    of ``grid.points`` (targets: x then y; tensions: p_1, p_2, ...) and the
    lattice axes, so a 2-D map is ``A[index[:, 1], index[:, 0]] = field``."""
    origin = grid.points.min(axis=0)
    spacing = float(grid.meta["spacing"])
    index = np.rint((grid.points - origin) / spacing).astype(np.int64)
    axes = [origin[d] + spacing * np.arange(index[:, d].max() + 1) for d in range(index.shape[1])]
    return index, axes


POINT_FIELDS = ("target", "tip")        # per sample a point [x, y]; other vectors: per tendon


def sample_dims(name: str, shape) -> tuple[str, ...]:
    """Named dimensions of a per-sample field beyond ``sample``: (), (component,)
    for a point in the plane, (tendon,) for one value per tendon."""
    if shape == ():
        return ()
    return ("component",) if name in POINT_FIELDS else ("tendon",)


MAP_FIELDS = ("status", "tip_error", "tensions", "tensions_N", "cable_lengths", "kappa_max",
              "lambda_min", "strain_energy")


def write_map_grids(group, results, index, axes, limits: dict, descriptions: dict) -> None:
    """The map of targets as (y, x) grids with coordinate arrays x and y [mm]
    (``map/``): the masks, the status code and the fields of MAP_FIELDS, NaN
    (status -1, masks false) at lattice points outside the sampled region."""
    from .hdf5 import put

    coords = {"x": (axes[0], "mm", "target x"), "y": (axes[1], "mm", "target y")}
    shape = (len(axes[1]), len(axes[0]))
    rows, cols = index[:, 1], index[:, 0]

    def grid(values, fill):
        values = np.asarray(values)
        out = np.full(shape + values.shape[1:], fill, dtype=values.dtype)
        out[rows, cols] = values
        return out

    for name, mask in results.masks(limits).items():
        put(group, name, grid(mask, False), "1", descriptions[name], ("y", "x"), coords)
    for name in MAP_FIELDS:
        shape_k, _, units, description = results.schema[name]
        values = results.data[name]
        fill = -1 if values.dtype.kind in "iu" else np.nan
        put(group, name, grid(values, fill), units,
            description + " (on the lattice; outside the region: " + str(fill) + ")",
            ("y", "x") + sample_dims(name, shape_k), coords)


def write_results(path: Path, results, attrs: dict, limits: dict, timing: dict):
    """Write the whole file of a workspace map's ``results``
    (:class:`~elastica_petsc.studies.workspace.schema.Results`) aside and rename
    it into place (always valid); returns its :class:`~.inplace.Layout`, with
    which later checkpoints write only new rows (:func:`new_map_rows`)."""
    from .hdf5 import put, write_attrs
    from .inplace import FullWrite

    with FullWrite(path) as full:
        fh = full.file
        write_attrs(fh, attrs)
        fh.attrs["complete"] = bool(results.chunk_done.all())
        full.mark(fh, "samples_done", results.samples_done, "i8")
        fh.attrs["samples_total"] = results.grid.size
        targets = results.grid.mode == "targets"
        coordinate = "component" if targets else "tendon"      # of a sample point
        grid = fh.create_group("grid")
        put(grid, "points", results.grid.points, "mm" if targets else "P l^2/B",
            "sample points: targets (mm) or tensions (P l^2/B)", ("sample", coordinate))
        bounds = np.cumsum([0] + [len(c) for c in results.grid.chunks])
        put(grid, "chunk_order", np.concatenate(results.grid.chunks), "1",
            "sample indices in chunk order; chunk c is chunk_order[chunk_bounds[c]:chunk_bounds[c+1]]",
            ("sample",))
        put(grid, "chunk_bounds", bounds, "1", "offsets of the chunks in chunk_order",
            ("chunk_bound",))
        put(grid, "chunk_done", results.chunk_done, "1", "chunk finished and stored", ("chunk",))
        index, axes = lattice_index(results.grid)
        put(grid, "index", index, "1", "lattice indices of each sample along each coordinate of "
            "points: a 2-D map is A[index[:, 1], index[:, 0]] = samples/FIELD",
            ("sample", coordinate))
        for d, axis in enumerate(axes):
            put(grid, f"axis_{d}", axis, "mm" if targets else "P l^2/B",
                f"lattice coordinates along coordinate {d} of points (index[:, {d}])",
                (f"lattice_{d}",))
        samples = fh.create_group("samples")
        done = np.zeros(results.grid.size, bool)
        for c in np.flatnonzero(results.chunk_done):
            done[results.grid.chunks[c]] = True
        put(samples, "done", done, "1", "sample finished and stored", ("sample",))
        for name, (shape, _, units, description) in results.schema.items():
            put(samples, name, results.data[name], units, description,
                ("sample",) + sample_dims(name, shape))
        masks = fh.create_group("masks")
        descriptions = {"W0": "reached with non-negative tensions (Eq. (18))",
                        "WY": "W0 and l*kappa_max below the strain limit (Eq. (19))",
                        "WS": "W0 and stable: lambda_min > 0 (Eq. (20))",
                        "WE": "W0 and strain energy below SE_max (Eq. (21))",
                        "WP": "W0 and all tensions below P_crit (Eq. (22))",
                        "WC": "W0 and every cable clear of the arm (no cable segment crosses "
                              "the arm, core/clearance.py)"}
        for name, mask in results.masks(limits).items():
            put(masks, name, mask, "1", descriptions[name], ("sample",))
        write_attrs(masks, {k: v for k, v in limits.items() if v is not None})
        if targets:
            write_map_grids(fh.create_group("map"), results, index, axes, limits, descriptions)
        write_timing(full, fh.create_group("timing"), timing)
    return full.layout


def write_timing(full, group, timing: dict) -> None:
    """The ``timing`` attributes, the wall and I/O times updatable in place."""
    from .hdf5 import write_attrs

    write_attrs(group, {k: v for k, v in timing.items() if k not in UPDATED_TIMING})
    for key in UPDATED_TIMING:
        full.mark(group, key, timing.get(key, 0.0), "f8")


UPDATED_TIMING = ("seconds_wall", "seconds_io")     # rewritten at every checkpoint


def new_map_rows(results, samples: np.ndarray, limits: dict) -> list:
    """The rows a checkpoint writes in place for ``samples`` besides their
    ``samples/`` fields: their masks (``masks/``) and, on a target lattice, their
    cells of ``map/`` (:func:`write_map_grids`), as (dataset, index, values)."""
    masks = results.masks(limits, samples)
    rows = [(f"masks/{name}", samples, mask) for name, mask in masks.items()]
    if results.grid.mode == "targets":
        index = results.lattice[0][samples]
        cell = (index[:, 1], index[:, 0])
        rows += [(f"map/{name}", cell, mask) for name, mask in masks.items()]
        rows += [(f"map/{name}", cell, results.data[name][samples]) for name in MAP_FIELDS]
    return rows


def read_results(path: Path, attrs: dict, results):
    """Load a partial file for ``resume`` into the empty ``results`` (a
    :class:`~elastica_petsc.studies.chunks.ChunkResults`) and return them;
    refuse a file made for another grid or arm (its root attributes
    :data:`GRID_ATTRS` differ from ``attrs``)."""
    import h5py

    try:
        with h5py.File(path, "r") as fh:
            for key in GRID_ATTRS:
                stored = fh.attrs.get(key, ATTR_DEFAULTS.get(key))
                if isinstance(stored, bytes):
                    stored = stored.decode()
                if key == "sampler":
                    stored = sampler_of(fh.attrs, attrs["mode"])
                now = attrs.get(key, ATTR_DEFAULTS.get(key))
                if stored != now:
                    raise InputError(f"{path}: cannot resume: it was made with "
                                     f"{_difference(key, stored, now)}")
            results.chunk_done[:] = fh["grid/chunk_done"][()]
            read_samples(fh, results)
    except InputError:
        raise                                   # a mismatch found above, already in words
    except OSError as err:
        raise InputError(f"{path}: cannot resume from this file: {err}") from None
    except (KeyError, ValueError, TypeError) as err:
        raise InputError(f"{path}: cannot resume: not a complete workspace file "
                         f"(missing or malformed {err})") from None
    return results


def _difference(key: str, stored, now) -> str:
    """What differs between a file's grid attribute and this run's, in words."""
    if key == "grid_json":
        try:
            a, b = json.loads(stored), json.loads(now)
            diff = [f"{k} {a.get(k)!r} (now {b.get(k)!r})" for k in sorted(set(a) | set(b))
                    if a.get(k) != b.get(k)]
            return "another grid: " + "; ".join(diff)
        except (TypeError, ValueError):
            pass
    if key == "config_json":
        return "another arm configuration (--config/--elements)"
    if key == "sampler":
        return (f"the {stored!r} sampler (now {now!r}): its unreached samples are "
                + ("local verdicts" if stored == "local" else "searched globally")
                + "; start a new file, or resume it with the same sampler"
                + f" (--sampler {stored}" + (" or --local-only)" if stored == "local" else ")"))
    if key in ATTR_DEFAULTS:
        option, what = (("--share", "the sharing rule") if key == "share" else
                        ("--min-tension-N", "the tension floor [N]"))
        return (f"{what} {option} {stored} (now {now}): its samples hold other tensions; "
                f"start a new file, or resume it with the same {option}")
    if key == "petsc_options":
        return f"other PETSc options: {stored or '(none)'} (now {now or '(none)'})"
    return f"another {key}: {stored!r} (now {now!r})"


def continue_provenance(out: Path, attrs: dict) -> None:
    """A resumed file keeps its first command line and creation time and lists
    the command lines of every resume (``resumed_command_lines``, JSON)."""
    import h5py

    with h5py.File(out, "r") as fh:
        first = {key: fh.attrs[key] for key in ("command_line", "created_utc") if key in fh.attrs}
        resumed = json.loads(fh.attrs.get("resumed_command_lines", "[]"))
    resumed.append(attrs.get("command_line", ""))
    attrs.update(first, resumed_command_lines=jsontext.dumps(resumed))


def read_map_file(path, new_results) -> tuple:
    """A workspace file (complete or partial) read back: (results, limits, ranks,
    sampler, share), the results made empty by ``new_results(mode, points,
    chunks, grid meta, n_tendons)`` and filled from the file."""
    import h5py

    try:
        with h5py.File(path, "r") as fh:
            order, bounds = fh["grid/chunk_order"][()], fh["grid/chunk_bounds"][()]
            chunks = tuple(order[bounds[c]:bounds[c + 1]] for c in range(len(bounds) - 1))
            mode = fh.attrs["mode"]
            mode = mode.decode() if isinstance(mode, bytes) else str(mode)
            results = new_results(mode, fh["grid/points"][()], chunks,
                                  json.loads(fh.attrs.get("grid_json", "{}")),
                                  int(fh.attrs["n_tendons"]))
            results.chunk_done[:] = fh["grid/chunk_done"][()]
            read_samples(fh, results)
            sampler = sampler_of(fh.attrs, mode)
            share = share_of(fh.attrs)
            limits = {key: fh["masks"].attrs.get(key) for key in
                      ("kappa_limit", "strain_energy_max", "max_tension")}
            ranks = int(fh["timing"].attrs.get("ranks", 1))
    except OSError as err:
        raise InputError(f"{path}: cannot read it as HDF5: {err}") from None
    except (KeyError, ValueError) as err:
        raise InputError(f"{path}: not a workspace file (missing or malformed {err})") from None
    return results, limits, ranks, sampler, share
