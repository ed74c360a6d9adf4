"""Figure of ``design --objective area``: the workspace within the motor limit
before and after (the loop the objective integrates over and the tips of the
independent re-sampling), and the objective along the optimisation."""
from __future__ import annotations

import numpy as np

from .common import figure, legend_below, save


def plot_area_design(result, path) -> None:
    """``result``: an :class:`~elastica_petsc.studies.design_area.AreaDesign`."""
    fig, (ax, hx) = figure(ncols=2, figsize=(13, 6), gridspec_kw={"width_ratios": [3, 2]})
    for label, arm, area, sampled, colour in (
            ("before", result.arm_before, result.before, result.resampled_before, "0.45"),
            ("after", result.arm_after, result.after, result.resampled_after, "tab:blue")):
        if sampled is not None and sampled.tips_mm is not None:
            ax.plot(sampled.tips_mm[:, 0], sampled.tips_mm[:, 1], ".", color=colour, ms=1.5,
                    alpha=0.5)
            text = f", re-sampled {sampled.area_mm2:.0f} ± {sampled.error_mm2:.0f} mm^2"
        else:
            text = ""
        closed = np.vstack((area.loop_mm, area.loop_mm[:1]))
        ax.plot(closed[:, 0], closed[:, 1], "-", color=colour, lw=1.5,
                label=f"{label}: loop area {area.area_mm2:.0f} mm^2{text}")
        routes = np.array([t.route_mm for t in arm.tendons])
        ax.plot(routes[:, 0], routes[:, 1], "^", color=colour, ms=7, ls="none",
                label=f"routing points {label}")
        for i, r in enumerate(routes, start=1):       # r_i named: the triangles look alike
            left = label == "before"                  # before on the left, after on the right
            ax.annotate(f"r_{i}", r, xytext=(-6 if left else 6, -3), textcoords="offset points",
                        fontsize=8, color=colour, ha="right" if left else "left")
    ax.plot([0, result.arm_before.length_mm], [0, 0], "k-", lw=0.8, label="straight arm")
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    verdict = "confirmed" if result.confirmed else "NOT confirmed"
    ax.set_title(f"W_0 within 0 <= P_i <= {result.p_max * result.arm_before.force_scale_N:.3g} N"
                 f" (gain {verdict} by re-sampling)", fontsize=10)
    legend_below(ax, ncol=1, fontsize=7)             # below the axes: it hides no loop
    ok = [h["area_mm2"] if h["feasible"] else np.nan for h in result.history]
    hx.plot(np.arange(1, len(ok) + 1), ok, "o", ms=3, color="tab:blue", label="feasible")
    bad = [(k + 1, h["area_mm2"]) for k, h in enumerate(result.history)
           if not h["feasible"] and h["area_mm2"] is not None]     # None: rejected untraced
    if bad:                              # at the loop area each rejected design had
        hx.plot(*np.array(bad).T, "x", color="tab:red",
                label="rejected: loop not solved or a cable across the arm")
    untraced = [k + 1 for k, h in enumerate(result.history) if h["area_mm2"] is None]
    if untraced:                         # no loop area: marked on the axis
        hx.plot(untraced, np.zeros(len(untraced)), "|", ms=12, color="tab:red",
                transform=hx.get_xaxis_transform(), clip_on=False,
                label="rejected by the clearance check (not traced)")
    hx.set_xlabel("evaluation")
    hx.set_ylabel("loop area [mm^2]")
    legend_below(hx, ncol=1, fontsize=7)             # nor the rejected marks on the axis
    save(fig, path)

