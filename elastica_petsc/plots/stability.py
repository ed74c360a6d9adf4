"""The stability figure: an equilibrium and its lowest stiffness modes (Sec. 4.3 (ii))."""
from __future__ import annotations

import numpy as np

from .common import draw_arm, draw_setting, figure, finish_geometry, save


def plot_modes(arm, eq, result, path) -> None:
    """Equilibrium (left) and its lowest modes as functions of arc length (right)."""
    fig, (ax, ax2) = figure(ncols=2, figsize=(12, 5))
    draw_setting(ax, arm)
    draw_arm(ax, arm, eq, label="equilibrium")
    finish_geometry(ax, "Equilibrium")
    s = np.linspace(0, arm.length_mm, eq.disc.n_elements + 1)
    for k, (lam, mode) in enumerate(zip(result.eigenvalues, result.modes)):
        ax2.plot(s, mode, label=f"mode {k + 1}: lambda l^2/B = {lam:.4g}")
    ax2.axhline(0, color="0.7", lw=0.8)
    ax2.set_xlabel("arc length s [mm]")
    ax2.set_ylabel("mode shape (theta, max-normalised)")
    ax2.set_title("Lowest stiffness modes")
    ax2.legend(fontsize=8)
    save(fig, path)
