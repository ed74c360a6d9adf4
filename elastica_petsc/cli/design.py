"""``elastica-petsc design``: routing points that make a path traceable."""
from __future__ import annotations

import numpy as np

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "design", help="move routing points so that a path of targets becomes reachable",
        description="Find routing points (within --reach mm of where they start and at least "
                    "--clearance mm off the arm's line y = 0, on their side) for which every "
                    "target of a path lies in the workspace W_0 (reached by tip control with "
                    "P >= 0). Minimises the sum over targets of |x_t - x_d|^2/2 at the closest "
                    "tips with TAO BLMVM and its exact gradient (Danskin: the derivative of "
                    "the tip at fixed tensions, one more right-hand side of the bordered "
                    "tangent), on the path scaled by --margin about its centroid. Writes the "
                    "designed arm as a TOML config (--out); confirm with `trace --config`.")
    parser.add_argument("--vary", nargs="+", required=True, metavar="tendonK.route",
                        help="design variables, e.g. tendon1.route tendon2.route")
    parser.add_argument("--objective", required=True, metavar="path:CSV",
                        help="path:FILE.csv (targets x_mm,y_mm) to be made reachable")
    parser.add_argument("--margin", type=float, default=1.1, metavar="S",
                        help="design for the path scaled by S about its centroid (default 1.1)")
    parser.add_argument("--iterations", type=int, default=20, metavar="K",
                        help="largest number of optimiser iterations (default 20)")
    parser.add_argument("--reach", type=float, default=100.0, metavar="MM",
                        help="half-width of each routing point's box (default 100)")
    parser.add_argument("--clearance", type=float, default=10.0, metavar="MM",
                        help="smallest distance of a routing point from y = 0 (default 10)")
    common.add_arm_options(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--out", metavar="TOML", help="write the designed arm to this config")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress bar or progress lines (for batch jobs)")
    parser.set_defaults(run=run)


def run(args) -> int:
    from ..core.errors import InputError
    from ..core.progress import Progress
    from ..studies.design import design_for_path, parse_vary
    from ..studies.trace import read_csv

    kind, _, source = args.objective.partition(":")
    if kind != "path" or not source:
        raise InputError(f"--objective {args.objective!r}: expected path:FILE.csv")
    if args.iterations < 1:
        raise InputError(f"--iterations must be at least 1, got {args.iterations}")
    if not (args.reach > 0 and args.clearance >= 0):
        raise InputError("--reach must be positive and --clearance non-negative")
    common.check_outputs(args)
    arm, disc = common.load_arm(args)
    tendons = parse_vary(args.vary, disc.n_tendons)
    targets = read_csv(source)
    with Progress(None, "design", unit="path traces") as bar:
        result = design_for_path(arm, tendons, targets, elements=disc.n_elements,
                                 reach_mm=args.reach, clearance_mm=args.clearance,
                                 margin=args.margin, max_iterations=args.iterations,
                                 progress=bar)
    summary = _summary(result, disc.n_elements, len(targets))
    if args.out:
        from ..io.design import write_config
        write_config(args.out, result.arm_after, _lines(summary), args.overwrite)
        summary["file"] = args.out
    if args.json:
        summary["history"] = result.history
        common.print_json(summary)
    else:
        print("\n".join(_lines(summary)))
    return 0 if result.misfit_after.reached.all() else 1


def _summary(result, elements: int, count: int) -> dict:
    before, after = result.misfit_before, result.misfit_after
    best = min(result.history, key=lambda h: h["f_mm2"])
    return {
        "objective": "path", "elements": elements, "targets": count,
        "margin_path_reached": best["reached"], "margin_path_misfit_mm2": best["f_mm2"],
        "smallest_tension_after_N": float(np.min(after.p) * result.arm_after.force_scale_N),
        "reached_before": int(before.reached.sum()), "reached_after": int(after.reached.sum()),
        "max_error_before_mm": float(before.errors_mm.max()),
        "max_error_after_mm": float(after.errors_mm.max()),
        "routes_before_mm": [list(t.route_mm) for t in result.arm_before.tendons],
        "routes_after_mm": [list(t.route_mm) for t in result.arm_after.tendons],
        "iterations": result.iterations, "evaluations": result.evaluations,
        "seconds": result.seconds, "tao_reason": result.reason,
    }


def _lines(s: dict) -> list[str]:
    lines = [f"design (path of {s['targets']} targets, {s['elements']} elements): reached "
             f"{s['reached_before']} -> {s['reached_after']} "
             f"(largest miss {s['max_error_before_mm']:.2f} -> {s['max_error_after_mm']:.2g} mm)",
             f"  {s['iterations']} iterations, {s['evaluations']} path traces, "
             f"{s['seconds']:.1f} s; TAO: {s['tao_reason']}",
             f"  path scaled by the margin: {s['margin_path_reached']} of {s['targets']} "
             f"reached (misfit {s['margin_path_misfit_mm2']:.3g} mm^2); smallest tension "
             f"on the path: {s['smallest_tension_after_N']:.3f} N"]
    for k, (a, b) in enumerate(zip(s["routes_before_mm"], s["routes_after_mm"]), start=1):
        lines.append(f"  r_{k}: ({a[0]:.2f}, {a[1]:.2f}) -> ({b[0]:.2f}, {b[1]:.2f}) mm")
    return lines
