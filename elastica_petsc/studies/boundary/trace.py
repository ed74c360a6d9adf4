"""The boundary of W_0 (and of the restricted workspace) of a two-tendon arm,
traced (:func:`trace_boundary`), and the one trace per arm and mesh that a
process shares (:func:`traced_w0`, :func:`boundary_proof`)."""
from __future__ import annotations

import dataclasses
from collections import OrderedDict

import time

import numpy as np

from ...core.errors import InputError
from ...core.fem import Discretisation
from ...core.geometry import self_intersections, union_area, union_area_gradient
from ...core.model import Arm
from ...solvers.continuation import CurveTracer, OffsetParameter, RouteParameter, TraceCounts
from .faces import classify_faces, curve_polyline, loop_polygon
from .result import BoundaryResult
from .walker import (DS0, SCAN_TIP_STEP, FoldTracer, RegionBoundary, Walker, constraints_for, scan_rays,
                     tip_fold_crossings)


class BoundaryError(InputError):
    """An arm whose boundary this method cannot trace (e.g. not two tendons)."""


def _area_gradient(walker: Walker, region: RegionBoundary, start_rows, parameters,
                   length_mm: float) -> np.ndarray:
    """d|A|/dq for each parameter block of ``parameters`` (routing points
    (r_i x, r_i y), guide offsets) [mm^2 per mm]."""
    grads = []
    for velocity in walker.parameter_velocities(region, start_rows, parameters):  # (nodes, 2, k)
        poly, dense_velocity = loop_polygon(region, length_mm, node_values=velocity,
                                            monotone=True)
        grads.append(union_area_gradient(poly, dense_velocity))          # mm^2 per mm
    return np.concatenate(grads)


def trace_boundary(arm: Arm, disc: Discretisation | None = None, *, restricted: bool = True,
                   tip_folds: bool = True, route_gradients=(), offset_gradients=(),
                   progress=None, refine: float = 1.0) -> BoundaryResult:
    """The boundary of W_0 (and of the restricted workspace) of a two-tendon arm.

    Returns polygons in mm and areas in mm^2 (module docstring for the
    definitions).  ``solves`` counts nonlinear solves of the continuation's
    extended system (each: a few Newton iterations, like one warm-started
    equilibrium solve).  Raises :class:`BoundaryError` for n != 2 tendons.

    ``route_gradients``: tendon indices (0-based) whose routing points'
    derivatives of each area are wanted: ``area_gradients[name]`` holds
    d area / d(r_x, r_y) per tendon, in mm^2 per mm, from the boundary
    integral of the normal velocity of the loop's nodes (exact for the node
    polygon; the area itself is that of the Hermite-densified polygon).
    ``offset_gradients``: guide offsets, each a list of the arm points
    (:class:`~elastica_petsc.core.guided.GuidedDiscretisation` order) whose
    offset it moves together; their derivatives follow the routes' in
    ``area_gradients[name]``, in mm^2 per mm (docs/model.md §26).
    ``progress(solves, note)``, if given, is called after every continuation
    step (the number of solves is not known in advance).  ``refine``: every
    step limit (tip step, step length, first step, the scan's) divided by it,
    for a finer reference trace (:func:`~.compare.compare_traces`).
    """
    disc = Discretisation.from_arm(arm) if disc is None else disc
    if disc.n_tendons != 2:
        raise BoundaryError(
            f"boundary traces curves in a 2-D tension space: it needs exactly 2 tendons, this "
            f"arm has {disc.n_tendons} (with 3 or more the faces of the tension domain map to "
            "2-D patches of tip positions; use `workspace` to sample)")
    t0 = time.perf_counter()
    regions, polygons, areas, messages, gradients = {}, {}, {}, [], {}
    fold_crossings, fold_curves, scan, scan_solves = [], [], [], 0
    if not (np.isfinite(refine) and refine >= 1.0):
        raise InputError(f"refine must be a number >= 1, got {refine}")
    counts = TraceCounts()                 # this trace's solves, over both walks
    with CurveTracer(disc) as tracer:
        tracer.max_tip_step /= refine
        tracer.ds_max /= refine
        w0 = np.concatenate((disc.straight(), np.zeros(2)))
        wanted = (("W0", False), ("restricted", True)) if restricted else (("W0", False),)
        for name, extra in wanted:
            cons = constraints_for(tracer, arm, extra)
            # the restricted region lies in D: its walk takes over W_0's nodes
            known = regions["W0"].curves if name == "restricted" else ()
            walker = Walker(tracer, cons, progress=progress, ds0=DS0 / refine, known=known,
                            counts=counts)
            try:
                region = walker.walk(name, w0, first=cons[1], previous=cons[0])
                if name == "W0" and tip_folds:
                    fold_crossings = tip_fold_crossings(region)
                    fold_curves = FoldTracer(walker).trace(region, fold_crossings)
                    before = counts.solves
                    scan = scan_rays(walker, w0, fold_curves,
                                     max_tip_step=SCAN_TIP_STEP / refine)
                    scan_solves = counts.solves - before
                parameters = ([RouteParameter(tracer.mf, i) for i in route_gradients]
                              + [OffsetParameter(tracer.mf, a) for a in offset_gradients])
                if parameters and region.closed:
                    gradients[name] = _area_gradient(walker, region, cons[1::-1],
                                                     parameters, arm.length_mm)
            finally:
                walker.destroy()
            regions[name] = region
            poly = loop_polygon(region, arm.length_mm)
            polygons[name] = [poly]
            areas[name] = union_area(poly)
            if not region.closed:
                messages.append(f"{name}: the walk around the region did not close: "
                                f"{region.message}")
            crossings = self_intersections(poly)
            if crossings:
                faces = (", plus the faces of winding number 0 covered twice (docs/model.md "
                         "§9.1)") if name == "W0" and tip_folds else ""
                messages.append(f"{name}: the loop's image crosses itself {crossings} times "
                                "(the tip map is not one-to-one on the region); the area is "
                                f"that of the set it winds around{faces}")
    folds = np.array([x.tip for x in fold_crossings]).reshape(-1, 2) * arm.length_mm
    result = BoundaryResult(arm, regions, polygons, areas, folds, counts.solves,
                            time.perf_counter() - t0, messages, gradients, fold_curves,
                            [curve_polyline(c, arm.length_mm) for c in fold_curves], fold_crossings,
                            cell_mm=arm.length_mm / 500, scan=scan, scan_solves=scan_solves,
                            rejected_steps=counts.rejected)
    messages += [f"W0: tip-map fold not traced: {why} (no OUTSIDE_BOUNDARY verdicts)"
                 for why in result.untraced_folds]
    if tip_folds and regions["W0"].closed and not result.untraced_folds:
        result = _assemble_w0(result)
    result = dataclasses.replace(result, seconds=time.perf_counter() - t0)
    if progress is not None:
        progress(counts.solves, "traced")
    return result


def _assemble_w0(result: BoundaryResult) -> BoundaryResult:
    """W_0's area from the faces (docs/model.md §9): the set the loop winds
    around, plus the faces of winding number 0 covered twice (N > 0);
    faces whose N is undecided widen ``area_bounds_mm2``."""
    faces = classify_faces(result)
    extra = sum(f["area_mm2"] for f in faces
                if f["winding"] == 0 and (f["preimages"] or 0) > 0)
    undecided = sum(f["area_mm2"] for f in faces
                    if f["winding"] == 0 and f["preimages"] is None)
    bad = [f for f in faces if f["preimages"] is not None
           and (f["preimages"] < abs(f["winding"]) or (f["preimages"] - f["winding"]) % 2)]
    lower = result.areas_mm2["W0"] + extra
    result.areas_mm2["W0"] = lower
    result = dataclasses.replace(result, faces=faces, area_bounds_mm2=(lower, lower + undecided))
    if undecided:
        result.messages.append(f"W0: {undecided:.0f} mm^2 of faces with winding number 0 are "
                               "undecided (every ray from them crosses a fold image)")
    if bad:
        result.messages.append(f"W0: {len(bad)} faces with a preimage count inconsistent with "
                               "their winding number (N >= |w|, N = w mod 2): check the loop")
    return result


TRACE_CACHE_SIZE = 4        # W_0 traces kept by the process's default cache (least recent out)


class TraceCache:
    """W_0 boundaries per arm and mesh, at most ``size`` of them (the least
    recently used is dropped).  A caller that owns one (a map's sampler, a
    script tracing many arms) passes it to :func:`traced_w0`; the process's
    default keeps the last :data:`TRACE_CACHE_SIZE`."""

    def __init__(self, size: int = TRACE_CACHE_SIZE):
        self.size = int(size)
        self._traces: OrderedDict = OrderedDict()

    def __len__(self) -> int:
        return len(self._traces)

    @staticmethod
    def _key(arm: Arm, disc: Discretisation) -> tuple:
        return (arm.length_mm, disc.n_elements, disc.attach_nodes,
                np.asarray(disc.routes).tobytes(), arm.max_tension, tuple(arm.tendons),
                arm.gravity_m_s2, arm.tip_mass_kg, arm.mass_per_length_kg_m,
                arm.bending_stiffness_Nm2)

    def holds(self, arm: Arm, disc: Discretisation) -> bool:
        """True if the W_0 boundary of this arm and mesh is traced already."""
        return self._key(arm, disc) in self._traces

    def get(self, arm: Arm, disc: Discretisation) -> BoundaryResult:
        key = self._key(arm, disc)
        if key in self._traces:
            self._traces.move_to_end(key)
        else:
            self._traces[key] = trace_boundary(arm, disc, restricted=False)
            while len(self._traces) > self.size:
                self._traces.popitem(last=False)
        return self._traces[key]


_PROCESS_TRACES = TraceCache()


def traced_w0(arm: Arm, disc: Discretisation, cache: TraceCache | None = None) -> BoundaryResult:
    """The W_0 boundary of a two-tendon arm (no restricted level curves),
    traced on the first call and kept per arm and mesh in ``cache`` (default:
    the process's, bounded to :data:`TRACE_CACHE_SIZE` arms): the one trace
    that tip control's proof and the sampled map share."""
    return (_PROCESS_TRACES if cache is None else cache).get(arm, disc)


def boundary_proof(arm: Arm, disc: Discretisation | None = None,
                   cache: TraceCache | None = None):
    """A callable for :class:`~elastica_petsc.solvers.reach.Reacher`'s ``boundary``:
    target (units of l) -> (evidence, distance in units of l), from
    :meth:`BoundaryResult.outside` on :func:`traced_w0` (traced on the first
    call; with ``trace=False`` only a boundary already traced answers, else
    ('', nan)); arms with other than two tendons give no evidence ('')."""
    disc = Discretisation.from_arm(arm) if disc is None else disc

    traces = _PROCESS_TRACES if cache is None else cache

    def outside(target: np.ndarray, trace: bool = True) -> tuple[str, float]:
        if disc.n_tendons != 2 or not (trace or traces.holds(arm, disc)):
            return "", float("nan")
        evidence, dist = traced_w0(arm, disc, cache).outside(np.asarray(target, float) * arm.length_mm)
        return evidence, dist / arm.length_mm

    return outside
