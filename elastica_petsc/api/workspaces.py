"""The workspace W_0 and its restrictions (Eqs. (18)-(22)): sampled on a grid
(:func:`workspace`) or its boundary traced (:func:`boundary`)."""
from __future__ import annotations

from pathlib import Path

from ..core import inputs
from ..core.model import Arm
from .arguments import (
    takes_petsc_options as _takes_petsc_options, mesh as _mesh, floor_N as _floor_N,
    progress_bar as _progress)


MIN_SPACING_MM = 1e-100        # finer: the grid count overflows before its limit is checked


@_takes_petsc_options
def workspace(arm: Arm, *, spacing_mm: float = 20.0, box_mm=None, mode: str = "targets",
              out: str | Path | None = None, overwrite: bool = False, comm=None,
              elements: int | None = None, global_search: bool = True,
              share: str | None = None, min_tension_N: float = 0.0, progress: bool = False,
              sampler: str | None = None):
    """Sample the workspace W_0 and its restrictions (Eqs. (18)-(22), Figs. 4-5)
    on a grid of targets (``mode="targets"``: tip control to each) or of
    tensions (``"tensions"``).  Runs in this process alone (``comm`` None:
    ``MPI.COMM_SELF``, also on one rank of ``mpiexec``), or collectively on
    every rank of ``comm`` (e.g. ``MPI.COMM_WORLD``); writes HDF5 only when
    ``out`` is given.  ``progress=True``: a bar (rank 0; default none).  Returns a ``WorkspaceMap`` of per-sample
    arrays (``status``, masks ``W0``... , ``tip_mm``, ``tensions_N``).
    Targets (mm) that local tip control does not reach go through the global
    search (seeds over every loading order, reached neighbours) and are
    classed REACHED, UNDECIDED (no proof either way) or BEYOND_REACH
    (|x| > l, proven); ``global_search=False`` keeps the local verdicts.
    ``share="min-norm"``/``"min-energy"`` and ``min_tension_N`` (the floor
    P_min, N; mode targets): the tensions stored per reached target are the
    sharing rule's (n >= 3 tendons; minimum |P| or strain energy, Eq. (21));
    with a floor the map samples W_0(P_min) (reached with every P_i >= P_min;
    BELOW_FLOOR: reached with P >= 0 but no tensions >= P_min found, not a
    proof; UNIQUE_BELOW_FLOOR: two tendons, the target's only tensions are
    below P_min, proven; docs/model.md §9.3).  ``sampler`` (mode targets):
    "boundary-fill" (the default: classes from the traced boundary of W_0,
    Newton sweeps on the tip, the global search for what they miss; two
    tendons), "global-search" or "local" (docs/model.md §22)."""
    from ..io.hdf5 import H5_SUFFIXES, check_output_path
    from ..studies.workspace import run_map

    disc = _mesh(arm, elements)
    inputs.positive(spacing_mm, "spacing_mm", "mm", at_least=MIN_SPACING_MM)
    if box_mm is not None:
        box_mm = tuple(inputs.box_mm(box_mm, "box_mm"))
    if out is not None:
        check_output_path(out, overwrite, H5_SUFFIXES, "out")
    return run_map(arm, disc, mode=mode, spacing_mm=spacing_mm, box_mm=box_mm,
                   comm=comm, out=out, overwrite=overwrite, global_search=global_search,
                   share=share, min_tension_N=_floor_N(min_tension_N), progress=progress,
                   sampler=sampler)


@_takes_petsc_options
def boundary(arm: Arm, *, restricted: bool = True, elements: int | None = None,
             progress=None):
    """The boundary of the workspace W_0 of a two-tendon arm (and of the
    restricted workspace, Eqs. (18)-(22)) traced by pseudo-arclength
    continuation in tension space instead of sampling.  Returns a
    ``BoundaryResult``: ``polygons_mm`` and ``areas_mm2`` per set
    (``"W0"``, ``"restricted"``; mm, mm^2), ``solves``, ``messages`` (where
    the method stops); for W_0 also the fold curves of the tip map
    (det d x_t/dp = 0, Eq. (13): ``fold_polylines_mm``), the faces they and
    the loop cut the plane into (``faces``: winding number, preimage count),
    ``area_bounds_mm2``, ``contains(points_mm)`` and ``outside(target_mm)``
    (the OUTSIDE_BOUNDARY evidence of tip control; docs/model.md §9.1).
    ``progress`` (True: a bar, or a callable ``progress(solves, note)``)
    reports the continuation solves."""
    from ..studies.boundary import trace_boundary

    with _progress(progress, "boundary", "continuation solves") as bar:
        return trace_boundary(arm, _mesh(arm, elements), restricted=restricted, progress=bar)
