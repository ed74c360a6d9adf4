"""Builds the compiled kernels of core/fem.py and core/dynamics.py (docs/model.md
§20, §29); everything else is declared in pyproject.toml.  Needs a C compiler and
Python's headers (Debian: gcc, python3-dev, in scripts/system-packages-dev.txt)."""
from setuptools import Extension, setup

setup(ext_modules=[Extension("elastica_petsc.core.fem_kernels",
                             ["elastica_petsc/core/fem_kernels.c",
                              "elastica_petsc/core/fem_inertia.c",
                              "elastica_petsc/core/fem_dynamics.c"],
                             depends=["elastica_petsc/core/fem_kernels.h"],
                             extra_compile_args=["-O2", "-std=c99"])])
