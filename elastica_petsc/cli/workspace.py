"""``elastica-petsc workspace``: sample the workspace and its restrictions (Sec. 4.3, Figs. 4-5).

Run under MPI for speed: ``mpiexec -n 4 elastica-petsc workspace --spacing 10 --out ws.h5``.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "workspace", help="sample the workspace (Fig. 4) and its restrictions (Fig. 5), MPI-parallel",
        description="Sample tip targets on a grid (mode targets, paper Fig. 4: tip control to "
                    "each) or tensions on a grid (mode tensions: forward solves), and record for "
                    "every sample the tip, tensions, cable lengths, l*kappa_max, the smallest "
                    "stiffness eigenvalue, the strain energy and the admissibility masks "
                    "W_0, W_Y, W_S, W_E, W_P (Eqs. (18)-(22)). Runs on all ranks of mpiexec; "
                    "interrupted runs keep every finished sample and continue with --resume.")
    parser.add_argument("--mode", choices=("targets", "tensions"), default="targets")
    parser.add_argument("--spacing", type=float, default=20.0, metavar="MM",
                        help="target grid spacing in mm (mode targets; default 20)")
    parser.add_argument("--box", type=float, nargs=4, metavar=("XMIN", "XMAX", "YMIN", "YMAX"),
                        help="target box in mm (default: the half-disc y >= 0 within reach l)")
    common.add_tension_option(parser, "--tension-spacing", default=2.0,
                              help="tension grid spacing in mode tensions")
    common.add_tension_option(parser, "--tension-max", default=40.0,
                              help="largest tension on the grid in mode tensions")
    parser.add_argument("--chunk", type=int, default=24, metavar="K",
                        help="samples per work unit (warm-started in a row; default 24)")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted run in --out, computing only what is missing "
                             "(on a complete file: nothing to compute, e.g. to redraw --plot)")
    parser.add_argument("--overlay", nargs="+", metavar="H5",
                        help="traced paths (files from `trace --out`) drawn on the --plot maps")
    common.add_arm_options(parser)
    parser.add_argument("--vtk", metavar="DIR",
                        help="also write the map for ParaView as DIR/workspace.vtu (samples as "
                             "points with every field, lattice cells as quads)")
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from mpi4py import MPI

    from ..studies.workspace import CollectiveInputError

    comm = MPI.COMM_WORLD
    try:
        return _run(args, comm)
    except CollectiveInputError:                   # raised on every rank alike: one line, exit 2
        if comm.rank == 0:
            raise
        return 2
    except Exception as err:                       # never leave the other ranks waiting
        if comm.size == 1:
            raise
        from ..core.errors import InputError
        kind = "error" if isinstance(err, InputError) else f"{type(err).__name__}"
        print(f"elastica-petsc: rank {comm.rank}: {kind}: {err}", file=sys.stderr, flush=True)
        comm.Abort(2 if isinstance(err, InputError) else 1)


def _run(args, comm) -> int:
    from ..core.config import arm_to_dict
    from ..core.errors import InputError
    from ..io.hdf5 import provenance
    from ..studies.sampling import TargetSampler, TensionSampler
    from ..studies import workspace

    # Input errors are agreed on by all ranks before any collective work (one line, exit 2).
    try:
        arm, disc, grid, out, checkpoint_seconds = _check_inputs(args)
        error = None
    except InputError as err:
        error = str(err)
    workspace.agree(comm, error)
    if grid.mode == "targets":
        sampler = TargetSampler(arm, disc)
    else:
        sampler = TensionSampler(arm, disc)
    attrs = provenance(arm, "workspace")
    attrs.update(mode=grid.mode, elements=disc.n_elements, n_tendons=disc.n_tendons,
                 config_json=json.dumps(arm_to_dict(arm)), grid_json=json.dumps(grid.meta))
    limits = {"kappa_limit": arm.kappa_limit,
              "strain_energy_max": arm.limits.strain_energy_max_SE0,
              "max_tension": arm.max_tension}
    try:
        results = workspace.run(grid, sampler, out, attrs, limits, comm=comm, resume=args.resume,
                                checkpoint_seconds=checkpoint_seconds,
                                progress_label=f"workspace ({grid.mode}, {comm.size} rank(s))")
    finally:
        sampler.destroy()
    if comm.rank != 0:
        return 0
    summary = workspace_summary(results, limits, out)
    if args.json:
        common.print_json(summary)
    else:
        print(format_summary(summary))
    if not summary["complete"]:
        print(f"elastica-petsc: interrupted: {summary['samples_done']} of "
              f"{summary['samples_total']} samples saved in {out}; continue with --resume",
              file=sys.stderr)
        return 130
    if args.plot:
        from ..plots.workspace import plot_workspace, read_overlays
        plot_workspace(out, args.plot, paths=read_overlays(args.overlay or ()))
    if args.vtk:
        from ..io.vtk import write_workspace_vtk
        write_workspace_vtk(args.vtk, out)
    return 0


def _check_inputs(args):
    """Everything that can be refused before computing:
    (arm, discretisation, grid, output path, checkpoint seconds)."""
    from ..core.errors import InputError
    from ..studies import workspace

    if not args.out:
        raise InputError("workspace needs --out FILE.h5 (results are written as they come)")
    if args.chunk < 1:
        raise InputError(f"--chunk must be at least 1, got {args.chunk}")
    if args.vtk:
        from ..io.vtk import check_directory
        check_directory(args.vtk, args.overwrite)
    arm, disc = common.load_arm(args)
    if args.overlay:
        from ..plots.workspace import read_overlays
        read_overlays(args.overlay)                 # refuse a bad file before computing
    out = Path(args.out)
    if args.resume and not out.exists():
        raise InputError(f"--resume: {out} does not exist")
    if not args.resume:
        common.check_outputs(args)
    elif args.plot:
        from ..io.hdf5 import check_output_path
        check_output_path(args.plot, args.overwrite)
    if args.mode == "targets":
        if disc.n_tendons < 2:
            raise InputError("mode targets needs at least 2 tendons (a 2-D workspace); "
                             "use --mode tensions")
        grid = workspace.target_grid(arm.length_mm, args.spacing,
                                     None if args.box is None else tuple(args.box), args.chunk)
    else:
        grid = workspace.tension_grid(disc.n_tendons, args.tension_spacing, args.tension_max,
                                      args.chunk)
    return arm, disc, grid, out, workspace.checkpoint_interval()


def workspace_summary(results, limits: dict, out: Path) -> dict:
    import numpy as np

    from ..studies.workspace import STATUS_NAMES

    status = results.data["status"]
    masks = results.masks(limits)
    return {
        "file": str(out),
        "complete": bool(results.chunk_done.all()),
        "samples_total": int(results.grid.size),
        "samples_done": int(results.samples_done),
        "status_counts": {STATUS_NAMES[k]: int(np.sum(status == k)) for k in STATUS_NAMES
                          if k != 0},
        "masks": {name: int(m.sum()) for name, m in masks.items()},
        "lambda_min_raw_min": float(np.nanmin(results.data["lambda_min_raw"]))
        if masks["W0"].any() else None,
        "kappa_max_max": float(np.nanmax(results.data["kappa_max"])) if masks["W0"].any() else None,
    }


def format_summary(s: dict) -> str:
    lines = [f"workspace samples: {s['samples_done']}/{s['samples_total']} done -> {s['file']}"]
    for name, count in s["status_counts"].items():
        lines.append(f"  {name}: {count}")
    lines.append("  admissible: " + ", ".join(f"{k} {v}" for k, v in s["masks"].items()))
    if s["lambda_min_raw_min"] is not None:
        lines.append(f"  smallest raw eigenvalue lambda_min(K)/(B/l): {s['lambda_min_raw_min']:.3g}"
                     f";  largest l*kappa_max: {s['kappa_max_max']:.3g}")
    return "\n".join(lines)
