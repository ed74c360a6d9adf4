"""Workspace boundary figure: the W_0 and restricted polygons traced by
continuation, their continuation nodes and corners, over a sampled map."""
from __future__ import annotations

import numpy as np

from .common import figure, save

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
        ax.plot(routes_mm[:, 0], routes_mm[:, 1], "k^", ms=6, ls="none", label="routing points")
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
    ax.plot(0, 0, "ks", ms=6)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title("Workspace boundary by continuation")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    save(fig, path)

