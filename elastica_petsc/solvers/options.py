"""PETSc options given in code: pushed under a solver's prefix only for its
``setFromOptions()``, only where the user has not set them (the command line
wins), and removed again so they never leak into the next solver."""
from __future__ import annotations

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
