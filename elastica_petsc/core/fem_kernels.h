/* Shared by the compiled kernels of core/fem.py (fem_kernels.c: the elastica;
 * fem_inertia.c: the Sylvester inertia of the bordered stability matrix) and of
 * core/dynamics.py (fem_dynamics.c: the arm in motion); docs/model.md §20, §29. */
#ifndef ELASTICA_FEM_KERNELS_H
#define ELASTICA_FEM_KERNELS_H
#define _GNU_SOURCE             /* sincos */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* PETSc's default zero pivot of a factorisation (100 machine epsilons, absolute) */
#define ZERO_PIVOT (100.0 * DBL_EPSILON)

/* 0, or -1 with a ValueError if the buffer does not hold count items of item bytes. */
int check_len(Py_buffer *b, Py_ssize_t count, Py_ssize_t item, const char *what);

/* inertia(indptr, indices, values, n_angles) of the Python module (fem_inertia.c). */
PyObject *inertia(PyObject *self, PyObject *args);

/* The kernels of the arm in motion (fem_dynamics.c), added to the module at import. */
extern PyMethodDef dynamics_methods[];

#endif
