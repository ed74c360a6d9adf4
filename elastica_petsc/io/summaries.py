"""The JSON summaries of the studies (what ``--json`` prints and ``summary()``
returns), built from their results in the user's units: mm, N, p = P l^2/B.
The command line only prints them (cli/); the single-state summaries are in
:mod:`.summary`."""
from __future__ import annotations

import math

import numpy as np

from ..core.clearance import state_cable_clear
from .summary import equilibrium_summary, rounded

def control_summary(arm, result) -> dict:
    """A tip-control result (:class:`~elastica_petsc.solvers.control.ControlResult`) on ``arm``."""
    state = equilibrium_summary(arm, result.equilibrium)
    return {
        "converged": bool(result.converged),
        "reachable": result.reachable,
        "evidence": result.evidence,
        "reason": result.reason,
        "local_reason": result.local_reason or result.reason,
        "strategy": result.strategy,
        "loading": None if result.loading is None else result.loading.to_json(),
        "tao_reason": result.tao_reason,
        "message": result.message,
        "method": result.method,
        "iterations": int(result.iterations),
        "evaluations": int(result.evaluations),
        "target_mm": rounded(result.target_mm),
        "tip_mm": state["tip_mm"],
        "tip_error_mm": float(f"{result.tip_error_mm:.6g}"),
        "tensions": state["tensions"],
        "tensions_N": state["tensions_N"],
        "cable_lengths_mm": state["cable_lengths_mm"],
        "attachments_mm": state["attachments_mm"],
        "cable_clear": state["cable_clear"],
        "on_bound": [{"tendon": i, "bound": side} for i, side in result.on_bound],
        "tip_sensitivity": [rounded(v * arm.length_mm) for v in result.sensitivity.tip],
        "stable": state["stable"],
        "strain_energy": state["strain_energy"],
        "kappa_max": state["kappa_max"],
        "units": {"tensions": "P l^2/B", "tensions_N": "N", "tip_sensitivity":
                  "d x_t / d p_i in mm per unit p (Eq. (13)), one [x, y] per tendon"},
    }


def boundary_summary(result) -> dict:
    """A traced boundary (:class:`~elastica_petsc.studies.boundary.BoundaryResult`)."""
    return {
        "area_mm2": result.areas_mm2["W0"],
        "restricted_area_mm2": result.areas_mm2.get("restricted"),
        "solves": result.solves,
        "scan_solves": result.scan_solves,
        "rejected_steps": result.rejected_steps,
        "scan": [{"ray": ray, "sign_changes": n, "unexplained": bad}
                 for ray, n, bad in result.scan],
        "seconds": result.seconds,
        "area_bounds_mm2": list(result.area_bounds_mm2),
        "fold_curves": len(result.fold_curves),
        "untraced_folds": result.untraced_folds,
        "closed": {k: r.closed for k, r in result.regions.items()},
        "curves": {k: [c.constraint for c in r.curves] for k, r in result.regions.items()},
        "messages": result.messages,
        "polygon_convention": "closed (last vertex joins the first); inside = nonzero "
                              "winding number; no separate hole lists",
    }


def path_design_summary(result, elements: int | None = None) -> dict:
    """A path design (:class:`~elastica_petsc.studies.design.DesignResult`)."""
    count = int(result.misfit_before.reached.size)
    before, after = result.misfit_before, result.misfit_after
    best = min(result.history, key=lambda h: h["f_mm2"])
    return {
        "objective": "path", "elements": elements, "targets": count,
        "margin_path_reached": best["reached"], "margin_path_misfit_mm2": best["f_mm2"],
        "smallest_tension_after_N": float(np.min(after.p) * result.arm_after.force_scale_N),
        "reached_before": int(before.reached.sum()), "reached_after": int(after.reached.sum()),
        "max_error_before_mm": float(before.errors_mm.max()),
        "max_error_after_mm": float(after.errors_mm.max()),
        "routes_before_mm": [list(t.route_mm) for t in result.arm_before.tendons],
        "routes_after_mm": [list(t.route_mm) for t in result.arm_after.tendons],
        "iterations": result.iterations, "evaluations": result.evaluations,
        "seconds": result.seconds, "tao_reason": result.reason,
        **_offset_summary(result),
    }


def _offset_summary(result) -> dict:
    """Guide offsets varied by a path or area design (studies/design_offsets.py), mm."""
    offsets = getattr(result, "offsets", None)
    if not offsets:
        return {}
    return {"offset_variables": [v.name for v in offsets],
            "offsets_before_mm": [v.value_mm(result.arm_before) for v in offsets],
            "offsets_after_mm": [v.value_mm(result.arm_after) for v in offsets]}


def area_summary(r, elements: int | None = None) -> dict:
    """The JSON summary of an area design (mm, mm^2, N)."""
    def sampled(s):
        if s is None:                            # not re-sampled (an infeasible start)
            return None
        return {"area_mm2": s.area_mm2, "error_mm2": s.error_mm2, "samples": s.samples,
                "reached": s.reached, "stable": s.stable, "cables_clear": s.cables_clear}
    force = r.arm_before.force_scale_N
    return {
        "objective": "area", "elements": elements, "tension_max": r.p_max,
        "tension_max_N": r.p_max * force,
        "area_before_mm2": r.before.area_mm2, "area_after_mm2": r.after.area_mm2,
        "fold_sign_changes_before": r.before.det_sign_changes,
        "fold_sign_changes_after": r.after.det_sign_changes,
        "resampled_before": sampled(r.resampled_before),
        "resampled_after": sampled(r.resampled_after),
        "confirmed": bool(r.confirmed),
        "routes_before_mm": [list(t.route_mm) for t in r.arm_before.tendons],
        "routes_after_mm": [list(t.route_mm) for t in r.arm_after.tendons],
        "attach_before_mm": [t.attach_mm for t in r.arm_before.tendons],
        "attach_after_mm": [t.attach_mm for t in r.arm_after.tendons],
        **_offset_summary(r),
        "iterations": r.iterations, "evaluations": len(r.history), "seconds": r.seconds,
        "tao_reason": r.reason,
    }


def sweep_summary(sweep) -> dict:
    """A design sweep (:class:`~elastica_petsc.studies.design_sweep.Sweep`): counts and the best design."""
    v = sweep.values
    best = sweep.best()
    return {"objective": "sweep", "designs": int(len(sweep.designs)),
            "done": int(sweep.done.sum()),
            "complete": sweep.complete, "ranks": sweep.ranks, "axes": sweep.names,
            "file": sweep.file,
            "errors": int(np.sum(v["error"][sweep.done] != b"")),
            "not_converged": int(np.sum(~v["area_converged"][sweep.done])),
            "cables_crossing": int(np.sum(~v["cables_clear"][sweep.done])),
            "best": None if best is None else {
                "design_mm": dict(zip(sweep.names, sweep.designs[best].tolist())),
                "area_mm2": float(v["area"][best]),
                "path_reached": int(v["path_reached"][best])},
            "seconds_designs": float(np.nansum(v["seconds"]))}


def trace_summary(result, schedule=None) -> dict:
    """A traced path (:class:`~elastica_petsc.studies.trace.TraceResult`); with its
    motor ``schedule``, the microstep rounding."""
    mono = result.monotonic_fraction()
    return {
        "points": int(result.n_points),
        "reached": int(np.sum(result.converged)),
        "all_reached": bool(result.all_converged),
        "max_tip_error_mm": float(f"{np.max(result.tip_errors_mm):.6g}"),
        "iterations_median": float(np.median(result.iterations[1:] if result.n_points > 1
                                             else result.iterations)),
        "iterations_max_warm": int(np.max(result.iterations[1:])) if result.n_points > 1 else None,
        "iterations_first": int(result.iterations[0]),
        "seconds": round(result.seconds, 4),
        "seconds_per_point": round(result.seconds / result.n_points, 6),
        "tension_range_N": [rounded([result.tensions_N[:, i].min(), result.tensions_N[:, i].max()])
                            for i in range(result.tensions_N.shape[1])],
        "cable_length_range_mm": [rounded([result.cable_lengths_mm[:, i].min(),
                                           result.cable_lengths_mm[:, i].max()])
                                  for i in range(result.cable_lengths_mm.shape[1])],
        "monotonic_fraction": [None if np.isnan(v) else round(float(v), 4) for v in mono],
        "work_fraction": round(float(result.work_fraction()), 4),
        "closes": bool(np.allclose(result.targets_mm[0], result.targets_mm[-1], atol=1e-9)),
        "closure_cable_length_change_mm": float(f"{np.max(np.abs(result.cable_lengths_mm[-1] - result.cable_lengths_mm[0])):.3g}"),
        "cable_crossing_points": [int(sum(1 for r in result.results
                                          if not state_cable_clear(r.equilibrium)[i]))
                                  for i in range(result.tensions_N.shape[1])],
        "not_reached_undecided": int(sum(1 for r in result.results
                                         if not r.converged and r.reachable is None)),
        "not_reached_proven_unreachable": int(sum(1 for r in result.results
                                                  if r.reachable is False)),
        "loading_first_point": (None if not result.results or result.results[0].loading is None
                                else result.results[0].loading.to_json()),
        "loading_note": "each point's loading path from the straight arm is in the HDF5 "
                        "/loading tree (/path/loading_node); `solve --from FILE --point K` "
                        "replays it",
        "max_rounding_error_mm": None if schedule is None else
        float(f"{np.max(np.abs(schedule.rounding_error_mm)):.3g}"),
        "mm_per_microstep": None if schedule is None else float(f"{schedule.mm_per_step:.6g}"),
        "min_tension_N": rounded(result.tensions_N.min(axis=0)),
    }


def point_entries(result, schedule) -> list[dict]:
    """One JSON entry per path point (mm, N, p = P l^2/B, s)."""
    times = schedule.time_s[schedule.path_rows()]
    out = []
    for k, r in enumerate(result.results):
        out.append({"point": k, "target_mm": rounded(result.targets_mm[k]),
                    "tip_mm": rounded(result.tips_mm[k]), "reached": bool(result.converged[k]),
                    "tip_error_mm": float(f"{result.tip_errors_mm[k]:.6g}"),
                    "tensions": rounded(result.p[k]), "tensions_N": rounded(result.tensions_N[k]),
                    "cable_lengths_mm": rounded(result.cable_lengths_mm[k]),
                    "iterations": int(result.iterations[k]), "reason": r.reason,
                    "time_s": None if math.isnan(times[k]) else round(float(times[k]), 4)})
    return out


def schedule_summary(planned, guessed: bool | None = None) -> dict:
    """The approach and the timing of the schedule (for the summary); ``guessed``:
    whether the approach started at a guess (None: not known)."""
    sched, before = planned.schedule, planned.approach
    out = {"approach_start": None if before is None or guessed is None else
           ("load-controlled state at --guess" if guessed else "straight arm"),
           "approach_points": 0 if before is None else int(before.n_points),
           "approach_reached": None if before is None else int(before.converged.sum()),
           "schedule_rows": int(sched.n_rows),
           "speed_mm_s": planned.speed["speed_mm_s"],
           "speed_source": planned.speed["speed_source"],
           "duration_s": None if math.isnan(sched.duration_s) else round(sched.duration_s, 3)}
    out.update(motor_summary(sched))
    return out


def motor_summary(sched) -> dict:
    """Peak motor rates of the timed schedule, the limits and where they slowed the tip."""
    from collections import Counter

    from ..core.motion import rates_and_accelerations

    if math.isnan(sched.duration_s) or sched.n_rows < 2:
        return {"motor_limits": None, "peak_speed_steps_s": None, "peak_accel_steps_s2": None,
                "rows_slowed_by_motor": 0, "slowed_by": {}, "slowed_rows": [],
                "time_bound_s": None}
    r, a = rates_and_accelerations(sched.positions_steps, sched.durations_s[1:])
    labels = [str(x) for x in sched.limited_by]
    slowed = [x for x in labels if x.startswith(("speed_", "accel_"))]
    return {"motor_limits": None if sched.limits is None else sched.limits.to_json(),
            "peak_speed_steps_s": rounded(abs(r).max(axis=0)),
            "peak_accel_steps_s2": rounded(abs(a).max(axis=0)),
            "rows_slowed_by_motor": len(slowed), "slowed_by": dict(sorted(Counter(slowed).items())),
            "slowed_rows": slowed_runs(labels), "time_bound_s": round(sched.speed_bound_s, 6)}


def slowed_runs(labels: list[str]) -> list[list]:
    """[first row, last row, limit code] of each run of rows a motor limit slowed."""
    runs = []
    for k, label in enumerate(labels):
        if not label.startswith(("speed_", "accel_")):
            continue
        if runs and runs[-1][1] == k - 1 and runs[-1][2] == label:
            runs[-1][1] = k
        else:
            runs.append([k, k, label])
    return runs


def state_summary(arm, state, control: str, found=None) -> dict:
    """One equilibrium (a LengthEquilibrium) in the user's units.  ``stable`` is
    the stability under the command's own control (length or load)."""
    l_mm = arm.length_mm
    s = equilibrium_summary(arm, state)
    length_modes = int(getattr(state, "length_unstable_modes", -1))
    by_length = None if length_modes < 0 else length_modes == 0
    slack = np.asarray(state.slack_mm, float)
    slack = np.where(slack > 0.0, slack, 0.0)
    s.update({
        "stable_under_load_control": bool(state.stable),
        "stable_under_length_control": by_length,
        "unstable_modes_length_control": length_modes,
        "stable": by_length if control == "length" else bool(state.stable),
        "stability_control": control,
        "lengths_requested_mm": rounded(state.lengths_requested * l_mm),
        "slack_mm": rounded(slack),
        "taut": [bool(t) for t in state.taut],
        "jumps_at_lengths_mm": [rounded(np.asarray(L) * l_mm) for L in state.jumps],
        "instabilities_at_lengths_mm": [rounded(np.asarray(L) * l_mm)
                                        for L in state.instabilities],
    })
    s["number"] = int(found.number) if found is not None and found.number else 1
    if found is not None:
        s["found_from"] = {"start": found.start, "method": found.method,
                           "attempts_reaching_it": int(found.hits)}
    s["units"].update({"slack_mm": "mm", "lengths_requested_mm": "mm",
                       "cable_lengths_mm": "mm"})
    return s


def search_summary(result, settings: dict | None = None) -> dict:
    """How a SearchResult was obtained, and its coverage; ``settings``: the
    effort settings of the command line (None: the method is not described)."""
    method = _search_method(result, settings) if settings is not None else None
    return {"method": method, "effort": settings,
            "coverage": {"by_method": {m: {"attempts": a, "new_states": k}
                                       for m, (a, k) in result.methods().items()},
                         "last_new_state_at_attempt": result.last_new_attempt,
                         "curves": dict(result.curves)},
            "starts": len(result.starts), "attempts": int(result.attempts),
            "failed": int(result.failures), "refound": int(result.duplicates),
            "start_labels": list(result.starts),
            "found_from": [{"state": f.number, "start": f.start, "method": f.method,
                            "attempts_reaching_it": int(f.hits)}
                           for f in result.states],
            "complete": False, "outcome": result.outcome, "stopped": result.stopped}


def _search_method(result, settings: dict) -> str:
    """The search method of :func:`search_summary` in one sentence."""
    what = "cable lengths" if result.control == "length" else "tensions"
    how = "length continuation" if result.control == "length" else "loading paths"
    method = (f"deflated continuation in the {what} from the straight arm along every "
              f"loading order ({settings['steps']} points per segment; Farrell et al. 2016), "
              f"then a multi-start search: {how} and up to {settings['deflation_rounds']} "
              "deflated Newton solves (Farrell et al. 2015) from each start (load-controlled "
              "states at the tension levels " + " ".join(f"{v:g}" for v in settings["levels"])
              + " in every loading order, and any branch the continuation lost)")
    if result.control == "load":
        method = ("loading paths from the straight arm (every order, both sides of each "
                  "bifurcation), " + method)
    if settings["effort"] > 1:
        method += (f"; effort {settings['effort']}: the searches of every lower effort first, "
                   "then this one (the numbers above are its own)")
    if result.curves:
        method = result.curve_method() + "; around it (its curves also followed from the "\
            "states these add): " + method
    return method
