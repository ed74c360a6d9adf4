"""PETSc options: defaults given in code, and command-line options nobody read.

* :func:`set_from_options` — options given in code are pushed under a
  solver's prefix only for its ``setFromOptions()``, only where the user has
  not set them (the command line wins), and removed again so they never leak
  into the next solver.
* :func:`unused_options` — options in PETSc's database that no solver read
  (like ``-options_left``).  petsc4py 3.18 has no binding for
  ``PetscOptionsUsed``; it is called through ctypes on the PETSc library this
  process has loaded.  When that library cannot be found the check is
  skipped (returns None): it is a convenience, never a reason to fail.
"""
from __future__ import annotations

import ctypes
import os

from petsc4py import PETSc


def set_from_options(obj, prefix: str, defaults: dict | None = None) -> None:
    """``obj.setFromOptions()`` with ``defaults`` ({"snes_rtol": 1e-8, ...}, keys
    without the prefix) in force for that call only."""
    opts = PETSc.Options()
    pushed = [prefix + key for key in (defaults or {}) if not opts.hasName(prefix + key)]
    for name in pushed:
        opts[name] = defaults[name[len(prefix):]]
    try:
        obj.setFromOptions()
    finally:
        for name in pushed:
            opts.delValue(name)


def _petsc_library():
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
    lib = _petsc_library()
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
