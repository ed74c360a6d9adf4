/* Shared by the compiled kernels of core/fem.py (fem_kernels.c: the elastica;
 * fem_inertia.c: the Sylvester inertia of the bordered stability matrix) and of
 * core/dynamics.py (fem_dynamics.c: the arm in motion); docs/model.md §20, §30. */
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

/* One arm's mesh and tendon data plus per-element work arrays (fem_kernels.c). */
typedef struct {
    Py_ssize_t N, n;            /* elements, tendons */
    double h;
    const double *routes;       /* (n, 2) */
    const int64_t *nodes;       /* (n,) attachment nodes m_i */
    double *c, *s;              /* cos, sin phi_e (N) */
    double *fx, *fy;            /* tendon force beyond element e (N) */
    double *len, *dx, *dy;      /* cable lengths and unit directions (n) */
} Arm;

/* The arm from routes (n, 2) and nodes (n,), N elements (0, or -1 with an exception);
 * arm_free releases its work arrays. */
int arm_init(Arm *a, Py_buffer *routes, Py_buffer *nodes, Py_ssize_t N);
void arm_free(Arm *a);
/* cos, sin of the element angles; cable lengths and directions from the attachment
 * points y (n, 2); the tendon forces beyond each element at tensions p; all three. */
void arm_trig(Arm *a, const double *angles);
void arm_cables(Arm *a, const double *y);
void arm_forces(Arm *a, const double *p);
void arm_state(Arm *a, const double *u, const double *p);
/* The angle rows of the static residual (Eq. (9)) at the state set by arm_state. */
void arm_angle_rows(const Arm *a, const double *th, double tip_moment, double *f);

/* 0, or -1 with a ValueError if the buffer does not hold count items of item bytes. */
int check_len(Py_buffer *b, Py_ssize_t count, Py_ssize_t item, const char *what);

/* inertia(indptr, indices, values, n_angles) of the Python module (fem_inertia.c). */
PyObject *inertia(PyObject *self, PyObject *args);

/* The kernels of the arm in motion (fem_dynamics.c), added to the module at import. */
extern PyMethodDef dynamics_methods[];

#endif
