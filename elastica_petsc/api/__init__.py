"""The public Python API: one call per study, in millimetres and newtons.

Every function takes an :class:`~elastica_petsc.core.model.Arm` (``Arm.paper()``
or ``Arm.from_toml(path)``) and returns a frozen result whose fields carry
their unit in their name (``tip_mm``, ``tensions_N``); the non-dimensional
values of the solvers (lengths / l, p = P l^2 / B, docs/model.md §3) sit
beside them (``tensions``, ``equilibrium``).  Solver objects stay available
for loops (``with TipController(arm) as c: c.solve_mm(...)``).

Every study takes ``petsc_options=`` (a mapping such as
``{"snes_rtol": 1e-10}`` or ``{"eq_snes_monitor": None}``, names with or
without their leading dash): they are put in PETSc's options database for
that call only, so they apply to the solvers it creates whether or not an
earlier call has solved; names that no solver of the call read raise
:class:`~elastica_petsc.core.errors.InputError` (a misspelt or misplaced
option never passes silently).  PETSc itself is initialised on first use
(``petsc4py.init(sys.argv)`` before the first call also works, as the
command line does).

The library prints nothing unless asked: the long studies take
``progress=`` (False by default; True draws the command line's bar on
stderr, a callable is called as ``progress(done, note)``).  Single-arm
studies run on ``PETSc.COMM_SELF``; the sampled studies (:func:`workspace`,
:func:`design_sweep`) take ``comm=`` and run on this process alone unless a
communicator is given (``comm=MPI.COMM_WORLD``: collective over its ranks).

One module per concept, every public name importable from here (``ep.X``
reaches them through the package's ``__init__``): :mod:`.states` (the
:class:`State` result, solve, stability, frequencies, length control and the
equilibrium searches), :mod:`.tip` (control, trace, schedule),
:mod:`.workspaces` (workspace, boundary), :mod:`.designs` (design,
design_area, design_sweep), :mod:`.files` (save, read), :mod:`.calibration`,
:mod:`.motion` (simulate); :mod:`.arguments` holds the checks they share and
``petsc_options=`` (through :func:`elastica_petsc.solvers.options.call_options`).
"""
from __future__ import annotations

from .states import (State, equilibria, frequencies, length_equilibria, lengths, solve,
                     stability)
from .tip import control, schedule, trace
from .workspaces import MIN_SPACING_MM, boundary, workspace
from .designs import DESIGN_NAMES, design, design_area, design_sweep
from .files import read, save
from .calibration import calibrate
from .motion import fastest_speed, simulate
from .friction import FrictionResult, friction_path

__all__ = ["State", "solve", "stability", "frequencies", "lengths", "length_equilibria",
           "equilibria", "control", "trace", "schedule", "MIN_SPACING_MM", "workspace",
           "boundary", "design", "DESIGN_NAMES", "design_area", "design_sweep", "save", "read",
           "calibrate", "simulate", "friction_path", "FrictionResult", "fastest_speed"]
