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


def test_half_disc_area_counts_faces_covered_twice_as_the_membership_does():
    """compare_map over the half-disc takes W_0 as assembled: a face of winding
    number 0 covered twice (N = 2) counts in the samples' membership
    (BoundaryResult.contains) and in the area in y >= 0 alike.  The paper arm
    has no such face, so its hole around r_1 (winding 0, N = 0) is declared
    covered twice here: the area in y >= 0 grows by that face's part in y >= 0,
    measured independently by counting a fine lattice of points that
    ``contains`` adds."""
    import dataclasses

    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.core.model import load_config
    from elastica_petsc.studies.boundary.compare import compare_map
    from elastica_petsc.studies.boundary.trace import traced_w0

    arm = load_config()
    real = traced_w0(arm, Discretisation.from_arm(arm, 30))
    hole, = [f for f in real.faces if f["winding"] == 0 and f["area_mm2"] > 1e4]
    assert hole["preimages"] == 0
    faces = [dict(f, preimages=2) if f is hole else f for f in real.faces]
    twice = dataclasses.replace(real, faces=faces)
    grid = target_grid(arm.length_mm, 20.0, region="half-disc")
    status = np.where(real.contains(grid.points), 1, 2)
    areas = [compare_map(r, grid.points, status, 20.0, grid.meta["region"])["area_in_region_mm2"]
             for r in (real, twice)]
    h = 1.0
    x, y = np.meshgrid(np.arange(-100.0, 650.0, h) + h / 2, np.arange(0.0, 100.0, h) + h / 2)
    pts = np.column_stack((x.ravel(), y.ravel()))
    added = (twice.contains(pts) & ~real.contains(pts)).reshape(x.shape)
    assert not (added[-1].any() or added[:, 0].any() or added[:, -1].any())   # all in the box
    lattice = float(np.sum(added)) * h * h
    assert lattice > 1000.0                                  # the hole reaches into y >= 0
    assert abs((areas[1] - areas[0]) - lattice) < 0.05 * lattice, (areas, lattice)
    disc = target_grid(arm.length_mm, 20.0, region="disc").points     # the whole W_0
    whole = compare_map(real, disc, np.ones(len(disc), int), 20.0, "disc")
    assert whole["area_in_region_mm2"] == real.area_mm2
