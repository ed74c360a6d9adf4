"""The hysteresis of a load-unload cycle with capstan friction at the guides
(docs/model.md §27): the tip against the motor tension, loading and unloading,
with the stick phases marked, and the arm at one tension on both branches."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.friction import STICK
from ..core.model import Arm
from .common import TENDON_COLOURS, figure, save

CURVE_COLOURS = ("k", "tab:blue", "tab:red", "tab:green", "tab:purple")


def _branches(p_motor: np.ndarray):
    """Indices of the loading (tension rising) and unloading parts of a cycle."""
    top = int(np.argmax(p_motor))
    return np.arange(top + 1), np.arange(top, len(p_motor))


def _arm_shape(disc, path, k: int) -> np.ndarray:
    theta = disc.split(path.states[k][:disc.size])[0]
    return disc.node_positions(theta)


def plot_hysteresis(arm: Arm, disc, paths: dict, path: str | Path, tendon: int = 0,
                    shape_at_N: float | None = None) -> None:
    """``paths``: {mu: FrictionPath of one cycle of ``tendon``'s motor tension}, mu = 0
    among them.  Left: the tip's y against the motor tension, loading solid, unloading
    dashed.  Middle: the same minus the frictionless tip (the loop), increments in which
    a guide of the cable stuck ringed.  Right: the arm and its cable at ``shape_at_N``
    (default half the peak) on both branches of the largest mu."""
    l_mm, scale_N = arm.length_mm, arm.force_scale_N
    fig, (ax, loop, shape) = figure(ncols=3, figsize=(18.0, 5.4))
    cable = np.flatnonzero(disc.point_tendon == tendon)
    guides = np.flatnonzero(np.isin(np.flatnonzero(~disc.last_point), cable))
    free = paths[0.0].tip[:, 1] * l_mm
    for k, (mu, fp) in enumerate(sorted(paths.items())):
        colour = CURVE_COLOURS[k % len(CURVE_COLOURS)]
        p_N = fp.p_motor[:, tendon] * scale_N
        y_mm = fp.tip[:, 1] * l_mm
        up, down = _branches(fp.p_motor[:, tendon])
        for axis, y in ((ax, y_mm), (loop, y_mm - free)):
            axis.plot(p_N[up], y[up], "-", color=colour, lw=1.6, label=f"mu = {mu:g}, loading")
            axis.plot(p_N[down], y[down], "--", color=colour, lw=1.6,
                      label=f"mu = {mu:g}, unloading")
        stuck = 1 + np.flatnonzero(np.any(fp.modes[1:, guides] == STICK, axis=1))  # not the start
        if stuck.size:
            loop.plot(p_N[stuck], (y_mm - free)[stuck], "o", mfc="none", color=colour, ms=6,
                      label=f"mu = {mu:g}: a guide of cable {tendon + 1} sticks")
    for axis, what in ((ax, "tip y [mm]"), (loop, "tip y minus the frictionless tip y [mm]")):
        axis.set_xlabel(f"motor tension P{tendon + 1} [N]")
        axis.set_ylabel(what)
        axis.grid(True, lw=0.3, alpha=0.6)
        axis.legend(fontsize=8, frameon=False)
    ax.set_title("tip against motor tension: load-unload cycle", fontsize=10)
    loop.set_title("hysteresis: the loop about the frictionless curve", fontsize=10)
    _draw_shapes(shape, disc, paths[max(paths)], max(paths), tendon, l_mm, scale_N, shape_at_N)
    save(fig, path)


def _draw_shapes(shape, disc, fp, mu, tendon, l_mm, scale_N, shape_at_N) -> None:
    """The arm and its cable at one tension on the loading and unloading branches."""
    p_N = fp.p_motor[:, tendon] * scale_N
    target = 0.5 * p_N.max() if shape_at_N is None else shape_at_N
    cable = np.flatnonzero(disc.point_tendon == tendon)
    up, down = _branches(fp.p_motor[:, tendon])
    for idx, style, name in ((up, "-", "loading"), (down, "--", "unloading")):
        k = idx[int(np.argmin(np.abs(p_N[idx] - target)))]
        x = _arm_shape(disc, fp, k) * l_mm
        shape.plot(x[:, 0], x[:, 1], style, color="k", lw=2.0,
                   label=f"{name}, P{tendon + 1} = {p_N[k]:.1f} N")
        points = disc.point_positions(disc.split(fp.states[k][:disc.size])[0])[cable] * l_mm
        line = np.vstack((disc.routes[tendon] * l_mm, points))
        shape.plot(line[:, 0], line[:, 1], style, color=TENDON_COLOURS[tendon], lw=1.0)
        shape.plot(points[:, 0], points[:, 1], "o", color=TENDON_COLOURS[tendon], ms=3)
    shape.set_aspect("equal")
    shape.set_xlabel("x [mm]")
    shape.set_ylabel("y [mm]")
    shape.grid(True, lw=0.3, alpha=0.6)
    shape.legend(fontsize=8, frameon=False)
    shape.set_title(f"the arm and cable {tendon + 1} at one motor tension (mu = {mu:g})",
                    fontsize=10)
