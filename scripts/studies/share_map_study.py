#!/usr/bin/env python3
"""Tension sharing inside the workspace map (issue 11, docs/model.md §9.3): a
small three-tendon map (configs/three_tendon.toml) in target mode, plain and
with ``share``/``min_tension_N``; the fast checks are tests/test_workspace_share.py.

Variants (each a whole map, serial): plain (no sharing: the tensions tip
control found), min-norm without a floor, min-norm with every P >= ``--floor``
N, min-energy with the same floor.  Run ``--repeats`` times, interleaved
(plain, min-norm, ..., plain, min-norm, ...), so that a change of load on a
shared machine hits every variant alike.  Per variant: samples per class,
the wall time of the map (median over the repeats) and its ratio to the
plain map's, the median per reached sample of ``seconds_control`` (tip control
plus sharing), and checks: the reached set equals the plain map's without a
floor (the rule changes the tensions, not the reach); with a floor, reached
plus BELOW_FLOOR equals the plain map's reached set and every reached sample
has every P_i >= the floor; every repeat gives the same samples (bitwise).

Usage: python scripts/studies/share_map_study.py [--elements 180] [--spacing 40]
           [--box 200 560 0 400] [--floor 1] [--repeats 3] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "three_tendon.toml"
VARIANTS = {"plain": (None, 0.0), "min-norm": ("min-norm", 0.0),
            "min-norm floor": ("min-norm", None), "min-energy floor": ("min-energy", None)}


def run_variant(arm, args, share, floor_N):
    import elastica_petsc as ep

    t0 = time.perf_counter()
    wmap = ep.workspace(arm, spacing_mm=args.spacing, box_mm=args.box, elements=args.elements,
                        share=share, min_tension_N=floor_N)
    return wmap, time.perf_counter() - t0


def fingerprint(wmap) -> bytes:
    s = wmap.samples
    return b"".join(np.ascontiguousarray(s[k]).tobytes() for k in
                    ("status", "tensions", "tip", "cable_lengths", "shared"))


def main() -> None:
    from elastica_petsc.core.model import load_config
    from elastica_petsc.studies.workspace import Status

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, default=180)
    parser.add_argument("--spacing", type=float, default=40.0)
    parser.add_argument("--box", type=float, nargs=4, default=[200.0, 560.0, 0.0, 400.0])
    parser.add_argument("--floor", type=float, default=1.0, help="the floor in N")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="write the numbers here")
    args = parser.parse_args()
    arm = load_config(CONFIG)
    walls = {k: [] for k in VARIANTS}
    maps, prints = {}, {k: set() for k in VARIANTS}
    for rep in range(args.repeats):
        for key, (share, floor) in VARIANTS.items():
            wmap, wall = run_variant(arm, args, share, args.floor if floor is None else floor)
            walls[key].append(wall)
            maps[key] = wmap
            prints[key].add(fingerprint(wmap))
            print(f"repeat {rep + 1} {key}: {wall:.1f} s", flush=True)
    plain_reached = maps["plain"].samples["status"] == Status.REACHED
    base = float(np.median(walls["plain"]))
    report = {"elements": args.elements, "spacing_mm": args.spacing, "box_mm": args.box,
              "floor_N": args.floor, "repeats": args.repeats, "variants": {}}
    for key, wmap in maps.items():
        s = wmap.samples
        reached = s["status"] == Status.REACHED
        floor = wmap.min_tension_N
        checks = {"repeats_identical": len(prints[key]) == 1}
        if floor > 0:
            checks["reached_or_below_floor_equals_plain_reached"] = bool(np.array_equal(
                reached | (s["status"] == Status.BELOW_FLOOR), plain_reached))
            checks["floor_holds"] = bool(np.all(s["tensions_N"][reached] >= floor - 1e-9))
        else:
            checks["reached_equals_plain"] = bool(np.array_equal(reached, plain_reached))
        if key != "plain":
            checks["all_reached_shared"] = bool(np.all(s["shared"][reached]))
        counts = dict(zip(*np.unique(wmap.status, return_counts=True)))
        wall = float(np.median(walls[key]))
        report["variants"][key] = {
            "share": wmap.share, "min_tension_N": floor,
            "counts": {str(k): int(v) for k, v in counts.items()},
            "wall_s_median": wall, "wall_s_all": [round(w, 2) for w in walls[key]],
            "wall_ratio_to_plain": wall / base,
            "seconds_per_reached_sample_median": float(np.median(s["seconds_control"][reached]))
            if reached.any() else None,
            "samples": int(wmap.samples_total), "checks": checks}
    print(json.dumps(report, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
