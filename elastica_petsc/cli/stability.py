"""``elastica-petsc stability``: smallest stiffness eigenvalues at an equilibrium (Sec. 4.3 (ii))."""
from __future__ import annotations

import sys

from . import common
from .solve import add_side_option, solve_state


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "stability", help="stability of the equilibrium at given tensions (SLEPc eigenvalues)",
        description="Solve the equilibrium for given tensions (as `solve`), then compute with "
                    "SLEPc the smallest eigenvalues of K v = lambda M v (paper Sec. 4.3 (ii), "
                    "Fig. 5b): stable under load control iff all are positive. Reports "
                    "lambda l^2/B (mesh independent; pi^2/4 for the unloaded arm), the paper's "
                    "raw lambda_min(K)/(B/l), the measured asymmetry of K, and, when the "
                    "config gives mass_per_length_kg_m, the lowest natural frequencies and a "
                    "suggested maximum tracing speed.")
    common.add_tension_options(parser)
    common.add_order_option(parser)
    add_side_option(parser)
    parser.add_argument("--modes", type=int, default=4, metavar="K",
                        help="number of eigenvalues/modes to compute (default 4)")
    parser.add_argument("--amplitude-mm", type=float, default=1.0, metavar="MM",
                        help="tolerated vibration amplitude for the tracing-speed rule "
                             "v_max = 2 pi f_1 * amplitude (default 1 mm)")
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from .. import api
    from ..core.inputs import modes as check_modes
    from ..core.inputs import positive
    from ..io.summary import format_stability, stability_summary

    positive(args.amplitude_mm, "--amplitude-mm", "mm", at_least=1e-6)
    arm, disc = common.load_arm(args)
    check_modes(args.modes, disc.n_elements, "--modes")
    common.check_outputs(args)
    state = solve_state(args, arm, disc)
    if not state.converged:
        print(f"elastica-petsc: solve failed: {state.message}", file=sys.stderr)
        return 1
    result = api.stability(state, modes=args.modes)
    freqs = None
    if arm.mass_per_length_kg_m is not None:
        freqs = {control: api.frequencies(state, control=control) for control in ("load", "length")}
    eq = state.equilibrium
    summary = stability_summary(arm, eq, result, freqs, args.amplitude_mm)
    if args.json:
        common.print_json(args.command, summary)
    else:
        print(format_stability(arm, summary))
    if args.out:
        from ..io.save import save_stability
        save_stability(args.out, arm, eq, result, freqs, overwrite=args.overwrite,
                       loading=args.order or "proportional")
    if args.plot:
        from ..plots.stability import plot_modes
        plot_modes(arm, eq, result, args.plot)
    return 0
