#!/usr/bin/env python3
"""Hysteresis of a load-unload cycle with capstan friction at the guides
(docs/model.md §27; the fast checks are tests/test_friction_path.py).

configs/guided3.toml: tendon 1's motor tension from 0 to ``--peak`` N and back in
``--steps`` increments each way, tendon 2 slack, for mu = 0, 0.1 and 0.3.  Prints per
mu the tip's y at the peak, the largest gap between unloading and loading at one
tension, the loop's area in (P, y) and the increments in which a guide of the cable
sticks; draws docs/friction_hysteresis.png.

Usage: python scripts/studies/friction_hysteresis.py [--peak 22] [--steps 40]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.core.friction import STICK
    from elastica_petsc.core.model import load_config
    from elastica_petsc.plots.friction import plot_hysteresis
    from elastica_petsc.studies.friction import friction_path

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--peak", type=float, default=22.0, help="peak motor tension [N]")
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--out", default=str(ROOT / "docs" / "friction_hysteresis.png"))
    args = parser.parse_args()
    arm = load_config(ROOT / "configs" / "guided3.toml")
    disc = Discretisation.from_arm(arm)
    up = np.linspace(0.0, args.peak / arm.force_scale_N, args.steps + 1)
    cycle = np.concatenate((up, up[::-1][1:]))
    history = np.column_stack((cycle, np.zeros_like(cycle)))
    guides = np.flatnonzero(disc.point_tendon[np.flatnonzero(~disc.last_point)] == 0)
    paths = {}
    for mu in (0.0, 0.1, 0.3):
        start = time.perf_counter()
        fp = friction_path(disc, mu, history)
        seconds = time.perf_counter() - start
        y = fp.tip[:, 1] * arm.length_mm
        p_N = fp.p_motor[:, 0] * arm.force_scale_N
        top = args.steps
        gap = y[top:][::-1] - y[:top + 1]
        area = np.trapz(gap, p_N[:top + 1])
        stuck = 1 + np.flatnonzero(np.any(fp.modes[1:, guides] == STICK, axis=1))
        print(f"mu = {mu:g}: converged {fp.converged}, {fp.increments} increments, "
              f"{fp.iterations} Newton iterations, {seconds:.2f} s; tip y at the peak "
              f"{y[top]:.2f} mm; largest gap (unloading - loading) {gap.max():.3f} mm at "
              f"{p_N[int(np.argmax(gap))]:.2f} N; loop area {area:.2f} N mm; a guide sticks at "
              f"increments {stuck.tolist()} (P1 = {np.round(p_N[stuck], 2).tolist()} N)")
        paths[mu] = fp
    plot_hysteresis(arm, disc, paths, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
