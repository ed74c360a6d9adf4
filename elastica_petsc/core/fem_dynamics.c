/* Compiled kernels of the arm in motion (core/dynamics.py, docs/model.md §16), part of
 * the module fem_kernels (docs/model.md §20, §30).
 *
 * Non-dimensional (l = 1, rho_A = 1, B = 1), N elements of length h = 1/N, nodal
 * angles theta_0..theta_N (theta_0 = 0), element angles phi_e = (theta_e +
 * theta_{e+1}) / 2, nodes x_k = h sum_{e<k} t_e (Eq. (2)).  G = dx/dtheta is a
 * cumulative sum, so every product with G or G^T is O(N):
 *
 *   inertial_force: G^T D (G a' + c) + M_rot a' + b L v,  a' = a + viscous v,
 *                   c_k = -h sum_{e<k} t_e (dphi_e/dt)^2 (centripetal);
 *   motion_residual: that plus the static residual R(theta, p) of fem_kernels.c
 *                   (its angle rows), the residual of the integrator in one call;
 *   principal_factor / principal_solve: the banded LU of (sigma G^T D G + T) in
 *                   the interleaved unknowns of core/dynamics.BandedInverse
 *                   (angle increment, node displacement X = G x, tail force F),
 *                   LAPACK's band storage and partial pivoting (dgbtf2/dgbtrs).
 *
 * Arrays through the buffer protocol (C-contiguous float64; pivots int32), sizes
 * checked; outputs written in place. */
#include "fem_kernels.h"

#define KL 7                    /* sub-diagonals of the interleaved system */
#define KU 9                    /* super-diagonals */
#define KV (KL + KU)            /* U's super-diagonals after pivoting */
#define LDAB (2 * KL + KU + 1)  /* rows of the band storage */
#define UNKNOWNS 5              /* per element: x_{j+1}, X_{j+1} (2), F_j (2) */

/* (lower, diag, upper) band (N, 3) times v, added to out. */
static void band_add(const double *band, const double *v, double scale, Py_ssize_t N,
                     double *out)
{
    for (Py_ssize_t j = 0; j < N; j++) {
        double s = band[3 * j + 1] * v[j];
        if (j > 0)
            s += band[3 * j] * v[j - 1];
        if (j + 1 < N)
            s += band[3 * j + 2] * v[j + 1];
        out[j] += scale * s;
    }
}

/* out += G^T D (G a' + c) + M_rot a' + kv L v, a' = a + viscous v (theta (N+1,), v, a,
 * m, out (N,), the bands rot, el (N, 3)); work holds 4N doubles. */
static void add_inertial(const double *theta, const double *vel, const double *acc,
                         const double *m, const double *rot, const double *el, double viscous,
                         double kv, Py_ssize_t N, double *work, double *o)
{
    double *fx = work, *fy = work + N, *nx = work + 2 * N, *ny = work + 3 * N;
    double h = 1.0 / (double)N, ax = 0.0, ay = 0.0;
    for (Py_ssize_t e = 0; e < N; e++) {             /* node accelerations, forward */
        double c, s, phi = 0.5 * (theta[e] + theta[e + 1]);
        sincos(phi, &s, &c);
        double a_prev = e > 0 ? acc[e - 1] + viscous * vel[e - 1] : 0.0;
        double v_prev = e > 0 ? vel[e - 1] : 0.0;
        double phi_a = 0.5 * (a_prev + acc[e] + viscous * vel[e]);
        double phi_v = 0.5 * (v_prev + vel[e]);
        nx[e] = -h * s;
        ny[e] = h * c;
        ax += nx[e] * phi_a - h * c * phi_v * phi_v;
        ay += ny[e] * phi_a - h * s * phi_v * phi_v;
        fx[e] = m[e] * ax;                           /* node e + 1 */
        fy[e] = m[e] * ay;
    }
    double tx = 0.0, ty = 0.0, g_next = 0.0;
    for (Py_ssize_t e = N - 1; e >= 0; e--) {        /* tail forces, backward: G^T f */
        tx += fx[e];
        ty += fy[e];
        double g = nx[e] * tx + ny[e] * ty;
        o[e] += 0.5 * (g + g_next);
        g_next = g;
    }
    for (Py_ssize_t e = 0; e < N; e++)
        fx[e] = acc[e] + viscous * vel[e];
    band_add(rot, fx, 1.0, N, o);
    if (kv != 0.0)
        band_add(el, vel, kv, N, o);
}

/* 0 if v, a, weights, out hold N doubles and the bands 3N, else -1 with a ValueError. */
static int check_motion(Py_buffer *v, Py_buffer *a, Py_buffer *w, Py_buffer *rot,
                        Py_buffer *el, Py_buffer *out, Py_ssize_t N)
{
    if (N < 1) {
        PyErr_SetString(PyExc_ValueError, "need at least one element");
        return -1;
    }
    return check_len(v, N, sizeof(double), "v") || check_len(a, N, sizeof(double), "a")
           || check_len(w, N, sizeof(double), "weights")
           || check_len(rot, 3 * N, sizeof(double), "rotary")
           || check_len(el, 3 * N, sizeof(double), "elastic")
           || check_len(out, N, sizeof(double), "out") ? -1 : 0;
}

/* inertial_force(theta, v, a, weights, rotary, elastic, viscous, kelvin_voigt, out):
 * out = G^T D (G a' + c) + M_rot a' + kelvin_voigt L v with a' = a + viscous v
 * (theta (N+1,), v, a, weights, out (N,), the bands (N, 3)); v = 0, a = w gives the
 * kinetic mass M w = G^T D G w + M_rot w (docs/model.md §16.1). */
static PyObject *inertial_force(PyObject *self, PyObject *args)
{
    Py_buffer th, v, a, w, rot, el, out;
    double viscous, kv;
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*y*ddw*", &th, &v, &a, &w, &rot, &el, &viscous, &kv,
                          &out))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t N = th.len / (Py_ssize_t)sizeof(double) - 1;
    if (!check_motion(&v, &a, &w, &rot, &el, &out, N)) {
        double *work = malloc(sizeof(double) * 4 * N);
        if (!work)
            PyErr_NoMemory();
        else {
            memset(out.buf, 0, sizeof(double) * N);
            add_inertial(th.buf, v.buf, a.buf, w.buf, rot.buf, el.buf, viscous, kv, N, work,
                         out.buf);
            free(work);
            result = Py_None;
            Py_INCREF(result);
        }
    }
    PyBuffer_Release(&th); PyBuffer_Release(&v); PyBuffer_Release(&a); PyBuffer_Release(&w);
    PyBuffer_Release(&rot); PyBuffer_Release(&el); PyBuffer_Release(&out);
    return result;
}

/* motion_residual(theta, v, a, p, routes, nodes, weights, rotary, elastic, viscous,
 * kelvin_voigt, out): the angle rows of the equations of motion, inertial_force plus
 * the static residual R(theta, p) (Eq. (9), fem_kernels.residual's angle rows) with
 * the cables ending at the nodes x_{m_i}(theta) (docs/model.md §16.1), in one call. */
static PyObject *motion_residual(PyObject *self, PyObject *args)
{
    Py_buffer th, v, a, p, routes, nodes, w, rot, el, out;
    double viscous, kv;
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*y*y*y*y*ddw*", &th, &v, &a, &p, &routes, &nodes,
                          &w, &rot, &el, &viscous, &kv, &out))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t N = th.len / (Py_ssize_t)sizeof(double) - 1;
    Arm arm;
    if (!check_motion(&v, &a, &w, &rot, &el, &out, N) && !arm_init(&arm, &routes, &nodes, N)) {
        double *work = NULL;
        if (!check_len(&p, arm.n, sizeof(double), "p")
            && !(work = malloc(sizeof(double) * (4 * N + 2 * arm.n + 1))))
            PyErr_NoMemory();
        if (work) {
            const double *theta = th.buf;
            double *y = work + 4 * N, x = 0.0, yv = 0.0;
            arm_trig(&arm, theta + 1);
            for (Py_ssize_t e = 0; e < N; e++) {         /* the attachment nodes, Eq. (2) */
                x += arm.h * arm.c[e];
                yv += arm.h * arm.s[e];
                for (Py_ssize_t i = 0; i < arm.n; i++)
                    if (arm.nodes[i] == e + 1) {
                        y[2 * i] = x;
                        y[2 * i + 1] = yv;
                    }
            }
            arm_cables(&arm, y);
            arm_forces(&arm, p.buf);
            arm_angle_rows(&arm, theta + 1, 0.0, out.buf);
            add_inertial(theta, v.buf, a.buf, w.buf, rot.buf, el.buf, viscous, kv, N, work,
                         out.buf);
            free(work);
            result = Py_None;
            Py_INCREF(result);
        }
        arm_free(&arm);
    }
    PyBuffer_Release(&th); PyBuffer_Release(&v); PyBuffer_Release(&a); PyBuffer_Release(&p);
    PyBuffer_Release(&routes); PyBuffer_Release(&nodes); PyBuffer_Release(&w);
    PyBuffer_Release(&rot); PyBuffer_Release(&el); PyBuffer_Release(&out);
    return result;
}

/* Entry (row, col) of the n x n matrix in LAPACK band storage with KL + KU
 * super-diagonals room (column-major, LDAB rows per column). */
#define AB(ab, row, col) (ab)[(col) * LDAB + KV + (row) - (col)]

/* The matrix of core/dynamics.BandedInverse into ab (zeroed first). */
static void principal_assemble(const double *theta, const double *m, double sigma,
                               const double *band, Py_ssize_t N, double *ab)
{
    double h = 1.0 / (double)N;
    memset(ab, 0, sizeof(double) * LDAB * UNKNOWNS * N);
    for (Py_ssize_t j = 0; j < N; j++) {
        double c, s, c1 = 0.0, s1 = 0.0;
        sincos(0.5 * (theta[j] + theta[j + 1]), &s, &c);
        if (j + 1 < N)
            sincos(0.5 * (theta[j + 1] + theta[j + 2]), &s1, &c1);
        double hn[2] = {-0.5 * h * s, 0.5 * h * c}, hn1[2] = {-0.5 * h * s1, 0.5 * h * c1};
        Py_ssize_t r = UNKNOWNS * j;                 /* angle row of node j + 1 */
        for (int k = 0; k < 2; k++) {
            AB(ab, r, r + 3 + k) = sigma * hn[k];            /* F_j (element j) */
            if (j + 1 < N)
                AB(ab, r, r + 8 + k) = sigma * hn1[k];       /* F_{j+1} (element j + 1) */
        }
        AB(ab, r, r) = band[3 * j + 1];
        if (j > 0)
            AB(ab, r, r - UNKNOWNS) = band[3 * j];
        if (j + 1 < N)
            AB(ab, r, r + UNKNOWNS) = band[3 * j + 2];
        for (int k = 0; k < 2; k++) {
            Py_ssize_t rx = r + 1 + k, rf = r + 3 + k;       /* X_{j+1}, F_j definitions */
            AB(ab, rx, rx) = 1.0;
            AB(ab, rx, r) = -hn[k];
            if (j > 0) {
                AB(ab, rx, rx - UNKNOWNS) = -1.0;
                AB(ab, rx, r - UNKNOWNS) = -hn[k];
            }
            AB(ab, rf, rf) = 1.0;
            if (j + 1 < N)
                AB(ab, rf, rf + UNKNOWNS) = -1.0;
            AB(ab, rf, rx) = -m[j];
        }
    }
}

/* LU with partial pivoting of the band matrix in ab, n unknowns (LAPACK's dgbtf2:
 * L's multipliers below the diagonal, U with KV super-diagonals); piv 0-based.
 * Returns 0, or the 1-based column of a zero pivot. */
static Py_ssize_t band_lu(double *ab, Py_ssize_t n, int32_t *piv)
{
    Py_ssize_t ju = 0, info = 0;
    for (Py_ssize_t j = 0; j < n; j++) {
        double *col = ab + j * LDAB + KV;            /* col[i]: row j + i, column j */
        Py_ssize_t km = KL < n - 1 - j ? KL : n - 1 - j, jp = 0;
        for (Py_ssize_t i = 1; i <= km; i++)
            if (fabs(col[i]) > fabs(col[jp]))
                jp = i;
        piv[j] = (int32_t)(j + jp);
        if (col[jp] == 0.0) {
            if (!info)
                info = j + 1;
            continue;
        }
        Py_ssize_t last = j + KU + jp < n - 1 ? j + KU + jp : n - 1;
        ju = ju > last ? ju : last;
        if (jp)                                      /* swap rows j and j + jp, columns j..ju */
            for (Py_ssize_t c = j; c <= ju; c++) {
                double t = AB(ab, j, c);
                AB(ab, j, c) = AB(ab, j + jp, c);
                AB(ab, j + jp, c) = t;
            }
        double inv = 1.0 / col[0];
        for (Py_ssize_t i = 1; i <= km; i++)
            col[i] *= inv;
        for (Py_ssize_t c = j + 1; c <= ju; c++) {   /* rank-one update of the trailing band */
            double u = AB(ab, j, c);
            if (u != 0.0)
                for (Py_ssize_t i = 1; i <= km; i++)
                    AB(ab, j + i, c) -= col[i] * u;
        }
    }
    return info;
}

/* Solve with the factors of band_lu for k right-hand sides at once (LAPACK's dgbtrs):
 * b (n, k) row-major, overwritten; one pass over the factors for all of them. */
static void band_lu_solve(const double *restrict ab, Py_ssize_t n, const int32_t *restrict piv,
                          Py_ssize_t k, double *restrict b)
{
    for (Py_ssize_t j = 0; j < n; j++) {             /* L: row swaps and multipliers */
        Py_ssize_t km = KL < n - 1 - j ? KL : n - 1 - j;
        double *bj = b + j * k, *bp = b + (Py_ssize_t)piv[j] * k;
        for (Py_ssize_t c = 0; c < k; c++) {
            double t = bp[c];
            bp[c] = bj[c];
            bj[c] = t;
        }
        const double *col = ab + j * LDAB + KV;
        for (Py_ssize_t i = 1; i <= km; i++)
            for (Py_ssize_t c = 0; c < k; c++)
                bj[i * k + c] -= col[i] * bj[c];
    }
    for (Py_ssize_t j = n - 1; j >= 0; j--) {        /* U: back substitution by columns */
        const double *col = ab + j * LDAB + KV - j;  /* col[i]: row i, column j */
        double *bj = b + j * k, inv = 1.0 / col[j];
        for (Py_ssize_t c = 0; c < k; c++)
            bj[c] *= inv;
        Py_ssize_t first = j - KV > 0 ? j - KV : 0;
        for (Py_ssize_t i = first; i < j; i++)
            for (Py_ssize_t c = 0; c < k; c++)
                b[i * k + c] -= col[i] * bj[c];
    }
}

/* principal_factor(theta, weights, sigma, band, ab, piv) -> info: assemble the
 * interleaved system of sigma G^T D G + T (T: the band (N, 3)) into ab (LDAB x 5N
 * doubles) and factor it in place (pivots into piv, 5N int32); info 0 or the column
 * of a zero pivot (1-based). */
static PyObject *principal_factor(PyObject *self, PyObject *args)
{
    Py_buffer th, w, band, ab, piv;
    double sigma;
    if (!PyArg_ParseTuple(args, "y*y*dy*w*w*", &th, &w, &sigma, &band, &ab, &piv))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t N = th.len / (Py_ssize_t)sizeof(double) - 1;
    if (N < 1)
        PyErr_SetString(PyExc_ValueError, "need at least one element");
    else if (!check_len(&w, N, sizeof(double), "weights")
             && !check_len(&band, 3 * N, sizeof(double), "band")
             && !check_len(&ab, LDAB * UNKNOWNS * N, sizeof(double), "ab")
             && !check_len(&piv, UNKNOWNS * N, sizeof(int32_t), "piv")) {
        principal_assemble(th.buf, w.buf, sigma, band.buf, N, ab.buf);
        result = PyLong_FromSsize_t(band_lu(ab.buf, UNKNOWNS * N, piv.buf));
    }
    PyBuffer_Release(&th); PyBuffer_Release(&w); PyBuffer_Release(&band);
    PyBuffer_Release(&ab); PyBuffer_Release(&piv);
    return result;
}

/* principal_solve(ab, piv, rhs, out): the angle increments x (N, k) of the
 * factored system for k right-hand sides rhs (N, k) on the angle rows. */
static PyObject *principal_solve(PyObject *self, PyObject *args)
{
    Py_buffer ab, piv, rhs, out;
    if (!PyArg_ParseTuple(args, "y*y*y*w*", &ab, &piv, &rhs, &out))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t n = piv.len / (Py_ssize_t)sizeof(int32_t), N = n / UNKNOWNS;
    Py_ssize_t k = N > 0 ? rhs.len / (Py_ssize_t)sizeof(double) / N : 0;
    double *b = NULL;
    if (N < 1 || n != UNKNOWNS * N)
        PyErr_SetString(PyExc_ValueError, "pivots: expected 5 per element");
    else if (!check_len(&ab, LDAB * n, sizeof(double), "ab")
             && !check_len(&rhs, k * N, sizeof(double), "rhs")
             && !check_len(&out, k * N, sizeof(double), "out")) {
        b = calloc(n * k + 1, sizeof(double));
        if (!b)
            PyErr_NoMemory();
    }
    if (b) {
        const double *r = rhs.buf;
        double *x = out.buf;
        for (Py_ssize_t j = 0; j < N; j++)           /* the angle rows: unknown 5j */
            memcpy(b + UNKNOWNS * j * k, r + j * k, sizeof(double) * k);
        band_lu_solve(ab.buf, n, piv.buf, k, b);
        for (Py_ssize_t j = 0; j < N; j++)
            memcpy(x + j * k, b + UNKNOWNS * j * k, sizeof(double) * k);
        free(b);
        result = Py_None;
        Py_INCREF(result);
    }
    PyBuffer_Release(&ab); PyBuffer_Release(&piv); PyBuffer_Release(&rhs);
    PyBuffer_Release(&out);
    return result;
}

PyMethodDef dynamics_methods[] = {
    {"inertial_force", inertial_force, METH_VARARGS,
     "inertial_force(theta, v, a, weights, rotary, elastic, viscous, kelvin_voigt, out)"},
    {"motion_residual", motion_residual, METH_VARARGS,
     "motion_residual(theta, v, a, p, routes, nodes, weights, rotary, elastic, viscous, "
     "kelvin_voigt, out)"},
    {"principal_factor", principal_factor, METH_VARARGS,
     "principal_factor(theta, weights, sigma, band, ab, piv) -> info"},
    {"principal_solve", principal_solve, METH_VARARGS,
     "principal_solve(ab, piv, rhs (N, k), out (N, k))"},
    {NULL, NULL, 0, NULL},
};
