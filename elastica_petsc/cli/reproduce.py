"""``elastica-petsc reproduce``: the paper's computations end to end, with a comparison report."""
from __future__ import annotations

import sys
from pathlib import Path

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "reproduce", help="reproduce the paper's figures and numbers into a folder with REPORT.md",
        description="Run every experiment of the paper (Figs. 2, 3a, 3b, 4, 5a-d, 6a-c, 7, 8 and "
                    "the aluminium thought experiment of Sec. 4.3) on the paper's arm: an HDF5 "
                    "file per experiment, a PNG per figure and REPORT.md, a table of every "
                    "reference number with the paper's value beside ours. --quick uses coarse "
                    "grids (about 30 s on an idle 2-core machine, longer on a busy one); the full run uses the paper's resolution (about "
                    "4201 workspace samples). Under mpiexec, or with --jobs > 1, the workspace "
                    "sampling runs on several MPI ranks.")
    parser.add_argument("--out", default="results", metavar="DIR",
                        help="output folder (default ./results)")
    parser.add_argument("--quick", action="store_true", help="coarse grids for a first look")
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="MPI ranks for the workspace sampling (spawns mpiexec; default 1)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace the files of an earlier run in --out (without it, any of "
                         "them there is refused before computing)")
    parser.add_argument("--config", metavar="TOML",
                        help="arm configuration (default: the paper's arm)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress output (per-experiment lines and progress bars); the "
                             "closing line and errors are still printed")
    parser.add_argument("--aluminium-config", metavar="TOML",
                        help="arm for the Sec. 4.3 thought experiment (default: shipped "
                             "configs/aluminium.toml)")
    parser.set_defaults(run=run)


def run(args) -> int:
    from importlib import resources

    from mpi4py import MPI

    from ..core.model import load_config
    from ..core.errors import InputError
    from ..reproduce import Context, check_output_folder, run as run_all

    comm = MPI.COMM_WORLD
    if args.jobs < 1:
        raise InputError(f"--jobs must be at least 1, got {args.jobs}")
    from ..studies.chunks import agree

    out, error = Path(args.out), None
    alu = Path(args.aluminium_config) if args.aluminium_config else \
        Path(str(resources.files("elastica_petsc") / "configs" / "aluminium.toml"))
    try:
        if comm.rank == 0:
            check_output_folder(args.out, args.overwrite)
        arm = load_config(args.config)
        from ..core.friction import check_frictionless
        check_frictionless(arm, "`reproduce`")
        load_config(alu)                    # refused now, not after the other experiments
        seconds = common.checkpoint_seconds()
    except InputError as err:
        error = str(err)
    agree(comm, error)
    if comm.rank == 0:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise InputError(f"--out {out}: cannot create the folder ({err.strerror})") \
                from None
    ctx = Context(arm=arm, out=out, quick=args.quick, jobs=args.jobs, comm=comm,
                  checkpoint_seconds=seconds)
    log = ((lambda message: None) if args.quiet else
           (lambda message: print(message, file=sys.stderr, flush=True)))
    report = run_all(ctx, "elastica-petsc " + " ".join(sys.argv[1:]), alu, log=log)
    if report is not None:
        print(f"wrote {report} and {sum(len(v) for v in ctx.files.values())} result files "
              f"into {out}/")
    return 0
