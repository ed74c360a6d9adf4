"""Export for ParaView: VTK XML unstructured grids (.vtu) and collections (.pvd).

Written with numpy alone (ASCII XML), read by ParaView, VTK and meshio.
Coordinates in mm (z = 0: the arm is planar); tensions in N with p = P l^2/B
beside them; booleans as UInt8 0/1 (VTK has no boolean type).

* :func:`write_state` — one equilibrium: the centreline as N line cells
  (point data ``s_mm``, ``theta_rad``; cell data ``curvature`` l*theta',
  ``part`` = 0) and each cable as one line cell from its attachment node to
  its routing point (``part`` = i, ``tension_N``, ``tension_p``,
  ``cable_length_mm``).  Eqs. (2)-(4).  A cable through guides is one line
  cell per segment, routing point -> guides -> end (docs/model.md §11).
* :func:`write_states` — equilibria into a folder (``solve``, ``control``,
  ``lengths``, ``equilibria`` ``--vtk``): one such file each, and a
  ``.pvd`` listing several by their number.
* :func:`write_trace` — a traced path: one state file per point (and per
  point of the approach from the straight arm, when given),
  ``<name>.pvd`` listing them with the schedule's time (s) or the point
  index, and ``<name>_path.vtu``: the tips joined by line cells, with per-point
  ``target_x_mm``, ``reached``, ``tip_error_mm``, ``tension_i_N``,
  ``tension_i_p``, ``cable_length_i_mm``, ``time_s``.
* :func:`write_simulation` — a run of ``simulate``: one state file per recorded
  step, ``simulation.pvd`` with their times in seconds, and ``simulation_tip.vtu``.
* :func:`write_workspace` — a workspace map (HDF5 of ``elastica-petsc
  workspace``): every sample as a vertex, plus a quad for every lattice
  cell whose four corners were sampled, with every per-sample field as point
  data (vectors split per tendon: ``tensions_N_1``, ...) and the masks
  ``W0`` ... ``WP`` (W_0: tips of stable equilibria connected to the
  straight arm by quasi-static loading with all P_i >= 0, Eq. (18)).
"""
from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ..core.errors import InputError

VTK_VERTEX, VTK_LINE, VTK_QUAD = 1, 3, 9
_TYPES = {"f": "Float64", "i": "Int64", "u": "UInt8", "b": "UInt8"}


def check_directory(path, overwrite: bool = False, option: str = "--vtk") -> Path:
    """An output folder for VTK files: created if missing (its parent must
    exist and be writable); an existing non-empty one only with ``overwrite``."""
    from .hdf5 import probe_writable

    if not str(path).strip():
        raise InputError(f"{option}: empty folder name")
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(f"{option} {path}: exists and is not a directory (a folder is wanted)")
    if path.is_dir() and any(path.iterdir()) and not overwrite:
        raise InputError(f"{path}: folder is not empty; pass --overwrite to write into it")
    if not path.parent.exists():
        raise InputError(f"{path.parent}: no such directory for the VTK folder")
    probe_writable(path if path.is_dir() else path.parent, path)
    return path


def _array(name, values) -> str:
    a = np.asarray(values)
    kind = a.dtype.kind
    if kind == "b":
        a = a.astype(np.uint8)
    comps = "" if a.ndim == 1 else f' NumberOfComponents="{a.shape[1]}"'
    fmt = "%.12g" if kind == "f" else "%d"
    body = " ".join(fmt % v for v in a.ravel())
    name_attr = "" if name is None else f" Name={quoteattr(name)}"
    return (f'<DataArray type="{_TYPES.get(kind, "Float64")}"{name_attr}{comps} '
            f'format="ascii">{body}</DataArray>')


def write_vtu(path, points, cells, point_data=None, cell_data=None) -> Path:
    """An unstructured grid: ``points`` (m, 2 or 3), ``cells`` a list of
    (vtk type, connectivity (k, nodes)) blocks; data: name -> array per
    point / per cell (cells counted over the blocks in order).  Written
    aside and renamed into place."""
    path = Path(path)
    pts = np.asarray(points, float)
    if pts.shape[1] == 2:
        pts = np.column_stack((pts, np.zeros(len(pts))))
    conn, offsets, types = [], [], []
    end = 0
    for vtk_type, c in cells:
        c = np.asarray(c, np.int64).reshape(len(c), -1)
        conn.append(c.ravel())
        offsets.append(end + c.shape[1] * np.arange(1, len(c) + 1))
        end += c.size
        types.append(np.full(len(c), vtk_type, np.uint8))
    n_cells = sum(len(t) for t in types)
    parts = ['<?xml version="1.0"?>',
             '<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">',
             f'<UnstructuredGrid><Piece NumberOfPoints="{len(pts)}" NumberOfCells="{n_cells}">']
    for tag, data, count in (("PointData", point_data, len(pts)), ("CellData", cell_data, n_cells)):
        parts.append(f"<{tag}>")
        for name, values in (data or {}).items():
            if len(values) != count:
                raise ValueError(f"{tag} {name}: {len(values)} values for {count}")
            parts.append(_array(name, values))
        parts.append(f"</{tag}>")
    parts += ["<Points>", _array(None, pts), "</Points>", "<Cells>",
              _array("connectivity", np.concatenate(conn) if conn else np.zeros(0, np.int64)),
              _array("offsets", np.concatenate(offsets) if offsets else np.zeros(0, np.int64)),
              _array("types", np.concatenate(types) if types else np.zeros(0, np.uint8)),
              "</Cells>", "</Piece></UnstructuredGrid>", "</VTKFile>"]
    _write_text(path, "\n".join(parts) + "\n")
    return path


def write_pvd(path, entries) -> Path:
    """A ParaView collection: ``entries`` = [(time, file name relative to path's folder)]."""
    path = Path(path)
    rows = "\n".join(f'<DataSet timestep="{t:.12g}" part="0" file={quoteattr(str(f))}/>'
                     for t, f in entries)
    _write_text(path, '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                      f"<Collection>\n{rows}\n</Collection>\n</VTKFile>\n")
    return path


def _write_text(path: Path, text: str) -> None:
    from .exclusive import replace_file

    replace_file(path, text.encode())


# --- states and paths -----------------------------------------------------------------------
def state_grid(arm, eq):
    """(points, cells, point data, cell data) of one equilibrium (see the module doc)."""
    if eq.disc.has_paths:
        return _guided_state_grid(arm, eq)
    l_mm, N, n = arm.length_mm, eq.disc.n_elements, arm.n_tendons
    routes = arm.routes() * l_mm
    points = np.vstack((eq.x * l_mm, routes))
    arm_cells = np.column_stack((np.arange(N), np.arange(1, N + 1)))
    cable_cells = np.column_stack((np.asarray(eq.disc.attach_nodes), N + 1 + np.arange(n)))
    nan_n = np.full(n, np.nan)
    P = arm.tensions_to_N(eq.p)
    point_data = {"s_mm": np.concatenate((np.linspace(0.0, l_mm, N + 1), nan_n)),
                  "theta_rad": np.concatenate((eq.theta, nan_n))}
    cell_data = {"part": np.concatenate((np.zeros(N, np.int64), np.arange(1, n + 1))),
                 "curvature": np.concatenate((eq.curvature, nan_n)),
                 "tension_N": np.concatenate((np.full(N, np.nan), P)),
                 "tension_p": np.concatenate((np.full(N, np.nan), eq.p)),
                 "cable_length_mm": np.concatenate((np.full(N, np.nan), eq.cable_lengths * l_mm))}
    return points, [(VTK_LINE, np.vstack((arm_cells, cable_cells)))], point_data, cell_data


def _guided_state_grid(arm, eq):
    """:func:`state_grid` with every cable a polyline from its routing point through
    its guides to its end (docs/model.md §11): one line cell per segment, whose
    tension and cable length (the whole path) are the cable's."""
    l_mm, N = arm.length_mm, eq.disc.n_elements
    lines = eq.cable_points
    points = np.vstack([eq.x * l_mm] + [c * l_mm for c in lines])
    first = N + 1 + np.cumsum([0] + [len(c) for c in lines[:-1]])
    segs = [np.column_stack((f + np.arange(len(c) - 1), f + np.arange(1, len(c))))
            for f, c in zip(first, lines)]
    tendon = np.concatenate([np.full(len(s), i) for i, s in enumerate(segs)])
    n_cable_points, n_segs = len(points) - N - 1, len(tendon)
    nan_p, nan_s = np.full(n_cable_points, np.nan), np.full(N, np.nan)
    P = arm.tensions_to_N(eq.p)
    point_data = {"s_mm": np.concatenate((np.linspace(0.0, l_mm, N + 1), nan_p)),
                  "theta_rad": np.concatenate((eq.theta, nan_p))}
    cell_data = {"part": np.concatenate((np.zeros(N, np.int64), tendon + 1)),
                 "curvature": np.concatenate((eq.curvature, np.full(n_segs, np.nan))),
                 "tension_N": np.concatenate((nan_s, P[tendon])),
                 "tension_p": np.concatenate((nan_s, np.asarray(eq.p)[tendon])),
                 "cable_length_mm": np.concatenate((nan_s, eq.cable_lengths[tendon] * l_mm))}
    arm_cells = np.column_stack((np.arange(N), np.arange(1, N + 1)))
    return points, [(VTK_LINE, np.vstack([arm_cells] + segs))], point_data, cell_data


def write_state(path, arm, eq) -> Path:
    """One equilibrium as a .vtu file (arm and cables, mm)."""
    return write_vtu(path, *state_grid(arm, eq))


def write_states(directory, arm, states, *, name: str = "state", numbers=None) -> list[Path]:
    """Equilibria ``states`` into ``directory`` (created if missing): one
    ``<name>.vtu`` for a single state without ``numbers``, else
    ``<name>_<K>.vtu`` per state K of ``numbers`` (default 1, 2, ...) and
    ``<name>s.pvd`` listing them with K as the time step.  Returns the files."""
    directory = Path(directory)
    directory.mkdir(exist_ok=True)
    if numbers is None and len(states) == 1:
        return [write_state(directory / f"{name}.vtu", arm, states[0])]
    numbers = range(1, len(states) + 1) if numbers is None else numbers
    files = [write_state(directory / f"{name}_{k}.vtu", arm, eq) for k, eq in zip(numbers, states)]
    return files + [write_pvd(directory / f"{name}s.pvd",
                              [(k, f.name) for k, f in zip(numbers, files)])]


def write_trace(directory, arm, trace, *, name: str = "trace", times_s=None,
                approach=None, approach_times_s=None) -> list[Path]:
    """A traced path (``trace.results`` needed) into ``directory``: one state
    per point, ``<name>.pvd`` (time: ``times_s`` per point, else the index)
    and ``<name>_path.vtu``.  With ``approach`` (the trace from the straight
    arm that precedes the path in a motor schedule, with its
    ``approach_times_s``) its states come first in the .pvd
    (``<name>_approach_*.vtu``).  Returns the files written."""
    directory = Path(directory)
    directory.mkdir(exist_ok=True)
    parts = [(f"{name}_approach", approach, approach_times_s), (name, trace, times_s)]
    entries, files = [], []
    for stem, part, times in parts:
        if part is None:
            continue
        if not part.results:
            raise InputError("exporting a trace needs its per-point states: trace with "
                             "keep_results=True (ep.trace) or use ep.schedule")
        t = np.arange(part.n_points, dtype=float) if times is None else np.asarray(times, float)
        digits = max(4, len(str(part.n_points - 1)))
        written = [write_state(directory / f"{stem}_{k:0{digits}d}.vtu", arm, r.equilibrium)
                   for k, r in enumerate(part.results)]
        entries += [(tk, f.name) for tk, f in zip(t, written)]
        files += written
    files.append(write_pvd(directory / f"{name}.pvd", entries))
    K = trace.n_points
    data = {"target_x_mm": trace.targets_mm[:, 0], "target_y_mm": trace.targets_mm[:, 1],
            "reached": np.asarray(trace.converged, bool), "tip_error_mm": trace.tip_errors_mm,
            "time_s": np.arange(K, dtype=float) if times_s is None else np.asarray(times_s, float),
            "point": np.arange(K)}
    for i in range(trace.p.shape[1]):
        data[f"tension_{i + 1}_N"] = trace.tensions_N[:, i]
        data[f"tension_{i + 1}_p"] = trace.p[:, i]
        data[f"cable_length_{i + 1}_mm"] = trace.cable_lengths_mm[:, i]
    files.append(write_vtu(directory / f"{name}_path.vtu", trace.tips_mm,
                           [(VTK_LINE, np.column_stack((np.arange(K - 1), np.arange(1, K))))],
                           data))
    return files


def write_simulation(directory, result, *, name: str = "simulation",
                     on_step=None) -> list[Path]:
    """A run of ``simulate`` (a SimulationResult) into ``directory``: the arm and
    its cables at every recorded step (``<name>_<K>.vtu``, as :func:`write_state`),
    ``<name>.pvd`` listing them with their time in seconds, and ``<name>_tip.vtu``:
    the tip's path as line cells with per-step ``time_s``, ``tension_i_N``,
    ``cable_length_i_mm`` and the energies ``kinetic_J``, ``strain_J``, ``work_J``,
    ``gravity_J``;
    ``on_step(done, total)`` after each state file."""
    directory = Path(directory)
    directory.mkdir(exist_ok=True)
    T = len(result.time_s)
    digits = max(4, len(str(T - 1)))
    files = []
    for k, state in enumerate(result.snapshots()):
        files.append(write_state(directory / f"{name}_{k:0{digits}d}.vtu", result.arm, state))
        if on_step is not None:
            on_step(k + 1, T)
    files.append(write_pvd(directory / f"{name}.pvd",
                           [(t, f.name) for t, f in zip(result.time_s, files)]))
    data = {"time_s": result.time_s, "step": np.arange(T)}
    for i in range(result.tensions_N.shape[1]):
        data[f"tension_{i + 1}_N"] = result.tensions_N[:, i]
        data[f"cable_length_{i + 1}_mm"] = result.cable_lengths_mm[:, i]
    for c, kind in enumerate(("kinetic", "strain", "work", "gravity")):
        data[f"{kind}_J"] = result.energy_J[:, c]
    cells = (VTK_LINE, np.column_stack((np.arange(T - 1), np.arange(1, T)))) if T > 1 else \
        (VTK_VERTEX, np.zeros((1, 1), np.int64))        # a run stopped at its first step
    files.append(write_vtu(directory / f"{name}_tip.vtu", result.tip_mm, [cells], data))
    return files


# --- workspace maps -------------------------------------------------------------------------
def lattice_quads(index) -> np.ndarray:
    """Quads (k, 4) of sample numbers over lattice cells whose 4 corners exist;
    ``index`` (S, 2) integer lattice coordinates (column, row) of the samples."""
    index = np.asarray(index, np.int64)
    lookup = {tuple(ij): s for s, ij in enumerate(index)}
    quads = []
    for s, (i, j) in enumerate(index):
        corners = (lookup.get((i + 1, j)), lookup.get((i + 1, j + 1)), lookup.get((i, j + 1)))
        if None not in corners:
            quads.append((s, *corners))
    return np.array(quads, np.int64).reshape(-1, 4)


PER_TENDON = {"tensions": "tension_{}_p", "tensions_N": "tension_{}_N",
              "cable_lengths": "cable_length_{}_mm"}


def workspace_point_data(samples: dict, masks: dict) -> dict:
    """Per-sample fields as VTK point data: per-tendon fields split and named
    as in the trace files (``tension_1_N``, ``tension_1_p``,
    ``cable_length_1_mm``), positions as ``tip_x_mm``..., strings left out
    (``status`` codes the reason)."""
    out = {}
    for name, values in samples.items():
        a = np.asarray(values)
        if a.dtype.kind in "SUO":
            continue
        if a.ndim == 1:
            out[name] = a
        elif name in ("target", "tip"):
            out[f"{name}_x_mm"], out[f"{name}_y_mm"] = a[:, 0], a[:, 1]
        else:
            pattern = PER_TENDON.get(name, name + "_{}")
            for i in range(a.shape[1]):
                out[pattern.format(i + 1)] = a[:, i]
    out.update({name: np.asarray(m, bool) for name, m in masks.items()})
    return out


def workspace_map(h5path, field: str, component: int | None = None):
    """A per-sample field of a workspace file as a 2-D array on its lattice:
    returns (axis_0, axis_1, A) with A[j, i] the value at (axis_0[i],
    axis_1[j]) (targets: x and y in mm; tensions: p_1 and p_2) and NaN where
    no sample lies.  ``component`` picks a tendon (0-based) of a per-tendon
    field such as ``tensions_N``.  Booleans (``masks/W0``...) come back as
    0/1 floats with NaN outside the grid."""
    import h5py

    with h5py.File(h5path, "r") as fh:
        if "grid/index" not in fh:
            raise InputError(f"{h5path}: no grid/index (written by an older version); "
                             "rerun the workspace")
        index = fh["grid/index"][()]
        axes = fh["grid/axis_0"][()], fh["grid/axis_1"][()]
        group = "masks" if field in fh.get("masks", {}) else "samples"
        if field not in fh[group]:
            raise InputError(f"{h5path}: no field {field!r} (samples: "
                             f"{', '.join(sorted(fh['samples']))}; masks: "
                             f"{', '.join(sorted(fh.get('masks', {})))})")
        values = fh[group][field][()]
    if values.ndim == 2:
        if component is None:
            raise InputError(f"{field} has one value per tendon: give component=0..."
                             f"{values.shape[1] - 1}")
        values = values[:, component]
    if index.shape[1] != 2:
        raise InputError(f"{h5path}: a {index.shape[1]}-D grid has no 2-D map")
    A = np.full((len(axes[1]), len(axes[0])), np.nan)
    A[index[:, 1], index[:, 0]] = values.astype(float)
    return axes[0], axes[1], A


def write_workspace_vtk(directory, h5path, name: str = "workspace") -> Path:
    """``directory/<name>.vtu`` from a workspace HDF5 file (folder created if missing)."""
    directory = Path(directory)
    directory.mkdir(exist_ok=True)
    return write_workspace(directory / f"{name}.vtu", h5path)


def write_workspace(path, h5path) -> Path:
    """A workspace HDF5 file (``elastica-petsc workspace --out``) as one .vtu:
    samples as vertices at their targets (mm; mode tensions: at their
    tensions p, two tendons shown in the plane) and lattice quads."""
    import h5py

    from .dims import fields

    with h5py.File(h5path, "r") as fh:
        points = fh["grid/points"][()]
        index = fh["grid/index"][()] if "grid/index" in fh else None
        samples = fields(fh["samples"])
        masks = fields(fh["masks"]) if "masks" in fh else {}
    S = len(points)
    xy = points[:, :2] if points.shape[1] >= 2 else np.column_stack((points[:, 0], np.zeros(S)))
    cells = [(VTK_VERTEX, np.arange(S)[:, None])]
    if index is not None and index.shape[1] == 2:
        quads = lattice_quads(index)
        if len(quads):
            cells.append((VTK_QUAD, quads))
    return write_vtu(path, xy, cells, workspace_point_data(samples, masks))
