"""Command-line entry point: ``elastica-petsc COMMAND [options] [PETSc options]``.

Every subcommand lives in :mod:`elastica_petsc.cli` as a module with
``add_parser(subparsers)`` (argument definitions only, no PETSc import) and
``run(args) -> exit status``.  Options that argparse does not know and that
start with a single dash (``-eq_snes_monitor``, ``-ctl_tao_monitor``,
``-stab_eps_view``) are handed to PETSc: ``petsc4py.init`` happens here,
once, before any solver module is imported.

Exit status: 0 success; 1 a solve that did not converge; 2 bad input or an
output that cannot be written (one line on stderr, no traceback; with
``--json`` also an error object on stdout, docs/json.md); 3 a target
outside the workspace; 4 a target neither reached nor proven unreachable;
5 stopped by ``--max-seconds`` (TIME_LIMIT: what was found in time is
printed, and what was not decided is said); 130 interrupted (SIGINT or SIGTERM).  Under mpiexec an
input error found by every rank is printed once, by rank 0; Open MPI's own
banner about a non-zero exit status is mpiexec's to print (``mpiexec --quiet``
or ``OMPI_MCA_orte_execute_quiet=1`` silences it).
"""
from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys

from ..core import inputs
from ..core.errors import InputError

COMMANDS = ("solve", "control", "trace", "stability", "workspace", "boundary", "design", "lengths",
            "equilibria", "replay", "schedule", "simulate", "reproduce", "calibrate", "friction")

EPILOG = """\
PETSc options: any option starting with a single dash that is not listed
above is passed to PETSc, e.g. -eq_snes_monitor, -eq_snes_rtol 1e-12
(equilibrium Newton solver, prefix eq_), -ctl_tao_monitor (tip control,
prefix ctl_), -stab_eps_view (eigen solver, prefix stab_).

Exit status: 0 ok, 1 not converged, 2 bad input (or an output that cannot be
written), 3 target proven unreachable (control: |target| > l), 4 target not
reached and not proven unreachable, 5 stopped by --max-seconds (TIME_LIMIT:
the answer so far, incomplete), 130 interrupted."""


class Parser(argparse.ArgumentParser):
    """argparse that also prints a JSON error object for a usage error when the
    command line asks for ``--json`` (its subcommand parsers are of this class too)."""

    def error(self, message):
        if "--json" in _ARGV:
            _json_error("USAGE_ERROR", f"{self.prog}: {message}")
        super().error(message)


_ARGV: list[str] = []


def _json_error(code: str, message: str) -> None:
    """The object ``--json`` prints on stdout with exit status 2 (docs/json.md)."""
    from .common import print_json
    print_json("error", {"status": 2, "error": code, "message": message})
    sys.stdout.flush()


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = Parser(
        prog="elastica-petsc",
        description="Equilibria, tip control, stability and workspaces of tendon-actuated "
                    "elastic arms (Handral & Rangarajan 2019) with PETSc, TAO and SLEPc.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f".{name}", __package__).add_parser(sub)
    return parser


def split_petsc_options(parser: argparse.ArgumentParser, rest: list[str]) -> list[str]:
    """The leftovers of argparse that are PETSc options (``-name [value]``)."""
    petsc, expecting_value = [], False
    for token in rest:
        if token.startswith("-") and not token.startswith("--") and len(token) > 1 \
                and not _is_number(token):
            petsc.append(token)
            expecting_value = True
        elif expecting_value and not token.startswith("--"):
            petsc.append(token)
            expecting_value = False
        else:
            parser.error(f"unrecognized argument: {token}")
    return petsc


OPTIONS_FILE_FLAGS = ("-options_file", "-options_file_yaml")


def check_options_files(petsc_options: list[str]) -> None:
    """A PETSc options file that PETSc could not open (it would abort its own
    initialisation with an error stack): one line instead."""
    for flag, value in zip(petsc_options, petsc_options[1:] + [None]):
        if flag not in OPTIONS_FILE_FLAGS:
            continue
        if value is None or value.startswith("-"):
            raise InputError(f"{flag} needs a file name")
        if not os.path.isfile(value) or not os.access(value, os.R_OK):
            raise InputError(f"{flag} {value}: no such readable file")


def _is_number(token: str) -> bool:
    try:
        float(token)
        return True
    except ValueError:
        return False


def main(argv: list[str] | None = None) -> int:
    # SIGTERM (a batch system, kill) ends a command like Ctrl-C: "interrupted", 130
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        status = _main(argv)
    except KeyboardInterrupt:                   # during start-up
        print("elastica-petsc: interrupted", file=sys.stderr)
        status = 130
    if status == 130:
        _forget_unhandled_interrupt()
    return status


def _forget_unhandled_interrupt() -> None:
    """Let an interrupted command exit with status 130.  CPython marks a
    KeyboardInterrupt that leaves code run by ``PyRun_String`` as unhandled (petsc4py's
    module initialisation runs such code), keeps the mark after the interrupt was
    handled here, and at the end of ``python -m`` kills itself with SIGINT (status
    -2) instead: a SIGTERM about 0.2 s into PETSc's start-up did so (1 run in 50).
    Running an empty string through ``PyRun_String`` resets the mark."""
    import ctypes

    ctypes.pythonapi.PyRun_SimpleString(b"")


def warn_unused(petsc_options: list[str]) -> None:
    """One line per PETSc option from the command line that no solver read
    (a misspelt -eq_snes_monitr), as PETSc's -options_left would (rank 0)."""
    from ..solvers.options import unused_options

    names = [t for t in petsc_options if t.startswith("-") and not _is_number(t)]
    for name in (unused_options(names, root_only=True) if names else None) or ():
        print(f"elastica-petsc: warning: PETSc option {name} was not used by any solver "
              "(misspelt, or not for this command?)", file=sys.stderr)


def _show_deprecations() -> None:
    """Deprecated input (core/errors.py InputDeprecation) as one line on stderr."""
    import warnings

    from ..core.errors import InputDeprecation

    shown = warnings.showwarning
    if getattr(shown, "elastica_petsc", False):          # installed by an earlier main()
        return

    def show(message, category, *args, **kwargs):
        if issubclass(category, InputDeprecation):
            if _is_root():          # every rank reads the same input: one line per run
                print(f"elastica-petsc: warning: {message}", file=sys.stderr)
        else:
            shown(message, category, *args, **kwargs)
    show.elastica_petsc = True
    warnings.showwarning = show


def _main(argv: list[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    _show_deprecations()
    _ARGV[:] = argv
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    petsc_options = split_petsc_options(parser, rest)
    try:
        check_options_files(petsc_options)
    except InputError as err:
        print(f"elastica-petsc: error: {err}", file=sys.stderr)
        if getattr(args, "json", False):
            _json_error("INPUT_ERROR", str(err))
        return 2
    from ..solvers import runtime
    # PETSc errors become one line here (main), not PETSc's error stack on stderr
    runtime.init(parser.prog, petsc_options, os.environ)
    from ..ui import progress
    # PETSc traps SIGPIPE and aborts MPI; a closed pipe (| head) should end quietly.
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, _interrupt)   # again: PETSc's initialisation may take it
    progress.configure(quiet=getattr(args, "quiet", False), delay=_progress_delay())
    as_json = getattr(args, "json", False)
    try:
        inputs.configure_limits(os.environ)     # ELASTICA_PETSC_MAX_*: the size limits
        status = args.run(args)
    except InputError as err:
        progress.close_all()
        if _first_to_say(err):
            print(f"elastica-petsc: error: {err}", file=sys.stderr)
            if as_json:
                _json_error("INPUT_ERROR", str(err))
        return 2
    except OSError as err:                      # an output that could not be written
        progress.close_all()
        where = f" {err.filename}" if err.filename else ""
        message = f"cannot write{where}: {err.strerror or err}"
        print(f"elastica-petsc: error: {message}", file=sys.stderr)
        if as_json:
            _json_error("OUTPUT_ERROR", message)
        return 2
    except KeyboardInterrupt:
        progress.close_all()
        print("elastica-petsc: interrupted", file=sys.stderr)
        return 130
    except Exception as err:
        what = runtime.error_text(err)
        if what is None:
            raise
        progress.close_all()
        status = _petsc_error(what, petsc_options)
        if as_json and status == 2:
            _json_error("PETSC_OPTION_ERROR", f"PETSc: {what}")
        return status
    finally:
        from .common import release_outputs
        release_outputs()
    warn_unused(petsc_options)
    return status


def _progress_delay() -> float | None:
    """``ELASTICA_PETSC_PROGRESS_DELAY_S``: seconds before any bar is drawn (None: each
    command's own; 0 draws at once, as the progress tests do)."""
    text = os.environ.get("ELASTICA_PETSC_PROGRESS_DELAY_S", "").strip()
    try:
        return max(float(text), 0.0) if text else None
    except ValueError:
        return None


def _petsc_error(what: str, petsc_options: list[str]) -> int:
    """One line for a PETSc error: with PETSc options given, most likely one of
    them (a value PETSc cannot read): bad input, status 2; otherwise status 1."""
    if petsc_options:
        print(f"elastica-petsc: error: PETSc: {what}; check the PETSc options "
              f"{' '.join(petsc_options)}", file=sys.stderr)
        return 2
    print(f"elastica-petsc: error: PETSc: {what}", file=sys.stderr)
    return 1


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def _first_to_say(err: InputError) -> bool:
    """An error every rank raised alike is printed by rank 0 only."""
    from ..studies.chunks import CollectiveInputError

    if not isinstance(err, CollectiveInputError):
        return True
    return _is_root()


def _is_root() -> bool:
    """Rank 0 of COMM_WORLD (True without mpiexec)."""
    from mpi4py import MPI
    return MPI.COMM_WORLD.rank == 0


if __name__ == "__main__":
    sys.exit(main())
