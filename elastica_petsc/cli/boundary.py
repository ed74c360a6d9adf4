"""``elastica-petsc boundary``: the workspace boundary by continuation (two tendons)."""
from __future__ import annotations

from pathlib import Path

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "boundary", help="trace the boundary of the workspace W_0 by continuation (2 tendons)",
        description="Trace the boundary of the workspace W_0 (tips of stable equilibria "
                    "connected to the straight arm by quasi-static loading with all P_i >= 0) "
                    "by pseudo-arclength continuation around the region of tension space it "
                    "comes from: the faces P_i = 0 (and P_i = P_crit, Eq. (22)), cable "
                    "collapse and the fold where stability is lost (Eq. (20)); and the "
                    "restricted workspace (also l*kappa_max and strain energy within their "
                    "limits, Eqs. (19), (21)). Polygons in mm: each is closed (the last vertex "
                    "joins the first); the region is where its winding number is nonzero.")
    parser.add_argument("--no-restricted", action="store_true",
                        help="trace W_0 only (not the restricted workspace)")
    parser.add_argument("--overlay", metavar="H5",
                        help="a sampled map (`workspace --out`, mode targets) drawn under the "
                             "--plot and compared with the W_0 polygon")
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from ..ui.progress import Progress
    from ..studies.boundary import compare_map, compare_restricted, trace_boundary

    common.check_outputs(args)
    arm, disc = common.load_arm(args)
    samples = _read_samples(args.overlay) if args.overlay else None
    with Progress(None, "boundary", unit="continuation solves") as bar:
        result = trace_boundary(arm, disc, restricted=not args.no_restricted, progress=bar)
    from ..io.summaries import boundary_summary

    summary = boundary_summary(result)
    if samples is not None:
        summary["agreement"] = compare_map(result, samples["target"], samples["status"],
                                           samples["spacing"], samples.get("region"))
        if "restricted" in result.polygons_mm:
            summary["agreement_restricted"] = compare_restricted(
                result.polygons_mm["restricted"][0], samples["target"], samples["masks"],
                samples["spacing"])
    if args.out:
        from ..io.boundary import write_boundary
        write_boundary(args.out, result, args.overwrite)
        summary["file"] = args.out
    if args.plot:
        from ..plots.boundary import plot_boundary
        plot_boundary(_as_data(result), args.plot, arm_length_mm=arm.length_mm,
                      routes_mm=arm.routes() * arm.length_mm, samples=samples)
    if args.json:
        summary["polygons"] = {k: [p.tolist() for p in v] for k, v in result.polygons_mm.items()}
        summary["tip_folds_mm"] = result.tip_folds_mm.tolist()
        summary["fold_curves_mm"] = [line.tolist() for line in result.fold_polylines_mm]
        summary["faces"] = result.faces
        common.print_json(args.command, summary)
    else:
        print(_format(summary))
    return 0 if all(r.closed for r in result.regions.values()) else 1


def _read_samples(path):
    from ..core.errors import InputError
    from ..plots.workspace import read_workspace

    if not Path(path).is_file():
        raise InputError(f"--overlay {path}: no such file")
    try:
        data = read_workspace(path)
    except (OSError, KeyError) as err:
        raise InputError(f"--overlay {path}: not a workspace file ({err})") from None
    if data["mode"] != "targets":
        raise InputError(f"--overlay {path}: needs a map of targets (workspace --mode targets)")
    return data


def _as_data(result) -> dict:
    regions = {}
    for name, region in result.regions.items():
        nodes = region.nodes()
        regions[name] = {"polygon": result.polygons_mm[name][0],
                         "area_mm2": result.areas_mm2[name],
                         "tip": nodes["tip"] * result.arm.length_mm,
                         "folds": result.fold_polylines_mm if name == "W0" else [],
                         "faces": result.faces if name == "W0" else []}
    return {"regions": regions, "tip_folds": result.tip_folds_mm}


def _format(s: dict) -> str:
    lines = [f"W_0 area: {s['area_mm2']:.0f} mm^2 ({s['solves']} continuation solves, "
             f"{s['seconds']:.2f} s)"]
    lo, hi = s["area_bounds_mm2"]
    if lo == lo:                                            # not NaN: faces classified
        lines.append(f"  tip-map fold curves traced: {s['fold_curves']} (scan: "
                     + ", ".join(f"{r['ray']} {r['sign_changes']} sign changes" for r in s["scan"])
                     + f", {s['scan_solves']} of the solves); W_0 area "
                     + (f"exact (faces decided)" if lo == hi else f"between {lo:.0f} and {hi:.0f} mm^2"))
    if s["restricted_area_mm2"] is not None:
        lines.append(f"restricted workspace area: {s['restricted_area_mm2']:.0f} mm^2")
    for name, curves in s["curves"].items():
        lines.append(f"  {name} loop ({'closed' if s['closed'][name] else 'NOT closed'}): "
                     + " -> ".join(curves))
    lines += [f"  note: {m}" for m in s["messages"]]
    if "agreement" in s:
        a = s["agreement"]
        lines.append(
            f"  vs sampled map: {a['reached_outside']} of {a['reached']} reached samples "
            f"outside by more than one spacing; {a['needs_negative_inside']} of "
            f"{a['needs_negative']} needing a negative tension inside by more than one spacing")
        if "area_in_region_mm2" in a:
            lines.append(f"  area in the map's region ({a['compared_region']}): "
                         f"{a['area_in_region_mm2']:.0f} mm^2; sample count "
                         f"estimate {a['sample_area_mm2']:.0f} "
                         f"+- {a['sampling_error_mm2']:.0f} mm^2")
        else:
            lines.append("  areas not compared: the map's region (a box) cuts W_0")
    if "agreement_restricted" in s:
        r = s["agreement_restricted"]
        lines.append(
            f"  restricted vs sampled masks: {r['admissible_outside']} of {r['admissible']} "
            f"admissible samples outside by more than one spacing; "
            f"{r['reached_inadmissible_inside']} of {r['reached_inadmissible']} reached but "
            "inadmissible inside by more than one spacing")
    if "file" in s:
        lines.append(f"  -> {s['file']}")
    return "\n".join(lines)
