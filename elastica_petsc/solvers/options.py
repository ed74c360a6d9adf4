"""PETSc options: the one contract of every class here that owns PETSc objects.

Every such class (the DOLFINx ``NonlinearProblem`` style) takes

* ``comm``: the communicator of its objects (one process: each arm is a
  small problem, parallelism is across arms), :func:`check_comm`;
* ``options_prefix``: checked by :func:`check_prefix` (non-empty, ending in
  ``_``, letters, digits and ``_``), given to its solvers, matrices and
  vectors, so ``-eq_snes_monitor`` or ``-ctl_tao_view`` reach them;
* ``petsc_options``: a mapping of options without the prefix, nested dicts
  flattened (``{"snes": {"rtol": 1e-8}}`` is ``snes_rtol``,
  :func:`flatten_options`).

:class:`SolverOptions` holds them: the class's own defaults, then
``petsc_options`` over them, are pushed under the prefix for the objects'
``setFromOptions()`` only where the user has not set them (the command line
wins), and removed again so they never leak into the next solver.  Options
given after the first solve (in the database, or by
:meth:`SolverOptions.update`) are applied at the next solve
(:meth:`SolverOptions.refresh`).

* :func:`call_options` — the ``petsc_options=`` of one library call
  (``elastica_petsc.api``): the same push and removal, over the database.
* :func:`unused_options` — options in PETSc's database that no solver read
  (like ``-options_left``).  petsc4py 3.18 has no binding for
  ``PetscOptionsUsed``; it is called through ctypes on the PETSc library this
  process has loaded.  When that library cannot be found the check is
  skipped (returns None): it is a convenience, never a reason to fail.
"""
from __future__ import annotations

import ctypes
import os
import re
from collections.abc import Mapping
from contextlib import contextmanager

from petsc4py import PETSc

from ..core.errors import InputError

# An options prefix: starts with a letter, letters/digits/underscores, ends in "_".
PREFIX_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_]*_")


def check_prefix(prefix) -> str:
    """``prefix`` if it is a legal options prefix, else an InputError saying why."""
    if not isinstance(prefix, str) or not prefix:
        raise InputError(f"options prefix must be a non-empty string, got {prefix!r}")
    if not PREFIX_PATTERN.fullmatch(prefix):
        why = ("must end with '_'" if not prefix.endswith("_") else
               "must start with a letter and hold only letters, digits and '_'")
        raise InputError(f"options prefix {prefix!r} {why} (e.g. 'eq_')")
    return prefix


def check_comm(comm=None) -> PETSc.Comm:
    """The communicator of a solver of one arm: COMM_SELF by default; any
    other must hold a single process (parallelism is across arms)."""
    comm = PETSc.COMM_SELF if comm is None else PETSc.Comm(comm)
    if comm.getSize() != 1:
        raise InputError(f"this solver works on one process (one arm); got a communicator of "
                         f"{comm.getSize()} processes: give PETSc.COMM_SELF")
    return comm


def flatten_options(options: Mapping | None, parent: str = "") -> dict:
    """``{"snes": {"rtol": 1e-8}, "ksp_type": "preonly"}`` ->
    ``{"snes_rtol": 1e-8, "ksp_type": "preonly"}`` (keys without a leading '-')."""
    flat = {}
    for key, value in (options or {}).items():
        if not isinstance(key, str) or not key.lstrip("-"):
            raise InputError(f"PETSc option names must be non-empty strings, got {key!r}")
        name = parent + key.lstrip("-")
        if isinstance(value, Mapping):
            flat.update(flatten_options(value, name + "_"))
        else:
            flat[name] = value
    return flat


@contextmanager
def pushed_options(prefix: str, options: Mapping | None, *, override: bool = False):
    """``options`` (flat, keys without ``prefix``; None for a flag) in PETSc's
    database under ``prefix`` for the duration, then removed.  Names already
    in the database are left alone (the user's win: a class's defaults), or
    with ``override`` replaced and their earlier values restored afterwards
    (the options of one library call).  Yields the names pushed."""
    opts = PETSc.Options()
    names = [prefix + key for key in (options or {})]
    before = {name: opts.getString(name) for name in names if opts.hasName(name)}
    pushed = names if override else [name for name in names if name not in before]
    for name in pushed:
        opts[name] = options[name[len(prefix):]]
    try:
        yield pushed
    finally:
        for name in pushed:
            opts.delValue(name)
            if name in before:
                opts[name] = before[name]


@contextmanager
def call_options(petsc_options: Mapping | None):
    """The ``petsc_options=`` of one library call (names with or without their
    leading '-', nested dicts flattened) in force for the ``with`` block only,
    over whatever the database held (restored afterwards); InputError for
    names that nothing read during the block (when that check is available,
    :func:`unused_options`)."""
    if not petsc_options:
        yield
        return
    if not isinstance(petsc_options, Mapping):
        raise InputError("petsc_options must be a mapping {name: value}, "
                         "e.g. {'eq_snes_rtol': 1e-10}")
    with pushed_options("", flatten_options(petsc_options), override=True) as names:
        yield
        unused = unused_options(names)
    if unused:
        raise InputError(f"PETSc options not used by any solver of this call: "
                         f"{' '.join(unused)} (check the name and its prefix)")


def options_under(prefix: str) -> dict:
    """The entries of PETSc's database whose names start with ``prefix``."""
    return {k: v for k, v in PETSc.Options().getAll().items() if k.startswith(prefix)}


class SolverOptions:
    """The options of one PETSc-owning object (module doc): its checked
    prefix, and the options given in code (``defaults`` of the class, then
    ``petsc_options`` over them), flat and without the prefix."""

    def __init__(self, options_prefix: str, petsc_options: Mapping | None = None,
                 defaults: Mapping | None = None):
        self.prefix = check_prefix(options_prefix)
        self.options = {**flatten_options(defaults), **flatten_options(petsc_options)}
        self._seen: dict | None = None        # the database under the prefix when applied
        self._updated = False

    def name(self, suffix: str = "") -> str:
        """The prefix of a part, e.g. ``name("raw_")`` -> ``stab_raw_``."""
        return self.prefix + suffix

    def part(self, suffix: str) -> dict:
        """The code options of a part with its own prefix ``<prefix><suffix>``,
        keys relative to it: ``{"eq_snes_rtol": 1}`` -> ``part("eq_")`` = ``{"snes_rtol": 1}``."""
        return {k[len(suffix):]: v for k, v in self.options.items() if k.startswith(suffix)}

    def label(self, *objs) -> None:
        """Give PETSc objects (solvers, Mats, Vecs) the prefix."""
        for obj in objs:
            obj.setOptionsPrefix(self.prefix)

    def apply(self, *objs) -> None:
        """``setFromOptions()`` of each object (it has its own prefix, this one
        or longer) with the code options pushed under this prefix."""
        with pushed_options(self.prefix, self.options):
            for obj in objs:
                obj.setFromOptions()
        self._seen, self._updated = options_under(self.prefix), False

    def update(self, petsc_options: Mapping) -> None:
        """More options in code (over the earlier ones), applied at the next
        :meth:`refresh`."""
        self.options.update(flatten_options(petsc_options))
        self._updated = True

    def refresh(self, *objs) -> bool:
        """Apply options given since the last :meth:`apply` (in the database
        under the prefix, or by :meth:`update`) to ``objs``; True if any were."""
        if not self._updated and options_under(self.prefix) == self._seen:
            return False
        self.apply(*objs)
        return True


def petsc_library():
    """The loaded libpetsc (from /proc/self/maps), else the one in PETSC_DIR/lib."""
    paths = []
    try:
        with open("/proc/self/maps") as fh:
            paths = [line.split()[-1] for line in fh if "libpetsc" in line and "/" in line]
    except OSError:
        pass
    if not paths:
        import petsc4py
        lib = os.path.join(petsc4py.get_config().get("PETSC_DIR", ""), "lib")
        if os.path.isdir(lib):
            paths = [os.path.join(lib, f) for f in sorted(os.listdir(lib))
                     if f.startswith("libpetsc") and ".so" in f]
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
            lib.PetscOptionsUsed                                   # noqa: B018 (lookup)
            return lib
        except (OSError, AttributeError):
            continue
    return None


def unused_options(names=None, *, root_only: bool = False) -> list[str] | None:
    """Options in PETSc's database (default: all of them) that nothing has
    read so far, as ``-name``; None if the check is not available.
    ``root_only``: [] on every rank of COMM_WORLD but 0 (one report per run)."""
    if root_only and PETSc.COMM_WORLD.rank != 0:
        return []
    lib = petsc_library()
    if lib is None:
        return None
    names = list(PETSc.Options().getAll()) if names is None else [n.lstrip("-") for n in names]
    unused = []
    for name in names:
        flag = ctypes.c_int(0)
        if lib.PetscOptionsUsed(None, name.encode(), ctypes.byref(flag)) != 0:
            return None
        if not flag.value:
            unused.append(f"-{name}")
    return unused
