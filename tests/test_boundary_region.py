"""A traced boundary and a sampled map are compared over the map's own region
(issue 26): the half-disc y >= 0 of the paper's Fig. 4, the whole disc of reach
of a user arm's default map; a box is not compared."""
from __future__ import annotations

import numpy as np

from elastica_petsc.studies.boundary.compare import compare_with_samples, sampled_region
from elastica_petsc.studies.workspace.grids import target_grid

R = 240.0                                  # W_0 here: the disc of radius R about (0, 60)
CIRCLE = np.column_stack((R * np.cos(np.linspace(0, 2 * np.pi, 721)[:-1]),
                          60.0 + R * np.sin(np.linspace(0, 2 * np.pi, 721)[:-1])))


def samples(region, spacing=10.0):
    grid = target_grid(300.0, spacing, region=region)
    pts = grid.points
    status = np.where(np.hypot(pts[:, 0], pts[:, 1] - 60.0) <= R, 1, 2)
    return pts, status, grid.meta["region"]


def test_whole_disc_map_compares_the_whole_area():
    pts, status, region = samples("disc")
    assert sampled_region(pts, 10.0, region) == sampled_region(pts, 10.0, None) == "disc"
    out = compare_with_samples(CIRCLE, pts, status, 10.0, region=region)
    assert out["compared_region"] == "whole disc of reach" and "area_y_ge_0_mm2" not in out
    exact = np.pi * R**2
    assert abs(out["area_in_region_mm2"] - exact) < 1e-3 * exact
    assert abs(out["sample_area_mm2"] - exact) < out["sampling_error_mm2"]


def test_half_disc_map_compares_the_area_in_y_ge_0():
    pts, status, region = samples("half-disc")
    assert sampled_region(pts, 10.0, region) == sampled_region(pts, 10.0, None) == "half-disc"
    out = compare_with_samples(CIRCLE, pts, status, 10.0, region=region)
    # the circle's part above y = 0: the disc minus the segment below the chord at y = 0
    c = 60.0
    segment = R**2 * np.arccos(c / R) - c * np.sqrt(R**2 - c**2)
    exact = np.pi * R**2 - segment
    assert out["compared_region"] == "y >= 0" and out["area_y_ge_0_mm2"] == out[
        "area_in_region_mm2"]
    assert abs(out["area_in_region_mm2"] - exact) < 1e-3 * exact
    assert abs(out["sample_area_mm2"] - exact) < out["sampling_error_mm2"]


def test_a_box_map_is_not_compared():
    grid = target_grid(300.0, 10.0, box=(0, 200, 0, 200))
    status = np.ones(len(grid.points), int)
    out = compare_with_samples(CIRCLE, grid.points, status, 10.0, region=grid.meta["region"])
    assert "area_in_region_mm2" not in out
