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
                    "Prints the tip, attachment points, cable lengths, energy and curvature.")
    common.add_tension_options(parser)
    common.add_order_option(parser)
    add_side_option(parser)
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


def run(args) -> int:
    from ..io.summary import equilibrium_summary, format_equilibrium

    arm, disc = common.load_arm(args)
    common.check_outputs(args)
    eq = solve_state(args, arm, disc).equilibrium
    summary = equilibrium_summary(arm, eq)
    if args.json:
        common.print_json(summary)
    else:
        print(format_equilibrium(arm, summary))
    if args.out:
        from ..io.save import save_state
        save_state(args.out, arm, eq, overwrite=args.overwrite, loading=args.order or "proportional")
    if args.plot:
        from ..plots.common import plot_equilibria, tension_label
        order = f"order {args.order}" if args.order else "proportional loading"
        plot_equilibria(arm, [(eq, tension_label(arm, eq.p))], args.plot,
                        title=f"Equilibrium, {order}")
    if not eq.converged:
        print(f"elastica-petsc: solve failed: {eq.message}", file=sys.stderr)
        return 1
    return 0
