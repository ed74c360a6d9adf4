"""``elastica-petsc design``: routing points for a task (a path) or a larger
workspace (area), and sweeps over a grid of designs (MPI)."""
from __future__ import annotations

import sys

import numpy as np

from . import common

DEFAULT_TENSION_MAX_N = 10.0


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "design", help="optimise routing points for a path or the workspace area; sweep designs",
        description="Optimise routing points (within --reach mm of where they start and at "
                    "least --clearance mm off the arm's line y = 0, on their side) with TAO "
                    "BLMVM and exact gradients. --objective path:CSV: every target of the path "
                    "in W_0 (sum over targets of min_p |x_t - x_d|^2/2, Danskin's gradient). "
                    "--objective area: the area of W_0 within 0 <= P_i <= --tension-max "
                    "(attachments, tendonK.attach, by a pattern search over mesh nodes) "
                    "(on its traced boundary, the area `boundary` reports for that motor limit; "
                    "gradient the boundary integral of the normal tip derivative), confirmed by an "
                    "independent tension-grid re-sampling of both arms. --sweep: evaluate the "
                    "area (and a path's misfit) over a grid of designs on all ranks of mpiexec, "
                    "into one HDF5 file (resumable). W_0: tips of stable equilibria connected to "
                    "the straight arm by quasi-static loading with all P_i >= 0.")
    parser.add_argument("--vary", nargs="+", metavar="tendonK.route",
                        help="design variables of the optimiser, e.g. tendon1.route "
                             "tendon2.route (and, for --objective area, tendon1.attach; "
                             "guide offsets in mm: tendonK.offset, every "
                             "guide and the end of tendon K at one offset, or "
                             "tendonK.guideJ.offset)")
    parser.add_argument("--objective", metavar="area|path:CSV",
                        help="area, or path:FILE.csv (targets x_mm,y_mm) to be made reachable")
    parser.add_argument("--sweep", nargs="+", metavar="AXIS=START:STOP:STEP",
                        help="grid of designs instead of an optimisation; AXIS is "
                             "tendonK.route.x, tendonK.route.y, tendonK.attach (mm; "
                             "attachments on mesh nodes) or tendonK.offset (mm: the offset "
                             "of the cable's guides and end point)")
    common.add_tension_option(parser, "--tension-max",
                              help=f"motor limit of the area objective (default "
                                   f"{DEFAULT_TENSION_MAX_N:g} N)")
    parser.add_argument("--resample-cells", type=int, default=32, metavar="K",
                        help="tension-grid cells per axis of the re-sampling that checks an "
                             "area design (default 32)")
    parser.add_argument("--margin", type=float, default=1.1, metavar="S",
                        help="path: design for the path scaled by S about its centroid "
                             "(default 1.1)")
    parser.add_argument("--iterations", type=int, default=20, metavar="K",
                        help="largest number of optimiser iterations (default 20)")
    parser.add_argument("--reach", type=float, default=100.0, metavar="MM",
                        help="half-width of each routing point's box (default 100)")
    parser.add_argument("--clearance", type=float, default=10.0, metavar="MM",
                        help="smallest distance of a routing point from y = 0 (default 10)")
    common.add_max_seconds_option(parser, "the optimiser (--objective)")
    parser.add_argument("--resume", action="store_true",
                        help="--sweep: continue an interrupted sweep in --out")
    common.add_arm_options(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--out", metavar="FILE",
                        help="the designed arm as a TOML config; with --sweep an .h5 file")
    parser.add_argument("--plot", metavar="PNG",
                        help="--objective area: the workspace before and after, and the history")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress bar or progress lines (for batch jobs)")
    parser.set_defaults(run=run)


def run(args) -> int:
    from ..core.errors import InputError

    if args.sweep:
        if args.vary or args.plot:
            raise InputError("--sweep evaluates a grid of designs; leave out --vary and --plot")
        if args.max_seconds is not None:
            raise InputError("--max-seconds limits an optimisation (--objective); a --sweep "
                             "is interrupted and resumed instead (--resume)")
        return _run_sweep(args)
    if not args.vary or not args.objective:
        raise InputError("design needs --vary and --objective (area or path:FILE.csv), "
                         "or --sweep")
    from ..core.inputs import design_options
    design_options({k: "--" + k.removesuffix("_mm").replace("_", "-") for k in
                    ("iterations", "reach_mm", "clearance_mm", "margin", "resample_cells")},
                   iterations=args.iterations, reach_mm=args.reach, clearance_mm=args.clearance,
                   margin=args.margin, resample_cells=args.resample_cells)
    from ..core.budget import TimeBudget
    args.budget = TimeBudget(common.max_seconds(args))
    from ..io.hdf5 import PLOT_SUFFIXES, check_output_path
    if args.out:
        check_output_path(args.out, args.overwrite, (".toml",))
    if args.plot:
        if args.objective != "area":
            raise InputError("--plot draws an area design; use it with --objective area")
        check_output_path(args.plot, args.overwrite, PLOT_SUFFIXES, "--plot")
    common.lock_outputs([args.out, args.plot])
    if args.objective == "area":
        return _run_area(args)
    return _run_path(args)


def _path_targets(objective: str):
    from ..core.errors import InputError
    from ..core.inputs import design_points, design_points_limit
    from ..studies.trace import read_csv

    kind, _, source = objective.partition(":")
    if kind != "path" or not source:
        raise InputError(f"--objective {objective!r}: expected area or path:FILE.csv")
    targets = read_csv(source, max_rows=design_points_limit() + 1)   # no need to read more
    design_points(targets, f"--objective path:{source}")
    return targets


def _tension_max(args, arm) -> float:
    """--tension-max (p; --tension-max-N was converted by load_arm) or the default."""
    from ..core.inputs import positive, tensions

    if args.tension_max is None:
        return float(arm.tensions_from_N([DEFAULT_TENSION_MAX_N])[0])
    p = tensions([args.tension_max], 1, "--tension-max", "P l^2/B")[0]
    return positive(p, "--tension-max", "P l^2/B", at_least=1e-3 / arm.force_scale_N)


# outcome codes of an optimised design (JSON "outcome"); only IMPROVED writes --out
IMPROVED = "IMPROVED"                  # the design changed and its objective improved (confirmed)
NOT_CONFIRMED = "NOT_CONFIRMED"        # area: the optimiser's gain is within the re-sampling error
NO_IMPROVEMENT = "NO_IMPROVEMENT"      # path: the task is not better reached than before
UNCHANGED = "UNCHANGED"                # no design step was taken
TIME_LIMIT = "TIME_LIMIT"              # --max-seconds stopped it before an improvement was shown
INFEASIBLE_START = "INFEASIBLE_START"  # the starting design violates a constraint


def _write(args, arm, summary: dict, lines) -> None:
    """--out only for an improved design; otherwise say why nothing was written."""
    summary["file"] = None
    if not args.out:
        return
    if summary["outcome"] != IMPROVED:
        summary["file_note"] = (f"{args.out} not written: the design did not improve "
                                f"({summary['outcome']})")
        return
    from ..io.design import write_config
    write_config(args.out, arm, lines(summary), args.overwrite)
    summary["file"] = args.out


def _step_line(s: dict) -> str:
    """Iterations and TAO's reason, or that the optimiser took no step."""
    counts = f"{s['iterations']} iterations, {s['evaluations']} evaluations, {s['seconds']:.1f} s"
    if s["iterations"] == 0:
        return f"  {counts}: the optimiser took no step (TAO stopped at the start: " \
               f"{s['tao_reason']}), so there is no optimised design to report"
    return f"  {counts}; TAO: {s['tao_reason']}"


def _run_path(args) -> int:
    from ..ui.progress import Progress
    from ..studies.design import design_for_path, parse_vary

    targets = _path_targets(args.objective)
    from ..studies.design_offsets import split_offset_names

    arm, disc = common.load_arm(args)
    names, offsets = split_offset_names(args.vary, arm)       # guide offsets (issue 24)
    tendons = parse_vary(names, disc.n_tendons) if names or not offsets else []
    with Progress(None, "design", unit="path traces") as bar:
        result = design_for_path(arm, tendons, targets, elements=disc.n_elements,
                                 reach_mm=args.reach, clearance_mm=args.clearance,
                                 margin=args.margin, max_iterations=args.iterations,
                                 progress=bar, offsets=offsets, stop=args.budget.expired)
    from ..io.summaries import path_design_summary

    summary = path_design_summary(result, disc.n_elements)
    summary["outcome"] = timed_outcome(path_outcome(result), args.budget)
    _write(args, result.arm_after, summary, _lines)
    _show(args, summary, result.history, _lines)
    if summary["outcome"] == TIME_LIMIT:
        return common.TIME_LIMIT_EXIT
    return 0 if result.misfit_after.reached.all() else 1


def timed_outcome(outcome: str, budget) -> str:
    """TIME_LIMIT when the time budget ended the optimisation before an
    improvement was shown (an improved design stays IMPROVED)."""
    return TIME_LIMIT if budget.reached and outcome not in (IMPROVED, INFEASIBLE_START) \
        else outcome


def path_outcome(result) -> str:
    before, after = result.misfit_before, result.misfit_after
    if result.arm_after == result.arm_before:
        return UNCHANGED
    better = (after.reached.sum(), -after.errors_mm.max()) > (before.reached.sum(),
                                                              -before.errors_mm.max())
    return IMPROVED if better else NO_IMPROVEMENT


def _show(args, summary: dict, history, lines) -> None:
    if args.json:
        summary["history"] = history
        common.print_json(args.command, summary)
    else:
        print("\n".join(lines(summary)))


def _run_area(args) -> int:
    from ..core.errors import InputError
    from ..ui.progress import Progress
    from ..studies.design import parse_design_variables
    from ..studies.design_area import design_for_area

    arm, disc = common.load_arm(args)
    if disc.n_tendons != 2:
        raise InputError("--objective area needs exactly two tendons")
    from ..studies.design_offsets import split_offset_names

    names, offsets = split_offset_names(args.vary, arm)       # guide offsets (issue 24)
    tendons, attaches = parse_design_variables(names, disc.n_tendons) if names else ([], [])
    with Progress(None, "design", unit="evaluations") as bar:
        result = design_for_area(arm, tendons, _tension_max(args, arm),
                                 elements=disc.n_elements, attaches=attaches,
                                 reach_mm=args.reach, clearance_mm=args.clearance,
                                 max_iterations=args.iterations,
                                 resample_cells=args.resample_cells, progress=bar,
                                 stop=args.budget.expired, offsets=offsets)
    from ..io.summaries import area_summary

    from ..studies.design_area import infeasibility

    summary = area_summary(result, disc.n_elements)
    summary.update(outcome=timed_outcome(area_outcome(result), args.budget),
                   start=result.history[0] | infeasibility(result.before,
                                                           result.arm_before.force_scale_N))
    _write(args, result.arm_after, summary, area_lines)
    if args.plot:
        from ..plots.design import plot_area_design
        plot_area_design(result, args.plot)
        summary["plot"] = args.plot
    _show(args, summary, result.history, area_lines)
    if summary["outcome"] == TIME_LIMIT:
        return common.TIME_LIMIT_EXIT
    return 0 if summary["outcome"] == IMPROVED else 1


def area_outcome(r) -> str:
    if not r.before.feasible:
        return INFEASIBLE_START
    if r.arm_after == r.arm_before:
        return UNCHANGED
    return IMPROVED if r.confirmed else NOT_CONFIRMED


def infeasible_start_lines(start: dict, tension_max_N: float) -> list[str]:
    """What fails at the starting design of an area objective and what to change
    (``start``: :func:`~elastica_petsc.studies.design_area.infeasibility`)."""
    lines = [f"  the starting design is infeasible on the edge of the tension box 0 <= P_i <= "
             f"{tension_max_N:.3g} N, so the optimiser cannot start from it:"]
    for c in start["crossings"]:
        first, last = c["first_tensions_N"], c["last_tensions_N"]
        where = f"P = ({first[0]:.3g}, {first[1]:.3g}) N"
        if c["nodes"] > 1:
            where = f"from {where} to ({last[0]:.3g}, {last[1]:.3g}) N along the edge"
        lines.append(f"  - tendon {c['tendon']}'s cable crosses the arm at {c['nodes']} of the "
                     f"{c['of']} nodes, {where} (core/clearance.py)")
    if start["unsolved_tensions_N"]:
        P = start["unsolved_tensions_N"][0]
        lines.append(f"  - {len(start['unsolved_tensions_N'])} equilibria along the edge were "
                     f"not solved, the first at P = ({P[0]:.3g}, {P[1]:.3g}) N")
    fixes = [f"move r_{c['tendon']} farther from the arm" for c in start["crossings"]]
    lowest = min((c["lowest_max_tension_N"] for c in start["crossings"]), default=None)
    if lowest is not None:
        fixes.append(f"lower --tension-max-N below {lowest:.3g} N (where the first crossing is)")
    lines.append("  to change: " + ("; or ".join(fixes) if fixes else
                                    "a smaller --tension-max or other routing points")
                 + ", and run design again")
    return lines


def area_lines(s: dict) -> list[str]:
    a, b = s["resampled_before"], s["resampled_after"]
    head = (f"design (area of W_0 within 0 <= P_i <= {s['tension_max_N']:.3g} N, p = "
            f"{s['tension_max']:.3g}; {s['elements']} elements): ")
    if s["outcome"] == INFEASIBLE_START:
        return [head + f"start {s['area_before_mm2']:.0f} mm^2, not optimised",
                *infeasible_start_lines(s["start"], s["tension_max_N"]), *_file_lines(s)]
    if s["outcome"] == UNCHANGED:
        return [head + f"{s['area_before_mm2']:.0f} mm^2, unchanged", _step_line(s),
                *_file_lines(s)]
    if s["outcome"] == TIME_LIMIT:
        return [head + f"{s['area_before_mm2']:.0f} -> {s['area_after_mm2']:.0f} mm^2 when "
                "--max-seconds stopped the optimiser (TIME_LIMIT): not re-sampled, so no "
                "gain is claimed", _step_line(s), *_file_lines(s)]
    gain = 100.0 * (s["area_after_mm2"] / s["area_before_mm2"] - 1.0)
    verdict = ("confirmed by re-sampling" if s["confirmed"] else
               "NOT confirmed by re-sampling (the optimiser's gain is not claimed)")
    lines = [head + f"{s['area_before_mm2']:.0f} -> {s['area_after_mm2']:.0f} mm^2 "
             f"({gain:+.1f} %)",
             f"  {verdict}: area {a['area_mm2']:.0f} ± {a['error_mm2']:.0f} mm^2 before, "
             f"{b['area_mm2']:.0f} ± {b['error_mm2']:.0f} after (forward solves on a "
             f"{int(round(np.sqrt(a['samples'])))}^2 tension grid; stable "
             f"{a['stable']}/{a['samples']} and {b['stable']}/{b['samples']}, cables clear "
             f"{a['cables_clear']} and {b['cables_clear']})",
             _step_line(s)]
    for k, (x, y) in enumerate(zip(s["routes_before_mm"], s["routes_after_mm"]), start=1):
        lines.append(f"  r_{k}: ({x[0]:.2f}, {x[1]:.2f}) -> ({y[0]:.2f}, {y[1]:.2f}) mm")
    for k, (x, y) in enumerate(zip(s["attach_before_mm"], s["attach_after_mm"]), start=1):
        if x != y:
            lines.append(f"  s_{k} (attachment): {x:g} -> {y:g} mm")
    lines += _offset_lines(s)
    if s["fold_sign_changes_after"] or s["fold_sign_changes_before"]:
        lines.append(f"  note: det(d x_t/d p) changes sign {s['fold_sign_changes_before']} -> "
                     f"{s['fold_sign_changes_after']} times along the loop: a fold of the tip "
                     "map reaches the box's edge, so the loop's area is not exactly the image's; "
                     "the re-sampled area (the union of the images of the tension grid's "
                     "cells) is the one to trust")
    return lines + _file_lines(s)


def _file_lines(s: dict) -> list[str]:
    if s.get("file"):
        return [f"  wrote {s['file']}"]
    return [f"  {s['file_note']}"] if s.get("file_note") else []


def _run_sweep(args) -> int:
    from mpi4py import MPI

    from ..core.errors import InputError
    from ..studies.chunks import agree
    from ..studies.design_sweep import parse_axis, run_sweep

    comm = MPI.COMM_WORLD
    try:                       # input errors agreed on by all ranks (one line, exit 2)
        common.check_outputs(args, resume=args.resume, lock=comm.rank == 0)
        arm, disc = common.load_arm(args)
        axes = [parse_axis(text, disc.n_tendons) for text in args.sweep]
        targets = None
        if args.objective and args.objective != "area":
            targets = _path_targets(args.objective)
        seconds = common.checkpoint_seconds()
        error = None
    except InputError as err:
        error = str(err)
    agree(comm, error)
    sweep = run_sweep(arm, disc.n_elements, axes, _tension_max(args, arm), targets_mm=targets,
                      comm=comm, out=args.out, resume=args.resume, overwrite=args.overwrite,
                      provenance={"command_line": " ".join(sys.argv)},
                      checkpoint_seconds=seconds, progress=True)
    if comm.rank != 0:
        return 0
    from ..io.summaries import sweep_summary

    summary = sweep_summary(sweep)
    if args.json:
        common.print_json(args.command, summary)
    else:
        print("\n".join(sweep_lines(summary)))
    return 0 if sweep.complete else 130


def sweep_lines(s: dict) -> list[str]:
    lines = [f"design sweep over {', '.join(s['axes'])}: {s['done']} of {s['designs']} designs "
             f"on {s['ranks']} rank(s) ({s['seconds_designs']:.1f} s of design evaluations)",
             f"  loop not solved: {s['not_converged']}; a cable across the arm: "
             f"{s['cables_crossing']}; errors: {s['errors']}"]
    if s["best"]:
        design = ", ".join(f"{k} = {v:g}" for k, v in s["best"]["design_mm"].items())
        lines.append(f"  largest area (loop solved, cables clear): {s['best']['area_mm2']:.0f} "
                     f"mm^2 at {design} mm")
    if s["file"]:
        lines.append(f"  wrote {s['file']}")
    return lines


def _offset_lines(s: dict) -> list[str]:
    """The guide offsets a design varied, before and after (mm)."""
    return [f"  {name}: {a:.2f} -> {b:.2f} mm"
            for name, a, b in zip(s.get("offset_variables", ()), s.get("offsets_before_mm", ()),
                                  s.get("offsets_after_mm", ()))]


def _lines(s: dict) -> list[str]:
    lines = [f"design (path of {s['targets']} targets, {s['elements']} elements): reached "
             f"{s['reached_before']} -> {s['reached_after']} "
             f"(largest miss {s['max_error_before_mm']:.2f} -> {s['max_error_after_mm']:.2g} mm)",
             _step_line(s),
             f"  path scaled by the margin: {s['margin_path_reached']} of {s['targets']} "
             f"reached (misfit {s['margin_path_misfit_mm2']:.3g} mm^2); smallest tension "
             f"on the path: {s['smallest_tension_after_N']:.3f} N"]
    for k, (a, b) in enumerate(zip(s["routes_before_mm"], s["routes_after_mm"]), start=1):
        lines.append(f"  r_{k}: ({a[0]:.2f}, {a[1]:.2f}) -> ({b[0]:.2f}, {b[1]:.2f}) mm")
    lines += _offset_lines(s)
    if s["outcome"] == TIME_LIMIT:
        lines.append("  --max-seconds stopped the optimiser (TIME_LIMIT): the best design so "
                     "far, not an improvement of the task")
    return lines
