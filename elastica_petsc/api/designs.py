"""Design of the routing points: for a path (:func:`design`), for the area of
the workspace (:func:`design_area`) and over a grid of designs
(:func:`design_sweep`)."""
from __future__ import annotations

from pathlib import Path

from ..core import inputs
from ..core.model import Arm
from .arguments import (
    takes_petsc_options as _takes_petsc_options, mesh as _mesh, progress_bar as _progress,
    points_mm as _points)


@_takes_petsc_options
def design(arm: Arm, points_mm, *, vary=("tendon1.route", "tendon2.route"),
           reach_mm: float = 100.0, margin: float = 1.1, elements: int | None = None,
           progress=None, max_seconds: float | None = None):
    """Routing points that make every point of a path reachable with P >= 0
    (TAO BLMVM on the exact gradient; ``vary``: ``"tendonK.route"`` names, and
    guide offsets ``"tendonK.offset"``/``"tendonK.guideJ.offset"``, mm).
    Returns a ``DesignResult``: ``arm_after`` is the designed arm,
    ``misfit_before``/``misfit_after`` the path's reachability, ``history``.
    ``progress`` (True: a bar, or a callable ``progress(traces, note)``)
    reports each path trace (one per objective evaluation).  ``max_seconds``:
    a time budget; once spent the optimiser stops at its next iteration and
    the result (the best design so far, both paths traced) has ``reason``
    ``"TIME_LIMIT"``."""
    import dataclasses

    from ..core.budget import TIME_LIMIT, TimeBudget, check_max_seconds
    from ..studies.design import design_for_path, parse_vary
    from ..studies.design_offsets import split_offset_names

    elements = _mesh(arm, elements).n_elements
    names, offsets = split_offset_names(list(vary), arm)
    tendons = parse_vary(names, arm.n_tendons) if names or not offsets else []
    points = _points(points_mm, arm)
    inputs.design_points(points, "points_mm")
    inputs.design_options(DESIGN_NAMES, reach_mm=reach_mm, margin=margin)
    budget = TimeBudget(check_max_seconds(max_seconds))
    with _progress(progress, "design", "path traces") as bar:
        result = design_for_path(arm, tendons, points, elements=elements, reach_mm=reach_mm,
                                 margin=margin, progress=bar, offsets=offsets,
                                 stop=budget.expired)
    return dataclasses.replace(result, reason=TIME_LIMIT) if budget.reached else result


DESIGN_NAMES = {k: k for k in ("iterations", "reach_mm", "clearance_mm", "margin",
                                "resample_cells")}


def _tension_max(arm: Arm, tension_max_N) -> float:
    """The motor limit of an area design, N -> p (a box of tensions with an area)."""
    value = inputs.tensions([inputs.number(tension_max_N, "tension_max_N", "N")], 1,
                            "tension_max_N", "N", arm.force_scale_N)[0]
    return float(arm.tensions_from_N([inputs.positive(value, "tension_max_N", "N",
                                                      at_least=1e-3)])[0])


@_takes_petsc_options
def design_area(arm: Arm, *, vary=("tendon1.route", "tendon2.route"),
                tension_max_N: float = 10.0, reach_mm: float = 100.0,
                iterations: int = 15, resample_cells: int | None = 32,
                elements: int | None = None, max_seconds: float | None = None):
    """Routing points (mm; ``vary`` may add ``"tendonK.attach"``: attachment
    arc lengths on mesh nodes, by a pattern search, and guide offsets
    ``"tendonK.offset"``/``"tendonK.guideJ.offset"``, mm) maximising the area A
    [mm^2] of the workspace W_0 within 0 <= P_i <= ``tension_max_N`` (tips of stable equilibria connected
    to the straight arm by quasi-static loading; the motor limit of Eq. (22)):
    A is the area of its traced boundary (as :func:`boundary` measures it for
    the arm with that motor limit), dA/dq the boundary integral of the normal
    component of the tip derivative (TAO BLMVM).  Both arms are then re-sampled on a tension grid; the gain
    is ``confirmed`` only if the re-sampled areas differ by more than their
    errors.  Returns an ``AreaDesign`` (``arm_after``, ``before``/``after``,
    ``resampled_before``/``resampled_after``, ``confirmed``, ``history``).
    ``max_seconds``: a time budget; once spent the optimiser stops at its next
    iteration, the re-sampling is skipped (nothing confirmed) and ``reason``
    is ``"TIME_LIMIT"``."""
    import dataclasses

    from ..core.budget import TIME_LIMIT, TimeBudget, check_max_seconds
    from ..studies.design import parse_design_variables
    from ..studies.design_area import design_for_area

    from ..studies.design_offsets import split_offset_names

    elements = _mesh(arm, elements).n_elements
    names, offsets = split_offset_names(list(vary), arm)         # guide offsets, mm
    tendons, attaches = (parse_design_variables(names, arm.n_tendons) if names
                         else ([], []))
    p_max = _tension_max(arm, tension_max_N)
    inputs.design_options(DESIGN_NAMES, reach_mm=reach_mm, iterations=iterations,
                          resample_cells=resample_cells)
    budget = TimeBudget(check_max_seconds(max_seconds))
    result = design_for_area(arm, tendons, p_max, elements=elements, attaches=attaches,
                             reach_mm=reach_mm, max_iterations=iterations,
                             resample_cells=resample_cells, stop=budget.expired,
                             offsets=offsets)
    return dataclasses.replace(result, reason=TIME_LIMIT) if budget.reached else result


@_takes_petsc_options
def design_sweep(arm: Arm, axes, *, tension_max_N: float = 10.0, path_mm=None,
                 out: str | Path | None = None, overwrite: bool = False, resume: bool = False,
                 comm=None, elements: int | None = None, progress: bool = False):
    """Evaluate a grid of designs: ``axes`` are strings
    ``"tendonK.route.x|route.y|attach|offset=START:STOP:STEP"`` (mm; attachments on
    mesh nodes).  Per design: the area [mm^2] of W_0 within 0 <= P_i <=
    ``tension_max_N`` (as :func:`design_area`) and, with ``path_mm``, the
    path's misfit [mm^2] and targets reached.  In this process alone (``comm``
    None), or collectively on every rank of ``comm``; ``progress=True``: a
    bar (default none); checkpointed to ``out`` (.h5) and
    resumable.  Returns a ``Sweep`` (``designs``, ``values``, ``best()``)."""
    from ..studies.design_sweep import parse_axis, run_sweep

    disc = _mesh(arm, elements)
    parsed = [parse_axis(text, disc.n_tendons) for text in axes]
    p_max = _tension_max(arm, tension_max_N)
    if path_mm is not None:
        inputs.design_points(_points(path_mm, arm, "path_mm"), "path_mm")
    return run_sweep(arm, disc.n_elements, parsed, p_max,
                     targets_mm=None if path_mm is None else _points(path_mm), comm=comm,
                     out=out, resume=resume, overwrite=overwrite, progress=progress)
