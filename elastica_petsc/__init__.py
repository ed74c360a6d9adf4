"""elastica_petsc: tendon-actuated elastic arms (Handral & Rangarajan 2019) on PETSc.

A library first, in millimetres and newtons at its edge::

    import elastica_petsc as ep
    arm = ep.Arm.paper()
    state = ep.solve(arm, tensions_N=[14.0, 6.0], order=(2, 1))   # Fig. 8, state 1
    state.cable_lengths_mm, state.tip_mm, state.stable
    ep.control(arm, [535.8, 222.6]).tensions_N                     # Fig. 2

One call per study: :func:`solve`, :func:`control`, :func:`trace`,
:func:`schedule`, :func:`stability`, :func:`frequencies`, :func:`lengths`, :func:`equilibria`,
:func:`workspace`, :func:`boundary`, :func:`design`, :func:`design_area`,
:func:`design_sweep`, :func:`calibrate`, :func:`read`, :func:`simulate`.  The solver classes
(:class:`EquilibriumSolver`, :class:`TipController`, :class:`LengthSolver`,
:class:`StabilitySolver`) can be kept for loops; they work in the
non-dimensional units of docs/model.md §3.

Names are imported on first use, so ``import elastica_petsc`` does not start
PETSc: a script that wants PETSc options calls ``petsc4py.init(sys.argv)``
before its first solve, as the command line does.
"""
from importlib import import_module

__version__ = "0.1.0"

_EXPORTS = {
    "Arm": ".core.model", "Tendon": ".core.model", "Motor": ".core.model",
    "Limits": ".core.model", "InputError": ".core.errors",
    "State": ".api", "solve": ".api", "control": ".api", "trace": ".api", "schedule": ".api",
    "stability": ".api", "frequencies": ".api", "lengths": ".api", "equilibria": ".api",
    "workspace": ".api", "boundary": ".api", "design": ".api",
    "design_area": ".api", "design_sweep": ".api",
    "read": ".api", "calibrate": ".api", "simulate": ".api",
    "Equilibrium": ".solvers.equilibrium", "EquilibriumSolver": ".solvers.equilibrium",
    "TipController": ".solvers.control", "LengthSolver": ".solvers.lengths",
    "StabilitySolver": ".solvers.stability",
}
__all__ = list(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'elastica_petsc' has no attribute {name!r}")
    value = getattr(import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
