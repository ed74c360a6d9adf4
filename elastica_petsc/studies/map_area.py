"""The area a sampled workspace map covers, with an error bar, and its JSON fields.

A map of targets on a square lattice of spacing h (``workspace --spacing``)
estimates the area of W_0 within its region as

    A = h^2 sum_k w_k [sample k in W_0]

(w_k = 1/2 on the line y = 0 of the default half-plane region, whose lattice
cells it halves; 1 elsewhere).  Each lattice edge joining a sample in W_0 to one
outside it is crossed by the boundary of W_0 somewhere along its length h; by
Cauchy-Crofton a curve of length P crosses on average 4 P / (pi h) such edges,
so P ~ (pi / 4) h n_cross, and the error bar is half a lattice spacing times
that perimeter, 0.5 h P (the convention of studies/boundary.py's comparison):

    error = (pi / 8) h^2 n_cross
"""
from __future__ import annotations

import math
from collections import Counter

import numpy as np


def lattice_area(points_mm, inside, spacing_mm: float, half_plane: bool) -> tuple[float, float]:
    """(area [mm^2], error [mm^2]) of the samples ``inside`` ((k,) bool) at
    ``points_mm`` ((k, 2), on a lattice of ``spacing_mm``), module docstring."""
    pts = np.asarray(points_mm, float)
    inside = np.asarray(inside, bool)
    h = float(spacing_mm)
    weight = np.where(half_plane & np.isclose(pts[:, 1], 0.0, atol=1e-9 * h), 0.5, 1.0)
    area = float(np.sum(weight[inside])) * h * h
    cells = np.rint((pts - pts.min(axis=0)) / h).astype(np.int64)
    state = {tuple(c): bool(v) for c, v in zip(cells, inside)}
    crossings = sum(1 for (i, j), v in state.items() if v
                    for n in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1))
                    if state.get(n) is False)
    return area, math.pi / 8.0 * h * h * crossings


def map_json(result, box_mm=None) -> dict:
    """The JSON fields of a workspace map (docs/json.md): status counts keyed by
    status code, the lattice (``spacing_mm``, ``box_mm`` as given, None for the
    default half-disc, ``region``) and, for a map of targets, the area of W_0 in
    that region with its error bar."""
    counts = Counter(str(s) for s in result.status)
    status_counts = {"REACHED": counts.pop("REACHED", 0)}
    status_counts.update(sorted((k, n) for k, n in counts.items() if k != "NOT_COMPUTED"))
    meta = result.grid
    out = {"status_counts": status_counts, "mode": result.mode,
           "region": meta.get("region"), "spacing_mm": None, "box_mm": None,
           "area_mm2": None, "area_error_mm2": None}
    if result.mode != "targets":
        return out
    out.update(spacing_mm=float(meta["spacing"]),
               box_mm=None if box_mm is None else [float(v) for v in box_mm])
    area, error = lattice_area(result.points, result.masks["W0"] & result.done,
                               meta["spacing"], half_plane=str(meta["region"]).startswith("half"))
    out.update(area_mm2=round(area, 3), area_error_mm2=round(error, 3))
    return out
