"""``elastica-petsc simulate``: the arm in motion on PETSc TS (docs/model.md §16).

Start: the straight arm at rest, the static equilibrium at
``--initial-tensions-N`` (loaded in ``--order``), or the last shape in
``--from FILE`` (a dataset ``theta``).  Input, one of: constant
``--tensions-N``, a tension history ``--history CSV`` (``time_s``,
``tension_i_N``) or a motor schedule ``--schedule CSV`` as written by
``trace --schedule`` (``time_s``, ``length_i_mm`` or ``steps_i``), played
from its first row to its last plus ``--settle S``.

HDF5 layout (``--out``), every accepted step of the integrator::

    time_s (T) s, tip_mm (T, 2), x_mm (T, N+1, 2) mm, theta (T, N+1) rad,
    tensions_N (T, n) N, cable_lengths_mm (T, n) mm,
    energy_J (T, 4) J: kinetic, strain, work done by the tensions, potential of the weight,
    event_time_s, event_tendon, event_kind (slack/taut events),
    planned_tip_mm (T, 2) mm (schedule: the quasi-static tip at time_s)

``--vtk DIR``: simulation.pvd (one .vtu per recorded step, time in s) and
simulation_tip.vtu; ``--animate GIF|MP4``: the run in real time (``--slow-motion K``).

Root attributes: provenance (like every file), elements, input, completed,
reason, steps, rejected, f1_hz, wall_s, summary_json.  An interrupted run
(Ctrl-C) writes the steps computed so far (``completed`` false), exit 130.
PETSc options of the integrator: prefix ``sim_`` (``-sim_ts_monitor``,
``-sim_ts_adapt_monitor``, ``-sim_snes_monitor``, ``-sim_ts_alpha_radius`` ...).
"""
from __future__ import annotations

import sys

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "simulate", help="the arm in motion: free vibration, tension histories, motor schedules",
        description="Integrate the equations of motion of the arm (PETSc TS, generalized-alpha, "
                    "adaptive steps) from rest, under constant tensions, a tension history or a "
                    "motor schedule with cables that can go slack.")
    common.add_arm_options(parser)
    parser.add_argument("--initial-tensions-N", type=float, nargs="+", metavar="N",
                        help="start from the static equilibrium at these tensions (default: "
                             "the straight arm; with --schedule, the tensions of its first row)")
    common.add_order_option(parser)
    parser.add_argument("--from", dest="from_file", metavar="H5",
                        help="start from the last shape (dataset theta) of a file the tool wrote")
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--tensions-N", type=float, nargs="+", metavar="N",
                       help="constant tensions during the run (e.g. 0 0: a free vibration)")
    group.add_argument("--history", metavar="CSV",
                       help="tension history: columns time_s, tension_1_N, ..., tension_n_N")
    group.add_argument("--schedule", dest="schedule_csv", metavar="CSV",
                       help="motor schedule as written by `trace --schedule` (cable lengths)")
    parser.add_argument("--settle", type=float, default=0.0, metavar="S",
                        help="with --schedule: keep simulating S seconds after its last row")
    parser.add_argument("--duration", type=float, metavar="S",
                        help="simulated time in seconds (needed with --tensions-N/--history)")
    parser.add_argument("--dt", type=float, metavar="S",
                        help="fixed time step in seconds (default: the start state's first "
                             "period / --steps-per-period)")
    parser.add_argument("--steps-per-period", type=int, default=200, metavar="K",
                        help="default fixed step: K steps per first period (default 200)")
    parser.add_argument("--adaptive", action="store_true",
                        help="adaptive steps (TSAdapt basic, --rtol/--atol) instead of fixed "
                             "steps (docs/model.md §16.4 says when they pay)")
    parser.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance of the "
                        "adaptive steps on the angles (default 1e-6)")
    parser.add_argument("--atol", type=float, default=1e-8, help="absolute tolerance [rad] "
                        "(default 1e-8)")
    parser.add_argument("--radius", type=float, default=None, metavar="RHO",
                        help="spectral radius at infinite step of the alpha method, in [0, 1] "
                             "(1: no numerical dissipation; default 1, with --schedule 0.5)")
    parser.add_argument("--vtk", metavar="DIR",
                        help="write ParaView files into this folder: simulation.pvd (the arm and "
                             "cables at every recorded step, time in s) and simulation_tip.vtu "
                             "(the tip's path with tensions, cable lengths and energies)")
    parser.add_argument("--animate", metavar="GIF|MP4",
                        help="write an animation of the arm, its cables and the tip trail, timed "
                             "to the simulated clock (.gif with Pillow; .mp4 needs ffmpeg)")
    parser.add_argument("--slow-motion", type=float, default=1.0, metavar="K",
                        help="--animate: play the run K times slower than real time (default 1)")
    common.add_output_options(parser, plot=False)
    parser.set_defaults(run=run)


def _check(args) -> None:
    from ..core.errors import InputError

    import math
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise InputError(f"--duration must be a positive number of seconds, got {args.duration:g}")
    if not (math.isfinite(args.settle) and args.settle >= 0):
        raise InputError(f"--settle must be >= 0 s, got {args.settle:g}")
    for name in ("rtol", "atol"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"--{name} must be positive, got {value:g}")
    if args.dt is not None and not (math.isfinite(args.dt) and args.dt > 0):
        raise InputError(f"--dt must be a positive number of seconds, got {args.dt:g}")
    if args.steps_per_period < 4:
        raise InputError(f"--steps-per-period must be at least 4, got {args.steps_per_period}")
    if args.radius is not None and not 0 <= args.radius <= 1:
        raise InputError(f"--radius must lie in [0, 1], got {args.radius:g}")
    if not (math.isfinite(args.slow_motion) and args.slow_motion > 0):
        raise InputError(f"--slow-motion must be positive, got {args.slow_motion:g}")


def run(args) -> int:
    from ..core.errors import InputError
    from ..ui.progress import Progress
    from ..io.simulation import read_theta, write_simulation
    from ..studies.simulate import simulate
    from ..studies.simulate import time_scale_s

    _check(args)
    arm, disc = common.load_arm(args)
    time_scale_s(arm)                       # an arm without mass: refused before anything
    if args.animate:
        from ..plots.animate import check_animation_path
        check_animation_path(args.animate, args.overwrite)
    common.check_outputs(args, {"--animate": args.animate} if args.animate else None)
    if args.schedule_csv is None and args.duration is None:
        raise InputError("--duration is needed with --tensions-N or --history")
    from_theta = read_theta(args.from_file) if args.from_file else None
    with Progress(None, "simulate", unit="steps") as bar:
        count = [0]

        def on_step(t_s):
            count[0] += 1
            if count[0] % 50 == 0:
                bar.update(count[0], note=f"t = {t_s:.3f} s")

        result = simulate(arm, elements=args.elements, initial_tensions_N=args.initial_tensions_N,
                          order=common.order(args), from_theta=from_theta,
                          tensions_N=args.tensions_N, history_csv=args.history,
                          schedule_csv=args.schedule_csv, settle_s=args.settle,
                          duration_s=args.duration, rtol=args.rtol, atol=args.atol,
                          radius=args.radius, dt_s=args.dt, adaptive=args.adaptive,
                          steps_per_period=args.steps_per_period, on_step=on_step)
    data = result.summary()
    if args.out:
        write_simulation(args.out, args.overwrite, result)
    if args.vtk:
        with Progress(len(result.time_s), "simulate --vtk", unit="steps") as bar:
            result.to_vtk(args.vtk, on_step=lambda done, total: bar.update(done))
    if args.animate:
        from ..plots.animate import animate_simulation
        with Progress(None, "simulate --animate", unit="frames") as bar:
            animate_simulation(result, args.animate, slow_motion=args.slow_motion,
                               on_frame=lambda done, total: bar.update(done, total=total))
    if args.json:
        common.print_json("simulate", data)
    else:
        print(format_summary(data))
    if result.reason == "INTERRUPTED":
        print(f"elastica-petsc: interrupted at t = {data['duration_s']:.4g} s; the steps so far "
              "are in the output", file=sys.stderr)
        return 130
    return 0 if result.completed else 1


def format_summary(s: dict) -> str:
    lines = [f"simulated {s['duration_s']:.4g} s ({s['input']}, {s['elements']} elements): "
             f"{s['steps']} steps, {s['rejected']} rejected, {s['wall_s']:.3g} s wall, "
             f"real-time factor {s['real_time_factor']:.3g}",
             f"first natural frequency of the start state: {s['f1_hz']:.4g} Hz",
             f"final tip: ({s['final']['tip_mm'][0]:.3f}, {s['final']['tip_mm'][1]:.3f}) mm, "
             f"tensions {', '.join(f'{v:.4g}' for v in s['final']['tensions_N'])} N",
             f"energy balance drift: {s['energy_drift_J']:.3g} J"]
    if s["max_tip_deviation_mm"] is not None:
        lines.append(f"max tip deviation from the quasi-static path: "
                     f"{s['max_tip_deviation_mm']:.4g} mm")
    for e in s["events"]:
        lines.append(f"event: tendon {e['tendon']} {e['kind']} at t = {e['time_s']:.6g} s")
    if not s["completed"]:
        lines.append(f"stopped: {s['reason']}")
    return "\n".join(lines)
