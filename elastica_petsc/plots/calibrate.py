"""Figure of a calibration: measured against predicted tips, residual arrows
(scaled, the scale in the legend) and 95 % error ellipses of the predicted
tips (from the parameters' covariance); right panel: error per row."""
from __future__ import annotations

import numpy as np

from .common import figure, save

CHI2_95_2DOF = 5.991      # 95 % quantile of chi^2 with 2 degrees of freedom


def ellipse(cov, centre, points: int = 60) -> np.ndarray:
    """The 95 % ellipse of a 2 x 2 covariance about ``centre``, (points, 2)."""
    w, v = np.linalg.eigh(np.asarray(cov, float))
    t = np.linspace(0, 2 * np.pi, points)
    circle = np.column_stack((np.cos(t), np.sin(t)))
    return centre + (circle * np.sqrt(np.maximum(w, 0.0) * CHI2_95_2DOF)) @ v.T


def plot_calibration(result, path) -> None:
    data = result.data
    measured = data.tips_mm
    predicted = result.fit.evaluation.points_mm[:, 0]
    errors = np.linalg.norm(predicted - measured, axis=1)
    span = np.ptp(np.vstack((measured, predicted)), axis=0).max()
    gain = max(1.0, 0.05 * span / max(errors.max(), 1e-12))
    fig, (ax, bx) = figure(ncols=2, figsize=(12, 5.2), gridspec_kw={"width_ratios": [3, 2]})
    ax.plot(*measured.T, "o", ms=4, mfc="none", color="k", label="measured tip")
    ax.plot(*predicted.T, ".", ms=4, color="tab:blue", label="fitted model")
    d = (measured - predicted) * gain
    ax.quiver(predicted[:, 0], predicted[:, 1], d[:, 0], d[:, 1], angles="xy",
              scale_units="xy", scale=1, width=0.004, color="tab:red",
              label=f"residual x {gain:.3g}")
    scale_ell = max(1.0, gain)
    for r in range(data.n_rows):
        e = ellipse(result.tip_covariance_mm2[r] * scale_ell**2, predicted[r])
        ax.plot(*e.T, "-", lw=0.7, color="tab:green",
                label=f"95 % ellipse x {scale_ell:.3g}" if r == 0 else None)
    down = result.fit.row_weights < 1.0
    if np.any(down):
        ax.plot(*measured[down].T, "x", ms=8, color="tab:red", label="down-weighted")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(f"Tips: {data.n_rows} rows, RMS {result.stats['rms_mm']:.3g} mm")
    ax.legend(fontsize=8, loc="best")
    bx.bar(np.arange(data.n_rows), result.stats["per_row_mm"], color="tab:blue",
           label="fit")
    cv = result.cross_validation
    if cv is not None and "per_row_mm" in cv:
        bx.plot(np.arange(data.n_rows), cv["per_row_mm"], "k_", ms=8,
                label=f"{cv['folds']}-fold cross-validation")
    bx.set_xlabel("row")
    bx.set_ylabel("largest point error [mm]")
    bx.legend(fontsize=8)
    save(fig, path)
