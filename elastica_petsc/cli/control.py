"""``elastica-petsc control``: tensions that put the tip on a target (Eqs. (10)-(12), Algorithm 1)."""
from __future__ import annotations

import sys

from . import common

UNREACHABLE = 3


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "control", help="cable tensions and lengths that put the tip on a target (tip control)",
        description="Minimise E(P) = |x_d - x_t(P)|^2 / 2 over tensions P >= 0 (and P <= P_crit "
                    "when the config gives a motor limit) with PETSc TAO BLMVM (default) or the "
                    "paper's gradient descent (Algorithm 1). Stops when the tip is within "
                    "--tol-mm of the target. Prints the tensions (non-dimensional and N), the "
                    "cable lengths to impose, and the tip sensitivities. A target outside the "
                    "workspace exits with status 3 and says how close the arm can get.")
    parser.add_argument("--target", type=float, nargs=2, required=True, metavar=("X", "Y"),
                        help="desired tip position in mm")
    parser.add_argument("--method", choices=("blmvm", "gd"), default="blmvm",
                        help="blmvm: TAO bound-constrained quasi-Newton (default); gd: the "
                             "paper's gradient descent with adaptive step (Algorithm 1)")
    common.add_tension_option(parser, "--guess", nargs="+",
                              help="initial tensions, one per tendon (default 0)")
    parser.add_argument("--tol-mm", type=float, default=1e-5, metavar="MM",
                        help="tip tolerance in mm (default 1e-5, the paper's eps = 1e-10 mm^2)")
    parser.add_argument("--animate", metavar="GIF|MP4",
                        help="write an animation of the arm through the optimiser's iterations "
                             "(Fig. 2 as a movie; .gif with Pillow, .mp4 needs ffmpeg)")
    parser.add_argument("--vtk", metavar="DIR",
                        help="write the final state (arm and cables) for ParaView as "
                             "DIR/control.vtu")
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def control_summary(arm, result) -> dict:
    from ..io.summary import equilibrium_summary, rounded

    state = equilibrium_summary(arm, result.equilibrium)
    return {
        "converged": bool(result.converged),
        "reachable": result.reachable,
        "reason": result.reason,
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
        "on_bound": [{"tendon": i, "bound": side} for i, side in result.on_bound],
        "tip_sensitivity": [rounded(v * arm.length_mm) for v in result.sensitivity.tip],
        "stable": state["stable"],
        "strain_energy": state["strain_energy"],
        "kappa_max": state["kappa_max"],
        "units": {"tensions": "P l^2/B", "tensions_N": "N", "tip_sensitivity":
                  "d x_t / d p_i in mm per unit p (Eq. (13)), one [x, y] per tendon"},
    }


def unreachable_message(s: dict) -> str:
    bounds = ", ".join(
        f"tendon {b['tendon']} sits on its {'lower bound P = 0 (it would have to push)' if b['bound'] == 'lower' else 'upper bound (motor force limit)'}"
        for b in s["on_bound"]) or "no tension is on a bound"
    return (f"target ({s['target_mm'][0]:g}, {s['target_mm'][1]:g}) mm is not reachable "
            f"with admissible tensions: the closest tip is ({s['tip_mm'][0]:.3f}, "
            f"{s['tip_mm'][1]:.3f}) mm, {s['tip_error_mm']:.3f} mm away; {bounds} "
            f"({s['reason']})")


def format_control(s: dict) -> str:
    lines = []
    if s["converged"]:
        lines.append(f"target reached: tip within {s['tip_error_mm']:.3g} mm "
                     f"({s['method']}, {s['iterations']} iterations, {s['evaluations']} "
                     f"equilibrium solves)")
    else:
        lines.append("target NOT reached: " + (unreachable_message(s) if s["reachable"] is False
                                                else f"{s['reason']}: {s['message']}"))
    lines.append(f"tip: ({s['tip_mm'][0]:.6f}, {s['tip_mm'][1]:.6f}) mm   target: "
                 f"({s['target_mm'][0]:g}, {s['target_mm'][1]:g}) mm")
    lines.append(f"{'tendon':>6} {'p=Pl^2/B':>10} {'P [N]':>9} {'cable length [mm]':>18} "
                 f"{'dx_t/dp [mm]':>22}")
    for i, (p, P, L, d) in enumerate(zip(s["tensions"], s["tensions_N"], s["cable_lengths_mm"],
                                         s["tip_sensitivity"]), start=1):
        lines.append(f"{i:>6} {p:>10.4f} {P:>9.4f} {L:>18.4f} {f'({d[0]:.2f}, {d[1]:.2f})':>22}")
    lines.append(f"stable: {'yes' if s['stable'] else 'NO'};  strain energy "
                 f"{s['strain_energy']:.3f} SE0;  l*kappa_max {s['kappa_max']:.3f}")
    return "\n".join(lines)


def run(args) -> int:
    from ..solvers.control import TipController
    from ..core.errors import InputError

    arm, disc = common.load_arm(args)
    common.check_outputs(args)
    if not args.tol_mm > 0:
        raise InputError(f"--tol-mm must be positive, got {args.tol_mm}")
    guess = common.guess(args, disc)
    common.check_target_mm(arm, args.target)
    if args.animate:
        from ..plots.animate import check_animation_path
        check_animation_path(args.animate, args.overwrite)
    if args.vtk:
        from ..io.vtk import check_directory
        check_directory(args.vtk, args.overwrite)
    with TipController(arm, n_elements=disc.n_elements, method=args.method,
                       tip_tol_mm=args.tol_mm) as controller:
        result = controller.solve_mm(args.target, p0=guess)
        if args.animate:
            from ..plots.animate import animate_control
            animate_control(controller, result, args.animate)
    summary = control_summary(arm, result)
    if args.json:
        common.print_json(summary)
    else:
        print(format_control(summary))
    if args.out:
        from ..io.hdf5 import atomic_h5, provenance, write_attrs, write_control
        with atomic_h5(args.out, args.overwrite) as fh:
            write_attrs(fh, provenance(arm, "control"))
            write_control(fh, arm, result)
    if args.plot:
        from ..plots.control import plot_descent
        plot_descent(arm, result, args.plot)
    if args.vtk:
        from pathlib import Path

        from ..io.vtk import write_state
        Path(args.vtk).mkdir(exist_ok=True)
        write_state(Path(args.vtk) / "control.vtu", arm, result.equilibrium)
    if result.converged:
        return 0
    if result.reachable is False:
        print(f"elastica-petsc: {unreachable_message(summary)}", file=sys.stderr)
        return UNREACHABLE
    print(f"elastica-petsc: tip control failed: {result.reason}: {result.message}", file=sys.stderr)
    return 1
