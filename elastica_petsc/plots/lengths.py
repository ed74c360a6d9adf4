"""Figures of length control (Sec. 4.6): several equilibria (Fig. 8) and the
replay of a traced path under length control.  Geometry in mm, equal aspect."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.model import Arm
from .common import TENDON_COLOURS, draw_setting, figure, save

MARKERS_UP_TO = 60           # replay figure: mark every point of paths up to this length
STATE_COLOURS = ("k", "tab:red", "tab:cyan", "tab:olive", "tab:pink", "tab:gray", "tab:brown")


def draw_state(ax, arm: Arm, eq, label: str, colour: str, number: int | None = None) -> None:
    """Centreline, tip, attachments; taut cables solid, slack cables dotted; a
    cable that crosses the arm (core/clearance.py) on a red band, said in the label."""
    from ..core.clearance import state_cable_clear

    l_mm = arm.length_mm
    x = eq.x * l_mm
    clear = state_cable_clear(eq)
    crossing = [i + 1 for i, ok in enumerate(clear) if not ok]
    if crossing:
        label += "; cable " + ", ".join(map(str, crossing)) + " crosses the arm (red band)"
    ax.plot(x[:, 0], x[:, 1], "-", color=colour, lw=2.2, label=label, zorder=3)
    ax.plot(*x[-1], "o", color=colour, ms=5, zorder=4)
    taut = np.asarray(getattr(eq, "taut", np.asarray(eq.p) > 0))
    for i, (a, line) in enumerate(zip(eq.attachments * l_mm, eq.cable_points)):
        if not clear[i]:
            ax.plot(line[:, 0] * l_mm, line[:, 1] * l_mm, "-", lw=6, color="tab:red",
                    alpha=0.3, zorder=1.5, solid_capstyle="butt")
        ax.plot(line[:, 0] * l_mm, line[:, 1] * l_mm, "-" if taut[i] else ":", lw=1.0,
                color=TENDON_COLOURS[i % len(TENDON_COLOURS)], zorder=2)
        ax.plot(*a, "o", color=colour, ms=3, mfc="white", zorder=4)
    if number is not None:
        ax.annotate(str(number), x[-1], xytext=(6, 6), textcoords="offset points",
                    color=colour, fontsize=11, fontweight="bold", zorder=6)


def plot_states(arm: Arm, entries, path: str | Path, title: str, circles_mm=None,
                numbers=None) -> None:
    """Every equilibrium in ``entries`` [(state, label)], numbered at the tip
    (``numbers``, default 1, 2, ...: the states' own numbers).
    ``circles_mm``: prescribed cable lengths; the circles of radius L_i about
    r_i are drawn dashed (Fig. 8: x_i must lie on them when the cable is taut)."""
    fig, ax = figure(figsize=(8.5, 8.5))
    draw_setting(ax, arm)
    l_mm = arm.length_mm
    if circles_mm is not None:
        a = np.linspace(0.0, 2.0 * np.pi, 361)
        for i, (L, r) in enumerate(zip(circles_mm, arm.routes() * l_mm)):
            ax.plot(r[0] + L * np.cos(a), r[1] + L * np.sin(a), "--", lw=0.9,
                    color=TENDON_COLOURS[i % len(TENDON_COLOURS)], zorder=1,
                    label=f"|x{i + 1} - r{i + 1}| = L{i + 1} = {L:.1f} mm")
    numbers = range(1, len(entries) + 1) if numbers is None else numbers
    for k, ((eq, label), number) in enumerate(zip(entries, numbers)):
        draw_state(ax, arm, eq, label, STATE_COLOURS[k % len(STATE_COLOURS)], number=number)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), fontsize=8, ncol=1,
              frameon=False)
    save(fig, path)


def _replay_paths(ax, data: dict, arrows: bool) -> None:
    planned, tip = np.asarray(data["planned_tip"]), np.asarray(data["tip"])
    few = len(planned) <= MARKERS_UP_TO          # markers only where they stay readable
    if data.get("target") is not None:
        t = np.asarray(data["target"])
        ax.plot(t[:, 0], t[:, 1], "-", color="0.8", lw=5, zorder=2, label="traced targets")
    ax.plot(planned[:, 0], planned[:, 1], ".-" if few else "-", color="tab:blue", lw=1.5,
            ms=6, zorder=4, label="planned tip (load-controlled trace)")
    if not len(tip):
        return
    ax.plot(tip[:, 0], tip[:, 1], "x--" if few else "--", color="tab:red", lw=1.0, ms=6,
            zorder=5, label="replayed tip (length control)")
    off = ~np.asarray(data["on_branch"], bool)
    if off.any():
        ax.plot(tip[off, 0], tip[off, 1], "s", mfc="none", color="tab:red", ms=10, zorder=6,
                label="off the planned branch")
    unstable = ~np.asarray(data["stable"], bool)
    if unstable.any():
        ax.plot(tip[unstable, 0], tip[unstable, 1], "D", mfc="none", color="tab:purple",
                ms=10, zorder=6, label="unstable under length control")
    for n, k in enumerate(np.flatnonzero(np.asarray(data["jumped"], bool))):
        if arrows:
            a = tip[k - 1] if k > 0 else planned[k]
            ax.annotate("", xy=tip[k], xytext=a, zorder=7,
                        arrowprops=dict(arrowstyle="->", color="tab:purple", lw=2.0))
        ax.plot(*tip[k], "*", color="tab:purple", ms=16, zorder=7,
                label=f"jump (snap/buckling) before point {k}" if n < 3 else None)


def plot_replay(arm: Arm, data: dict, path: str | Path, title: str) -> None:
    """Left: the arm at the last replayed point with both tip paths.  Middle:
    the tip paths zoomed, points off the planned branch and jumps
    (snap/buckling, arrows from the previous point) marked.  Right: distance
    of the replayed tip (and shape) from the plan per point.

    ``data``: planned_tip (K, 2), target (K, 2) or None, tip (k, 2) replayed,
    tip_error (k,) mm, shape_error (k,) rad or None, on_branch, jumped, stable
    (k,), criterion ("tip" or "shape"), tol (threshold of that criterion),
    last_state (LengthEquilibrium or None)."""
    fig, (ax0, ax, ax2) = figure(ncols=3, figsize=(18, 6),
                                 gridspec_kw={"width_ratios": [1.2, 1.0, 1.0]})
    draw_setting(ax0, arm)
    if data.get("last_state") is not None:
        eq = data["last_state"]
        draw_state(ax0, arm, eq, f"arm at the last replayed point ({len(data['tip']) - 1})",
                   "0.3")
    _replay_paths(ax0, data, arrows=False)
    for a, t in ((ax0, "Arm and tip paths"), (ax, "Tip paths (zoom)")):
        a.set_aspect("equal", adjustable="datalim")
        a.set_xlabel("x [mm]")
        a.set_ylabel("y [mm]")
        a.grid(True, lw=0.3, alpha=0.6)
        a.set_title(t, fontsize=10)
    _replay_paths(ax, data, arrows=True)
    ax0.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), fontsize=8, ncol=2,
               frameon=False)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), fontsize=8, ncol=1,
              frameon=False)

    _replay_errors(ax2, data)
    fig.subplots_adjust(wspace=0.3)
    fig.suptitle(title, fontsize=11)
    save(fig, path)


def _replay_errors(ax2, data: dict) -> None:
    """Distance from the plan per point: the tip error in mm on the left log
    axis, the shape error in rad on its own right log axis."""
    floor = 1e-15
    err = np.asarray(data["tip_error"], float)
    k = np.arange(len(err))
    few = len(err) <= MARKERS_UP_TO
    handles = ax2.semilogy(k, np.maximum(err, floor), "o-" if few else "-", color="tab:red",
                           ms=4, label="|replayed tip - planned tip| [mm] (left axis)")
    tol_axis = ax2
    if data.get("shape_error") is not None:
        right = ax2.twinx()
        se = np.asarray(data["shape_error"], float)
        handles += right.semilogy(k, np.maximum(se, floor), "s--" if few else "--",
                                  color="tab:green", ms=4,
                                  label="max |theta - planned theta| [rad] (right axis)")
        right.set_ylabel("shape error [rad]", color="tab:green")
        right.tick_params(axis="y", colors="tab:green")
        if data["criterion"] == "shape":
            tol_axis = right
    unit = "mm (tip)" if data["criterion"] == "tip" else "rad (shape, right axis)"
    handles.append(tol_axis.axhline(data["tol"], color="0.4", ls="--", lw=1.0,
                                    label=f"on-branch threshold {data['tol']:g} {unit}"))
    for n, j in enumerate(np.flatnonzero(np.asarray(data["jumped"], bool))):
        line = ax2.axvline(j, color="tab:purple", lw=1.2, label="jump")
        if n == 0:
            handles.append(line)
    ax2.set_xlabel("point of the traced path")
    ax2.set_ylabel("tip error [mm]", color="tab:red")
    ax2.tick_params(axis="y", colors="tab:red")
    ax2.xaxis.get_major_locator().set_params(integer=True)
    ax2.set_title(f"Distance from the plan (below {floor:g} drawn at {floor:g})", fontsize=10)
    ax2.grid(True, which="both", lw=0.3, alpha=0.6)
    ax2.legend(handles=handles, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13),
               frameon=False)
