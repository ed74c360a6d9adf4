"""``elastica-petsc trace``: tip control along a path, warm-started, with a motor schedule (Sec. 4.2)."""
from __future__ import annotations

import sys

from . import common

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
    parser.add_argument("--guess", type=float, nargs="+", metavar="P",
                        help="initial tensions for the first point, non-dimensional")
    parser.add_argument("--schedule", metavar="CSV", help="write the motor schedule CSV here")
    parser.add_argument("--amplitude-mm", type=float, default=1.0, metavar="MM",
                        help="tolerated vibration amplitude for the suggested tracing speed "
                             "v_max = 2 pi f_1 * amplitude (default 1 mm; needs "
                             "mass_per_length_kg_m in the config)")
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def targets(args):
    from ..studies import trace as paths
    from ..core.errors import InputError

    if not args.amplitude_mm > 0:
        raise InputError(f"--amplitude-mm must be positive, got {args.amplitude_mm}")
    if not args.step > 0:
        raise InputError(f"--step must be positive, got {args.step}")
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
    common.check_path_points(points, args.step)
    return paths.densify(points, args.step)


def trace_summary(arm, result, schedule) -> dict:
    import numpy as np

    from ..io.summary import rounded

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
        "max_rounding_error_mm": float(f"{np.max(np.abs(schedule.rounding_error_mm)):.3g}"),
        "mm_per_microstep": float(f"{schedule.mm_per_step:.6g}"),
    }


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
    lines.append(f"motor schedule: {s['mm_per_microstep']:.4g} mm per microstep, largest rounding "
                 f"error {s['max_rounding_error_mm']:.3g} mm")
    if s.get("max_tracing_speed_mm_s") is not None:
        lines.append(f"lowest natural frequency along the path {s['f1_min_hz']:.3g} Hz (tensions "
                     f"held): suggested max tracing speed {s['max_tracing_speed_mm_s']:.3g} mm/s, "
                     f"{s['path_length_mm'] / s['max_tracing_speed_mm_s']:.0f} s for the "
                     f"{s['path_length_mm']:.0f} mm path")
    return "\n".join(lines)


def tracing_speed(arm, disc, result, amplitude_mm: float, snapshots: int = 6) -> dict:
    """Suggested maximum tracing speed (Sec. 4.5 (vi)): the lowest first
    natural frequency f_1 over a few states along the path, tensions held
    (the lower, conservative one), and v_max = 2 pi f_1 * amplitude — a jump
    dv of the tip velocity excites a vibration of amplitude dv / (2 pi f_1)."""
    import numpy as np

    from ..solvers.stability import StabilitySolver, max_tracing_speed_mm_s

    if arm.mass_per_length_kg_m is None:
        return {}
    picks = np.unique(np.linspace(0, result.n_points - 1, snapshots).round().astype(int))
    with StabilitySolver(disc, nev=1) as stab:
        f1 = min(stab.frequencies(result.results[k].equilibrium.u, result.results[k].p,
                                  arm, nev=1).f1_hz for k in picks)
    steps = np.linalg.norm(np.diff(result.targets_mm, axis=0), axis=1)
    return {"f1_min_hz": round(f1, 4),
            "max_tracing_speed_mm_s": round(max_tracing_speed_mm_s(f1, amplitude_mm), 4),
            "path_length_mm": round(float(steps.sum()), 3),
            "amplitude_mm": amplitude_mm}


def run(args) -> int:
    from ..solvers.control import TipController
    from ..studies.trace import trace
    from ..core.progress import Progress
    from ..core.schedule import schedule_from_trace

    arm, disc = common.load_arm(args)
    common.check_outputs(args)
    if args.schedule:
        from ..io.hdf5 import check_output_path
        check_output_path(args.schedule, args.overwrite)
    points = targets(args)
    guess = common.guess(args, disc)
    bar = Progress(len(points), "trace")
    with TipController(arm, n_elements=disc.n_elements) as controller:
        result = trace(controller, points, p0=guess, keep_results=True, on_point=bar.update)
    bar.close(result.n_points)
    schedule = schedule_from_trace(result, arm)
    summary = trace_summary(arm, result, schedule)
    summary.update(tracing_speed(arm, disc, result, args.amplitude_mm))
    if args.json:
        common.print_json(summary)
    else:
        print(format_trace(summary))
    if args.schedule:
        schedule.write_csv(args.schedule)
    if args.out:
        from ..io.hdf5 import atomic_h5, provenance, write_attrs, write_trace
        with atomic_h5(args.out, args.overwrite) as fh:
            write_attrs(fh, provenance(arm, "trace"))
            fh.attrs["elements"] = disc.n_elements
            fh.attrs["step_mm"] = args.step
            fh.attrs["source"] = args.path or args.shape
            write_trace(fh, arm, result, schedule)
    if args.plot:
        from ..plots.control import plot_trace_figures
        plot_trace_figures(arm, result, args.plot)
    if not result.all_converged:
        print(f"elastica-petsc: {result.n_points - summary['reached']} of {result.n_points} "
              "points were not reached (see the HDF5/JSON per-point results)", file=sys.stderr)
        return 1
    return 0
