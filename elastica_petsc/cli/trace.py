"""``elastica-petsc trace``: tip control along a path, warm-started, with a motor schedule (Sec. 4.2)."""
from __future__ import annotations

import sys

from . import common
from .control import add_share_options

SHAPES = ("paper-triangle", "convoluted", "circle", "line")


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "trace", help="tensions and cable lengths along a path of tip targets, with a motor schedule",
        description="Densify a path (a built-in shape or a CSV of x_mm,y_mm points) to --step "
                    "mm, solve tip control at each point warm-started from the previous one "
                    "(paper Sec. 4.5 (v)), and write the motor schedule (cable lengths to "
                    "spool revolutions and microsteps), HDF5 and figures (Figs. 3, 6a-c).")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--shape", choices=SHAPES,
                        help="paper-triangle: Fig. 3a (equilateral triangle of side 80 sqrt(3) "
                             "mm edge by edge, then its incircle r = 40 mm and circumcircle "
                             "r = 80 mm); convoluted: our stand-in for Fig. 3b (a meander, see "
                             "paths.convoluted_curve); circle: --radius about --center; line: "
                             "--center to --end")
    source.add_argument("--path", metavar="CSV", help="target points, columns x_mm,y_mm")
    parser.add_argument("--center", type=float, nargs=2, default=(400.0, 200.0),
                        metavar=("X", "Y"), help="centre of the shape in mm (default 400 200)")
    parser.add_argument("--radius", type=float, default=80.0, metavar="MM",
                        help="circle radius in mm (default 80)")
    parser.add_argument("--end", type=float, nargs=2, metavar=("X", "Y"),
                        help="end point of --shape line in mm")
    parser.add_argument("--step", type=float, default=1.0, metavar="MM",
                        help="largest distance between consecutive targets in mm (default 1)")
    common.add_tension_option(parser, "--guess", nargs="+",
                              help="initial tensions, one per tendon: the approach starts at "
                                   "their load-controlled state (default: the straight arm)")
    parser.add_argument("--schedule", metavar="CSV",
                        help="write the timed motor schedule CSV here: an approach move from "
                             "the straight arm, then the path; columns row, phase, point, "
                             "time_s, reached, targets, tips, and per tendon tension (N and p), "
                             "cable length, revolutions, steps from row 0 (> 0 pays the cable "
                             "out, < 0 reels it in), step increment, rounding error")
    parser.add_argument("--speed-mm-s", type=float, metavar="V",
                        help="tip speed of the schedule's time column in mm/s (default: the "
                             "suggested safe tracing speed, see --amplitude-mm)")
    parser.add_argument("--step-table", metavar="STEM",
                        help="write one step/direction timing table per motor, "
                             "STEM_motorI.csv (time_s, direction, position_steps)")
    parser.add_argument("--animate", metavar="GIF|MP4",
                        help="write an animation of the arm, its cables and the tip trail along "
                             "the path (.gif with Pillow; .mp4 needs ffmpeg)")
    parser.add_argument("--slow-motion", type=float, default=1.0, metavar="K",
                        help="--animate: play the schedule K times slower than real time "
                             "(default 1: real time, frames timed to the schedule)")
    parser.add_argument("--vtk", metavar="DIR",
                        help="write ParaView files into this folder: trace.pvd (the arm and "
                             "cables at every point of the approach and the path, timed as the "
                             "schedule) and trace_path.vtu (the tips with per-point fields)")
    parser.add_argument("--per-point", action="store_true",
                        help="with --json: add 'per_point', one entry per path point (target, "
                             "tip, reached, tip error, tensions in p and N, cable lengths, "
                             "iterations, stopping reason, time in the schedule)")
    parser.add_argument("--no-approach", action="store_true",
                        help="start the schedule at the first target instead of tracing an "
                             "approach from the straight arm (or from --guess)")
    parser.add_argument("--amplitude-mm", type=float, default=1.0, metavar="MM",
                        help="tolerated vibration amplitude for the suggested tracing speed "
                             "v_max = 2 pi f_1 * amplitude (default 1 mm; needs "
                             "mass_per_length_kg_m in the config)")
    add_share_options(parser)
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def targets(args, arm):
    from ..core.errors import InputError
    from ..core.inputs import path_step_mm, points_mm, positive
    from ..studies import trace as paths

    positive(args.amplitude_mm, "--amplitude-mm", "mm", at_least=1e-6)
    if args.speed_mm_s is not None:
        positive(args.speed_mm_s, "--speed-mm-s", "mm/s", at_least=1e-6)
    if args.path:
        points = paths.read_csv(args.path)
    elif args.shape == "paper-triangle":
        points = paths.paper_triangle(args.center)
    elif args.shape == "convoluted":
        points = paths.convoluted_curve(args.center)
    elif args.shape == "circle":
        points = paths.circle(args.center, args.radius)
    else:
        if args.end is None:
            raise InputError("--shape line needs --end X Y (it runs from --center)")
        points = paths.line(args.center, args.end)
    points = points_mm(points, "the path", arm)
    path_step_mm(points, args.step, "path", "--step")
    return paths.densify(points, args.step)


def share_summary(args) -> dict:
    """The sharing rule asked for (the library resolves None the same way)."""
    share = args.share or ("min-norm" if args.min_tension_N > 0 else "none")
    return {"share": share, "min_tension_floor_N": args.min_tension_N}


def format_trace(s: dict) -> str:
    lines = [f"traced {s['points']} points: {s['reached']} reached "
             f"(max tip error {s['max_tip_error_mm']:.2e} mm) in {s['seconds']:.2f} s "
             f"({1e3 * s['seconds_per_point']:.2f} ms per point)",
             f"iterations per warm-started point: median {s['iterations_median']:g}, max "
             f"{s['iterations_max_warm']} (first point: {s['iterations_first']})"]
    for i, (P, L, m) in enumerate(zip(s["tension_range_N"], s["cable_length_range_mm"],
                                      s["monotonic_fraction"]), start=1):
        mono = "n/a" if m is None else f"{100 * m:.0f} %"
        lines.append(f"tendon {i}: tension {P[0]:.3f}..{P[1]:.3f} N, cable length "
                     f"{L[0]:.2f}..{L[1]:.2f} mm; length and tension move oppositely in {mono} "
                     "of the steps (Sec. 4.1)")
    if s["share"] != "none":
        lines.append(f"tensions shared {s['share']} with every P >= {s['min_tension_floor_N']:g} "
                     f"N: lowest tension per tendon along the path "
                     + ", ".join(f"{v:.4g}" for v in s["min_tension_N"]) + " N")
    if s["closes"]:
        lines.append(f"closed path: cable lengths at the end differ from the start by at most "
                     f"{s['closure_cable_length_change_mm']:.3g} mm")
    for i, count in enumerate(s["cable_crossing_points"], start=1):
        if count:
            lines.append(f"WARNING: tendon {i}'s cable crosses the arm at {count} of the "
                         f"{s['points']} points (HDF5 /path/cable_clear)")
    if s["not_reached_undecided"] or s["not_reached_proven_unreachable"]:
        lines.append(f"not reached: {s['not_reached_proven_unreachable']} proven unreachable "
                     f"(|target| > l), {s['not_reached_undecided']} undecided")
    lines.append(f"motor schedule: {s['mm_per_microstep']:.4g} mm per microstep, largest rounding "
                 f"error {s['max_rounding_error_mm']:.3g} mm")
    if s["approach_points"]:
        lines.append(f"approach from the {s['approach_start']}: {s['approach_points']} points, "
                     f"{s['approach_reached']} reached")
    if s["duration_s"] is not None:
        lines.append(f"schedule: {s['schedule_rows']} rows, {s['duration_s']:.1f} s at "
                     f"{s['speed_mm_s']:.3g} mm/s ({s['speed_source']})")
    if s["peak_speed_steps_s"] is not None:
        peaks = ", ".join(f"motor {i}: {v:.4g} microsteps/s, {a:.4g} microsteps/s^2"
                          for i, (v, a) in enumerate(zip(s["peak_speed_steps_s"],
                                                         s["peak_accel_steps_s2"]), 1))
        if s["motor_limits"] is None:
            lines.append(f"motor peaks {peaks}; no [motor] max_speed_steps_s / "
                         "max_accel_steps_s2 in the config, so nothing checks that the motors "
                         "can play them (`elastica-petsc schedule CSV` checks and re-times)")
        else:
            runs = ", ".join(f"{a}" + (f"-{b}" if b > a else "") + f" ({code})"
                             for a, b, code in s["slowed_rows"][:8])
            more = len(s["slowed_rows"]) - 8
            lines.append(f"motor peaks {peaks}, within the [motor] limits; rows where a motor "
                         f"slowed the tip: {s['rows_slowed_by_motor']}"
                         + (f": {runs}" + (f" and {more} more runs" if more > 0 else "")
                            if runs else "")
                         + f"; no schedule under the limits is shorter than "
                           f"{s['time_bound_s']:.1f} s")
    if s.get("max_tracing_speed_mm_s") is not None:
        lines.append(f"lowest natural frequency along the path {s['f1_min_hz']:.3g} Hz (tensions "
                     f"held): suggested max tracing speed {s['max_tracing_speed_mm_s']:.3g} mm/s, "
                     f"{s['path_length_mm'] / s['max_tracing_speed_mm_s']:.0f} s for the "
                     f"{s['path_length_mm']:.0f} mm path")
    return "\n".join(lines)


def check_options(args) -> None:
    """Refuse, before any computing, options and output paths that cannot work."""
    from ..core.errors import InputError

    if args.animate:
        from ..plots.animate import check_animation_path
        check_animation_path(args.animate, args.overwrite)
    extra = {"--animate": args.animate} if args.animate else {}
    if args.step_table:
        for i in range(1, common.load_config(args.config).n_tendons + 1):
            extra[f"--step-table (motor {i})"] = f"{args.step_table}_motor{i}.csv"
    common.check_outputs(args, extra)
    if args.per_point and not args.json:
        raise InputError("--per-point adds per-point results to the JSON output: use it with "
                         "--json")
    if not args.slow_motion > 0:
        raise InputError(f"--slow-motion must be positive, got {args.slow_motion}")


def write_outputs(args, arm, disc, planned) -> None:
    """--schedule, --out, --plot, --vtk and --animate files."""
    result, schedule = planned.path, planned.schedule
    if args.schedule:
        schedule.write_csv(args.schedule)
    if args.step_table:
        schedule.write_step_tables(args.step_table)
    if args.out:
        from ..io.save import save_trace
        attrs = dict(elements=disc.n_elements, step_mm=args.step,
                     source=args.path or args.shape, **share_summary(args))
        save_trace(args.out, arm, planned, attrs, overwrite=args.overwrite)
    if args.plot:
        from ..plots.control import plot_trace_figures
        plot_trace_figures(arm, result, args.plot)
    if args.vtk:
        planned.to_vtk(args.vtk)
    if args.animate:
        from ..plots.animate import animate_trace
        animate_trace(arm, result, args.animate, approach=planned.approach,
                      times_s=schedule.time_s, slow_motion=args.slow_motion)


def run(args) -> int:
    from .. import api
    from ..ui.progress import Progress

    arm, disc = common.load_arm(args)
    check_options(args)
    points = targets(args, arm)
    guess = common.guess(args, disc)
    with Progress(len(points), "trace") as bar:
        planned = api.schedule(arm, points, step_mm=args.step, speed_mm_s=args.speed_mm_s,
                               amplitude_mm=args.amplitude_mm, approach=not args.no_approach,
                               guess=guess, elements=disc.n_elements, share=args.share,
                               min_tension_N=args.min_tension_N,
                               on_point=lambda done, total: bar.update(done, total=total))
    result = planned.path
    from ..io.summaries import point_entries, schedule_summary, trace_summary

    summary = trace_summary(result, planned.schedule)
    summary.update(share_summary(args))
    summary.update({k: v for k, v in planned.speed.items() if k not in ("speed_mm_s",
                                                                           "speed_source")})
    summary.update(schedule_summary(planned, guess is not None))
    if args.json:
        if args.per_point:
            summary["per_point"] = point_entries(result, planned.schedule)
        common.print_json(args.command, summary)
    else:
        print(format_trace(summary))
    write_outputs(args, arm, disc, planned)
    if args.speed_mm_s is not None and summary["rows_slowed_by_motor"]:
        print(f"elastica-petsc: warning: the motors cannot follow --speed-mm-s "
              f"{args.speed_mm_s:g} on {summary['rows_slowed_by_motor']} rows: the tip is slower "
              "there (the limited_by column of --schedule)", file=sys.stderr)
    before = planned.approach
    if before is not None and not before.all_converged:
        print(f"elastica-petsc: warning: {before.n_points - int(before.converged.sum())} of "
              f"{before.n_points} approach points were not reached (rows with reached = false "
              "in the schedule); try --no-approach or another --guess", file=sys.stderr)
    if not result.all_converged:
        print(f"elastica-petsc: {result.n_points - summary['reached']} of {result.n_points} "
              "points were not reached (per point: --json --per-point, or path/converged in "
              "--out, or the reached column of --schedule)", file=sys.stderr)
        return 1
    return 0
