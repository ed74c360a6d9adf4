"""``elastica-petsc friction``: a load-unload cycle of one motor, a history of motor
tensions or the replay of a motor schedule, with capstan friction at the guides
(docs/model.md §27)."""
from __future__ import annotations

import sys

import numpy as np

from . import common

MODE_SIGNS = {-1: "<", 0: "=", 1: ">"}


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "friction", help="load-unload cycle of a motor with capstan friction at the guides",
        description="Follow one motor's tension from 0 to --peak-N and back in --steps "
                    "increments each way (the other motors hold --hold-N, default 0) with "
                    "Coulomb friction --mu where the cables wrap their guides: at every guide "
                    "the cable sticks or slips (capstan law T_out = T_in e^(mu beta)), one "
                    "tension per cable segment (docs/model.md §27). Prints the tip against the "
                    "motor tension on both branches and the hysteresis (the largest gap between "
                    "unloading and loading). With --history CSV instead: any history of motor "
                    "tensions (columns time_s, tension_1_N, ... as `simulate --history`; the rows "
                    "in order, time ignored). With --replay CSV: replay a motor schedule of "
                    "`trace --schedule` with every motor holding its cable length, from the "
                    "frictionless state at the tensions of its row 0, and compare the tip with "
                    "the planned one. Needs an arm whose cables run through guides.")
    parser.add_argument("--mu", type=float, nargs="+", metavar="MU",
                        help="friction coefficient at every guide, or one per guide (each "
                             "cable's guides from its motor, tendon by tendon); >= 0, 0 is "
                             "frictionless (default: each [[tendon]] friction_coefficient)")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--peak-N", type=float, metavar="P",
                        help="the motor tension at the top of the cycle, N")
    source.add_argument("--history", metavar="CSV",
                        help="motor tensions row by row instead of a cycle (time_s, "
                             "tension_1_N, tension_2_N, ...), from the frictionless state of "
                             "the first row")
    source.add_argument("--replay", metavar="CSV",
                        help="cable lengths row by row (a `trace --schedule` file: length_1_mm, "
                             "..., and tension_1_N, ... in row 0 for the start)")
    parser.add_argument("--tendon", type=int, default=1, metavar="K",
                        help="the motor that is cycled (1-based, default 1)")
    parser.add_argument("--hold-N", type=float, nargs="+", metavar="P",
                        help="the tensions of the other motors, N, one per tendon (the cycled "
                             "tendon's value is ignored; default 0)")
    parser.add_argument("--cable-stiffness-kN", type=float, metavar="EA",
                        help="the cables' axial stiffness EA, kN (default inextensible): a "
                             "sticking guide or a length-controlled motor then holds the cable's "
                             "unstretched material; needed where antagonistic cables stick or "
                             "hold their lengths on both sides of one span (their tensions are "
                             "otherwise indeterminate)")
    parser.add_argument("--steps", type=int, default=20, metavar="K",
                        help="increments of the history each way (default 20)")
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def history_N(args, arm):
    """The rows of motor tensions, N (checked): the --history file's, or the cycle's."""
    from ..core import inputs
    from ..core.errors import InputError

    n_tendons = arm.n_tendons
    if args.history is not None:
        from ..core.drive import read_tension_history
        return read_tension_history(args.history, n_tendons)[1]
    if not 1 <= args.tendon <= n_tendons:
        raise InputError(f"--tendon {args.tendon}: the arm has tendons 1..{n_tendons}")
    inputs.positive(args.peak_N, "--peak-N", "N",
                    at_most=inputs.MAX_TENSION * arm.force_scale_N)
    if args.steps < 1:
        raise InputError(f"--steps must be at least 1, got {args.steps}")
    hold = np.zeros(n_tendons) if args.hold_N is None else np.asarray(
        inputs.tensions(args.hold_N, n_tendons, "--hold-N", "N", arm.force_scale_N), float)
    up = np.linspace(0.0, args.peak_N, args.steps + 1)
    cycle = np.concatenate((up, up[::-1][1:]))
    rows = np.tile(hold, (len(cycle), 1))
    rows[:, args.tendon - 1] = cycle
    return rows


def schedule_rows(args, arm):
    """(cable lengths of rows 1.. [mm], start tensions [N], planned tips [mm] or None)
    of a --replay file."""
    from ..core.drive import read_schedule
    from ..core.errors import InputError

    rows = read_schedule(args.replay, arm.n_tendons)
    if rows.lengths_mm is None or rows.start_tensions_N is None:
        raise InputError(f"{args.replay}: --replay needs the cable lengths (length_1_mm, ...) "
                         "and the tensions of row 0 (tension_1_N, ...): a `trace --schedule` file")
    return rows.lengths_mm[1:], rows.start_tensions_N, rows.tips_mm


def run(args) -> int:
    from .. import api
    from ..core import inputs

    from ..core.friction import guide_friction

    from ..core.errors import InputError

    arm, disc = common.load_arm(args, friction=True)
    if args.peak_N is None and args.plot:
        raise InputError("--plot draws the cycle of --peak-N (not a --history or --replay)")
    planned, start_N = None, None
    if args.replay is not None:
        rows, start_N, planned = schedule_rows(args, arm)
    else:
        rows = history_N(args, arm)
    if args.cable_stiffness_kN is not None:
        inputs.positive(args.cable_stiffness_kN, "--cable-stiffness-kN", "kN")
    common.check_outputs(args)
    mu = guide_friction(arm) if args.mu is None else np.asarray(args.mu, float)
    result = api.friction_path(arm, rows, mu=mu, elements=disc.n_elements,
                               cable_stiffness_N=_stiffness_N(args),
                               length_control=args.replay is not None, start_tensions_N=start_N)
    summary = result.summary()
    k = args.tendon - 1
    if planned is not None and len(result.tip_mm):
        gap = np.hypot(*(result.tip_mm - planned[:len(result.tip_mm)]).T)
        summary["plan_deviation_mm"] = float(gap.max())
    if args.peak_N is not None:
        y, top = result.tip_mm[:, 1], args.steps
        gaps = y[top:][::-1] - y[:top + 1] if result.converged else np.zeros(1)
        summary["largest_gap_mm"] = float(np.max(np.abs(gaps)))
    if args.json:
        common.print_json(args.command, summary)
    else:
        print(_table(result))
        if args.peak_N is not None:
            print(f"hysteresis: the tip's y differs between unloading and loading by up to "
                  f"{summary['largest_gap_mm']:.3f} mm (mu = {_mu_text(result.path.mu)})")
        if "plan_deviation_mm" in summary:
            print(f"the tip leaves the planned path by up to {summary['plan_deviation_mm']:.3f} mm "
                  f"(mu = {_mu_text(result.path.mu)})")
    if args.out:
        result.save(args.out, overwrite=args.overwrite)
    if args.plot and result.converged:
        from ..plots.friction import plot_hysteresis
        paths = {float(np.max(result.path.mu)): result.path}
        if np.any(result.path.mu != 0.0):
            paths[0.0] = api.friction_path(arm, rows, mu=0.0, elements=disc.n_elements,
                                           cable_stiffness_N=_stiffness_N(args)).path
        plot_hysteresis(arm, disc, paths, args.plot, tendon=k)
    if not result.converged:
        print(f"elastica-petsc: friction path failed: {result.message}", file=sys.stderr)
        return 1
    return 0


def _stiffness_N(args):
    """--cable-stiffness-kN in newtons (None: inextensible cables)."""
    return None if args.cable_stiffness_kN is None else 1e3 * args.cable_stiffness_kN


def _mu_text(mu) -> str:
    """One coefficient, or the list when the guides differ."""
    return f"{mu[0]:g}" if np.all(mu == mu[0]) else ", ".join(f"{m:g}" for m in mu)


def _table(result) -> str:
    """One line per row: the motor tensions, the tip, and every guide's mode
    (< slip toward the motor, = stick, > slip toward the end)."""
    n = result.motor_tensions_N.shape[1]
    lines = ["".join(f"{f'P{i + 1} [N]':>9}" for i in range(n))
             + f" {'tip x [mm]':>11} {'tip y [mm]':>11}  guides "
             "(< slip toward the motor, = stick, > slip toward the end)"]
    for p, tip, modes in zip(result.motor_tensions_N, result.tip_mm, result.modes):
        lines.append("".join(f"{v:9.3f}" for v in p) + f" {tip[0]:11.3f} {tip[1]:11.3f}  "
                     + "".join(MODE_SIGNS[int(m)] for m in modes))
    return "\n".join(lines)
