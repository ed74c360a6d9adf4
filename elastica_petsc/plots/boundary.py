"""Workspace boundary figure: the W_0 and restricted polygons traced by
continuation, their continuation nodes and corners, over a sampled map."""
from __future__ import annotations

import numpy as np

from .common import draw_routes, figure, save

REGION_STYLE = {"W0": ("tab:blue", "-", "W_0 boundary (continuation)"),
                "restricted": ("tab:purple", "--", "restricted workspace boundary")}


def plot_boundary(data: dict, path, *, arm_length_mm: float, routes_mm: np.ndarray,
                  samples: dict | None = None) -> None:
    """``data`` from :func:`elastica_petsc.io.boundary.read_boundary`; ``samples``
    from :func:`elastica_petsc.plots.workspace.read_workspace` (drawn underneath)."""
    fig, ax = figure(figsize=(9.5, 8))
    if samples is not None:
        from .workspace import plot_samples
        plot_samples(samples, ax)
    else:
        a = np.linspace(0, 2 * np.pi, 400)
        ax.plot(arm_length_mm * np.cos(a), arm_length_mm * np.sin(a), "k--", lw=0.8,
                label=f"rigid link of length l = {arm_length_mm:g} mm")
        draw_routes(ax, routes_mm, zorder=10)           # drawn over the curves, named
    if "W0" in data["regions"]:
        shade_w0(ax, data["regions"]["W0"], arm_length_mm / 300)     # holes (around r_1) white
    if "W0" in data["regions"] and samples is None:
        ax.set_xlim(-1.08 * arm_length_mm, 1.08 * arm_length_mm)     # the reach, whole
        ax.set_ylim(-1.08 * arm_length_mm, 1.08 * arm_length_mm)
    for name, region in data["regions"].items():
        colour, style, label = REGION_STYLE[name]
        poly = np.vstack((region["polygon"], region["polygon"][:1]))
        ax.plot(poly[:, 0], poly[:, 1], style, color=colour, lw=1.6, zorder=7,
                label=f"{label}: {region['area_mm2'] / 1e3:.0f}e3 mm^2")
        if name == "W0":
            ax.plot(region["tip"][:, 0], region["tip"][:, 1], ".", color=colour, ms=4, zorder=8,
                    label="continuation nodes")
            for k, line in enumerate(region.get("folds", [])):
                ax.plot(line[:, 0], line[:, 1], "-", color="tab:red", lw=1.4, zorder=8,
                        label="tip-map fold curves (det S = 0)" if k == 0 else None)
    folds = data["tip_folds"]
    if len(folds):
        ax.plot(folds[:, 0], folds[:, 1], "D", color="tab:orange", ms=5, zorder=9,
                label="where they meet the loop")
    ax.plot(0, 0, "ks", ms=6, zorder=10, label="clamp")
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title("Workspace boundary by continuation")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    save(fig, path)



def shade_w0(ax, region: dict, step_mm: float) -> None:
    """Shade W_0 (:func:`w0_mask`); holes stay white."""
    X, Y, inside = w0_mask(region, step_mm)
    ax.contourf(X, Y, inside.astype(float), levels=[0.5, 1.5], colors=["tab:blue"],
                alpha=0.12, zorder=1)
    ax.fill([], [], color="tab:blue", alpha=0.12, label="W_0 (holes white)")


def w0_mask(region: dict, step_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(X, Y, inside) on a grid of ``step_mm`` over the W0 loop's box: W_0 as
    assembled (docs/model.md §9.1), the points the loop winds around plus the
    faces of winding number 0 covered twice (N > 0).  ``region`` as read by
    :func:`elastica_petsc.io.boundary.read_boundary`."""
    from ..core.geometry import winding_number
    from ..studies.boundary.faces import OutsideMap

    poly = region["polygon"]
    lo, hi = poly.min(axis=0) - step_mm, poly.max(axis=0) + step_mm
    X, Y = np.meshgrid(np.arange(lo[0], hi[0], step_mm), np.arange(lo[1], hi[1], step_mm))
    points = np.column_stack((X.ravel(), Y.ravel()))
    inside = winding_number(poly, points) != 0
    twice = [f["point_mm"] for f in region.get("faces", [])
             if f["winding"] == 0 and (f["preimages"] or 0) > 0]
    if twice:
        faces = OutsideMap([poly, *region.get("folds", [])], step_mm, closed=(0,))
        inside |= np.isin(faces.label(points), faces.label(np.array(twice)))
    return X, Y, inside.reshape(X.shape)
