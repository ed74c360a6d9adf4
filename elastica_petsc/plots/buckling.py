"""Fig. 7 of the paper, computed (:mod:`elastica_petsc.studies.buckling`):
buckling of the straight segment under length control."""
from __future__ import annotations

import numpy as np

from ..studies.buckling import segment_profile
from ..studies.buckling_result import PAPER, Fig7Result
from .common import draw_arm, draw_setting, figure, finish_geometry, legend_below, save


def plot_fig7(arm, result: Fig7Result, png) -> None:
    """Fig. 7 of the paper, computed.  Left: the critical configuration and
    both post-buckling states, zoomed on the segment beyond x_1 (equal
    aspect, mm), and below it each state's deviation from its chord
    x_1 -> tip.  Right: p_2 and the constrained eigenvalue against the
    shortening of L_2 for the aligned family (perfect column) and for the
    paper's experiment (L_1 held), with the critical point, the
    clamped-column estimate and the continuation's instability."""
    r = result
    disc = r.critical.disc
    fig, axes = figure(nrows=2, ncols=2, figsize=(15, 11),
                       gridspec_kw={"width_ratios": [1.1, 1.0], "height_ratios": [1.6, 1.0]})
    (ax, ax_p), (ax_w, ax_l) = axes
    post_colours = ("tab:red", "tab:cyan")
    states = [(r.critical, f"critical: p = ({r.p1_star:.2f}, 0), cable 2 just taut", "k")]
    for k, (s, w) in enumerate(zip(r.post_buckling, r.post_deviation_mm)):
        states.append((s, f"post-buckling {k + 1}: deviation {w:+.2f} mm, p = ({s.p[0]:.2f}, "
                          f"{s.p[1]:.2f})", post_colours[k % 2]))
    straight_label = (f"straight column at the same lengths (unstable), p = "
                      f"({r.straight.p[0]:.2f}, {r.straight.p[1]:.2f})")

    _geometry_panel(ax, arm, r, states, straight_label)
    _deviation_panel(ax_w, arm, r, states)
    _tension_panel(ax_p, arm, r, post_colours)
    _eigenvalue_panel(ax_l, r)
    fig.suptitle(f"Buckling of the straight segment under length control ({PAPER}); "
                 f"{disc.n_elements} elements", fontsize=11)
    fig.tight_layout()
    save(fig, png)


def _geometry_panel(ax, arm, r: Fig7Result, states, straight_label: str) -> None:
    """The states in mm (equal aspect) around the segment beyond x_1, with a zoom."""
    l_mm, m1 = arm.length_mm, r.critical.disc.attach_nodes[0]
    # -- geometry (equal aspect, mm), the segment beyond x_1 in view, and a zoom on its middle
    draw_setting(ax, arm)
    for s, label, colour in states:
        draw_arm(ax, arm, s, label=label, colour=colour)
    x_s = r.straight.x * l_mm
    ax.plot(x_s[m1:, 0], x_s[m1:, 1], ":", color="0.3", lw=1.4, zorder=3, label=straight_label)
    x1 = r.critical.x[m1] * l_mm
    ax.plot(*x1, "o", color="k", ms=6, mfc="white", zorder=6)
    ax.annotate("x1", x1, xytext=(-18, -12), textcoords="offset points", fontsize=10)
    pts = np.vstack([q.x[m1:] * l_mm for q, _, _ in states] + [arm.routes()[1:2] * l_mm])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.08 * np.max(hi - lo)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    finish_geometry(ax, "Critical state and the two post-buckling states "
                        f"(dL2 = {r.post_dL2_mm:.2f} mm on the aligned path)")
    ax.title.set_fontsize(10)
    legend_below(ax, ncol=1, fontsize=7.5)
    # zoom: a square window (equal aspect) around the middle of the straight column
    mid = 0.5 * (x_s[m1] + x_s[-1])
    half = max(4.0 * float(np.max(np.abs(r.post_deviation_mm), initial=0.0)), 5.0)
    ins = ax.inset_axes([0.60, 0.58, 0.38, 0.38])
    for s, _, colour in states:
        x = s.x * l_mm
        ins.plot(x[:, 0], x[:, 1], "-", color=colour, lw=2.0)
    ins.plot(x_s[:, 0], x_s[:, 1], ":", color="0.3", lw=1.6)
    ins.set_xlim(mid[0] - half, mid[0] + half)
    ins.set_ylim(mid[1] - half, mid[1] + half)
    ins.set_aspect("equal")
    ins.tick_params(labelsize=6)
    ins.grid(True, lw=0.3, alpha=0.6)
    ins.set_title(f"zoom, middle of the segment ({2 * half:.0f} mm square)", fontsize=8, pad=3)
    ax.indicate_inset_zoom(ins, edgecolor="0.4")


def _deviation_panel(ax, arm, r: Fig7Result, states) -> None:
    """Each state's deviation from its chord x_1 -> tip, magnified."""
    l_mm, disc = arm.length_mm, r.critical.disc
    m1 = disc.attach_nodes[0]
    # -- deviation from the chord, magnified
    for s, label, colour in states + [(r.straight, "straight column (unstable)", "0.3")]:
        xi, w = segment_profile(disc, s.u, m1)
        ax.plot(xi * l_mm, w * l_mm, ":" if s is r.straight else "-", color=colour, lw=1.8,
                  label=label.split(":")[0])
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("distance along the chord x1 -> tip [mm]")
    ax.set_ylabel("deviation from the chord [mm]")
    ax.set_title("Deviation of the segment from its chord (not to scale)", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.legend(fontsize=8)


def _tension_panel(ax, arm, r: Fig7Result, post_colours) -> None:
    """p_2 against the shortening of L_2: aligned family, experiment, critical point."""
    # -- p_2 against the shortening of L_2
    d_al, p_al = r.aligned_shortenings_mm, r.aligned_p2
    k_hi = r.bracket[1]
    ax.plot(d_al[:k_hi], p_al[:k_hi], "o-", color="tab:blue", ms=5,
              label="aligned family (perfect column, L1 let out), stable")
    ax.plot(d_al[k_hi - 1:], p_al[k_hi - 1:], "o--", color="tab:blue", ms=5, mfc="white",
              label="aligned family, unstable under length control")
    d_ex = np.concatenate(([0.0], r.experiment_shortenings_mm))
    p_ex = np.concatenate(([r.aligned[0].p[1]], r.experiment_p2))
    ax.plot(d_ex, p_ex, "s-", color="tab:green", ms=3.5,
              label="paper's experiment: L1 held (imperfect column), stable")
    load_unstable = np.array([False] + [s.unstable_modes > 0 for s in r.experiment])
    if load_unstable.any():
        ax.plot(d_ex[load_unstable], p_ex[load_unstable], "s", color="tab:green", ms=6,
                  mfc="white", label="  ... stable only under length control (K indefinite)")
    ax.axhline(r.p_clamped, color="tab:purple", ls=":", lw=1.4,
                 label=f"clamped-column estimate tan(ka) = -k(c - a): p2 = {r.p_clamped:.2f}")
    ax.plot(r.dL2_cr_mm, r.p2_cr, "*", color="k", ms=15, zorder=6,
              label=f"critical: dL2 = {r.dL2_cr_mm:.3f} mm, p2 = {r.p2_cr:.2f}")
    if r.event_dL2_mm is not None:
        ax.axvline(r.event_dL2_mm, color="0.5", lw=1.0, ls="-.",
                     label=f"continuation: {r.event_kind} reported at dL2 = "
                           f"{r.event_dL2_mm:.3f} mm")
    for k, s in enumerate(r.post_buckling):
        ax.plot(r.post_dL2_mm, s.p[1], "D", color=post_colours[k % 2], ms=7, zorder=6,
                  label=f"post-buckling {k + 1}" if k < 2 else None)
    ax.plot(r.post_dL2_mm, r.straight_p2, "D", color="0.3", mfc="white", ms=7, zorder=6,
              label="straight column there (unstable)")
    ax.set_xlabel("shortening of L2, dL2 [mm]")
    ax.set_ylabel("tension p2 = P2 l^2 / B")
    sec = ax.secondary_yaxis("right", functions=(lambda p: p * arm.force_scale_N,
                                                   lambda P: P / arm.force_scale_N))
    sec.set_ylabel("P2 [N]")
    ax.set_title("Tension of cable 2 as L2 is shortened", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.legend(fontsize=7.5, loc="lower right")


def _eigenvalue_panel(ax, r: Fig7Result) -> None:
    """The constrained eigenvalue of the aligned family through zero."""
    d_al = r.aligned_shortenings_mm
    # -- constrained eigenvalue
    ax.plot(d_al, r.aligned_lambda, "o-", color="tab:blue", ms=5,
              label="eigenvalue of K on null(C^T) nearest zero, aligned family")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.plot(r.dL2_cr_mm, 0.0, "*", color="k", ms=15, zorder=6,
              label=f"crossing: dL2 = {r.dL2_cr_mm:.3f} mm")
    unstable = np.array([s.unstable_modes > 0 for s in r.aligned])
    if unstable.any():
        ax.plot(d_al[unstable], r.aligned_lambda[unstable], "o", ms=11, mfc="none",
                  color="tab:orange", label="K alone indefinite (unstable under load control)")
    ax.set_xlabel("shortening of L2, dL2 [mm]")
    ax.set_ylabel("lambda  (K v = lambda h v)")
    ax.set_title("Stability under length control of the perfect column", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.legend(fontsize=8)
    ax.set_xlim(-0.05 * d_al[-1], 1.05 * d_al[-1])
