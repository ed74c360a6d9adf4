"""``elastica-petsc control``: tensions that put the tip on a target (Eqs. (10)-(12), Algorithm 1)."""
from __future__ import annotations

import re
import sys

from . import common

UNREACHABLE = 3      # proven outside W_0 (reachable: false, see "evidence")
UNDECIDED = 4        # not reached, not proven unreachable (reachable: null)


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "control", help="cable tensions and lengths that put the tip on a target (tip control)",
        description="Minimise E(P) = |x_d - x_t(P)|^2 / 2 over tensions P >= 0 (and P <= P_crit "
                    "when the config gives a motor limit) with PETSc TAO BLMVM (default) or the "
                    "paper's gradient descent (Algorithm 1). Stops when the tip is within "
                    "--tol-mm of the target. Prints the tensions (non-dimensional and N), the "
                    "cable lengths to impose, the tip sensitivities and the loading path that "
                    "reaches the state from the straight arm (reproduce it with `solve --from`). "
                    "When the local iteration stalls, a global search follows (homotopy in "
                    "target space, restarts from other loading orders). Exit status 0: reached; "
                    "3: proven unreachable (|target| > l, or outside the traced boundary of W_0 "
                    "with two tendons: evidence OUTSIDE_BOUNDARY, taken before any global search); "
                    "4: not reached and not proven unreachable (the closest tip found is "
                    "printed); 5: stopped by --max-seconds (TIME_LIMIT: the closest tip so far, "
                    "reachability undecided).")
    parser.add_argument("--target", type=float, nargs=2, required=True, metavar=("X", "Y"),
                        help="desired tip position in mm")
    parser.add_argument("--method", choices=("blmvm", "gd"), default="blmvm",
                        help="blmvm: TAO bound-constrained quasi-Newton (default); gd: the "
                             "paper's gradient descent with adaptive step (Algorithm 1)")
    common.add_tension_option(parser, "--guess", nargs="+",
                              help="initial tensions, one per tendon (default 0)")
    parser.add_argument("--tol-mm", type=float, default=1e-5, metavar="MM",
                        help="tip tolerance in mm (default 1e-5, the paper's eps = 1e-10 mm^2)")
    parser.add_argument("--local", action="store_true",
                        help="local solve only (no global search when it stalls)")
    parser.add_argument("--cables", choices=("prefer", "require", "ignore"), default="prefer",
                        help="cables through the arm: prefer (default) searches for a state "
                             "with every cable clear of the arm when the first one found has "
                             "a crossing, keeping the crossing state if none is found; require "
                             "reports such a target as not reached (exit 4); ignore only flags")
    add_share_options(parser)
    common.add_max_seconds_option(parser, "the search")
    parser.add_argument("--animate", metavar="GIF|MP4",
                        help="write an animation of the arm through the optimiser's iterations "
                             "(Fig. 2 as a movie; .gif with Pillow, .mp4 needs ffmpeg)")
    parser.add_argument("--vtk", metavar="DIR",
                        help="write the final state (arm and cables) for ParaView as "
                             "DIR/control.vtu")
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def add_share_options(parser, where: str = "the target") -> None:
    """--share and --min-tension-N (redundant tendons); ``where``: what they apply to."""
    parser.add_argument("--share", choices=("min-norm", "min-energy", "none"), default=None,
                        help=f"how tension is shared among the tension sets that reach {where} "
                             "(n >= 3 tendons): min-norm |P|, min-energy (strain "
                             "energy, Eq. (21)), none (default: whatever the optimiser finds); "
                             "an SQP on the KKT conditions (tip on the target, P >= the floor). "
                             "With 2 tendons the tensions at a tip are unique: only the floor "
                             "matters")
    parser.add_argument("--min-tension-N", type=float, default=0.0, metavar="N",
                        help="pretension floor in newtons: every tension at least this "
                             "(every cable taut; implies --share min-norm unless given)")


def unreachable_message(s: dict) -> str:
    """Not reached: proven unreachable (with its evidence) or undecided."""
    bounds = ", ".join(
        f"tendon {b['tendon']} sits on its {'lower bound P = 0 (it would have to push)' if b['bound'] == 'lower' else 'upper bound (motor force limit)'}"
        for b in s["on_bound"]) or "no tension is on a bound"
    where = (f"the closest tip found is ({s['tip_mm'][0]:.3f}, {s['tip_mm'][1]:.3f}) mm, "
             f"{s['tip_error_mm']:.3f} mm away")
    if s["reason"] == "CABLE_CROSSES_ARM":
        return (f"target ({s['target_mm'][0]:g}, {s['target_mm'][1]:g}) mm is reached only "
                f"with a cable through the arm (cable_clear {s['cable_clear']}) and --cables "
                "require was given; no state with clear cables was found")
    if s["reason"] == "TIME_LIMIT":
        return (f"target ({s['target_mm'][0]:g}, {s['target_mm'][1]:g}) mm not reached within "
                f"--max-seconds and not proven unreachable (TIME_LIMIT): {where}; "
                "reachability undecided")
    if s["reason"].startswith("SHARE_"):
        return f"target ({s['target_mm'][0]:g}, {s['target_mm'][1]:g}) mm: {s['message']}"
    if s["reachable"] is False:
        return (f"target ({s['target_mm'][0]:g}, {s['target_mm'][1]:g}) mm is not reachable: "
                f"{s['evidence']}; {where}")
    capped = re.search(r"seed library capped by its budget[^;)]*", s["evidence"] or "")
    return (f"target ({s['target_mm'][0]:g}, {s['target_mm'][1]:g}) mm not reached and not "
            f"proven unreachable ({s['reason']}, local end {s['local_reason']}): {where}; "
            f"{bounds}" + (f"; {capped.group(0)}" if capped else ""))


def format_control(s: dict) -> str:
    from ..io.summary import crossing_lines

    lines = []
    if s["converged"]:
        lines.append(f"target reached: tip within {s['tip_error_mm']:.3g} mm "
                     f"({s['method']}, {s['iterations']} iterations, {s['evaluations']} "
                     f"equilibrium solves)")
    else:
        lines.append("target NOT reached: " + unreachable_message(s))
    lines.append(f"tip: ({s['tip_mm'][0]:.6f}, {s['tip_mm'][1]:.6f}) mm   target: "
                 f"({s['target_mm'][0]:g}, {s['target_mm'][1]:g}) mm")
    lines.append(f"{'tendon':>6} {'p=Pl^2/B':>10} {'P [N]':>9} {'cable length [mm]':>18} "
                 f"{'dx_t/dp [mm]':>22}")
    for i, (p, P, L, d) in enumerate(zip(s["tensions"], s["tensions_N"], s["cable_lengths_mm"],
                                         s["tip_sensitivity"]), start=1):
        lines.append(f"{i:>6} {p:>10.4f} {P:>9.4f} {L:>18.4f} {f'({d[0]:.2f}, {d[1]:.2f})':>22}")
    lines.append(f"stable: {'yes' if s['stable'] else 'NO'};  strain energy "
                 f"{s['strain_energy']:.3f} SE0;  l*kappa_max {s['kappa_max']:.3f}")
    lines.extend(crossing_lines(s["cable_clear"]))
    if s["loading"] is not None:
        lines.append(f"loading from the straight arm: {s['loading']['description']}"
                     + ("" if s["strategy"] == "local" else f" (found by {s['strategy']})")
                     + "; `solve --from FILE` replays it from an --out file")
    return "\n".join(lines)


def run(args) -> int:
    from .. import api

    arm, disc = common.load_arm(args)
    from ..core.inputs import target_mm, tip_tolerance_mm
    tip_tolerance_mm(arm, args.tol_mm, "--tol-mm")
    guess = common.guess(args, disc)
    target_mm(arm, args.target, "--target")
    max_seconds = common.max_seconds(args)
    if args.animate:
        from ..plots.animate import check_animation_path
        check_animation_path(args.animate, args.overwrite)
    common.check_outputs(args, {"--animate": args.animate} if args.animate else None)
    result = api.control(arm, args.target, guess=guess, method=args.method, tol_mm=args.tol_mm,
                         global_search=not args.local, cables=args.cables, share=args.share,
                         min_tension_N=args.min_tension_N, animate=args.animate,
                         elements=disc.n_elements, progress=True, max_seconds=max_seconds)
    from ..io.summaries import control_summary

    summary = control_summary(arm, result)
    if args.json:
        common.print_json(args.command, summary)
    else:
        print(format_control(summary))
    if args.out:
        from ..io.save import save_control
        save_control(args.out, arm, result, overwrite=args.overwrite)
    if args.plot:
        from ..plots.control import plot_descent
        plot_descent(arm, result, args.plot)
    if args.vtk:
        result.to_vtk(args.vtk)
    if result.converged:
        return 0
    print(f"elastica-petsc: {unreachable_message(summary)}", file=sys.stderr)
    if result.reason == "TIME_LIMIT":
        return common.TIME_LIMIT_EXIT
    return UNREACHABLE if result.reachable is False else UNDECIDED
