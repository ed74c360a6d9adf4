"""The traced boundary of W_0 as a result: polygons, areas, fold curves and
faces, and what they prove about a target (:meth:`BoundaryResult.outside`)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...core.results import Result
from ...core.geometry import winding_number
from ...core.model import Arm
from .faces import OutsideMap


@dataclass(frozen=True, repr=False)
class BoundaryResult(Result):
    """W_0 and restricted boundaries of one arm (units: mm and mm^2).

    fold_curves: fold curves of the tip map inside D (:class:`FoldTracer`),
    fold_polylines_mm their tip images; crossings: where the intrinsic tip-map
    test changes sign on the W0 loop (each traced or with a note why not).
    """

    arm: Arm
    regions: dict                       # name -> RegionBoundary ("W0", "restricted")
    polygons_mm: dict                   # name -> list of (k, 2) closed polygons
    areas_mm2: dict
    tip_folds_mm: np.ndarray            # where det S changes sign on the W0 loop
    solves: int
    seconds: float
    messages: list = field(default_factory=list)
    area_gradients: dict = field(default_factory=dict)   # name -> d area/d routes [mm^2/mm]
    fold_curves: list = field(default_factory=list)
    fold_polylines_mm: list = field(default_factory=list)
    crossings: list = field(default_factory=list)
    cell_mm: float = 0.0
    faces: list = field(default_factory=list)            # classify_faces (W0)
    scan: list = field(default_factory=list)             # scan_rays: (ray, changes, unexplained)
    scan_solves: int = 0                                 # of ``solves``, spent on the scan
    rejected_steps: int = 0                              # of ``solves``, steps not accepted
    area_bounds_mm2: tuple = (np.nan, np.nan)            # W0: (proven in, not proven out)
    _outside: object = field(default=None, repr=False)
    _trees: dict = field(default_factory=dict, repr=False, compare=False)   # step -> k-d tree

    @property
    def area_mm2(self) -> float:
        return self.areas_mm2["W0"]

    @property
    def untraced_folds(self) -> list[str]:
        """Why each loop crossing of a tip-map fold was not traced, and curves
        that did not end on the region's boundary ([] when all are traced)."""
        out = [f"crossing at ({x.tip[0] * self.arm.length_mm:.1f}, "
               f"{x.tip[1] * self.arm.length_mm:.1f}) mm: {x.note or 'not traced'}"
               for x in self.crossings if not x.traced]
        out += [f"fold curve from ({c.points[0].tip[0] * self.arm.length_mm:.1f}, "
                f"{c.points[0].tip[1] * self.arm.length_mm:.1f}) mm ended: {c.end}"
                for c in self.fold_curves if c.end != "corner"]
        out += [f"{ray}: {bad} sign change(s) of the tip-map test on no traced fold curve"
                for ray, _, bad in self.scan if bad]
        return out

    @property
    def outside_map(self) -> "OutsideMap":
        """The unbounded component of the plane minus the W0 loop's image and
        the fold images (:class:`OutsideMap`, built on first use)."""
        if self._outside is None:
            lines = self.polygons_mm["W0"] + self.fold_polylines_mm
            object.__setattr__(self, "_outside",                      # a cache, not a field value
                               OutsideMap(lines, self.cell_mm, closed=(0,)))
        return self._outside

    def contains(self, points_mm) -> np.ndarray:
        """True where a point is in W_0 as assembled (``trace._assemble_w0``): the
        W0 loop winds around it, or it lies in a face of winding number 0
        covered twice (N > 0).  Points on the walls count by the winding rule."""
        pts = np.atleast_2d(np.asarray(points_mm, float))
        inside = winding_number(self.polygons_mm["W0"][0], pts) != 0
        twice = [f["label"] for f in self.faces if f["winding"] == 0 and (f["preimages"] or 0) > 0]
        if twice:
            inside |= np.isin(self.outside_map.label(pts), twice)
        return inside

    def preimages(self, target_mm, margin_mm: float | None = None) -> tuple[int | None, float]:
        """(N, distance in mm): the number N of states of D whose tip is
        ``target_mm``, when the traced boundary decides it (docs/model.md
        §9.1): the loop is closed, every fold of the tip map meeting it is
        traced to the region's boundary, the target lies farther than
        ``margin_mm`` (default 3 cells) from the loop's and the folds'
        images, and its face of the plane minus them is the unbounded one
        (N = 0) or a bounded face whose preimage count (:func:`classify_faces`)
        is decided and consistent with its winding number (N >= |w|,
        N = w mod 2).  N is None otherwise.  The distance is to the nearest
        traced curve."""
        target = np.asarray(target_mm, float).reshape(1, 2)
        margin = 3 * self.cell_mm if margin_mm is None else margin_mm
        dist = float(self.outside_map.distance(target)[0])
        return self._counts(target, np.array([dist > margin]))[0], dist

    def preimage_counts(self, points_mm, margin_mm: float | None = None) -> list:
        """:meth:`preimages`'s N for many points at once (a list of N or None),
        with the same margin test, made fast by a k-d tree of points sampled on
        the curves (exact distances only where the tree cannot decide)."""
        pts = np.atleast_2d(np.asarray(points_mm, float)).reshape(-1, 2)
        margin = 3 * self.cell_mm if margin_mm is None else margin_mm
        step = 0.25 * margin if margin > 0 else self.outside_map.cell
        if step not in self._trees:        # a cache (a mutable dict), built once per step
            self._trees[step] = _curve_samples_tree(self.outside_map, step)
        return self._counts(pts, _farther_than(self.outside_map, self._trees[step], step,
                                               pts, margin))

    def _counts(self, pts: np.ndarray, far: np.ndarray) -> list:
        """N (or None) of each point of ``pts``, given whether it lies farther
        than the margin from the traced curves (:meth:`preimages`)."""
        counts = [None] * len(pts)
        if not self.regions["W0"].closed or self.untraced_folds:
            return counts
        decided = {f["label"]: f["preimages"] for f in self.faces
                   if f["preimages"] is not None and f["preimages"] >= abs(f["winding"])
                   and (f["preimages"] - f["winding"]) % 2 == 0}
        outside, labels = self.outside_map.outside(pts), self.outside_map.label(pts)
        for k in np.flatnonzero(far):
            counts[k] = 0 if outside[k] else decided.get(int(labels[k]))
        return counts

    def outside(self, target_mm, margin_mm: float | None = None) -> tuple[str, float]:
        """(evidence, distance in mm): evidence is '' unless ``target_mm`` is
        proven outside W_0 by docs/model.md §9.1, i.e. :meth:`preimages` is 0:
        the target lies in the unbounded face or in a hole of W_0."""
        n, dist = self.preimages(target_mm, margin_mm)
        if n != 0:
            return "", dist
        curves = (f"loop of {len(self.regions['W0'].curves)} curves and "
                  f"{len(self.fold_curves)} tip-map fold curves")
        if self.outside_map.outside(np.asarray(target_mm, float).reshape(1, 2))[0]:
            return (f"OUTSIDE_BOUNDARY: the target lies outside the traced boundary of W_0 "
                    f"({curves}), {dist:.3g} mm from it (docs/model.md §9.1)"), dist
        return (f"OUTSIDE_BOUNDARY: the target lies in a hole of W_0, a bounded face of the "
                f"plane minus the traced boundary ({curves}) with no preimage, counted along "
                f"a ray to infinity; {dist:.3g} mm from the boundary (docs/model.md §9.1)"), dist

    def summary(self) -> dict:
        """What ``boundary --json`` prints (areas, solves, folds, messages)."""
        from ...io.summaries import boundary_summary

        return boundary_summary(self)


def _curve_samples_tree(outside_map: OutsideMap, step: float):
    """A k-d tree of points every ``step`` (mm) or less along the polylines of
    ``outside_map`` (both ends of every segment included)."""
    from scipy.spatial import cKDTree

    samples = []
    for a, b in outside_map.segments:
        n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / step), 1).astype(int)
        seg = np.repeat(np.arange(len(a)), n + 1)
        frac = (np.arange(len(seg)) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)) / n[seg]
        samples.append(a[seg] + frac[:, None] * (b - a)[seg])
    return cKDTree(np.concatenate(samples))


def _farther_than(outside_map: OutsideMap, tree, step: float, pts: np.ndarray,
                  margin: float) -> np.ndarray:
    """Whether each point lies farther than ``margin`` (mm) from the polylines of
    ``outside_map``: ``tree`` (:func:`_curve_samples_tree`, points every ``step``
    along the segments) gives d_tree - step/2 <= d <= d_tree; exact distances
    where that brackets the margin."""
    d_tree = tree.query(pts)[0]
    far = d_tree - 0.5 * step > margin
    unsure = ~far & (d_tree > margin)
    if unsure.any():
        far[unsure] = outside_map.distance(pts[unsure]) > margin
    return far
