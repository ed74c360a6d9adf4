"""``elastica-petsc solve``: the load-controlled equilibrium (Eq. (9)) for given tensions."""
from __future__ import annotations

import sys

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "solve", help="equilibrium of the arm for given cable tensions (load control)",
        description="Solve the equilibrium (paper Eq. (9)) for given tensions with PETSc SNES, "
                    "stepping the load from the straight arm along the chosen loading order. "
                    "Where the path crosses a symmetric bifurcation (the straight arm buckling "
                    "under a cable along its axis) it switches onto a stable buckled branch "
                    "(--side). "
                    "Prints the tip, attachment points, cable lengths, energy and curvature. "
                    "With --from FILE: reproduce the state recorded in an --out file of solve, "
                    "control, trace (--point K), lengths or equilibria (--state K), replaying "
                    "its loading path (the arm and mesh come from the file).")
    common.add_tension_options(parser, required=False)
    common.add_order_option(parser)
    add_side_option(parser)
    parser.add_argument("--from", dest="source", metavar="H5",
                        help="reproduce the state recorded in this HDF5 output file")
    parser.add_argument("--point", type=int, metavar="K",
                        help="with --from a trace file: the point (row 0..K-1 of /path)")
    parser.add_argument("--state", type=int, metavar="K",
                        help="with --from a lengths/equilibria file: equilibria/state_K (1..)")
    parser.add_argument("--vtk", metavar="DIR",
                        help="write the state (arm with s, theta and curvature; cables with "
                             "tension and length) for ParaView as DIR/solve.vtu")
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def add_side_option(parser) -> None:
    parser.add_argument("--side", choices=("left", "right"),
                        help="at a symmetric bifurcation take the branch on which the tip moves "
                             "to the left (counter-clockwise) or right of its tangent (default: "
                             "the branch of lower potential energy; on equal energies the left "
                             "one)")


def solve_state(args, arm, disc):
    """The state of ``solve`` and ``stability`` (api.solve with the options)."""
    from .. import api

    return api.solve(arm, tensions=common.tensions(args, arm), order=common.order(args),
                     side=args.side, elements=disc.n_elements)


def check_source(args) -> None:
    from ..core.errors import InputError

    given = args.tensions is not None or args.tensions_N is not None
    if args.source is None:
        if not given:
            raise InputError("give --tensions (or --tensions-N), or --from FILE")
        for name in ("point", "state"):
            if getattr(args, name) is not None:
                raise InputError(f"--{name} needs --from FILE")
        return
    clash = [opt for opt, v in (("--tensions", given), ("--order", args.order),
                                ("--side", args.side), ("--config", args.config),
                                ("--elements", args.elements)) if v]
    if clash:
        raise InputError(f"--from FILE takes the state, arm and mesh from the file; drop "
                         f"{', '.join(clash)}")


def state_from_source(args):
    """(arm, equilibrium, loading, extra summary fields) of --from or --tensions."""
    from ..core.loading import Loading

    if args.source is not None:
        from ..studies.restore import state_from_file
        got = state_from_file(args.source, point=args.point, state=args.state)
        extra = {"from": got.source, "reproduced_by": got.how,
                 "stored_tip_mm": [round(float(v), 6) for v in got.stored_tip_mm],
                 "tip_difference_mm": float(f"{got.tip_difference_mm:.3g}"),
                 "theta_difference_rad": float(f"{got.theta_difference:.3g}")}
        return got.arm, got.equilibrium, got.loading, extra
    arm, disc = common.load_arm(args)
    eq = solve_state(args, arm, disc).equilibrium
    requested = eq.p if eq.p_requested is None else eq.p_requested
    return arm, eq, Loading.ordered(requested, common.order(args)), {}


def loading_order(args, loading) -> str:
    """The file's ``loading_order`` attribute: "2,1", "proportional" or "path"."""
    if args.order:
        return args.order
    order = None if loading is None else loading.order()
    if order:
        return ",".join(map(str, order))
    return "proportional" if loading is None or len(loading) <= 1 else "path"


def run(args) -> int:
    from ..io.summary import equilibrium_summary, format_equilibrium

    check_source(args)
    common.check_outputs(args)
    arm, eq, loading, extra = state_from_source(args)
    summary = equilibrium_summary(arm, eq)
    summary["loading"] = None if loading is None else loading.to_json()
    summary.update(extra)
    if args.json:
        common.print_json(args.command, summary)
    else:
        print(format_equilibrium(arm, summary))
        if extra:
            print(f"reproduced {extra['from']}: {extra['reproduced_by']}; tip differs from the "
                  f"stored one by {extra['tip_difference_mm']:.3g} mm")
    if args.out:
        from ..io.save import save_state
        save_state(args.out, arm, eq, overwrite=args.overwrite,
                   loading=loading_order(args, loading), loading_path=loading)
    if args.plot:
        from ..plots.common import plot_equilibria, tension_label
        order = f"order {args.order}" if args.order else "proportional loading"
        plot_equilibria(arm, [(eq, tension_label(arm, eq.p))], args.plot,
                        title=f"Equilibrium, {order}")
    if args.vtk:
        from ..io.vtk import write_states
        write_states(args.vtk, arm, [eq], name="solve")
    if not eq.converged:
        print(f"elastica-petsc: solve failed: {eq.message}", file=sys.stderr)
        return 1
    return 0
