"""Figures of tip control and path tracing: Fig. 2 (descent), Fig. 3 (traced
path with arm snapshots) and Fig. 6a-c (tensions and cable lengths along the
path, tip sensitivities, curvature along the arm)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.model import Arm
from .common import TENDON_COLOURS, draw_arm, draw_setting, figure, finish_geometry, save


def plot_descent(arm: Arm, result, path) -> None:
    """Fig. 2: (a) tip iterates approaching x_d, (b) load iterates in the
    tension plane, (c) E against iteration (log scale)."""
    l_mm = arm.length_mm
    fig, (ax1, ax2, ax3) = figure(ncols=3, figsize=(16, 5))
    draw_setting(ax1, arm)
    draw_arm(ax1, arm, result.equilibrium, label="final state")
    tips = result.history_tip * l_mm
    ax1.plot(tips[:, 0], tips[:, 1], "o-", color="tab:purple", ms=4, lw=1, label="tip iterates")
    ax1.plot(*(result.target * l_mm), "r*", ms=14, label="target x_d")
    finish_geometry(ax1, f"(a) tip iterates ({result.method})")
    P = arm.tensions_to_N(result.history_p)
    if P.shape[1] >= 2:
        ax2.plot(P[:, 0], P[:, 1], "o-", color="tab:purple", ms=4)
        ax2.plot(P[0, 0], P[0, 1], "ks", label="initial guess")
        ax2.plot(P[-1, 0], P[-1, 1], "r*", ms=12, label="final tensions")
        ax2.set_xlabel("P1 [N]")
        ax2.set_ylabel("P2 [N]")
        ax2.axvline(0, color="0.6", lw=0.8)
        ax2.axhline(0, color="0.6", lw=0.8)
        ax2.legend(fontsize=8)
    else:
        ax2.plot(P[:, 0], "o-")
        ax2.set_xlabel("iteration")
        ax2.set_ylabel("P1 [N]")
    ax2.set_title("(b) load iterates")
    ax2.grid(True, lw=0.3)
    E_mm2 = np.maximum(result.history_E * l_mm ** 2, 1e-300)
    ax3.semilogy(np.arange(len(E_mm2)), E_mm2, "o-", color="tab:purple")
    ax3.axhline(result.eps * l_mm ** 2, color="r", ls="--", label="tolerance eps")
    ax3.set_xlabel("iteration")
    ax3.set_ylabel("E = |x_d - x_t|^2 / 2 [mm^2]")
    ax3.set_title("(c) cost function")
    ax3.grid(True, which="both", lw=0.3)
    ax3.legend(fontsize=8)
    save(fig, path)


def _snapshots(count: int, wanted: int = 8) -> np.ndarray:
    return np.unique(np.linspace(0, count - 1, min(wanted, count)).round().astype(int))


def draw_direction(ax, points, count: int = 10, colour: str = "tab:green") -> None:
    """Arrowheads along a path of points (mm) showing its direction of travel."""
    pts = np.asarray(points, float)
    if len(pts) < 2:
        return
    for n, k in enumerate(np.unique(np.linspace(0, len(pts) - 2, count).round().astype(int))):
        a, b = pts[k], pts[k + 1]
        if np.allclose(a, b):
            continue
        ax.annotate("", xy=b, xytext=a, zorder=6,
                    arrowprops=dict(arrowstyle="-|>", color=colour, lw=1.5, mutation_scale=16))
    ax.plot([], [], marker=r"$\rightarrow$", ls="none", color=colour, ms=12,
            label="direction of travel")


def plot_trace(arm: Arm, trace, path) -> None:
    """Fig. 3: targets (with the direction of travel), tips reached and
    snapshots of the arm along the path."""
    fig, ax = figure(figsize=(8, 6))
    draw_setting(ax, arm)
    for k in _snapshots(trace.n_points, 6):
        draw_arm(ax, arm, trace.results[k].equilibrium, colour="0.55")
    ax.plot(*trace.targets_mm.T, "-", color="tab:green", lw=3, alpha=0.5, label="targets")
    ax.plot(*trace.tips_mm.T, "-", color="tab:red", lw=1, label="tip reached")
    draw_direction(ax, trace.targets_mm, count=12)
    ax.plot(*trace.targets_mm[0], "go", ms=8, zorder=7, label="start")
    ax.plot(*trace.targets_mm[-1], "ks", mfc="none", ms=9, label="end")
    finish_geometry(ax, f"Traced path: {trace.n_points} points, max tip error "
                        f"{np.max(trace.tip_errors_mm):.1e} mm")
    save(fig, path)


def plot_tensions_lengths(arm: Arm, trace, path) -> None:
    """Fig. 6a: tensions and cable lengths along the path."""
    fig, (ax1, ax2) = figure(nrows=2, figsize=(9, 6), sharex=True)
    k = np.arange(trace.n_points)
    for i in range(trace.p.shape[1]):
        colour = TENDON_COLOURS[i % len(TENDON_COLOURS)]
        ax1.plot(k, trace.tensions_N[:, i], color=colour, label=f"P{i + 1}")
        ax2.plot(k, trace.cable_lengths_mm[:, i] - trace.cable_lengths_mm[0, i], color=colour,
                 label=f"L{i + 1} - L{i + 1}(start), L{i + 1}(start) = "
                       f"{trace.cable_lengths_mm[0, i]:.1f} mm")
    ax1.set_ylabel("tension [N]")
    ax1.set_title("(Fig. 6a) tensions and cable lengths along the path")
    ax2.set_ylabel("cable length change [mm]")
    ax2.set_xlabel("path point")
    for ax in (ax1, ax2):
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=8)
    save(fig, path)


def plot_sensitivities(arm: Arm, trace, path) -> None:
    """Fig. 6b: tip sensitivity vectors d x_t / d P_i (Eq. (13)) along the
    path, every tendon's arrows on one scale (so their lengths show how much
    more one tendon moves the tip per newton), and a polar plot of their
    magnitudes [mm/N] and directions."""
    import matplotlib.pyplot as plt

    sens = np.array([r.sensitivity.tip for r in trace.results]) * arm.length_mm  # mm per p
    sens_N = sens / arm.force_scale_N            # mm per N: p = P / (B / l^2)
    fig = plt.figure(figsize=(13, 6.2))
    ax = fig.add_subplot(1, 2, 1)
    every = max(1, trace.n_points // 30)
    ax.plot(*trace.targets_mm.T, "-", color="0.6", lw=1)
    xy = trace.tips_mm[::every]
    ends = [trace.targets_mm]
    arrow_mm = 40.0                       # the longest arrow of all tendons
    norms = np.linalg.norm(sens_N, axis=2)
    biggest = float(np.max(norms))
    for i in range(sens.shape[1]):
        v = sens_N[::every, i] * (arrow_mm / biggest if biggest > 0 else 0.0)
        ax.quiver(xy[:, 0], xy[:, 1], v[:, 0], v[:, 1], angles="xy", scale_units="xy", scale=1,
                  color=TENDON_COLOURS[i % len(TENDON_COLOURS)], width=0.005, zorder=3,
                  label=f"d x_t / d P{i + 1} (largest {np.max(norms[:, i]):.3g} mm/N)")
        ends.append(xy + v)
    ax.plot([], [], " ", label=f"one scale: {arrow_mm:g} mm of arrow = {biggest:.3g} mm/N")
    ends = np.vstack(ends)
    ax.set_xlim(ends[:, 0].min() - 5, ends[:, 0].max() + 5)
    ax.set_ylim(ends[:, 1].min() - 5, ends[:, 1].max() + 5)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title("(Fig. 6b) tip sensitivities along the path")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.1), frameon=False)
    polar = fig.add_subplot(1, 2, 2, projection="polar")
    for i in range(sens.shape[1]):
        angle = np.arctan2(sens_N[:, i, 1], sens_N[:, i, 0])
        polar.plot(angle, np.linalg.norm(sens_N[:, i], axis=1), ".",
                   color=TENDON_COLOURS[i % len(TENDON_COLOURS)], label=f"|d x_t / d P{i + 1}|")
    polar.set_title(f"magnitude [mm/N] and direction (1 N = p {1 / arm.force_scale_N:.3g})",
                    fontsize=10)
    polar.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.08), frameon=False)
    save(fig, path)


def plot_curvature(arm: Arm, trace, path) -> None:
    """Fig. 6c: curvature along the arm at several path points against the
    constant-curvature assumption (a circular arc between attachment points
    with the same end angles)."""
    fig, ax = figure(figsize=(9, 5))
    disc = trace.results[0].equilibrium.disc
    s_mid = (np.arange(disc.n_elements) + 0.5) / disc.n_elements * arm.length_mm
    nodes = [0] + sorted(set(disc.attach_nodes))
    # a closed path ends where it started: a state drawn already is named in its
    # first curve's label ("point 0 = point 328"), not drawn over it
    shown: list[tuple[list[int], object]] = []
    for k in _snapshots(trace.n_points, 5):
        eq = trace.results[k].equilibrium
        same = [names for names, first in shown
                if np.max(np.abs(first.theta - eq.theta)) < 1e-6]
        if same:
            same[0].append(int(k))
        else:
            shown.append(([int(k)], eq))
    # states drawn later are thinner: a curve drawn over an earlier, nearly equal one
    # (two path points of similar shape) leaves it visible as a band on both sides
    widths = 1.4 + 1.0 * np.arange(len(shown))[::-1]
    for j, (names, eq) in enumerate(shown):
        line, = ax.plot(s_mid, eq.curvature, lw=widths[j], zorder=2 + j,
                        label=" = ".join(f"point {k}" for k in names)
                        + (" (the path is closed)" if len(names) > 1 else ""))
        piecewise = np.empty(disc.n_elements)
        for a, b in zip(nodes[:-1], nodes[1:]):
            piecewise[a:b] = (eq.theta[b] - eq.theta[a]) / ((b - a) / disc.n_elements)
        piecewise[nodes[-1]:] = 0.0
        ax.plot(s_mid, piecewise, "--", color=line.get_color(), lw=1, zorder=2 + j)
    for k in disc.attach_nodes:
        ax.axvline(k / disc.n_elements * arm.length_mm, color="0.6", lw=0.8, ls=":")
    ax.set_xlabel("arc length s [mm]")
    ax.set_ylabel("curvature l * kappa")
    ax.set_title("(Fig. 6c) curvature along the arm (solid) vs constant-curvature "
                 "segments (dashed)")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    save(fig, path)


def plot_trace_figures(arm: Arm, trace, png) -> list[Path]:
    """All tracing figures: ``png`` and ``<stem>_tensions``, ``_sensitivity``,
    ``_curvature`` beside it."""
    png = Path(png)
    names = [png] + [png.with_name(f"{png.stem}_{tag}.png")
                     for tag in ("tensions", "sensitivity", "curvature")]
    plot_trace(arm, trace, names[0])
    plot_tensions_lengths(arm, trace, names[1])
    plot_sensitivities(arm, trace, names[2])
    plot_curvature(arm, trace, names[3])
    return names
