"""``elastica-petsc workspace``: sample the workspace and its restrictions (Sec. 4.3, Figs. 4-5).

Run under MPI for speed: ``mpiexec -n 4 elastica-petsc workspace --spacing 10 --out ws.h5``.
"""
from __future__ import annotations

import sys

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
                        help="target box in mm (default: --region)")
    parser.add_argument("--region", choices=("half-disc", "disc"),
                        help="without --box: the half-disc y >= 0 within reach l (the paper's "
                             "Fig. 4; the default for the paper's arm) or the whole disc of "
                             "reach (the default with --config: a user's arm need not be "
                             "symmetric, and half of its W_0 may lie below y = 0)")
    common.add_tension_option(parser, "--tension-spacing", default=2.0,
                              help="tension grid spacing in mode tensions")
    common.add_tension_option(parser, "--tension-max", default=40.0,
                              help="largest tension on the grid in mode tensions")
    parser.add_argument("--sampler", choices=("boundary-fill", "global-search", "local"),
                        help="mode targets: 'boundary-fill' (the default) classes every target "
                             "by the traced boundary of W_0 first, fills its interior by Newton "
                             "sweeps on the tip and searches globally only the targets they "
                             "miss (two tendons; other arms: the global search); "
                             "'global-search': tip control and the global search for every "
                             "target (the sampler before); 'local': as --local-only")
    parser.add_argument("--local-only", action="store_true",
                        help="mode targets: no global search for the targets local tip control "
                             "does not reach; they keep its local verdicts (ended on P_i = 0, "
                             "not converged), as before the global search; faster "
                             "(= --sampler local)")
    from .control import add_share_options
    add_share_options(parser, "each reached target (mode targets; the map then samples "
                              "W_0(P_min), docs/model.md §9.3)")
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

    from ..studies.chunks import CollectiveInputError

    comm = MPI.COMM_WORLD
    try:
        return _run(args, comm)
    except CollectiveInputError:                   # raised on every rank alike: one line, exit 2
        raise
    except KeyboardInterrupt:                      # outside the stop protocol (set-up)
        if comm.size == 1:
            raise
        _exit_without_finalize(130, "interrupted")
    except Exception as err:                       # never leave the other ranks waiting
        if comm.size == 1:
            raise
        from ..core.errors import InputError
        kind = "error" if isinstance(err, InputError) else f"{type(err).__name__}"
        print(f"elastica-petsc: rank {comm.rank}: {kind}: {err}", file=sys.stderr, flush=True)
        comm.Abort(2 if isinstance(err, InputError) else 1)


def _sampler(args) -> str | None:
    """The --sampler asked for (--local-only: 'local'); InputError for both at odds
    or for a sampler in mode tensions."""
    from ..core.errors import InputError

    if args.local_only and args.sampler not in (None, "local"):
        raise InputError(f"--local-only contradicts --sampler {args.sampler}")
    if args.sampler is not None and args.mode != "targets":
        raise InputError("--sampler applies to mode targets (mode tensions: forward solves)")
    return "local" if args.local_only else args.sampler


def _run(args, comm) -> int:
    from ..core.errors import InputError
    from ..studies.chunks import agree
    from ..studies.workspace import run_map

    # Input errors are agreed on by all ranks before any collective work (one line, exit 2).
    try:
        arm, disc = _check_inputs(args)
        seconds = common.checkpoint_seconds()
        sampler = _sampler(args)
        error = None
    except InputError as err:
        error = str(err)
    agree(comm, error)
    result = run_map(
        arm, disc, mode=args.mode, spacing_mm=args.spacing, box_mm=args.box,
        tension_spacing=args.tension_spacing, tension_max=args.tension_max, chunk=args.chunk,
        comm=comm, out=args.out, resume=args.resume, overwrite=args.overwrite,
        global_search=not args.local_only, share=args.share, min_tension_N=args.min_tension_N,
        sampler=sampler,
        region=default_region(args), checkpoint_seconds=seconds, progress=True)
    if comm.rank != 0:
        if comm.size > 1 and not result.complete:
            comm.Barrier()                          # rank 0 has printed (a rank that ends
            _exit_without_finalize(130, None)       # first makes mpiexec kill the others)
        return 0
    from ..studies.map_area import map_json
    described = map_json(result, args.box)     # status codes, region, lattice, area
    summary = result.summary()                 # status counts in words, for the text
    if args.json:
        common.print_json(args.command, summary | described)
    else:
        print(format_summary(summary | {k: v for k, v in described.items()
                                        if k != "status_counts"}))
    summary = summary | described
    if not summary["complete"]:
        message = (f"interrupted: {summary['samples_done']} of {summary['samples_total']} "
                   f"samples saved in {args.out}; continue with --resume")
        if result.stranded or comm.size > 1:
            # after a stop under mpiexec, MPI's finalisation waits on a launcher that is
            # tearing the job down (measured: every rank held there until killed ~2 s
            # after the signal, exit status 1): every rank ends here, status 130, once
            # this line is out (the others wait for it at a barrier, unless stranded)
            if result.stranded:
                _exit_without_finalize(130, message)
            print(f"elastica-petsc: {message}", file=sys.stderr, flush=True)
            sys.stdout.flush()
            comm.Barrier()
            _exit_without_finalize(130, None)
        print(f"elastica-petsc: {message}", file=sys.stderr)
        return 130
    if args.plot:
        from ..plots.workspace import plot_workspace, read_overlays
        plot_workspace(args.out, args.plot, paths=read_overlays(args.overlay or ()))
    if args.vtk:
        from ..io.vtk import write_workspace_vtk
        write_workspace_vtk(args.vtk, args.out)
    return 0


def default_region(args) -> str:
    """--region, or the paper's half-disc for the paper's arm and the whole disc of
    reach for an arm of the user's own (--config)."""
    if args.region is not None:
        return args.region
    return "half-disc" if args.config is None else "disc"


def _exit_without_finalize(status: int, message: str | None) -> None:
    """End this rank now: another rank is busy and will never join MPI's
    finalisation; the launcher ends the others once this one is gone."""
    import os

    if message:
        print(f"elastica-petsc: {message}", file=sys.stderr, flush=True)
    sys.stdout.flush()
    common.release_outputs()                   # no lock file left beside the output
    os._exit(status)


def _check_inputs(args):
    """What the command line refuses before the library sees it: (arm, discretisation)."""
    from ..core.errors import InputError

    if not args.out:
        raise InputError("workspace needs --out FILE.h5 (results are written as they come)")
    from ..api import MIN_SPACING_MM
    from ..core.inputs import positive, tensions
    positive(args.spacing, "--spacing", "mm", at_least=MIN_SPACING_MM)
    arm, disc = common.load_arm(args)             # --tension-max-N etc. now in p
    for flag in ("--tension-max", "--tension-spacing"):
        tensions([getattr(args, flag[2:].replace("-", "_"))], 1, flag, "P l^2/B")
    positive(args.tension_spacing, "--tension-spacing", "P l^2/B", at_least=1e-9)
    if args.vtk:
        from ..io.vtk import check_directory
        check_directory(args.vtk, args.overwrite)
    if args.overlay:
        from ..plots.workspace import read_overlays
        read_overlays(args.overlay)                 # refuse a bad file before computing
    from mpi4py import MPI
    common.check_outputs(args, _derived_plots(args), resume=args.resume,
                         lock=MPI.COMM_WORLD.rank == 0)
    return arm, disc


def _derived_plots(args) -> dict:
    """The second figure ``plot_workspace`` draws beside --plot (Fig. 5)."""
    if not args.plot:
        return {}
    from pathlib import Path
    plot = Path(args.plot)
    return {"--plot (Fig. 5)": plot.with_name(plot.stem + "_restrictions.png")}


def format_summary(s: dict) -> str:
    lines = [f"workspace samples: {s['samples_done']}/{s['samples_total']} done -> {s['file']}"]
    if s.get("region"):
        lines.append(f"  region: {s['region']}")
    if s.get("area_mm2") is not None:
        lines.append(f"  area of W_0 in the region: {s['area_mm2']:.0f} ± "
                     f"{s['area_error_mm2']:.0f} mm^2 (lattice cells of the reached samples)")
    if s.get("share", "none") != "none":
        lines.append(f"  tensions shared {s['share']}, every P >= {s['min_tension_floor_N']:g} N "
                     "(W_0(P_min), docs/model.md §9.3)")
    for name, count in s["status_counts"].items():
        lines.append(f"  {name}: {count}")
    lines.append("  admissible: " + ", ".join(f"{k} {v}" for k, v in s["masks"].items()))
    if s["lambda_min_raw_min"] is not None:
        lines.append(f"  smallest raw eigenvalue lambda_min(K)/(B/l): {s['lambda_min_raw_min']:.3g}"
                     f";  largest l*kappa_max: {s['kappa_max_max']:.3g}")
    return "\n".join(lines)
