"""``design --sweep``: the objectives over a grid of designs, over MPI ranks (issue 13).

A sweep axis is ``tendonK.route.x``, ``tendonK.route.y`` (routing point
coordinates, mm), ``tendonK.attach`` (attachment arc length, mm) or
``tendonK.guideJ.s`` (arc length of guide J, mm) -- these two must fall on
mesh nodes, as every attachment and guide does (see
:meth:`Discretisation.from_arm`), inside the arm and strictly between their
neighbours on the cable path (studies/design_nodes.py) -- or
``tendonK.offset``, each given as START:STOP:STEP (mm, STOP included).  The
grid is their Cartesian product.  Every design gets:

* the area objective of :mod:`elastica_petsc.studies.design_area`: the area
  A of the workspace W_0 ∩ {0 <= P_i <= P_max} (mm^2, on its traced boundary:
  studies/traced_area.py, as ``boundary`` measures it), whether the walk
  around it closed and left every cable clear of the arm (core/clearance.py),
  and the sign changes of det(d x_t/d p) along the loop;
* with a path (``path:CSV``): the misfit f = sum_k min_p |x_t - x_k|^2/2 and
  the number of targets reached (:func:`~elastica_petsc.studies.design.path_misfit`).

Distribution, checkpoints and ``resume`` are those of the workspace sampler
(:func:`elastica_petsc.studies.chunks.run`: one design per chunk, handed
out through the shared atomic counter; rank 0 writes the file aside and
renames it).  Each design's result depends on the design alone, so a run
equals its interrupted-and-resumed twin and does not depend on the ranks.
"""
from __future__ import annotations

import itertools
import re
import time
from dataclasses import dataclass

import numpy as np

from ..core import jsontext
from ..core.results import Result
from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.model import Arm
from .design import DesignError, path_misfit
from .design_nodes import node_point
from .chunks import ChunkResults, Grid, Stop, agree, check_out, empty_fields, run
from .traced_area import traced_area

# offset: the cable's guides and end at one offset (docs/model.md §11); guide.s:
# tendonK.guideJ.s, guide J's arc length (studies/design_nodes.py)
KINDS = ("route.x", "route.y", "attach", "offset", "guide.s")
GUIDE_S = re.compile(r"guide(\d+)\.s$")


@dataclass(frozen=True)
class Axis:
    """One swept parameter: tendon index (0-based), kind, values (mm)."""

    tendon: int
    kind: str
    values: tuple
    guide: int | None = None        # kind "guide.s": the guide (0-based)

    @property
    def name(self) -> str:
        if self.kind == "guide.s":
            return f"tendon{self.tendon + 1}.guide{self.guide + 1}.s"
        return f"tendon{self.tendon + 1}.{self.kind}"

    def node_point(self):
        """The :class:`~.design_nodes.NodePoint` of an attach or guide.s axis, else None."""
        from .design_nodes import NodePoint

        return NodePoint(self.tendon, self.guide) if self.kind in ("attach", "guide.s") else None


def parse_axis(text: str, n_tendons: int) -> Axis:
    """``tendonK.route.y=0:40:5`` -> Axis (one-line DesignError otherwise)."""
    name, eq, spec = text.partition("=")
    head, _, kind = name.partition(".")
    guide = GUIDE_S.match(kind)
    if guide is not None:
        kind = "guide.s"
    if not eq or not head.startswith("tendon") or not head[6:].isdigit() or kind not in KINDS:
        raise DesignError(f"--sweep {text!r}: expected tendonK.route.x|route.y|attach|guideJ.s|"
                          "offset=START:STOP:STEP (mm), e.g. tendon2.route.y=20:60:10")
    k = int(head[6:])
    if not 1 <= k <= n_tendons:
        raise DesignError(f"--sweep {text!r}: the arm has tendons 1..{n_tendons}")
    try:
        start, stop, step = (float(v) for v in spec.split(":"))
    except ValueError:
        raise DesignError(f"--sweep {text!r}: expected START:STOP:STEP in mm") from None
    if not (np.isfinite([start, stop, step]).all() and step > 0 and stop >= start):
        raise DesignError(f"--sweep {text!r}: need a positive STEP and STOP >= START")
    count = int(np.floor((stop - start) / step + 1e-9)) + 1
    if count > 1000:
        raise DesignError(f"--sweep {text!r}: {count} values; at most 1000 per axis")
    return Axis(k - 1, kind, tuple(start + step * np.arange(count)),
                None if guide is None else int(guide.group(1)) - 1)


def design_arm(arm: Arm, axes, values) -> Arm:
    """``arm`` with the swept parameters set to ``values`` (mm)."""
    import dataclasses

    tendons = list(arm.tendons)
    for axis, v in zip(axes, values):
        t = tendons[axis.tendon]
        point = axis.node_point()
        if point is not None:                    # attachment or guide arc length
            t = point.placed(dataclasses.replace(arm, tendons=tuple(tendons)),
                             v).tendons[axis.tendon]
        elif axis.kind == "offset":              # every guide and the end point, signed as given
            t = dataclasses.replace(t, attach_offset_mm=float(v), guides=tuple(
                dataclasses.replace(g, offset_mm=float(v)) for g in t.guides))
        else:
            route = list(t.route_mm)
            route["xy".index(axis.kind[-1])] = float(v)
            t = dataclasses.replace(t, route_mm=tuple(route))
        tendons[axis.tendon] = t
    designed = dataclasses.replace(arm, tendons=tuple(tendons))
    for axis, v in zip(axes, values):        # two points of one cable swept together
        if axis.node_point() is not None:
            axis.node_point().check(designed, v, "design")
    return designed


def sweep_grid(arm: Arm, elements: int, axes) -> Grid:
    """The designs (Cartesian product, first axis slowest), one per chunk;
    attachments and guides must fall on mesh nodes, inside the arm and in
    order along their cable (checked here, before any work; where two points
    of one cable are swept together, their order is checked per design and a
    design out of order is recorded as an error, not evaluated)."""
    if not axes:
        raise DesignError("--sweep: name at least one axis, e.g. tendon2.route.y=20:60:10")
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise DesignError("--sweep: an axis is given twice")
    points = np.array(list(itertools.product(*(a.values for a in axes))), float)
    if len(points) > 100_000:
        raise DesignError(f"--sweep: {len(points)} designs; at most 100,000")
    for a in axes:
        point = node_point(a.name, arm, "--sweep")
        if point is None:
            continue
        joint = [b for b in axes if b is not a and b.node_point() is not None
                 and b.tendon == a.tendon]
        for v in a.values:
            if joint:         # order against the other swept points: per design (design_arm)
                _on_arm_node(arm, elements, a, v)
                continue
            point.check(arm, v, "--sweep")
            Discretisation.from_arm(design_arm(arm, [a], [v]), elements)
    meta = {"axes": [{"name": a.name, "values": list(a.values)} for a in axes]}
    return Grid("design-sweep", points, tuple(np.array([k]) for k in range(len(points))), meta)


def _on_arm_node(arm: Arm, elements: int, axis: Axis, s_mm: float) -> None:
    """A one-line error unless 0 < s_mm <= l on a node of the mesh."""
    from ..core.guided import on_node

    if not 0.0 < s_mm <= arm.length_mm * (1 + 1e-12):
        raise DesignError(f"--sweep {axis.name}: s = {s_mm:g} mm lies outside the arm "
                          f"(need 0 < s <= l = {arm.length_mm:g} mm)")
    on_node(s_mm / arm.length_mm, elements, f"--sweep {axis.name}:", arm.length_mm)


def sweep_fields() -> dict:
    """Per-design fields: (shape, dtype, units, description)."""
    return {
        "area": ((), "f8", "mm^2", "area of W_0 within 0 <= P_i <= P_max (design_area)"),
        "area_converged": ((), "?", "1", "every node of the tension box's boundary solved"),
        "cables_clear": ((), "?", "1", "no cable crosses the arm at any node of the loop"),
        "det_sign_changes": ((), "i4", "1",
                             "sign changes of det(d x_t/d p) along the loop (folds)"),
        "path_misfit": ((), "f8", "mm^2", "sum over targets of min_p |x_t - x_k|^2/2 "
                                           "(NaN without a path)"),
        "path_reached": ((), "i4", "1", "targets of the path reached (-1 without a path)"),
        "error": ((), "S80", "", "why the design could not be evaluated (empty: it was)"),
        "seconds": ((), "f8", "s", "wall time of this design"),
    }


class SweepResults(ChunkResults):
    """Per-design results with the sweep's schema and file (io/design.py)."""

    def __init__(self, grid: Grid):
        super().__init__(grid, sweep_fields())

    def write(self, path, attrs, limits, timing):
        from ..io.design import write_sweep

        return write_sweep(path, self, attrs, timing)


class SweepSampler:
    """Evaluates designs (``solve_chunk`` of the workspace protocol)."""

    def __init__(self, arm: Arm, elements: int, axes, p_max: float, targets_mm=None):
        self.arm, self.elements, self.axes = arm, elements, axes
        self.p_max, self.targets = p_max, targets_mm
        self.schema = sweep_fields()

    def solve_chunk(self, points: np.ndarray, stop) -> dict | None:
        out = empty_fields(self.schema, len(points))
        out["path_reached"][:] = -1
        for k, values in enumerate(points):
            if stop():
                return None
            t0 = time.perf_counter()
            try:
                arm = design_arm(self.arm, self.axes, values)
                a = traced_area(arm, (), self.p_max, elements=self.elements)
                out["area"][k], out["area_converged"][k] = a.area_mm2, a.converged
                out["cables_clear"][k], out["det_sign_changes"][k] = a.cables_clear, \
                    a.det_sign_changes
                if self.targets is not None:
                    m = path_misfit(arm, [], self.targets, self.elements)
                    out["path_misfit"][k], out["path_reached"][k] = m.f, int(m.reached.sum())
            except (InputError, ValueError, ArithmeticError) as err:
                out["error"][k] = str(err).encode()[:80]
            out["seconds"][k] = time.perf_counter() - t0
        return out

    def destroy(self) -> None:
        pass


@dataclass(frozen=True, repr=False)
class Sweep(Result):
    """A finished (or interrupted) sweep: designs (D, k) in mm and per-design fields."""

    names: list
    designs: np.ndarray
    values: dict
    done: np.ndarray
    ranks: int
    file: str | None = None

    @property
    def complete(self) -> bool:
        return bool(self.done.all())

    def best(self) -> int | None:
        """Index of the largest area among designs evaluated without error
        whose loop solved and kept the cables clear (None if none did)."""
        ok = (self.done & self.values["area_converged"] & self.values["cables_clear"]
              & (self.values["error"] == b""))
        return None if not ok.any() else int(np.flatnonzero(ok)[np.argmax(
            self.values["area"][ok])])

    def summary(self) -> dict:
        """What ``design --sweep --json`` prints (counts, the best design)."""
        from ..io.summaries import sweep_summary

        return sweep_summary(self)


def run_sweep(arm: Arm, elements: int, axes, p_max: float, *, targets_mm=None, comm=None,
              out=None, resume: bool = False, overwrite: bool = False, progress=None,
              checkpoint_seconds: float | None = None, provenance: dict | None = None) -> Sweep:
    """Evaluate every design of ``axes`` (list of :class:`Axis`) over the ranks of
    ``comm`` (default COMM_SELF: this process alone): the area objective on the tension box
    0 <= p_i <= ``p_max`` (p = P l^2/B) and, with ``targets_mm``, the path
    misfit.  ``out`` (.h5), ``resume``, ``overwrite``, ``progress`` and
    ``checkpoint_seconds`` as in :func:`~elastica_petsc.studies.workspace.run_map`.
    Collective; returns the :class:`Sweep` on every rank."""
    from mpi4py import MPI

    comm = MPI.COMM_SELF if comm is None else comm
    lock = path = grid = None
    with Stop() as stop:
        try:
            try:
                grid = sweep_grid(arm, elements, axes)
                if not (np.isfinite(p_max) and p_max > 0):
                    raise DesignError(f"--tension-max must be positive, got p = {p_max}")
                path = None if out is None else check_out(out, resume, overwrite)
                if path is not None and comm.rank == 0:
                    from ..io.hdf5 import OutputLock
                    lock = OutputLock(path)
                error = None
            except InputError as err:
                error = str(err)
            agree(comm, error)
            attrs = _attrs(arm, elements, grid, p_max, targets_mm, provenance)
            results = run(grid, SweepSampler(arm, elements, axes, p_max, targets_mm), path,
                          attrs, {}, comm=comm, resume=resume,
                          new_results=lambda: SweepResults(grid),
                          checkpoint_seconds=checkpoint_seconds, progress=progress,
                          progress_label=f"design sweep ({comm.size} rank(s))", stop=stop)
        finally:
            if lock is not None:
                lock.release()
    sweep = None
    if comm.rank == 0:
        done = np.zeros(grid.size, bool)
        for c in np.flatnonzero(results.chunk_done):
            done[grid.chunks[c]] = True
        sweep = Sweep([a.name for a in axes], grid.points, results.data, done, comm.size,
                      None if path is None else str(path))
    return comm.bcast(sweep, root=0)


def _attrs(arm, elements, grid, p_max, targets_mm, extra) -> dict:
    """Root attributes: provenance and everything a design's result depends on."""
    from ..core.config import arm_to_dict
    from ..io.hdf5 import provenance

    attrs = provenance(arm, "design-sweep")
    meta = dict(grid.meta, tension_max=p_max, tension_max_N=float(arm.tensions_to_N(
        np.array([p_max]))[0]),
        path=None if targets_mm is None else np.asarray(targets_mm, float).tolist())
    attrs.update(mode=grid.mode, sampler="design-sweep", elements=elements,
                 n_tendons=len(arm.tendons),
                 config_json=jsontext.dumps(arm_to_dict(arm)),
                 grid_json=jsontext.dumps(meta))
    attrs.update(extra or {})
    return attrs
