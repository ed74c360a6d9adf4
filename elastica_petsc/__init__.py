"""elastica_petsc: tendon-actuated elastic arms (Handral & Rangarajan 2019) on PETSc.

The library never initialises PETSc itself; the command-line entry point
(:mod:`elastica_petsc.cli`) calls ``petsc4py.init(argv)`` once.
"""
__version__ = "0.1.0"
