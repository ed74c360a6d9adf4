"""A traced boundary against a sampled workspace map (Fig. 4): samples on the
wrong side of it, and the areas compared."""
from __future__ import annotations

import numpy as np

from ...core.geometry import (clip_half_plane, distance_to_edges, inside_polygon,
                              polyline_distance, union_area)
from .result import BoundaryResult


def compare_restricted(poly_mm: np.ndarray, targets_mm: np.ndarray, masks: dict,
                       spacing_mm: float) -> dict:
    """Agreement of the restricted polygon with a sampled map's masks (Eqs. (18)-(22)):
    samples in W0 ∩ WY ∩ WS ∩ WE ∩ WP outside it by more than one spacing, and
    reached samples failing a restriction inside it by more than one spacing."""
    admissible = masks["W0"] & masks["WY"] & masks["WS"] & masks["WE"] & masks["WP"]
    failing = masks["W0"] & ~admissible
    inside = inside_polygon(poly_mm, targets_mm)
    far = distance_to_edges(poly_mm, targets_mm) > spacing_mm
    return {"admissible": int(admissible.sum()),
            "admissible_outside": int(np.sum(admissible & ~inside & far)),
            "reached_inadmissible": int(failing.sum()),
            "reached_inadmissible_inside": int(np.sum(failing & inside & far))}


def sampled_region(targets_mm: np.ndarray, spacing_mm: float, region: str | None) -> str | None:
    """"half-disc", "disc" or None (a box: no area comparison) of a target map, from
    its ``region`` text (the workspace file's grid_json) or, for older files, its
    samples."""
    if region is not None:
        text = str(region)
        return "half-disc" if text.startswith("half-disc") else (
            "disc" if text.startswith("disc") else None)
    reach = np.max(np.abs(targets_mm))
    wide = np.ptp(targets_mm[:, 0]) >= 2 * (reach - spacing_mm)
    if wide and np.min(targets_mm[:, 1]) == 0.0:
        return "half-disc"
    return "disc" if wide and np.ptp(targets_mm[:, 1]) >= 2 * (reach - spacing_mm) else None


def compare_with_samples(poly_mm: np.ndarray, targets_mm: np.ndarray, status: np.ndarray,
                         spacing_mm: float, inside: np.ndarray | None = None,
                         distance: np.ndarray | None = None, region: str | None = None,
                         area_mm2: float | None = None) -> dict:
    """Agreement of a W_0 polygon with a sampled target map (Fig. 4, y >= 0).

    status: 1 reached, 2 needs a negative tension, 3 not converged
    (:mod:`elastica_petsc.studies.workspace`).  Counts reached samples outside
    the polygon by more than one spacing, needing-negative samples inside by
    more than one spacing, and compares areas over the map's own region: for
    the map of Fig. 4 (the half-disc y >= 0 within reach) the polygon's area in
    y >= 0 with the sample count estimate (row y = 0 counts half a cell), for
    a map of the whole disc of reach (a user arm's default) the whole traced
    area with the full count (``area_mm2``: W_0's area in the region if not
    the polygon's by the winding rule, e.g. the assembled W_0's of
    :func:`assembled_area_in_region`); the sampling error is half a cell per
    unit length of boundary.  A --box map is
    not compared (the region cuts W_0).  ``region``: the map's region text.
    ``inside``: membership of the targets in W_0 if not the polygon's winding
    rule (:meth:`BoundaryResult.contains`); ``distance``: their distance (mm)
    to the boundary if not to the polygon's edges (e.g. folds included).
    """
    inside = inside_polygon(poly_mm, targets_mm) if inside is None else inside
    distance = distance_to_edges(poly_mm, targets_mm) if distance is None else distance
    far = distance > spacing_mm
    reached, negative = status == 1, status == 2
    out = {
        "reached": int(reached.sum()),
        "reached_outside": int(np.sum(reached & ~inside & far)),
        "needs_negative": int(negative.sum()),
        "needs_negative_inside": int(np.sum(negative & inside & far)),
        "not_converged_inside": int(np.sum((status == 3) & inside)),
    }
    kind = sampled_region(targets_mm, spacing_mm, region)
    if kind is None:                     # e.g. a --box map: no area comparison
        return out
    half = kind == "half-disc"
    clipped = clip_half_plane(poly_mm) if half else np.asarray(poly_mm, float)
    weight = np.where(half & np.isclose(targets_mm[:, 1], 0.0), 0.5, 1.0)
    estimate = float(np.sum(weight[reached])) * spacing_mm**2
    perimeter = float(np.sum(np.linalg.norm(np.diff(np.vstack((clipped, clipped[:1])), axis=0),
                                            axis=1)))
    traced = union_area(clipped) if len(clipped) > 2 else 0.0
    if area_mm2 is not None:
        traced = float(area_mm2)         # W_0 as assembled (faces covered twice too)
    areas = {"compared_region": "y >= 0" if half else "whole disc of reach",
             "area_in_region_mm2": traced, "sample_area_mm2": estimate,
             "sampling_error_mm2": 0.5 * spacing_mm * perimeter}
    return out | ({"area_y_ge_0_mm2": traced} if half else {}) | areas


def compare_map(result: BoundaryResult, targets_mm: np.ndarray, status: np.ndarray,
                spacing_mm: float, region: str | None = None) -> dict:
    """:func:`compare_with_samples` for W_0 as assembled (faces and folds):
    membership by :meth:`BoundaryResult.contains`, distances to the loop's and
    the fold curves' images."""
    inside = result.contains(targets_mm) if result.faces else None
    distance = (result.outside_map.distance(targets_mm) if result.fold_polylines_mm else None)
    half = sampled_region(targets_mm, spacing_mm, region) == "half-disc"
    return compare_with_samples(result.polygons_mm["W0"][0], targets_mm, status, spacing_mm,
                                inside=inside, distance=distance, region=region,
                                area_mm2=assembled_area_in_region(result, half))


def assembled_area_in_region(result: BoundaryResult, half: bool) -> float:
    """W_0 as assembled (:meth:`BoundaryResult.contains`: where the loop winds,
    plus the faces of winding number 0 covered twice) within a map's region
    [mm^2]: all of it for the disc of reach; for the half-disc, the loop
    clipped to y >= 0 by the winding rule plus the cells of those faces with
    their centres in y >= 0 (face areas count cells, as the assembled area
    does), so that the area and the samples' membership cover one set."""
    if not half:
        return float(result.area_mm2)
    clipped = clip_half_plane(result.polygons_mm["W0"][0])
    area = union_area(clipped) if len(clipped) > 2 else 0.0
    twice = [f["label"] for f in result.faces if f["winding"] == 0 and (f["preimages"] or 0) > 0]
    if twice:
        grid = result.outside_map
        y_mm = grid.origin[1] + (np.arange(grid.shape[1]) + 0.5) * grid.cell
        cells = np.isin(grid.labels, twice) & (y_mm >= 0.0)[None, :]
        area += float(np.sum(cells)) * grid.cell ** 2
    return area


def curves_distance_mm(a: list, b: list) -> float:
    """The Hausdorff distance (mm) between two sets of open polylines (mm):
    the farthest any point of one lies from the other's segments."""
    def one_way(src, dst):
        pts = np.vstack(src)
        return float(np.max(np.min([polyline_distance(line, pts) for line in dst], axis=0)))

    return max(one_way(a, b), one_way(b, a))


def compare_traces(result: BoundaryResult, reference: BoundaryResult) -> dict:
    """A trace against a finer one of the same arm (``trace_boundary(...,
    refine=k)``): per region the relative area difference and the Hausdorff
    distance (mm) between the loops' images, and between the tip-map fold
    curves' images (the curves the proof of docs/model.md §9.1 walls off)."""
    out = {}
    for name, polys in result.polygons_mm.items():
        ref = reference.polygons_mm[name][0]
        closed = [np.vstack((p, p[:1])) for p in (polys[0], ref)]
        out[name] = {"area_mm2": result.areas_mm2[name],
                     "reference_area_mm2": reference.areas_mm2[name],
                     "relative_area_difference": abs(result.areas_mm2[name]
                                                     - reference.areas_mm2[name])
                     / reference.areas_mm2[name],
                     "hausdorff_mm": curves_distance_mm(closed[:1], closed[1:])}
    if result.fold_polylines_mm and reference.fold_polylines_mm:
        out["fold_curves"] = {"count": (len(result.fold_polylines_mm),
                                        len(reference.fold_polylines_mm)),
                              "hausdorff_mm": curves_distance_mm(result.fold_polylines_mm,
                                                                 reference.fold_polylines_mm)}
    return out
