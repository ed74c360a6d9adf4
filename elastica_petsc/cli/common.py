"""Options and helpers shared by the subcommands (no PETSc import here)."""
from __future__ import annotations

import argparse
import json
import os
import sys

from ..core.model import load_config
from ..core.errors import InputError
from ..core.model import Arm


def add_arm_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", metavar="TOML",
                        help="arm configuration (default: the paper's arm, configs/paper.toml)")
    parser.add_argument("--elements", type=elements_count, metavar="N|auto",
                        help="number of finite elements (overrides the config); auto: the "
                             "count nearest the config's that puts every attachment on a node")


def elements_count(text: str):
    """``--elements``: an integer or ``auto``."""
    if text == "auto":
        return text
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer or auto, got {text!r}") from None


def add_output_options(parser: argparse.ArgumentParser, plot: bool = True) -> None:
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object on stdout instead of the text summary")
    parser.add_argument("--out", metavar="H5", help="write the results to this HDF5 file")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace existing output files (--out, --plot and the like)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress bar or progress lines (for batch jobs); results and "
                             "errors are still printed")
    if plot:
        parser.add_argument("--plot", metavar="PNG", help="draw a figure into this PNG file")


def add_tension_options(parser: argparse.ArgumentParser, required: bool = True) -> None:
    group = parser.add_mutually_exclusive_group(required=required)
    group.add_argument("--tensions", type=float, nargs="+", metavar="P",
                       help="cable tensions, non-dimensional p_i = P_i l^2 / B, one per tendon")
    group.add_argument("--tensions-N", type=float, nargs="+", metavar="P",
                       help="cable tensions in newtons, one per tendon")


def add_tension_option(parser: argparse.ArgumentParser, flag: str, *, help: str,
                       nargs=None, default=None, metavar: str = "P") -> None:
    """``flag`` in p = P l^2/B and its newton form ``flag-N``, mutually
    exclusive; :func:`load_arm` turns a given ``flag-N`` into ``flag``'s p."""
    group = parser.add_mutually_exclusive_group()
    shown = "" if default is None else "; default " + " ".join(
        f"{v:g}" for v in (default if isinstance(default, list) else [default]))
    group.add_argument(flag, type=float, nargs=nargs, default=default, metavar=metavar,
                       help=f"{help} (non-dimensional p = P l^2/B{shown})")
    group.add_argument(f"{flag}-N", type=float, nargs=nargs, metavar="N",
                       help=f"the same in newtons (instead of {flag})")


def newton_forms(args, arm: Arm) -> None:
    """Replace every given ``--X-N`` value (newtons) by ``--X`` in p = P l^2/B."""
    from ..core.inputs import tensions as check

    for key in list(vars(args)):
        value = getattr(args, key)
        if not key.endswith("_N") or key == "tensions_N" or value is None:
            continue
        flag = "--" + key[:-2].replace("_", "-") + "-N"
        if not isinstance(value, list) and value < 0:          # one value, not per tendon
            raise InputError(f"{flag} must be >= 0 N, got {value:g} (a cable cannot push)")
        values = value if isinstance(value, list) else [value]
        p = [float(v) for v in arm.tensions_from_N(check(values, len(values), flag, "N",
                                                         arm.force_scale_N))]
        setattr(args, key[:-2], p if isinstance(value, list) else p[0])


def add_order_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--order", metavar="I,J,...",
                        help="loading order: e.g. 2,1 brings tendon 2 to full tension first, "
                             "then tendon 1 (default: all tendons proportionally from zero)")


def load_arm(args, friction: bool = False) -> tuple[Arm, "Discretisation"]:
    """The configured arm and its mesh (``--config``, ``--elements``); an arm with
    friction at its guides only for the friction command (``friction``)."""
    from ..core.fem import Discretisation
    from ..core.friction import check_frictionless

    from ..core import inputs

    if args.elements != "auto":
        inputs.elements(args.elements, "--elements")       # before reading the config
    arm = load_config(args.config)
    if not friction:
        check_frictionless(arm, f"`{args.command}`")
    newton_forms(args, arm)
    if args.elements == "auto":
        from ..core.fem import nearest_element_count
        args.elements = nearest_element_count(arm)
    return arm, Discretisation.from_arm(arm, inputs.elements(args.elements, "--elements"))


def tensions(args, arm: Arm):
    """Non-dimensional tensions from --tensions or --tensions-N, checked in the
    unit given."""
    from ..core.inputs import tensions as check

    if getattr(args, "tensions_N", None) is not None:
        return list(arm.tensions_from_N(check(args.tensions_N, arm.n_tendons, "--tensions-N",
                                              "N", arm.force_scale_N)))
    return list(check(args.tensions, arm.n_tendons, "--tensions", "P l^2/B"))


def guess(args, disc):
    """Validated initial tensions from ``--guess`` (non-dimensional p) or
    ``--guess-N`` (newtons, converted by :func:`load_arm`), or None."""
    if args.guess is None:
        return None
    from ..core.inputs import tensions as check
    return check(args.guess, disc.n_tendons, "--guess", "P l^2/B")


def order(args) -> tuple[int, ...] | None:
    if args.order is None:
        return None
    try:
        return tuple(int(k) for k in args.order.split(","))
    except ValueError:
        raise InputError(f"--order {args.order!r}: expected tendon numbers separated by commas, "
                         "e.g. 2,1") from None


_LOCKS: list = []          # the outputs' locks, held until the command ends (release_outputs)


def check_outputs(args, extra: dict | None = None, resume: bool = False,
                  lock: bool = True) -> None:
    """Fail early, before any computing, on output paths that would be refused:
    --out (.h5), --plot (.png/.pdf/.svg), --schedule (.csv), the --vtk folder
    and ``extra`` ({option: path}); two options naming one file are refused too.  With
    ``resume`` an existing --out is the file to continue."""
    from ..io.hdf5 import H5_SUFFIXES, PLOT_SUFFIXES, check_distinct, check_output_path

    kinds = {"out": ("--out", H5_SUFFIXES), "plot": ("--plot", PLOT_SUFFIXES),
             "schedule": ("--schedule", (".csv",))}
    paths = {}
    for attr, (option, suffixes) in kinds.items():
        path = getattr(args, attr, None)
        if path is not None:
            check_output_path(path, args.overwrite or (resume and attr == "out"), suffixes,
                              option)
            paths[option] = path
    for option, path in (extra or {}).items():
        check_output_path(path, args.overwrite, None, option)
        paths[option] = path
    check_distinct(paths)
    if getattr(args, "vtk", None) is not None:
        from ..io.vtk import check_directory
        check_directory(args.vtk, args.overwrite)
    if lock:
        lock_outputs(paths.values())


def lock_outputs(paths) -> None:
    """Own the output files until the command ends: another run on one of them
    is refused now, before computing (the lock rules of io/exclusive.py);
    ``lock=False`` on the ranks other than 0 under mpiexec."""
    from ..io.exclusive import lock_outputs as take

    _LOCKS.extend(take(paths))


def release_outputs() -> None:
    while _LOCKS:
        _LOCKS.pop().release()


JSON_SCHEMA_VERSION = 1     # elastica_petsc/schema/output.schema.json, docs/json.md


def print_json(kind: str, data: dict) -> None:
    """One JSON object on stdout: ``kind`` (the command, or ``error``),
    ``schema_version``, then ``data`` (docs/json.md); numpy values as JSON
    (core/jsontext.py, the one encoder)."""
    from ..core import jsontext

    jsontext.dump({"kind": kind, "schema_version": JSON_SCHEMA_VERSION, **data}, sys.stdout,
                  indent=2)
    sys.stdout.write("\n")


CHECKPOINT_ENV = "ELASTICA_PETSC_CHECKPOINT_SECONDS"


def checkpoint_seconds() -> float | None:
    """``$ELASTICA_PETSC_CHECKPOINT_SECONDS`` (seconds between checkpoints of the
    MPI studies; None when unset: the library's default), or :class:`InputError`."""
    from ..studies.chunks import check_checkpoint_seconds

    value = os.environ.get(CHECKPOINT_ENV)
    if value is None:
        return None
    try:
        return check_checkpoint_seconds(value)
    except InputError:
        raise InputError(f"{CHECKPOINT_ENV}={value!r}: expected seconds >= 0") from None


TIME_LIMIT_EXIT = 5         # stopped at --max-seconds before the answer was complete (TIME_LIMIT)


def add_max_seconds_option(parser: argparse.ArgumentParser, what: str) -> None:
    """--max-seconds S: a time budget after which ``what`` stops and reports
    what it has (reason/outcome TIME_LIMIT, exit status 5)."""
    parser.add_argument("--max-seconds", type=float, default=None, metavar="S",
                        help=f"time budget in seconds: after it {what} stops at its next step "
                             "and reports what it has with the verdict TIME_LIMIT "
                             f"(exit status {TIME_LIMIT_EXIT}); default: no limit")


def max_seconds(args) -> float | None:
    """--max-seconds checked: None or a positive finite number (else InputError, exit 2)."""
    from ..core.budget import check_max_seconds

    return check_max_seconds(args.max_seconds, "--max-seconds")
