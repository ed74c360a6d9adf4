"""Figures (matplotlib, Agg backend): geometry in mm with equal aspect."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..solvers.equilibrium import Equilibrium
from ..core.model import Arm

TENDON_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown")


def figure(**kwargs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt.subplots(**kwargs)


def save(fig, path: str | Path) -> None:
    import matplotlib.pyplot as plt
    fig.savefig(path, dpi=150, bbox_inches="tight")
    plt.close(fig)


def draw_arm(ax, arm: Arm, eq: Equilibrium, label: str | None = None, colour: str = "k",
             tendons: bool = True) -> None:
    """The deformed centreline, its tendons as straight segments to their routing points
    (through their guides)."""
    l_mm = arm.length_mm
    x = eq.x * l_mm
    ax.plot(x[:, 0], x[:, 1], "-", color=colour, lw=2.2, label=label, zorder=3)
    ax.plot(*x[-1], "o", color=colour, ms=5, zorder=4)
    if tendons:
        for i, line in enumerate(eq.cable_points):
            ax.plot(line[:, 0] * l_mm, line[:, 1] * l_mm, "-", lw=1.0,
                    color=TENDON_COLOURS[i % len(TENDON_COLOURS)], zorder=2)


def draw_setting(ax, arm: Arm) -> None:
    """Undeformed arm (dashed), clamp and routing points."""
    l_mm = arm.length_mm
    ax.plot([0, l_mm], [0, 0], "--", color="0.6", lw=1.0, label="undeformed", zorder=1)
    ax.plot(0, 0, "ks", ms=7, zorder=5)
    for i, r in enumerate(arm.routes() * l_mm):
        ax.plot(*r, "^", color=TENDON_COLOURS[i % len(TENDON_COLOURS)], ms=8, zorder=5,
                label=f"routing point r{i + 1}")


def draw_routes(ax, routes_mm, zorder: float = 7) -> None:
    """The routing points as black triangles named r_1, r_2, ... (one legend entry),
    white-edged and with a white halo behind the names: legible over samples and curves."""
    from matplotlib.patheffects import withStroke

    routes_mm = np.asarray(routes_mm, float)
    ax.plot(routes_mm[:, 0], routes_mm[:, 1], "k^", ms=8, ls="none", mec="white", mew=0.6,
            zorder=zorder, label="routing points r_" + ", r_".join(
                str(i) for i in range(1, len(routes_mm) + 1)))
    for i, r in enumerate(routes_mm, start=1):
        ax.annotate(f"r_{i}", r, xytext=(5, -3), textcoords="offset points", fontsize=9,
                    zorder=zorder, path_effects=[withStroke(linewidth=3, foreground="white")])


def finish_geometry(ax, title: str) -> None:
    """Equal aspect, labels in mm, and the legend below the axes, off the drawing."""
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.set_title(title)
    legend_below(ax)


def legend_below(ax, ncol: int = 2, fontsize: float = 8) -> None:
    """The legend under the axes (beneath the x label), where it hides no data."""
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.0), borderaxespad=4.6, ncol=ncol,
              fontsize=fontsize, frameon=False)    # 4.6 font sizes below: under the x label


def plot_equilibria(arm: Arm, states: list[tuple[Equilibrium, str]], path: str | Path,
                    title: str = "Equilibrium of the tendon-actuated arm") -> None:
    """Deformed arm(s) with tendons; undeformed arm dashed; axes in mm."""
    fig, ax = figure(figsize=(7, 6))
    draw_setting(ax, arm)
    colours = ("k", "tab:red", "tab:cyan", "tab:olive", "tab:pink")
    for j, (eq, label) in enumerate(states):
        draw_arm(ax, arm, eq, label=label, colour=colours[j % len(colours)])
    finish_geometry(ax, title)
    save(fig, path)


def tension_label(arm: Arm, p) -> str:
    P = arm.tensions_to_N(p)
    return "p = (" + ", ".join(f"{v:.1f}" for v in np.asarray(p)) + ") = (" + \
        ", ".join(f"{v:.2f}" for v in P) + ") N"
