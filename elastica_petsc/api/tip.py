"""Tip control (Eqs. (10)-(12)): one target, a traced path, and a timed motor
schedule for a path (Sec. 4.5)."""
from __future__ import annotations

from ..core import inputs
from ..core.model import Arm
from .arguments import (
    takes_petsc_options as _takes_petsc_options, mesh as _mesh, guess_p as _guess,
    floor_N as _floor_N, progress_bar as _progress, sharer_for as _sharer,
    points_mm as _points)


@_takes_petsc_options
def control(arm: Arm, target_mm, *, guess_N=None, guess=None, method: str = "blmvm",
            tol_mm: float = 1e-5, global_search: bool = True, cables: str = "prefer",
            share: str | None = None, min_tension_N: float = 0.0, animate=None,
            elements: int | None = None, progress=None, max_seconds: float | None = None):
    """Non-negative tensions that put the tip on ``target_mm`` (Eqs. (10)-(12)):
    TAO BLMVM (``method="blmvm"``) or the paper's gradient descent (``"gd"``,
    Algorithm 1), from ``guess_N`` (or ``guess`` in p = P l^2/B; default 0).

    When the local solve stalls, a global search follows (other loading
    orders, a homotopy in target space) unless ``global_search=False``;
    ``reachable`` is True, False only with evidence about the whole
    (``evidence``: ``BEYOND_REACH``, |x_d| > l; ``OUTSIDE_BOUNDARY``, outside
    the traced boundary of W_0 or in a hole of it, docs/model.md §9, traced
    once per arm in the process when a short local solve first fails), or
    None when the strategies are exhausted without proof.
    ``cables``: ``"prefer"``/``"require"``/``"ignore"`` states whose cables
    cross the arm.  With n >= 3 tendons, ``share="min-norm"``/``"min-energy"``
    and ``min_tension_N`` choose among the tension sets that reach the target.
    ``animate``: a .gif/.mp4 path for the arm through the iterations.
    ``progress`` (True: a bar after 1 s, or a callable ``progress(steps, note)``)
    reports the search steps (local solves, homotopy sub-targets, the seed
    library, the boundary proof) with the stage.  With two tendons a target
    the traced boundary proves outside W_0 (or in a hole of it) is answered
    by that proof before the global search (``strategy`` "boundary proof";
    docs/model.md §21).  ``max_seconds``: a time budget; once spent the
    search stops at its next step and returns the closest tip so far with
    ``reason`` ``"TIME_LIMIT"`` and ``reachable`` None (the first local solve
    always returns a state; sharing, if asked, still runs).
    Returns a ``ControlResult`` (``tensions_N``, ``cable_lengths_mm``,
    ``tip_mm``, ``converged``, ``reachable``, ``loading``)."""
    import dataclasses

    from ..core.budget import TimeBudget, check_max_seconds
    from ..solvers.control import TipController
    from ..solvers.reach import Reacher, simplest_loading
    from ..solvers.share import share_rule
    from ..studies.boundary import boundary_proof

    elements = _mesh(arm, elements).n_elements
    target = inputs.target_mm(arm, target_mm, "target_mm")
    p0 = _guess(arm, guess_N, guess)
    inputs.tip_tolerance_mm(arm, tol_mm, "tol_mm")
    inputs.choice(cables, "cables", ("prefer", "require", "ignore"))
    inputs.choice(method, "method", ("blmvm", "gd"))
    sharer_asked = share_rule(share, _floor_N(min_tension_N))   # bad input before any solve
    max_seconds = check_max_seconds(max_seconds)
    if animate:
        from ..plots.animate import check_animation_path
        check_animation_path(animate, True, "animate")
    budget = TimeBudget(max_seconds)
    with (_progress(progress, "control", "search steps", delay=1.0) as bar,
          TipController(arm, n_elements=elements, method=method, tip_tol_mm=tol_mm) as ctl):
        reacher = Reacher(ctl, boundary=boundary_proof(arm, ctl.disc), progress=bar,
                          budget=budget)
        result = reacher.reach(arm.from_mm(target), p0=p0, global_search=global_search,
                               cables=cables)
        sharer = _sharer(arm, ctl, sharer_asked, min_tension_N)
        if sharer is not None and result.converged:
            reacher.step(f"tension sharing ({sharer.share})")
            result = sharer.solve(result)
        if not budget.expired():
            reacher.step("the simplest loading path that reaches the state", check=False)
            result = dataclasses.replace(result, loading=simplest_loading(
                ctl.solver, result.equilibrium, result.loading))
        result = dataclasses.replace(result, arm=arm)
        if animate:
            from ..plots.animate import animate_control
            animate_control(ctl, result, animate)
    return result


@_takes_petsc_options
def trace(arm: Arm, points_mm, *, step_mm: float | None = None, share: str | None = None,
          min_tension_N: float = 0.0, keep_results: bool = False, elements: int | None = None):
    """Tip control along a path, each target warm-started from the previous
    solution (Sec. 4.5, Fig. 3).  ``step_mm`` inserts points so that no two
    consecutive targets are further apart.  With n >= 3 tendons,
    ``share="min-norm"``/``"min-energy"`` (minimum |P| or strain energy,
    Eq. (21)) and ``min_tension_N`` (every P_i >= it, N) pick one tension set
    per point among those that reach it (SQP on the KKT system, followed from
    point to point), so a closed path closes in cable space.  Returns a
    ``TraceResult`` (``tips_mm``, ``tensions_N``, ``cable_lengths_mm`` per
    point; with ``keep_results`` also each point's ``ControlResult``, as
    ``to_vtk`` needs); for a timed motor schedule with an approach move see
    :func:`schedule`."""
    from ..solvers.control import TipController
    from ..studies import trace as paths

    elements = _mesh(arm, elements).n_elements
    points = _points(points_mm, arm)
    if step_mm is not None:
        points = paths.densify(points, inputs.path_step_mm(points, step_mm, "path", "step_mm"))
    with TipController(arm, n_elements=elements) as ctl:
        sharer = _sharer(arm, ctl, share, _floor_N(min_tension_N))
        return paths.trace(ctl, points, sharer=sharer, keep_results=keep_results)


@_takes_petsc_options
def schedule(arm: Arm, points_mm, *, step_mm: float = 1.0, speed_mm_s: float | None = None,
             amplitude_mm: float = 1.0, approach: bool = True, guess_N=None, guess=None,
             on_point=None, share: str | None = None, min_tension_N: float = 0.0,
             elements: int | None = None):
    """A timed motor schedule for a path (Sec. 4.5): an approach move from the
    straight arm (or the state at ``guess_N``, or ``guess`` in p) to the
    first point, then the path traced at ``step_mm`` spacing, cable lengths
    turned into spool revolutions and microsteps, timed at ``speed_mm_s``
    (default: the safe speed 2 pi f_1 * ``amplitude_mm`` from the lowest
    natural frequency, Sec. 4.5 (vi)).  ``on_point(done, total)`` reports
    progress.  ``share``/``min_tension_N``: tension sharing with n >= 3 tendons,
    as in :func:`trace` (along the approach the floor grows from 0 N at the
    straight arm to ``min_tension_N`` at the first point).
    Returns a ``TracedSchedule``: ``.schedule`` (``write_csv(path)``,
    ``lengths_at(t)``), ``.path`` and ``.approach`` (``TraceResult``), ``.speed``."""
    from ..solvers.control import TipController
    from ..studies import trace as paths
    from ..studies.schedule import trace_schedule

    elements = _mesh(arm, elements).n_elements
    p0 = _guess(arm, guess_N, guess)
    points = _points(points_mm, arm)
    points = paths.densify(points, inputs.path_step_mm(points, step_mm, "path", "step_mm"))
    if speed_mm_s is not None:
        inputs.positive(speed_mm_s, "speed_mm_s", "mm/s", at_least=1e-6)
    inputs.positive(amplitude_mm, "amplitude_mm", "mm", at_least=1e-6)
    with TipController(arm, n_elements=elements) as ctl:
        return trace_schedule(ctl, points, step_mm=step_mm, speed_mm_s=speed_mm_s,
                              amplitude_mm=amplitude_mm, approach=approach, p0=p0,
                              on_point=on_point,
                              sharer=_sharer(arm, ctl, share, _floor_N(min_tension_N)))
