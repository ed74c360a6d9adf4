"""The files of ``elastica-petsc replay``: the trace file it reads (written by
``elastica-petsc trace --out``) and the replay file it writes (layout in
:mod:`elastica_petsc.cli.replay`).  Lengths in mm, tensions p = P l^2/B."""
from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from ..core.model import arm_from_dict
from ..core.errors import InputError
from .hdf5 import atomic_h5, provenance, put, write_attrs


def read_trace(path) -> dict:
    """The planned path of a trace file; one-line InputError for anything else."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such trace file")
    try:
        fh = h5py.File(p, "r")
    except OSError:
        raise InputError(f"{p}: not an HDF5 file (expected the output of "
                         "`elastica-petsc trace --out`)") from None
    with fh:
        kind = fh.attrs.get("kind")
        kind = kind.decode() if isinstance(kind, bytes) else kind
        if kind != "trace":
            raise InputError(f"{p}: not a trace file (kind {kind!r}, expected 'trace'; write "
                             "one with `elastica-petsc trace --out`)")
        if "config_json" not in fh.attrs:
            raise InputError(f"{p}: trace file without the attribute config_json")
        try:
            arm = arm_from_dict(json.loads(fh.attrs["config_json"]))
        except (ValueError, TypeError) as err:
            raise InputError(f"{p}: attribute config_json: {err}") from None
        if "path" not in fh:
            raise InputError(f"{p}: trace file without the group /path")
        g = fh["path"]
        data = {}
        for name in ("cable_lengths", "tip", "tensions", "tensions_N", "theta", "target",
                     "converged"):
            data[name] = g[name][()] if name in g else None
        for name in ("cable_lengths", "tip"):
            if data[name] is None:
                raise InputError(f"{p}: trace file without the dataset /path/{name}")
        elements = fh.attrs.get("elements")
    L, tip = np.asarray(data["cable_lengths"], float), np.asarray(data["tip"], float)
    K, n = len(L), arm.n_tendons
    if K == 0:
        raise InputError(f"{p}: the traced path has no points")
    if L.shape != (K, n) or tip.shape != (K, 2):
        raise InputError(f"{p}: /path/cable_lengths must be ({K}, {n}) and /path/tip ({K}, 2); "
                         f"got {L.shape} and {tip.shape}")
    if elements is None:
        elements = arm.elements if data["theta"] is None else np.shape(data["theta"])[1] - 1
    elements = int(elements)
    for name, shape in (("tensions", (K, n)), ("theta", (K, elements + 1)), ("target", (K, 2)),
                        ("converged", (K,))):
        if data[name] is not None and np.shape(data[name]) != shape:
            raise InputError(f"{p}: /path/{name} has shape {np.shape(data[name])}, expected "
                             f"{shape}")
    data.update(arm=arm, elements=elements, K=K)
    return data


def write_replay(path, overwrite: bool, arm, trace: dict, result) -> None:
    """The replay of a trace (a studies.replay.Replay) with its plan."""
    pts = result.points
    n = arm.n_tendons
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(arm, "replay"))
        write_attrs(fh, {"elements": int(trace["elements"]), "completed": bool(result.completed),
                         "all_on_branch": bool(result.all_on_branch),
                         "first_departure": -1 if result.first_departure is None
                         else int(result.first_departure),
                         "start_method": result.start_method,
                         "max_tip_error_mm": float(result.max_tip_error_mm)})
        g = fh.create_group("planned")
        PT, P2 = ("point", "tendon"), ("point", "component")      # named dims (io/dims.py)
        put(g, "cable_lengths", trace["cable_lengths"], "mm", "planned cable lengths L_i", PT)
        put(g, "tip", trace["tip"], "mm", "planned tip (load-controlled trace)", P2)
        if trace["tensions"] is not None:
            put(g, "tensions", trace["tensions"], "P l^2/B", "planned tensions p_i", PT)
        r = fh.create_group("replay")
        R = ("point",)
        put(r, "index", [q.index for q in pts], "1", "point of the planned path", R)
        put(r, "tip", np.array([q.state.tip_mm for q in pts]).reshape(-1, 2), "mm",
            "replayed tip under length control", P2)
        put(r, "tip_error", [q.tip_error_mm for q in pts], "mm", "|replayed - planned tip|", R)
        put(r, "shape_error", [np.nan if q.shape_error is None else q.shape_error for q in pts],
            "rad", "max |theta - planned theta| (NaN: no planned shape)", R)
        put(r, "on_branch", [q.on_branch for q in pts], "1", "on the planned branch", R)
        put(r, "jumped", [q.jumped for q in pts], "1", "snap/buckling on the way to the point",
            R)
        put(r, "stable", [q.state.converged and q.stable for q in pts], "1",
            "stable under length control", R)
        put(r, "converged", [q.state.converged for q in pts], "1", "length-controlled solve "
                                                                    "converged", R)
        P = np.array([q.state.p for q in pts]).reshape(-1, n)
        put(r, "tensions", P, "P l^2/B", "replayed tensions p_i", PT)
        put(r, "tensions_N", arm.tensions_to_N(P), "N", "replayed tensions P_i", PT)
        put(r, "theta", np.array([q.state.theta for q in pts]).reshape(len(pts), -1), "rad",
            "replayed nodal angles", ("point", "node"))
        j = fh.create_group("jumps")
        jumps = result.jumps
        put(j, "before_point", [k for k, _ in jumps], "1", "point reached after the jump",
            ("jump",))
        put(j, "lengths", np.array([L for _, L in jumps]).reshape(-1, n), "mm",
            "cable lengths at which the arm jumped", ("jump", "tendon"))
        g = fh.create_group("instabilities")
        events = result.instabilities
        E = ("event",)
        put(g, "before_point", [k for k, _, _ in events], "1",
            "point reached after the loss of stability", E)
        put(g, "lengths", np.array([L for _, L, _ in events]).reshape(-1, n), "mm",
            "cable lengths at which the followed branch lost stability", ("event", "tendon"))
        put(g, "kind", np.array([kind for _, _, kind in events], dtype=str), "1",
            "bifurcation (buckling, switched to a stable branch) or limit point (snap)", E)
