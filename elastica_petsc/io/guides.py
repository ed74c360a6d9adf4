"""Per-point datasets of a cable routed through guides (docs/model.md §11): where
each guide and cable end sits on the arm, where the cable touches it, the angle
it wraps through there and the force it puts on the arm.  Written beside an
equilibrium (``write_equilibrium``) and per point of a trace (``write_trace``).

Layout of ``guides/`` (P points: each tendon's guides from the motor end, then
its end point)::

    guides/tendon          (P,)    1    tendon number (from 1)
    guides/is_end          (P,)    1    the cable's end point, not a guide
    guides/s               (P,)    mm   arc length of the point's node
    guides/offset          (P,)    mm   offset along the left normal
    guides/position        (P, 2)  mm   contact point X_a = x(s) + offset n(theta(s))
    guides/segment_length  (P,)    mm   straight segment from the point back toward the motor
    guides/wrap_angle      (P,)    rad  angle the cable turns through at a guide (NaN at an end)
    guides/force_N         (P, 2)  N    the cable's force on the arm at the point
"""
from __future__ import annotations

import numpy as np

from .dims import put

DIM = ("cable_point",)
DIM2 = ("cable_point", "component")
POINT_TEXT = "point of a cable on the arm: each tendon's guides from the motor end, then its end"


def has_guides(disc) -> bool:
    """A discretisation with cable paths (guides, offsets or weight)."""
    return bool(getattr(disc, "has_paths", False))


def write_guides(group, arm, eq) -> None:
    """``guides/`` of one equilibrium ``eq`` of a path discretisation (layout above)."""
    disc, l_mm = eq.disc, arm.length_mm
    table = disc.point_table(eq.theta, eq.p)
    g = group.create_group("guides")
    coords = {"cable_point": (np.arange(disc.n_points), "1", POINT_TEXT)}
    put(g, "tendon", table["tendon"] + 1, "1", "tendon number of the point (from 1)", DIM, coords)
    put(g, "is_end", table["is_end"], "1", "the cable's end point, not a guide (HDF5 boolean)",
        DIM, coords)
    put(g, "s", table["s"] * l_mm, "mm", "arc length of the point's node", DIM, coords)
    put(g, "offset", table["offset"] * l_mm, "mm",
        "offset of the point along the arm's left normal", DIM, coords)
    put(g, "position", table["position"] * l_mm, "mm",
        "contact point of the cable: x(s) + offset n(theta(s))", DIM2, coords)
    put(g, "segment_length", table["segment_length"] * l_mm, "mm",
        "length of the straight segment from the point back toward the motor", DIM, coords)
    put(g, "wrap_angle", table["wrap_angle"], "rad",
        "angle the cable turns through at the guide (NaN at a cable's end)", DIM, coords)
    put(g, "force_N", table["force"] * arm.force_scale_N, "N",
        "force of the cable on the arm at the point: P (e_a - e_a+1)", DIM2, coords)


def write_trace_guides(path_group, arm, equilibria) -> None:
    """``path/guide_position`` (K, P, 2) mm and ``path/guide_wrap_angle`` (K, P) rad
    of a traced path's equilibria (K points)."""
    disc, l_mm = equilibria[0].disc, arm.length_mm
    tables = [disc.point_table(eq.theta, eq.p) for eq in equilibria]
    coords = {"cable_point": (np.arange(disc.n_points), "1", POINT_TEXT)}
    put(path_group, "guide_position", np.array([t["position"] for t in tables]) * l_mm, "mm",
        "per path point: contact point of every guide and cable end (guides/ layout)",
        ("point", "cable_point", "component"), coords)
    put(path_group, "guide_wrap_angle", np.array([t["wrap_angle"] for t in tables]), "rad",
        "per path point: angle the cable turns through at every guide (NaN at an end)",
        ("point", "cable_point"), coords)
