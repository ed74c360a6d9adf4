/* Compiled kernels of the P1 elastica of core/fem.py (docs/model.md §2, §20).
 *
 * Non-dimensional (l = 1, B = 1).  The state is the bordered vector
 * u = (theta_1..theta_N, y_1..y_n) with theta_0 = 0; tendon i is attached at
 * node m_i and routed through r_i.  Every integral uses the midpoint rule at
 * the element angle phi_e = (theta_e + theta_{e+1}) / 2 (Eq. (9)); the
 * formulas are those of the docstrings of core/fem.py, which wraps these
 * functions.  Arrays are passed through the buffer protocol: C-contiguous
 * float64 (int64 for node indices, int32 for CSR patterns), sizes checked
 * here; outputs are written in place.  No numpy C API: the module builds
 * against Python's headers alone.
 */
#include "fem_kernels.h"

int check_len(Py_buffer *b, Py_ssize_t count, Py_ssize_t item, const char *what)
{
    if (b->len != count * item) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd items of %zd bytes, got %zd bytes",
                     what, count, item, b->len);
        return -1;
    }
    return 0;
}

/* Set up the arm from routes (n, 2) and nodes (n,), N elements; allocates the work arrays. */
int arm_init(Arm *a, Py_buffer *routes, Py_buffer *nodes, Py_ssize_t N)
{
    a->n = nodes->len / (Py_ssize_t)sizeof(int64_t);
    a->N = N;
    if (check_len(nodes, a->n, sizeof(int64_t), "nodes") ||
        check_len(routes, 2 * a->n, sizeof(double), "routes"))
        return -1;
    if (N < 1) {
        PyErr_SetString(PyExc_ValueError, "need at least one element");
        return -1;
    }
    a->h = 1.0 / (double)N;
    a->routes = routes->buf;
    a->nodes = nodes->buf;
    for (Py_ssize_t i = 0; i < a->n; i++)
        if (a->nodes[i] < 1 || a->nodes[i] > N) {
            PyErr_Format(PyExc_ValueError, "attachment node %lld outside 1..%zd",
                         (long long)a->nodes[i], N);
            return -1;
        }
    a->c = malloc(sizeof(double) * (4 * N + 3 * a->n + 3));
    if (!a->c) {
        PyErr_NoMemory();
        return -1;
    }
    a->s = a->c + N;
    a->fx = a->s + N;
    a->fy = a->fx + N;
    a->len = a->fy + N;
    a->dx = a->len + a->n + 1;
    a->dy = a->dx + a->n + 1;
    return 0;
}

void arm_free(Arm *a) { free(a->c); }

/* cos and sin of the element angles of theta_1..theta_N (theta_0 = 0). */
void arm_trig(Arm *a, const double *angles)
{
    double left = 0.0;
    for (Py_ssize_t e = 0; e < a->N; e++) {
        sincos(0.5 * (left + angles[e]), a->s + e, a->c + e);
        left = angles[e];
    }
}

/* Cable lengths L_i = |r_i - y_i| and directions d_i = (r_i - y_i) / L_i (Eq. (3)). */
void arm_cables(Arm *a, const double *y)
{
    for (Py_ssize_t i = 0; i < a->n; i++) {
        double cx = a->routes[2 * i] - y[2 * i], cy = a->routes[2 * i + 1] - y[2 * i + 1];
        double L = hypot(cx, cy);
        a->len[i] = L;
        a->dx[i] = cx / L;
        a->dy[i] = cy / L;
    }
}

/* F_e = sum over tendons with e < m_i of p_i d_i: the tendon forces beyond element e. */
void arm_forces(Arm *a, const double *p)
{
    memset(a->fx, 0, sizeof(double) * 2 * a->N);      /* fx and fy are adjacent */
    for (Py_ssize_t i = 0; i < a->n; i++) {
        a->fx[a->nodes[i] - 1] += p[i] * a->dx[i];
        a->fy[a->nodes[i] - 1] += p[i] * a->dy[i];
    }
    for (Py_ssize_t e = a->N - 2; e >= 0; e--) {
        a->fx[e] += a->fx[e + 1];
        a->fy[e] += a->fy[e + 1];
    }
}

/* Trig, cables and forces of the state u at tensions p. */
void arm_state(Arm *a, const double *u, const double *p)
{
    arm_trig(a, u);
    arm_cables(a, u + a->N);
    arm_forces(a, p);
}

/* The angle rows f (N,) of the residual at the state of arm_state (angles th =
 * theta_1..theta_N): (theta_{k+1} - theta_k) - (theta_{k+2} - theta_{k+1}) over h,
 * minus the load integral (h/2) t_e x F_e of the elements on both sides (Eq. (9)). */
void arm_angle_rows(const Arm *a, const double *th, double tip_moment, double *f)
{
    Py_ssize_t N = a->N;
    double h = a->h, prev = 0.0;
    for (Py_ssize_t k = 0; k < N; k++) {
        double jump = th[k] - prev;
        double q = 0.5 * h * (a->c[k] * a->fy[k] - a->s[k] * a->fx[k]);
        f[k] = jump / h - q;
        if (k > 0)
            f[k - 1] -= jump / h + q;
        prev = th[k];
    }
    f[N - 1] -= tip_moment;
}

/* The tridiagonal part T of the tangent, (N, 3) = (lower, diag, upper) per row:
 * the stiffness of theta'^2/2 plus d/dtheta of -(h/2) t_e x F_e, (h/4) t_e.F_e on
 * the element's two nodes. */
static void arm_band(const Arm *a, double *band)
{
    Py_ssize_t N = a->N;
    double h = a->h, q = 0.25 * h;
    for (Py_ssize_t k = 0; k < N; k++) {
        double w = q * (a->c[k] * a->fx[k] + a->s[k] * a->fy[k]);
        double w_next = k + 1 < N ? q * (a->c[k + 1] * a->fx[k + 1] + a->s[k + 1] * a->fy[k + 1])
                                  : 0.0;
        band[3 * k] = -1.0 / h + (k > 0 ? w : 0.0);
        band[3 * k + 1] = (k + 1 < N ? 2.0 : 1.0) / h + w + w_next;  /* free end theta'(l) = 0 */
        band[3 * k + 2] = -1.0 / h + w_next;
    }
}

/* g = dX_i/dtheta_{k+1} (x, y) at row k of tendon i: the half normals
 * (h/2) n_e of the elements k and k+1 that lie before m_i. */
static inline void gradient(const Arm *a, Py_ssize_t i, Py_ssize_t k, double *gx, double *gy)
{
    double half = 0.5 * a->h;
    Py_ssize_t m = a->nodes[i];
    *gx = *gy = 0.0;
    if (k < m) {
        *gx -= half * a->s[k];
        *gy += half * a->c[k];
    }
    if (k + 1 < m && k + 1 < a->N) {
        *gx -= half * a->s[k + 1];
        *gy += half * a->c[k + 1];
    }
}

/* residual(u, p, routes, nodes, tip_moment, out): F of the bordered system. */
static PyObject *residual(PyObject *self, PyObject *args)
{
    Py_buffer u, p, routes, nodes, out;
    double tip_moment;
    if (!PyArg_ParseTuple(args, "y*y*y*y*dw*", &u, &p, &routes, &nodes, &tip_moment, &out))
        return NULL;
    PyObject *result = NULL;
    Arm a;
    Py_ssize_t n = nodes.len / (Py_ssize_t)sizeof(int64_t);
    Py_ssize_t size = u.len / (Py_ssize_t)sizeof(double), N = size - 2 * n;
    if (arm_init(&a, &routes, &nodes, N) == 0) {
        if (!check_len(&p, n, sizeof(double), "p") &&
            !check_len(&out, size, sizeof(double), "out")) {
            const double *th = u.buf;
            double *f = out.buf, h = a.h;
            arm_state(&a, th, p.buf);
            arm_angle_rows(&a, th, tip_moment, f);
            /* y_i - X_i(theta), X_i = h sum_{e < m_i} t_e (Eq. (2)) */
            double x = 0.0, yv = 0.0;
            /* tendons in any order: accumulate the prefix sums once, in node order */
            for (Py_ssize_t e = 0; e < N; e++) {
                x += h * a.c[e];
                yv += h * a.s[e];
                for (Py_ssize_t i = 0; i < n; i++)
                    if (a.nodes[i] == e + 1) {
                        f[N + 2 * i] = th[N + 2 * i] - x;
                        f[N + 2 * i + 1] = th[N + 2 * i + 1] - yv;
                    }
            }
            result = Py_None;
            Py_INCREF(result);
        }
        arm_free(&a);
    }
    PyBuffer_Release(&u); PyBuffer_Release(&p); PyBuffer_Release(&routes);
    PyBuffer_Release(&nodes); PyBuffer_Release(&out);
    return result;
}

/* Gather source[src[k]] into out[k] (the CSR order of a bordered pattern). */
static int gather(const double *source, Py_ssize_t n_source, Py_buffer *src, Py_buffer *out)
{
    Py_ssize_t nnz = out->len / (Py_ssize_t)sizeof(double);
    if (check_len(src, nnz, sizeof(int64_t), "src"))
        return -1;
    const int64_t *idx = src->buf;
    double *v = out->buf;
    for (Py_ssize_t k = 0; k < nnz; k++) {
        if (idx[k] < 0 || idx[k] >= n_source) {
            PyErr_SetString(PyExc_ValueError, "pattern source index out of range");
            return -1;
        }
        v[k] = source[idx[k]];
    }
    return 0;
}

/* Shared front of jacobian() and stability(): parse, set up the state, allocate
 * the source array (band, border columns, border rows, corner) with nb border
 * columns per tendon. */
typedef struct {
    Py_buffer u, p, routes, nodes, src, out;
    Arm a;
    double *source;
    Py_ssize_t n_source, nb;
} Bordered;

static int bordered_begin(Bordered *b, PyObject *args, Py_ssize_t per_tendon)
{
    b->source = NULL;
    b->a.c = NULL;
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*w*", &b->u, &b->p, &b->routes, &b->nodes, &b->src,
                          &b->out))
        return -2;          /* nothing acquired */
    Py_ssize_t n = b->nodes.len / (Py_ssize_t)sizeof(int64_t);
    Py_ssize_t N = b->u.len / (Py_ssize_t)sizeof(double) - 2 * n;
    if (arm_init(&b->a, &b->routes, &b->nodes, N) || check_len(&b->p, n, sizeof(double), "p"))
        return -1;
    b->nb = per_tendon * n;
    b->n_source = 3 * N + 2 * b->nb * N + b->nb;
    b->source = malloc(sizeof(double) * b->n_source);
    if (!b->source) {
        PyErr_NoMemory();
        return -1;
    }
    arm_state(&b->a, b->u.buf, b->p.buf);
    arm_band(&b->a, b->source);
    return 0;
}

static PyObject *bordered_end(Bordered *b, int ok)
{
    ok = ok == 0 && gather(b->source, b->n_source, &b->src, &b->out) == 0;
    free(b->source);
    arm_free(&b->a);
    PyBuffer_Release(&b->u); PyBuffer_Release(&b->p); PyBuffer_Release(&b->routes);
    PyBuffer_Release(&b->nodes); PyBuffer_Release(&b->src); PyBuffer_Release(&b->out);
    if (!ok)
        return NULL;
    Py_RETURN_NONE;
}

/* jacobian(u, p, routes, nodes, src, out): dF/du in the order of the pattern:
 * band T; columns dF_theta/dy_i = p_i/L_i (d_i^perp . g) d_i^perp (Eq. (17));
 * rows dF_y/dtheta = -dX/dtheta; corner I. */
static PyObject *jacobian(PyObject *self, PyObject *args)
{
    Bordered b;
    int begun = bordered_begin(&b, args, 2);
    if (begun)
        return begun == -2 ? NULL : bordered_end(&b, -1);
    Arm *a = &b.a;
    Py_ssize_t N = a->N, n = a->n, nb = b.nb;
    double *cols = b.source + 3 * N, *rows = cols + nb * N, *corner = rows + nb * N;
    for (Py_ssize_t i = 0; i < n; i++) {
        const double *p = b.p.buf;
        double px = -a->dy[i], py = a->dx[i], weight = p[i] / a->len[i];
        for (Py_ssize_t k = 0; k < N; k++) {
            double gx, gy;
            gradient(a, i, k, &gx, &gy);
            double lever = weight * (gx * px + gy * py);
            cols[k * nb + 2 * i] = lever * px;
            cols[k * nb + 2 * i + 1] = lever * py;
            rows[(2 * i) * N + k] = -gx;
            rows[(2 * i + 1) * N + k] = -gy;
        }
        corner[2 * i] = corner[2 * i + 1] = 1.0;
    }
    return bordered_end(&b, 0);
}

/* W, (n, N): W[i, k] = sqrt(max(p_i, 0) / L_i) (dX_i/dtheta_{k+1}) . d_i^perp, so that
 * K = T + W^T W (docs/model.md §2). */
static void stiffness_rows(const Arm *a, const double *p, double *W)
{
    for (Py_ssize_t i = 0; i < a->n; i++) {
        double px = -a->dy[i], py = a->dx[i];
        double weight = sqrt((p[i] > 0.0 ? p[i] : 0.0) / a->len[i]);
        for (Py_ssize_t k = 0; k < a->N; k++) {
            double gx, gy;
            gradient(a, i, k, &gx, &gy);
            W[i * a->N + k] = weight * (gx * px + gy * py);
        }
    }
}

/* stability(u, p, routes, nodes, src, out): the upper triangle of
 * H = [[T, W^T], [W, -I]] in the order of its pattern. */
static PyObject *stability(PyObject *self, PyObject *args)
{
    Bordered b;
    int begun = bordered_begin(&b, args, 1);
    if (begun)
        return begun == -2 ? NULL : bordered_end(&b, -1);
    Arm *a = &b.a;
    Py_ssize_t N = a->N, n = a->n, nb = b.nb;
    double *cols = b.source + 3 * N, *rows = cols + nb * N, *corner = rows + nb * N;
    stiffness_rows(a, b.p.buf, rows);                 /* the border rows are W itself */
    for (Py_ssize_t i = 0; i < n; i++) {
        for (Py_ssize_t k = 0; k < N; k++)
            cols[k * nb + i] = rows[i * N + k];
        corner[i] = -1.0;
    }
    return bordered_end(&b, 0);
}

/* stiffness(u, p, routes, nodes, out): W, (n, N), of the state u. */
static PyObject *stiffness(PyObject *self, PyObject *args)
{
    Py_buffer u, p, routes, nodes, out;
    if (!PyArg_ParseTuple(args, "y*y*y*y*w*", &u, &p, &routes, &nodes, &out))
        return NULL;
    PyObject *result = NULL;
    Arm a;
    Py_ssize_t n = nodes.len / (Py_ssize_t)sizeof(int64_t);
    Py_ssize_t N = u.len / (Py_ssize_t)sizeof(double) - 2 * n;
    if (arm_init(&a, &routes, &nodes, N) == 0) {
        if (!check_len(&p, n, sizeof(double), "p") &&
            !check_len(&out, n * N, sizeof(double), "out")) {
            arm_trig(&a, u.buf);
            arm_cables(&a, (const double *)u.buf + N);
            stiffness_rows(&a, p.buf, out.buf);
            result = Py_None;
            Py_INCREF(result);
        }
        arm_free(&a);
    }
    PyBuffer_Release(&u); PyBuffer_Release(&p); PyBuffer_Release(&routes);
    PyBuffer_Release(&nodes); PyBuffer_Release(&out);
    return result;
}

/* load_derivative(u, routes, nodes, out): dF/dp, (n, size); row i is
 * -(dX_i/dtheta)^T d_i on the angles, zero on the border (Eq. (14)). */
static PyObject *load_derivative(PyObject *self, PyObject *args)
{
    Py_buffer u, routes, nodes, out;
    if (!PyArg_ParseTuple(args, "y*y*y*w*", &u, &routes, &nodes, &out))
        return NULL;
    PyObject *result = NULL;
    Arm a;
    Py_ssize_t n = nodes.len / (Py_ssize_t)sizeof(int64_t);
    Py_ssize_t size = u.len / (Py_ssize_t)sizeof(double), N = size - 2 * n;
    if (arm_init(&a, &routes, &nodes, N) == 0) {
        if (!check_len(&out, n * size, sizeof(double), "out")) {
            double *f = out.buf;
            arm_trig(&a, u.buf);
            arm_cables(&a, (const double *)u.buf + N);
            memset(f, 0, sizeof(double) * n * size);
            for (Py_ssize_t i = 0; i < n; i++)
                for (Py_ssize_t k = 0; k < a.nodes[i]; k++) {
                    double gx, gy;
                    gradient(&a, i, k, &gx, &gy);
                    f[i * size + k] = -(gx * a.dx[i] + gy * a.dy[i]);
                }
            result = Py_None;
            Py_INCREF(result);
        }
        arm_free(&a);
    }
    PyBuffer_Release(&u); PyBuffer_Release(&routes); PyBuffer_Release(&nodes);
    PyBuffer_Release(&out);
    return result;
}

/* band(c, s, force, out): T (N, 3) from the element angles' cos and sin (N,) and
 * the force beyond each element (N, 2), however it was summed (core/guided.py adds
 * the guides' and the weight's). */
static PyObject *band(PyObject *self, PyObject *args)
{
    Py_buffer c, s, force, out;
    if (!PyArg_ParseTuple(args, "y*y*y*w*", &c, &s, &force, &out))
        return NULL;
    Py_ssize_t N = c.len / (Py_ssize_t)sizeof(double);
    PyObject *result = NULL;
    Arm a = {.N = N, .h = 1.0 / (double)N};
    a.c = malloc(sizeof(double) * 4 * (N + 1));
    if (!a.c)
        PyErr_NoMemory();
    else if (!check_len(&s, N, sizeof(double), "s") &&
             !check_len(&force, 2 * N, sizeof(double), "force") &&
             !check_len(&out, 3 * N, sizeof(double), "out")) {
        a.s = a.c + N;
        a.fx = a.s + N;
        a.fy = a.fx + N;
        const double *f = force.buf;
        memcpy(a.c, c.buf, sizeof(double) * N);
        memcpy(a.s, s.buf, sizeof(double) * N);
        for (Py_ssize_t e = 0; e < N; e++) {
            a.fx[e] = f[2 * e];
            a.fy[e] = f[2 * e + 1];
        }
        arm_band(&a, out.buf);
        result = Py_None;
        Py_INCREF(result);
    }
    free(a.c);
    PyBuffer_Release(&c); PyBuffer_Release(&s); PyBuffer_Release(&force);
    PyBuffer_Release(&out);
    return result;
}

/* gradients(angles, nodes, out): dX_i/dtheta_k, (n, N, 2), at theta_1..theta_N. */
static PyObject *gradients(PyObject *self, PyObject *args)
{
    Py_buffer th, nodes, out;
    if (!PyArg_ParseTuple(args, "y*y*w*", &th, &nodes, &out))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t n = nodes.len / (Py_ssize_t)sizeof(int64_t);
    Py_ssize_t N = th.len / (Py_ssize_t)sizeof(double);
    Arm a;
    /* no routes are needed: the output stands in for the size check of arm_init */
    Py_buffer none = {.len = 2 * n * (Py_ssize_t)sizeof(double)};
    if (arm_init(&a, &none, &nodes, N) == 0) {
        if (!check_len(&out, 2 * n * N, sizeof(double), "out")) {
            double *g = out.buf;
            arm_trig(&a, th.buf);
            for (Py_ssize_t i = 0; i < n; i++)
                for (Py_ssize_t k = 0; k < N; k++)
                    gradient(&a, i, k, g + 2 * (i * N + k), g + 2 * (i * N + k) + 1);
            result = Py_None;
            Py_INCREF(result);
        }
        arm_free(&a);
    }
    PyBuffer_Release(&th); PyBuffer_Release(&nodes); PyBuffer_Release(&out);
    return result;
}

/* positions(angles, out): x_k at every node, (N+1, 2), x_0 = 0, x_{k+1} = x_k + h t_k
 * (Eq. (2), midpoint rule). */
static PyObject *positions(PyObject *self, PyObject *args)
{
    Py_buffer th, out;
    if (!PyArg_ParseTuple(args, "y*w*", &th, &out))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t N = th.len / (Py_ssize_t)sizeof(double);
    Arm a;
    Py_buffer none = {.len = 0};
    if (arm_init(&a, &none, &none, N) == 0) {
        if (!check_len(&out, 2 * (N + 1), sizeof(double), "out")) {
            double *x = out.buf;
            arm_trig(&a, th.buf);
            x[0] = x[1] = 0.0;
            for (Py_ssize_t e = 0; e < N; e++) {
                x[2 * e + 2] = x[2 * e] + a.h * a.c[e];
                x[2 * e + 3] = x[2 * e + 1] + a.h * a.s[e];
            }
            result = Py_None;
            Py_INCREF(result);
        }
        arm_free(&a);
    }
    PyBuffer_Release(&th); PyBuffer_Release(&out);
    return result;
}

/* position_derivative(angles, dstate, nodes, out): d x_m / dq at the queried nodes
 * m (0..N) for k variations of the state (rows of dstate, (k, stride), the angle
 * variations first): d x_m = sum_{e < m} h n_e (dtheta_e + dtheta_{e+1}) / 2, the
 * derivative of Eq. (2) with the midpoint rule (Eq. (13) at the tip); out (k, q, 2). */
static PyObject *position_derivative(PyObject *self, PyObject *args)
{
    Py_buffer th, dstate, nodes, out;
    if (!PyArg_ParseTuple(args, "y*y*y*w*", &th, &dstate, &nodes, &out))
        return NULL;
    PyObject *result = NULL;
    Py_ssize_t N = th.len / (Py_ssize_t)sizeof(double);
    Py_ssize_t q = nodes.len / (Py_ssize_t)sizeof(int64_t);
    Py_ssize_t k = q ? out.len / (Py_ssize_t)sizeof(double) / (2 * q) : 0;
    Py_ssize_t stride = k ? dstate.len / (Py_ssize_t)sizeof(double) / k : 0;
    Arm a;
    Py_buffer none = {.len = 0};
    if (arm_init(&a, &none, &none, N) == 0) {          /* no tendons: the trig only */
        const int64_t *m = nodes.buf;
        int ok = !check_len(&dstate, k * stride, sizeof(double), "dstate") &&
                 !check_len(&out, 2 * k * q, sizeof(double), "out");
        for (Py_ssize_t j = 0; ok && j < q; j++)
            if (m[j] < 0 || m[j] > N) {
                PyErr_Format(PyExc_ValueError, "node %lld outside 0..%zd", (long long)m[j], N);
                ok = 0;
            }
        if (ok && stride < N) {
            PyErr_SetString(PyExc_ValueError, "dstate rows shorter than the angles");
            ok = 0;
        }
        if (ok) {
            const double *dv = dstate.buf;
            double *o = out.buf;
            arm_trig(&a, th.buf);
            for (Py_ssize_t r = 0; r < k; r++) {
                const double *dt = dv + r * stride;       /* dtheta_1..dtheta_N */
                double x = 0.0, y = 0.0, left = 0.0;
                for (Py_ssize_t e = 0; e <= N; e++) {
                    for (Py_ssize_t j = 0; j < q; j++)
                        if (m[j] == e) {
                            o[2 * (r * q + j)] = x;
                            o[2 * (r * q + j) + 1] = y;
                        }
                    if (e == N)
                        break;
                    double dphi = 0.5 * (left + dt[e]);
                    x -= a.h * a.s[e] * dphi;
                    y += a.h * a.c[e] * dphi;
                    left = dt[e];
                }
            }
            result = Py_None;
            Py_INCREF(result);
        }
        arm_free(&a);
    }
    PyBuffer_Release(&th); PyBuffer_Release(&dstate); PyBuffer_Release(&nodes);
    PyBuffer_Release(&out);
    return result;
}

static PyMethodDef methods[] = {
    {"residual", residual, METH_VARARGS, "residual(u, p, routes, nodes, tip_moment, out)"},
    {"jacobian", jacobian, METH_VARARGS, "jacobian(u, p, routes, nodes, src, out)"},
    {"stability", stability, METH_VARARGS, "stability(u, p, routes, nodes, src, out)"},
    {"stiffness", stiffness, METH_VARARGS, "stiffness(u, p, routes, nodes, out)"},
    {"load_derivative", load_derivative, METH_VARARGS, "load_derivative(u, routes, nodes, out)"},
    {"band", band, METH_VARARGS, "band(c, s, force, out)"},
    {"gradients", gradients, METH_VARARGS, "gradients(angles, nodes, out)"},
    {"positions", positions, METH_VARARGS, "positions(angles, out)"},
    {"position_derivative", position_derivative, METH_VARARGS,
     "position_derivative(angles, dstate, nodes, out)"},
    {"inertia", inertia, METH_VARARGS, "inertia(indptr, indices, values, n_angles) -> int"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "fem_kernels",
    "Compiled kernels of the P1 elastica (core/fem.py, docs/model.md §20).", -1, methods,
};

PyMODINIT_FUNC PyInit_fem_kernels(void)
{
    PyObject *m = PyModule_Create(&module);
    if (m && PyModule_AddFunctions(m, dynamics_methods) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
