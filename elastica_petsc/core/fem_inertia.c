/* The Sylvester inertia of the symmetric bordered matrices of core/fem.py
 * (the stability matrix H of docs/model.md §2), part of the compiled module
 * fem_kernels (docs/model.md §20): an LDL^T in the natural order, as PETSc's
 * Cholesky on SBAIJ storage counts it, without a PETSc matrix. */
#include "fem_kernels.h"

/* The negative pivots of the LDL^T, in the natural order without pivoting (PETSc's
 * Cholesky on SBAIJ), of the symmetric matrix of M rows whose upper triangle is the
 * CSR given: a tridiagonal block of N rows, then dense border columns and a border
 * block of nb = M - N rows.  Eliminating the angles first fills only the border
 * (O(N nb^2)); work holds nb^2 + 2 nb doubles, zeroed.  -1 at a zero pivot; -2 if
 * the pattern is not of that shape. */
static long bordered_ldlt(const int32_t *indptr, const int32_t *indices, const double *v,
                          Py_ssize_t N, Py_ssize_t M, double *work)
{
    Py_ssize_t nb = M - N;
    double *S = work, *carry = S + nb * nb, *b = carry + nb;
    long count = 0;
    for (Py_ssize_t r = N; r < M; r++)                 /* the border block */
        for (int32_t k = indptr[r]; k < indptr[r + 1]; k++) {
            Py_ssize_t col = indices[k];
            if (col < r)
                return -2;
            S[(r - N) * nb + (col - N)] = S[(col - N) * nb + (r - N)] = v[k];
        }
    double carry_diag = 0.0;
    for (Py_ssize_t r = 0; r < N; r++) {
        double diag = carry_diag, upper = 0.0;
        memcpy(b, carry, sizeof(double) * nb);
        for (int32_t k = indptr[r]; k < indptr[r + 1]; k++) {
            Py_ssize_t col = indices[k];
            if (col == r)
                diag += v[k];
            else if (col == r + 1 && col < N)
                upper = v[k];
            else if (col >= N)
                b[col - N] += v[k];
            else
                return -2;
        }
        if (fabs(diag) <= ZERO_PIVOT)
            return -1;
        count += diag < 0.0;
        double l = upper / diag;           /* row r + 1 -= l row r; S -= b b^T / diag */
        carry_diag = -upper * l;
        for (Py_ssize_t j = 0; j < nb; j++) {
            carry[j] = -l * b[j];
            double bj = b[j] / diag;
            for (Py_ssize_t i = 0; i < nb; i++)
                S[i * nb + j] -= b[i] * bj;
        }
    }
    for (Py_ssize_t j = 0; j < nb; j++) {              /* LDL^T of the dense border block */
        double d = S[j * nb + j];
        if (fabs(d) <= ZERO_PIVOT)
            return -1;
        count += d < 0.0;
        for (Py_ssize_t i = j + 1; i < nb; i++) {
            double l = S[i * nb + j] / d;
            for (Py_ssize_t k = j + 1; k < nb; k++)
                S[i * nb + k] -= l * S[j * nb + k];
        }
    }
    return count;
}

/* inertia(indptr, indices, values, n_angles): bordered_ldlt of the CSR (int32) given. */
PyObject *inertia(PyObject *self, PyObject *args)
{
    Py_buffer ip, ix, val;
    Py_ssize_t N;
    if (!PyArg_ParseTuple(args, "y*y*y*n", &ip, &ix, &val, &N))
        return NULL;
    Py_ssize_t M = ip.len / (Py_ssize_t)sizeof(int32_t) - 1;
    const int32_t *indptr = ip.buf;
    PyObject *result = NULL;
    if (M < N || N < 0)
        PyErr_SetString(PyExc_ValueError, "more angle rows than matrix rows");
    else if (!check_len(&ix, indptr[M], sizeof(int32_t), "indices") &&
             !check_len(&val, indptr[M], sizeof(double), "values")) {
        double *work = calloc((M - N) * (M - N + 2) + 1, sizeof(double));
        if (!work)
            PyErr_NoMemory();
        else
            result = PyLong_FromLong(bordered_ldlt(indptr, ix.buf, val.buf, N, M, work));
        free(work);
    }
    PyBuffer_Release(&ip); PyBuffer_Release(&ix); PyBuffer_Release(&val);
    return result;
}
