"""``elastica-petsc schedule``: check a schedule CSV against the motors' limits, re-time it, export step tables."""
from __future__ import annotations

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "schedule", help="check a motor schedule CSV against motor speed/acceleration limits, "
                         "re-time it, export step/direction tables",
        description="Read a schedule CSV (written by `trace --schedule` or by hand in its "
                    "columns), list the rows a motor cannot play under the [motor] limits "
                    "max_speed_steps_s and max_accel_steps_s2 of --config (or the options "
                    "below), and optionally re-time it to the shortest schedule that every "
                    "motor can play (docs/model.md, Motor-aware schedules). Exit status 1 if "
                    "the checked schedule has rows a motor cannot play. With --max-deviation-mm D: "
                    "the fastest constant tip speed at which the simulated tip stays within D "
                    "mm (exit status 1 if no speed tried passes).")
    parser.add_argument("csv", metavar="CSV", help="the schedule to check")
    parser.add_argument("--config", metavar="TOML",
                        help="the arm and motors the schedule was made for (default: the "
                             "paper's arm)")
    parser.add_argument("--max-speed-steps-s", type=float, nargs="+", metavar="V",
                        help="motor speed limit in microsteps/s, one or one per tendon "
                             "(overrides [motor] max_speed_steps_s)")
    parser.add_argument("--max-accel-steps-s2", type=float, nargs="+", metavar="A",
                        help="motor acceleration limit in microsteps/s^2, one or one per "
                             "tendon (overrides [motor] max_accel_steps_s2)")
    parser.add_argument("--retime", metavar="CSV",
                        help="write the re-timed schedule here (then check that one)")
    parser.add_argument("--speed-mm-s", type=float, metavar="V",
                        help="with --retime: the tip is never faster than this (default: the "
                             "fastest tip speed of the CSV's own timing, so only the rows a "
                             "motor cannot play slow down; none if it has no time column)")
    parser.add_argument("--step-table", metavar="STEM",
                        help="write one step/direction timing table per motor, STEM_motorI.csv "
                             "(time_s, direction +1 out / -1 in, position_steps)")
    speed = parser.add_argument_group(
        "fastest speed (docs/model.md §16.8)",
        "simulate the schedule re-timed at candidate tip speeds (from --speed-mm-s, default "
        "its own) and bisect for the fastest at which the tip stays within D mm of its "
        "quasi-static tips and settles within D mm of the last one; no motor limits needed")
    speed.add_argument("--max-deviation-mm", type=float, metavar="D",
                       help="the largest tip deviation allowed, mm")
    speed.add_argument("--elements", type=int, metavar="N",
                       help="mesh of the simulations (default: the config's; 180 elements take "
                            "minutes per candidate, 30 seconds)")
    speed.add_argument("--settle-s", type=float, default=2.0, metavar="S",
                       help="settling window after the motors stop, s (default 2)")
    speed.add_argument("--rel-tol", type=float, default=0.05, metavar="R",
                       help="stop when the failing speed is within this fraction of the "
                            "passing one (default 0.05)")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object on stdout instead of the text summary")
    parser.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    parser.set_defaults(run=run)


def motor_of(args, arm):
    """The config's motor with the limits given on the command line."""
    from dataclasses import replace

    from ..core.errors import InputError
    from ..core.motion import MotorLimits

    changes = {}
    for key in ("max_speed_steps_s", "max_accel_steps_s2"):
        value = getattr(args, key)
        if value is not None:
            changes[key] = value[0] if len(value) == 1 else tuple(value)
    motor = replace(arm.motor, **changes)
    if MotorLimits.of(motor, arm.n_tendons) is None:
        raise InputError("no motor limits: give [motor] max_speed_steps_s and/or "
                         "max_accel_steps_s2 in --config, or --max-speed-steps-s / "
                         "--max-accel-steps-s2")
    return motor


def check_options(args, n_tendons: int) -> None:
    from ..core.errors import InputError
    from ..io.hdf5 import check_distinct, check_output_path

    if args.speed_mm_s is not None and not args.retime:
        raise InputError("--speed-mm-s re-times the schedule: use it with --retime OUT.csv")
    if args.speed_mm_s is not None and not args.speed_mm_s > 0:
        raise InputError(f"--speed-mm-s must be positive, got {args.speed_mm_s}")
    paths = {"CSV": args.csv}
    if args.retime:
        check_output_path(args.retime, args.overwrite, (".csv",), "--retime")
        paths["--retime"] = args.retime
    if args.step_table:
        for i in range(1, n_tendons + 1):
            path = f"{args.step_table}_motor{i}.csv"
            check_output_path(path, args.overwrite, (".csv",), "--step-table")
            paths[f"--step-table ({i})"] = path
    check_distinct(paths)


def summary(schedule, violations, retimed: bool) -> dict:
    from ..core.motion import rates_and_accelerations
    from ..core.schedule import tip_speed_max_mm_s
    from ..io.summary import rounded

    r, a = rates_and_accelerations(schedule.positions_steps, schedule.durations_s[1:])
    rows = sorted({v.row for v in violations})
    return {"rows": int(schedule.n_rows), "retimed": retimed,
            "tip_speed_max_mm_s": tip_speed_max_mm_s(schedule),
            "duration_s": round(schedule.duration_s, 6),
            "limits": schedule.limits.to_json(),
            "peak_speed_steps_s": rounded(abs(r).max(axis=0)) if len(r) else [],
            "peak_accel_steps_s2": rounded(abs(a).max(axis=0)),
            "playable": not violations, "rows_not_playable": rows,
            "violations": [v.to_json() for v in violations]}


def format_summary(s: dict) -> str:
    speed = s["tip_speed_max_mm_s"]
    lines = [f"{s['rows']} rows, {s['duration_s']:.3f} s"
             + (" (re-timed)" if s["retimed"] else "")
             + ("" if speed is None else f", tip at most {speed:.4g} mm/s")]
    for i, (v, a) in enumerate(zip(s["peak_speed_steps_s"], s["peak_accel_steps_s2"]), 1):
        V, A = s["limits"]["max_speed_steps_s"][i - 1], s["limits"]["max_accel_steps_s2"][i - 1]
        lines.append(f"motor {i}: peak {v:.6g} microsteps/s (limit {V if V else 'none'}), "
                     f"peak {a:.6g} microsteps/s^2 (limit {A if A else 'none'})")
    if s["playable"]:
        lines.append("every row is within the motors' limits")
        return "\n".join(lines)
    lines.append(f"{len(s['rows_not_playable'])} rows a motor cannot play:")
    for v in s["violations"][:20]:
        unit = "microsteps/s" if v["kind"] == "speed" else "microsteps/s^2"
        lines.append(f"  row {v['row']}: motor {v['motor']} {v['kind']} {abs(v['value']):.6g} "
                     f"> {v['limit']:g} {unit}")
    if len(s["violations"]) > 20:
        lines.append(f"  ... {len(s['violations']) - 20} more (--json lists them all)")
    lines.append("re-time it: --retime OUT.csv (the tip slows where a motor must)")
    return "\n".join(lines)


def run_speed(args, arm) -> int:
    """``--max-deviation-mm``: the fastest speed study, printed."""
    from ..core.errors import InputError
    from ..ui.progress import Progress
    from .. import api

    if args.retime or args.step_table:
        raise InputError("--max-deviation-mm runs a speed study: use it without --retime "
                         "and --step-table")
    if args.elements is not None:
        from ..core.inputs import elements
        elements(args.elements, "--elements")
    played = []
    with Progress(None, "schedule --max-deviation-mm", unit="speeds") as bar:
        study = api.fastest_speed(arm, args.csv, args.max_deviation_mm, elements=args.elements,
                                  settle_s=args.settle_s, start_mm_s=args.speed_mm_s,
                                  rel_tol=args.rel_tol,
                                  on_trial=lambda t: (played.append(t), bar.update(len(played))))
    s = study.summary()
    if args.json:
        common.print_json(args.command, s)
    else:
        print(format_speed(s))
    return 0 if s["fastest_mm_s"] is not None else 1


def format_speed(s: dict) -> str:
    lines = [f"speeds played ({s['elements']} elements, settling window {s['settle_s']:g} s, "
             f"D = {s['max_deviation_mm']:g} mm):"]
    for t in s["trials"]:
        settle = "not settled" if t["settling_s"] is None else f"settled {t['settling_s']:.3g} s"
        lines.append(f"  {t['speed_mm_s']:9.4g} mm/s: max deviation {t['max_deviation_mm']:.4g} mm"
                     f" at {t['max_deviation_at_s']:.3g} s, end {t['end_deviation_mm']:.3g} mm, "
                     f"{settle}: {'pass' if t['passed'] else 'fail'}")
    rule = (f"rule of thumb 2 pi f1 D = {s['rule_of_thumb_mm_s']:.4g} mm/s "
            f"(f1 = {s['f1_hz']:.4g} Hz at the start)")
    if s["fastest_mm_s"] is None:
        lines.append(f"no speed tried passes; {rule}")
    else:
        above = ("" if s["failing_mm_s"] is None
                 else f" ({s['failing_mm_s']:.4g} mm/s fails)")
        lines.append(f"fastest constant tip speed {s['fastest_mm_s']:.4g} mm/s{above}; {rule}")
    return "\n".join(lines)


def run(args) -> int:
    from ..core.model import load_config
    from ..core.schedule import read_schedule_csv, retimed, tip_speed_max_mm_s

    arm = load_config(args.config)
    if args.max_deviation_mm is not None:
        return run_speed(args, arm)
    motor = motor_of(args, arm)
    check_options(args, arm.n_tendons)
    schedule = read_schedule_csv(args.csv, motor)
    if args.retime:
        speed = args.speed_mm_s if args.speed_mm_s is not None else tip_speed_max_mm_s(schedule)
        schedule = retimed(schedule, motor, speed)
        schedule.write_csv(args.retime)
    if args.step_table:
        schedule.write_step_tables(args.step_table)
    violations = schedule.motor_check()
    s = summary(schedule, violations, bool(args.retime))
    if args.json:
        common.print_json(args.command, s)
    else:
        print(format_summary(s))
    return 0 if s["playable"] else 1
