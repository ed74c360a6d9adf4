"""elastica_petsc: tendon-actuated elastic arms (Handral & Rangarajan 2019) on PETSc.

A library first, in millimetres and newtons at its edge (an example that the
tests run, tests/test_doctests.py):

>>> import elastica_petsc as ep
>>> arm = ep.Arm.paper()
>>> state = ep.solve(arm, tensions_N=[14.0, 6.0], order=(2, 1))   # Fig. 8, state 1
>>> state
State(arm=Arm(...), equilibrium=Equilibrium(...), loading='order 2,1')
>>> state.cable_lengths_mm.round(1), state.tip_mm.round(1), state.stable
(array([147.2, 472.5]), array([489.8, 141.8]), True)
>>> ep.control(arm, [535.8, 222.6]).tensions_N.round(3)           # Fig. 2
array([1.206, 4.201])

One call per study: :func:`solve`, :func:`control`, :func:`trace`,
:func:`schedule`, :func:`stability`, :func:`frequencies`, :func:`lengths`,
:func:`length_equilibria`, :func:`equilibria`,
:func:`workspace`, :func:`boundary`, :func:`design`, :func:`design_area`,
:func:`design_sweep`, :func:`calibrate`, :func:`simulate`; :func:`save` and :func:`read` write and
read any result.  Every result type is exported (``ep.ControlResult``,
``ep.WorkspaceMap`` ...): frozen, printed in one line, with ``summary() -> dict``
and ``save(path)``.  Errors derive from :class:`ElasticaError`
(:class:`InputError` for bad input, :class:`SolverError` for a method that could
not run; "not converged" is a result, not an exception).  The solver classes
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
    "Limits": ".core.model",
    # errors (core/errors.py): the base, bad user input, a method that could not run
    "ElasticaError": ".core.errors", "InputError": ".core.errors",
    "SolverError": ".core.errors",
    "solve": ".api", "control": ".api", "trace": ".api", "schedule": ".api",
    "stability": ".api", "frequencies": ".api", "lengths": ".api",
    "length_equilibria": ".api", "equilibria": ".api",
    "workspace": ".api", "boundary": ".api", "design": ".api",
    "design_area": ".api", "design_sweep": ".api",
    "read": ".api", "save": ".api", "calibrate": ".api", "simulate": ".api",
    "friction_path": ".api", "fastest_speed": ".api",
    # result types: frozen, short repr, summary() -> dict, save(path); ep.read(path) -> same type
    "State": ".api", "Equilibrium": ".solvers.equilibrium",
    "ControlResult": ".solvers.control", "Stability": ".solvers.stability",
    "Frequencies": ".solvers.stability", "LengthEquilibrium": ".solvers.lengths",
    "TraceResult": ".studies.trace", "TracedSchedule": ".studies.schedule",
    "SearchResult": ".studies.search", "WorkspaceMap": ".studies.workspace",
    "BoundaryResult": ".studies.boundary", "DesignResult": ".studies.design",
    "AreaDesign": ".studies.design_area", "Sweep": ".studies.design_sweep",
    "SimulationResult": ".studies.simulate", "SpeedStudy": ".studies.speed",
    "CalibrationResult": ".studies.calibrate_report",
    "FrictionResult": ".api",
    # solver classes, for loops
    "EquilibriumSolver": ".solvers.equilibrium",
    "TipController": ".solvers.control", "LengthSolver": ".solvers.lengths",
    "StabilitySolver": ".solvers.stability",
    # animations of results (GIF/MP4)
    "animate_simulation": ".plots.animate",
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
