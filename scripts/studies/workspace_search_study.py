#!/usr/bin/env python3
"""The Fig. 4 map with the global search against the local map and a tension-grid map
(issue 11; W_0 = tips of stable equilibria connected to the straight arm by quasi-static
loading with all P_i >= 0).

Inputs: three workspace files of the same arm and element count, made with

    elastica-petsc workspace --spacing 11.67 --local-only --out old.h5
    elastica-petsc workspace --spacing 11.67 --out new.h5
    elastica-petsc workspace --mode tensions --tension-spacing 1 --tension-max 170 --out tens.h5

Prints markdown:

1. counts per class in the old (local) and new (global search) maps, and the
   transitions old class -> new class;
2. the old "ended on P_i = 0" samples inside the W_0 polygon of `boundary` by more
   than one spacing (the 210 of issue 13), and how many of them the new map reaches;
3. the reached region against the tension-grid map: the fraction of stable
   tension-grid tips (lambda_min > 0) in the sampled half-disc that fall in the
   lattice cell (side = spacing, centred on a sample) of a reached sample, and the
   fraction of reached samples with tensions inside the tension grid's range
   (every p_i <= its largest p) whose cell holds a tension-grid tip (also with a
   one-cell tolerance: the cell or one of its 8 neighbours);
4. the area of W_0 in y >= 0 from the sample count (row y = 0 counts half a cell),
   with its sampling error (half a cell per unit length of the boundary polygon,
   :func:`elastica_petsc.studies.boundary.compare_with_samples`), beside the polygon's.

With ``--figure PNG``: Fig. 4 of the new map with the paths of Figs. 3a and 3b
drawn on it (as ``reproduce`` draws it; docs/fig4.png), and ``PNG``'s stem
``_restrictions.png`` (Fig. 5).

Usage: workspace_search_study.py OLD.h5 NEW.h5 TENS.h5 [--no-boundary] [--figure PNG]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

NAMES = {1: "reached", 2: "ended on P_i = 0 (local)", 3: "not converged (local)",
         4: "undecided after global search", 5: "beyond reach (proven)"}


def load(path):
    from elastica_petsc.studies.workspace import read_map
    return read_map(path)


def counts(old, new) -> None:
    so, sn = old.samples["status"], new.samples["status"]
    print(f"| class | old map ({old.sampler}) | new map ({new.sampler}) |\n|---|---|---|")
    for code, name in NAMES.items():
        print(f"| {name} | {int(np.sum(so == code))} | {int(np.sum(sn == code))} |")
    print(f"\nsamples that changed class: {int(np.sum(so != sn))} of {len(so)}\n")
    print("| old class -> new class | samples |\n|---|---|")
    for a in np.unique(so):
        for b in np.unique(sn[so == a]):
            print(f"| {NAMES[a]} -> {NAMES[b]} | {int(np.sum((so == a) & (sn == b)))} |")
    strategy = new.strategy[(sn == 1) & (so != 1)]
    seeds = sum(s.startswith("seed") for s in strategy)
    print(f"\nnewly reached: {len(strategy)} ({seeds} from a seed, "
          f"{len(strategy) - seeds} carried on from a sample the search reached)")


def cell_index(xy, origin, h):
    return np.rint((xy - origin) / h).astype(np.int64)


def against_tension_grid(maps, tens, h: float, length_mm: float) -> None:
    """Section 3 of the module doc."""
    ok = (tens.samples["status"] == 1) & (tens.samples["lambda_min"] > 0)
    tips = tens.tip_mm[ok]
    inside = (tips[:, 1] >= -h / 2) & (np.linalg.norm(tips, axis=1) <= length_mm + h / 2)
    tips = tips[inside]
    print(f"\nstable tension-grid tips in the half-disc: {len(tips)} "
          f"(of {int(ok.sum())} stable, {len(ok)} grid points)\n")
    p_top = float(tens.points.max())
    print("| map | reached samples | tension tips on a reached cell | (one-cell tolerance) "
          f"| reached samples, all p_i <= {p_top:g} | their cells holding a tension tip "
          "| (one-cell tolerance) |\n|---|---|---|---|---|---|---|")
    for label, ws in maps:
        origin = ws.points.min(axis=0)
        reached = ws.samples["status"] == 1
        cells = {tuple(c) for c in cell_index(ws.points[reached], origin, h)}
        covered = reached & np.all(ws.tensions <= p_top, axis=1)
        own = [tuple(c) for c in cell_index(ws.points[covered], origin, h)]
        tip_cells = [tuple(c) for c in cell_index(tips, origin, h)]
        tip_set = set(tip_cells)
        near = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
        on = np.mean([c in cells for c in tip_cells])
        on1 = np.mean([any((c[0] + dx, c[1] + dy) in cells for dx, dy in near)
                       for c in tip_cells])
        held = np.mean([c in tip_set for c in own])
        held1 = np.mean([any((c[0] + dx, c[1] + dy) in tip_set for dx, dy in near)
                         for c in own])
        print(f"| {label} | {int(reached.sum())} | {on:.1%} | {on1:.1%} | {len(own)} | "
              f"{held:.1%} | {held1:.1%} |")


def against_boundary(old, new, h: float, elements: int) -> None:
    """Sections 2 and 4 of the module doc."""
    import elastica_petsc as ep
    from elastica_petsc.core.model import arm_from_dict
    from elastica_petsc.core.geometry import distance_to_edges, inside_polygon
    from elastica_petsc.studies.boundary import compare_with_samples
    import json
    import h5py

    with h5py.File(new.file, "r") as fh:
        arm = arm_from_dict(json.loads(fh.attrs["config_json"]))
    bd = ep.boundary(arm, restricted=False, elements=elements)
    polys = bd.polygons_mm["W0"]
    poly = np.asarray(max(polys, key=len), float)
    targets = new.target_mm
    deep = inside_polygon(poly, targets) & (distance_to_edges(poly, targets) > h)
    was = (old.samples["status"] == 2) & deep
    now = new.samples["status"][was]
    print(f"\nold 'ended on P_i = 0' samples inside the W_0 polygon by more than one spacing: "
          f"{int(was.sum())}; in the new map: reached {int(np.sum(now == 1))}, undecided "
          f"{int(np.sum(now == 4))}")
    undecided_deep = int(np.sum((new.samples["status"] == 4) & deep))
    print(f"new map: undecided samples inside the polygon by more than one spacing: "
          f"{undecided_deep}; reached samples outside it by more than one spacing: "
          f"{int(np.sum((new.samples['status'] == 1) & ~inside_polygon(poly, targets) & (distance_to_edges(poly, targets) > h)))}")
    print("\n| map | reached | area from the sample count, y >= 0 | sampling error | polygon "
          "area, y >= 0 |\n|---|---|---|---|---|")
    for label, ws in (("old", old), ("new", new)):
        status = np.where(ws.samples["status"] == 4, 2, ws.samples["status"])
        c = compare_with_samples(poly, ws.target_mm, status, h)
        print(f"| {label} | {c['reached']} | {c['sample_area_mm2']:,.0f} mm^2 | "
              f"+- {c['sampling_error_mm2']:,.0f} mm^2 | {c['area_y_ge_0_mm2']:,.0f} mm^2 |")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("tensions")
    ap.add_argument("--no-boundary", action="store_true")
    ap.add_argument("--figure", help="draw Fig. 4 of NEW with the Fig. 3 paths into this PNG")
    args = ap.parse_args(argv)
    import petsc4py
    petsc4py.init([])
    old, new, tens = load(args.old), load(args.new), load(args.tensions)
    h = float(new.grid["spacing"])
    import h5py
    import json
    with h5py.File(args.new, "r") as fh:
        length_mm = float(json.loads(fh.attrs["config_json"])["arm"]["length_mm"])
        elements = int(fh.attrs["elements"])
    counts(old, new)
    against_tension_grid((("old (local)", old), ("new (global search)", new)), tens, h,
                         length_mm)
    if not args.no_boundary:
        against_boundary(old, new, h, elements)
    if args.figure:
        from elastica_petsc.plots.workspace import plot_workspace
        from elastica_petsc.reproduce import CURVE_CENTER_MM, TRIANGLE_CENTER_MM
        from elastica_petsc.studies.trace import convoluted_curve, paper_triangle
        paths = [("fig3a", paper_triangle(TRIANGLE_CENTER_MM)),
                 ("fig3b", convoluted_curve(CURVE_CENTER_MM))]
        plot_workspace(args.new, args.figure, paths=paths)


if __name__ == "__main__":
    main()
