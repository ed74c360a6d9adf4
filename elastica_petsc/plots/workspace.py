"""Workspace figures from a workspace HDF5 file: Fig. 4 (samples) and Fig. 5
(contours of l*kappa_max, the smallest eigenvalue, the strain energy and each
tension over the reached samples), optionally with traced paths on top."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .common import draw_routes, figure, save
from ..io.workspace import share_of
from ..studies.workspace import Status, reason_counts


def read_workspace(path) -> dict:
    import h5py

    from ..io.dims import fields

    with h5py.File(path, "r") as fh:
        data = fields(fh["samples"])
        config = json.loads(fh.attrs["config_json"])
        data["length_mm"] = float(config["arm"]["length_mm"])
        data["routes_mm"] = np.array([t["route_mm"] for t in config["tendon"]], float)
        data["mode"] = fh.attrs["mode"]
        data["share"], data["min_tension_N"] = share_of(fh.attrs)
        grid = json.loads(fh.attrs.get("grid_json", "{}"))
        data["spacing"] = grid.get("spacing") if data["mode"] == "targets" else None
        data["region"] = grid.get("region")
        data["masks"] = fields(fh["masks"])
        data["limits"] = dict(fh["masks"].attrs)
    return data


def read_overlays(files) -> list[tuple[str, np.ndarray]]:
    """(label, targets in mm) of traced paths written by ``trace --out``."""
    import h5py

    from ..core.errors import InputError

    paths = []
    for name in files:
        try:
            with h5py.File(name, "r") as fh:
                if fh.attrs.get("kind") != "trace":
                    raise InputError(f"--overlay {name}: not a file written by `trace --out`")
                paths.append((Path(name).stem, fh["path/target"][()]))
        except OSError as err:
            raise InputError(f"--overlay {name}: cannot read it as HDF5: {err}") from None
    return paths


MARKER_SIZE = 3.0            # points, every class of sample in Fig. 4
PATH_COLOURS = ("k", "tab:purple", "tab:cyan", "tab:brown", "tab:blue")   # not orange: undecided samples


def _paths_overlay(ax, paths) -> None:
    for k, (label, xy) in enumerate(paths or ()):
        ax.plot(xy[:, 0], xy[:, 1], "-", color=PATH_COLOURS[k % len(PATH_COLOURS)], lw=1.4,
                label=label, zorder=6)


def _rigid_link(ax, length_mm: float, whole: bool = False) -> None:
    a = np.linspace(0, 2 * np.pi if whole else np.pi, 400)
    ax.plot(length_mm * np.cos(a), length_mm * np.sin(a), "k--", lw=1.0,
            label=f"rigid link of length l = {length_mm:g} mm")


def _classes(data: dict) -> list[tuple[np.ndarray, str, str, str]]:
    """(selection, colour, marker, label) of each class of sample drawn in Fig. 4:
    reached locally (green) or by the global search (dark green), not reached
    after the global search (orange: undecided), reached with P >= 0 but not
    with the floor's tensions (gold: undecided for W_0(P_min)), outside the traced W_0
    boundary (purple: proven), beyond reach (black), and the
    local sampler's classes (red: ended on P_i = 0; grey: not converged)."""
    status = data["status"]
    strategy = data.get("strategy", np.full(status.shape, b""))
    found = np.array([s.startswith((b"seed", b"neighbour")) for s in strategy], bool)
    reached = status == Status.REACHED
    floor = data.get("min_tension_N", 0.0)
    w0 = f"P >= {floor:g} N (W_0(P_min))" if floor > 0 else "P >= 0 (W_0)"
    return [(reached & ~found, "tab:green", "o", f"reached, {w0}"),
            (reached & found, "darkgreen", "D", f"reached, {w0}, by the global search"),
            (status == Status.BELOW_FLOOR, "gold", "s",
             "reached with P >= 0, no tensions >= the floor found (undecided)"),
            (status == Status.UNIQUE_BELOW_FLOOR, "tab:brown", "s",
             "reached with P >= 0, its only tensions below the floor (proven)"),
            (status == Status.UNDECIDED, "tab:orange", "o",
             "not reached after the global search (undecided)"),
            (status == Status.OUTSIDE_BOUNDARY, "tab:purple", "o",
             "outside the traced W_0 boundary (proven)"),
            (status == Status.BEYOND_REACH, "k", "o", "beyond reach |x| > l (proven)"),
            (status == Status.NEEDS_NEGATIVE, "tab:red", "o", "ended on P_i = 0 (local verdict)"),
            (status == Status.NOT_CONVERGED, "0.6", "x", "not converged")]


def plot_samples(data: dict, ax, paths=None) -> None:
    """Fig. 4: the classes of :func:`_classes` (reached samples at their tips, the
    others at their targets; not converged with their stopping reasons), and the
    tendons' routing points."""
    tip, target = data["tip"], data["target"]
    where = target if data["mode"] == "targets" else tip
    for sel, colour, marker, label in _classes(data):
        if sel.any():
            pts = tip[sel] if data["status"][sel][0] == Status.REACHED else where[sel]
            count = f"{int(sel.sum())}"
            if colour == "0.6":
                count += f": {reason_counts(data['reason'][sel])}"
            # one marker size for every class: only colour and shape tell them apart
            ax.plot(pts[:, 0], pts[:, 1], marker, color=colour, ms=MARKER_SIZE, ls="none",
                    label=f"{label} ({count})")
    draw_routes(ax, data["routes_mm"])
    _rigid_link(ax, data["length_mm"], whole=bool(np.any(where[:, 1] < 0)))
    _paths_overlay(ax, paths)
    ax.plot(0, 0, "ks", ms=6)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    region = data.get("region")
    ax.set_title("Sampled workspace (Fig. 4)" + (f"\nregion: {region}" if region else ""),
                 fontsize=11)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))   # off the samples


def _triangulation(xy: np.ndarray, spacing: float | None):
    """Delaunay triangles of the sample points; on a target lattice of
    ``spacing``, triangles with an edge longer than 1.5 spacing (they bridge
    samples that were not reached) are masked, so contours never fill
    regions without samples."""
    from matplotlib.tri import Triangulation

    tri = Triangulation(xy[:, 0], xy[:, 1])
    if spacing:
        corners = xy[tri.triangles]                               # (n, 3, 2)
        edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
        long = edges.max(axis=1) > 1.5 * spacing
        if not long.all():
            tri.set_mask(long)
    return tri


def _contour(fig, ax, xy, values, title, label, levels=12, limit=None, paths=None,
             spacing=None) -> None:
    ok = np.isfinite(values)
    if ok.sum() < 4:
        ax.set_title(title + " (too few samples)")
        return
    tri = _triangulation(xy[ok], spacing)
    tcf = ax.tricontourf(tri, values[ok], levels=levels, cmap="viridis")
    fig.colorbar(tcf, ax=ax, label=label, shrink=0.85)
    if limit is not None and np.nanmin(values[ok]) < limit < np.nanmax(values[ok]):
        ax.tricontour(tri, values[ok], levels=[limit], colors="r", linewidths=1.5)
    _paths_overlay(ax, paths)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title, fontsize=10)


def plot_restrictions(data: dict, path, paths=None) -> None:
    """Fig. 5a-d over the reached samples: curvature, smallest eigenvalue,
    strain energy and every tension."""
    reached = data["status"] == Status.REACHED
    xy = data["tip"][reached]
    n = data["tensions"].shape[1]
    panels = [("kappa_max", "(a) max curvature l*kappa_max", "l kappa_max",
               data["limits"].get("kappa_limit")),
              ("lambda_min_raw", "(b) smallest eigenvalue of K", "lambda_min(K) / (B/l)",
               0.0),
              ("strain_energy", "(c) strain energy / SE_0", "SE / SE_0",
               data["limits"].get("strain_energy_max"))]
    count = len(panels) + n
    cols = 3
    rows = -(-count // cols)
    fig, axes = figure(nrows=rows, ncols=cols, figsize=(5.2 * cols, 3.6 * rows),
                       layout="constrained")
    axes = np.atleast_1d(axes).ravel()
    for ax, (name, title, label, limit) in zip(axes, panels):
        _contour(fig, ax, xy, data[name][reached], title, label, limit=limit, paths=paths,
                 spacing=data.get("spacing"))
    # tensions in N, with the non-dimensional p of the same colour in the title
    p_max = data["limits"].get("max_tension")
    for i in range(n):
        P_N, p = data["tensions_N"][reached, i], data["tensions"][reached, i]
        per_N = float(np.nanmedian(p[P_N > 0] / P_N[P_N > 0])) if np.any(P_N > 0) else np.nan
        _contour(fig, axes[len(panels) + i], xy, P_N,
                 f"(d) tension of tendon {i + 1} [N] (p = P l^2/B = {per_N:.3g} P/N)", "P [N]",
                 limit=None if p_max is None or not np.isfinite(per_N) else p_max / per_N,
                 paths=paths, spacing=data.get("spacing"))
    for ax in axes[count:]:
        ax.axis("off")
    fig.suptitle("Restrictions on the workspace (Fig. 5); red lines: limits of Eqs. (19)-(22)")
    save(fig, path)


def plot_workspace(h5_path, png_path, paths=None) -> None:
    """Fig. 4 into ``png_path`` and Fig. 5 into ``<stem>_restrictions.png``."""
    data = read_workspace(h5_path)
    fig, ax = figure(figsize=(9.5, 5))
    plot_samples(data, ax, paths)
    save(fig, png_path)
    png_path = Path(png_path)
    plot_restrictions(data, png_path.with_name(png_path.stem + "_restrictions.png"), paths)
