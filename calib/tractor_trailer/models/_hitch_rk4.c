/*
 * Compiled loops of calib.tractor_trailer.models.hitch_rk4 (see its docstring for why they are compiled).
 *
 * The functions are plain C called through ctypes; the module init below exists only so that
 * setuptools builds this file as an ordinary extension module (a file Python can locate).
 *
 * logcal_rk4_hitch: classical RK4 of dy/dx = p0 U + p1 U cos y - p2 V sin y, the form every
 * joint-angle integrator of the project reduces to, for n_series input series (each
 * n_steps x 3 stage values: start, middle, end of each step) times n_params parameter sets.
 *
 * logcal_rk4_hitch_half: the same RK4 with U = v kappa, V = v on a half-step grid, split into
 * sub-steps where a step covers too much travel (discovery's model, calib.tractor_trailer.discovery.model).
 *
 * logcal_lag_recursion: y[k+1] = a[k] y[k] + u[k], the exact first-order lag on any grid.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "../_sincos.h"

static double rate(double y, double u, double v, double p0, double p1, double p2)
{
    return p0 * u + p1 * u * cos(y) - p2 * v * sin(y);
}

/*
 * h: n_steps step lengths.
 * U, V: [n_series][n_steps][3] stage inputs.
 * p0, p1, p2: n_params parameters.
 * y0: [n_series][n_params] start states.
 * keep: n_keep increasing step counts (1 = after the first step) at which the state is
 *   recorded; n_keep < 0 records after every step.
 * reset_at, reset_val: n_reset increasing step counts (among the recorded ones) after which
 *   the state is set to the given value, for every column.
 * out: [n_out][n_series][n_params], n_out = 1 + recorded count; y0 first.
 * chain: NULL, or n_series indices: where chain[i] >= 0 (and < i), series i starts from the
 *   last recorded state of series chain[i] instead of y0 (chunks of one run, in order).
 * Returns 0.
 */
/*
 * Whether the state after step ``done`` is recorded (keep: n_keep increasing step counts, or
 * every step when n_keep < 0; *kidx advances past it), and where it is, the value it is reset
 * to there (*reset, else left NULL; *ridx advances).
 */
static inline int recorded(int64_t done, int64_t n_keep, const int64_t *keep, int64_t *kidx,
                           int64_t n_reset, const int64_t *reset_at, const double *reset_val,
                           int64_t *ridx, const double **reset)
{
    if (n_keep >= 0) {
        if (*kidx >= n_keep || done != keep[*kidx]) {
            return 0;
        }
        (*kidx)++;
    }
    while (*ridx < n_reset && reset_at[*ridx] < done) {
        (*ridx)++;
    }
    if (*ridx < n_reset && reset_at[*ridx] == done) {
        *reset = reset_val + *ridx;
    }
    return 1;
}

/* One column (series i, parameter set j) with libm's sin and cos. */
static void scalar_column(int64_t n_steps, int64_t n_series, int64_t n_params, int64_t i,
                          int64_t j, const double *h, const double *u, const double *v,
                          const double *p0, const double *p1, const double *p2, double y,
                          int64_t n_keep, const int64_t *keep, int64_t n_reset,
                          const int64_t *reset_at, const double *reset_val, double *out)
{
    const int64_t cols = n_series * n_params, col = i * n_params + j;
    const double a = p0[j], b = p1[j], c = p2[j];
    int64_t rec = 0, kidx = 0, ridx = 0;
    out[col] = y;
    for (int64_t t = 0; t < n_steps; t++) {
        const double hs = h[t];
        const double *us = u + 3 * t, *vs = v + 3 * t;
        const double k1 = rate(y, us[0], vs[0], a, b, c);
        const double k2 = rate(y + 0.5 * hs * k1, us[1], vs[1], a, b, c);
        const double k3 = rate(y + 0.5 * hs * k2, us[1], vs[1], a, b, c);
        const double k4 = rate(y + hs * k3, us[2], vs[2], a, b, c);
        y = y + hs * (k1 + 2.0 * (k2 + k3) + k4) / 6.0;
        const double *reset = NULL;
        if (recorded(t + 1, n_keep, keep, &kidx, n_reset, reset_at, reset_val, &ridx, &reset)) {
            if (reset != NULL) {
                y = *reset;
            }
            rec++;
            out[rec * cols + col] = y;
        }
    }
}

#define FAST_ANGLE_LIMIT 1e5 /* rad: the fast sin/cos's accurate range (_sincos.h) */

/*
 * All parameter sets of series i at once, step by step, the inner loop over the sets
 * vectorised with the branch-free sin/cos of _sincos.h (a few ulp from libm's). y: the
 * n_params start states, updated. Returns 1 if an angle left the fast sin/cos's range (or was
 * NaN), so that the caller redoes the series with libm; else 0.
 */
LOGCAL_CLONES
static int batch_series(int64_t n_steps, int64_t n_series, int64_t n_params, int64_t i,
                           const double *h, const double *u, const double *v,
                           const double *restrict p0, const double *restrict p1,
                           const double *restrict p2, double *restrict y, int64_t n_keep,
                           const int64_t *keep, int64_t n_reset, const int64_t *reset_at,
                           const double *reset_val, double *out)
{
    const int64_t cols = n_series * n_params;
    double *restrict dst = out + i * n_params;
    int outside = 0;
    int64_t rec = 0, kidx = 0, ridx = 0;
    for (int64_t j = 0; j < n_params; j++) {
        dst[j] = y[j];
    }
    for (int64_t t = 0; t < n_steps; t++) {
        const double hs = h[t], half = 0.5 * h[t];
        const double u0 = u[3 * t], u1 = u[3 * t + 1], u2 = u[3 * t + 2];
        const double v0 = v[3 * t], v1 = v[3 * t + 1], v2 = v[3 * t + 2];
        for (int64_t j = 0; j < n_params; j++) {
            const double a = p0[j], b = p1[j], c = p2[j], y1 = y[j];
            double s, co;
            sin_cos(y1, &s, &co);
            const double k1 = a * u0 + b * u0 * co - c * v0 * s;
            const double y2 = y1 + half * k1;
            sin_cos(y2, &s, &co);
            const double k2 = a * u1 + b * u1 * co - c * v1 * s;
            const double y3 = y1 + half * k2;
            sin_cos(y3, &s, &co);
            const double k3 = a * u1 + b * u1 * co - c * v1 * s;
            const double y4 = y1 + hs * k3;
            sin_cos(y4, &s, &co);
            const double k4 = a * u2 + b * u2 * co - c * v2 * s;
            const double yn = y1 + hs * (k1 + 2.0 * (k2 + k3) + k4) / 6.0;
            y[j] = yn;
            /* an angle beyond the fast sin/cos's range, or NaN */
            const double m = fabs(y2) + fabs(y3) + fabs(y4) + fabs(yn);
            outside |= (m > FAST_ANGLE_LIMIT) | (m != m);
        }
        const double *reset = NULL;
        if (recorded(t + 1, n_keep, keep, &kidx, n_reset, reset_at, reset_val, &ridx, &reset)) {
            if (reset != NULL) {
                for (int64_t j = 0; j < n_params; j++) {
                    y[j] = *reset;
                }
            }
            rec++;
            double *row = out + rec * cols + i * n_params;
            for (int64_t j = 0; j < n_params; j++) {
                row[j] = y[j];
            }
        }
    }
    return outside;
}

/*
 * h: n_steps step lengths.
 * U, V: [n_series][n_steps][3] stage inputs.
 * p0, p1, p2: n_params parameters.
 * y0: [n_series][n_params] start states.
 * keep: n_keep increasing step counts (1 = after the first step) at which the state is
 *   recorded; n_keep < 0 records after every step.
 * reset_at, reset_val: n_reset increasing step counts (among the recorded ones) after which
 *   the state is set to the given value, for every column.
 * out: [n_out][n_series][n_params], n_out = 1 + recorded count; y0 first.
 * chain: NULL, or n_series indices: where chain[i] >= 0 (and < i), series i starts from the
 *   last recorded state of series chain[i] instead of y0 (chunks of one run, in order).
 * One parameter set is integrated with libm's sin and cos; several (a start-point grid, the
 * columns of a finite-difference Jacobian) together with the vectorised sin/cos, each series
 * redone with libm if an angle left the fast sin/cos's range.
 * Returns 0, or -1 when working memory could not be allocated.
 */
int logcal_rk4_hitch(int64_t n_steps, int64_t n_series, int64_t n_params, const double *h,
                     const double *U, const double *V, const double *p0, const double *p1,
                     const double *p2, const double *y0, int64_t n_keep, const int64_t *keep,
                     int64_t n_reset, const int64_t *reset_at, const double *reset_val,
                     double *out, const int64_t *chain)
{
    const int64_t cols = n_series * n_params;
    const int64_t last = (n_keep < 0 ? n_steps : n_keep) * cols;
    double *y = n_params > 1 ? malloc(sizeof(double) * (size_t)n_params) : NULL;
    if (n_params > 1 && y == NULL) {
        return -1;
    }
    for (int64_t i = 0; i < n_series; i++) {
        const double *u = U + i * n_steps * 3;
        const double *v = V + i * n_steps * 3;
        const int chained = chain != NULL && chain[i] >= 0 && chain[i] < i;
        int redo = 1;
        if (y != NULL) {
            for (int64_t j = 0; j < n_params; j++) {
                y[j] = chained ? out[last + chain[i] * n_params + j] : y0[i * n_params + j];
            }
            redo = batch_series(n_steps, n_series, n_params, i, h, u, v, p0, p1, p2, y, n_keep,
                               keep, n_reset, reset_at, reset_val, out);
        }
        if (!redo) {
            continue;
        }
        for (int64_t j = 0; j < n_params; j++) {
            const double start = chained ? out[last + chain[i] * n_params + j]
                                         : y0[i * n_params + j];
            scalar_column(n_steps, n_series, n_params, i, j, h, u, v, p0, p1, p2, start, n_keep,
                          keep, n_reset, reset_at, reset_val, out);
        }
    }
    free(y);
    return 0;
}

/* The rate and its partial derivatives: d/dy, d/dp0, d/dp1, d/dp2. */
static double rate_partials(double y, double u, double v, double p0, double p1, double p2,
                            double *fy, double *f0, double *f1, double *f2)
{
    const double c = cos(y), s = sin(y);
    *fy = -(p1 * u * s + p2 * v * c);
    *f0 = u;
    *f1 = u * c;
    *f2 = -v * s;
    return p0 * u + p1 * u * c - p2 * v * s;
}

/*
 * logcal_rk4_hitch as above (no resets), with the forward sensitivities of y to y0, p0, p1
 * and p2 integrated alongside by the same RK4 steps (the exact derivatives of the discrete
 * map). out: [n_out][n_series][n_params][5]: y, dy/dy0, dy/dp0, dy/dp1, dy/dp2. A chained
 * series continues its predecessor's state and sensitivities (y0 of the first series of a
 * chain is the one the sensitivity dy/dy0 refers to).
 */
int logcal_rk4_hitch_sens(int64_t n_steps, int64_t n_series, int64_t n_params, const double *h,
                          const double *U, const double *V, const double *p0, const double *p1,
                          const double *p2, const double *y0, int64_t n_keep,
                          const int64_t *keep, double *out, const int64_t *chain)
{
    const int64_t cols = n_series * n_params;
    const int64_t n_rec = n_keep < 0 ? n_steps : n_keep;
    for (int64_t i = 0; i < n_series; i++) {
        const double *u = U + i * n_steps * 3;
        const double *v = V + i * n_steps * 3;
        for (int64_t j = 0; j < n_params; j++) {
            const int64_t col = i * n_params + j;
            const double a = p0[j], b = p1[j], c = p2[j];
            double x[5] = {y0[col], 1.0, 0.0, 0.0, 0.0};
            if (chain != NULL && chain[i] >= 0 && chain[i] < i) {
                const double *prev = out + 5 * (n_rec * cols + chain[i] * n_params + j);
                for (int q = 0; q < 5; q++) {
                    x[q] = prev[q];
                }
            }
            int64_t rec = 0, kidx = 0;
            for (int q = 0; q < 5; q++) {
                out[5 * col + q] = x[q];
            }
            for (int64_t t = 0; t < n_steps; t++) {
                const double hs = h[t];
                const double *us = u + 3 * t, *vs = v + 3 * t;
                double k[4][5], z[5];
                const int st[4] = {0, 1, 1, 2};
                const double w[4] = {0.0, 0.5, 0.5, 1.0};
                for (int r = 0; r < 4; r++) {
                    for (int q = 0; q < 5; q++) {
                        z[q] = r == 0 ? x[q] : x[q] + w[r] * hs * k[r - 1][q];
                    }
                    double fy, f0, f1, f2;
                    k[r][0] = rate_partials(z[0], us[st[r]], vs[st[r]], a, b, c, &fy, &f0, &f1,
                                            &f2);
                    k[r][1] = fy * z[1];
                    k[r][2] = fy * z[2] + f0;
                    k[r][3] = fy * z[3] + f1;
                    k[r][4] = fy * z[4] + f2;
                }
                for (int q = 0; q < 5; q++) {
                    x[q] = x[q] + hs * (k[0][q] + 2.0 * (k[1][q] + k[2][q]) + k[3][q]) / 6.0;
                }
                const int64_t done = t + 1;
                if (n_keep < 0 || (kidx < n_keep && done == keep[kidx])) {
                    kidx += n_keep >= 0;
                    rec++;
                    for (int q = 0; q < 5; q++) {
                        out[5 * (rec * cols + col) + q] = x[q];
                    }
                }
            }
        }
    }
    return 0;
}

/*
 * logcal_rk4_hitch with U = v kappa, V = v, on a half-step grid: th, kappa, v hold n_samp
 * samples at even and the midpoints between them at odd indices (2 n_samp - 1 values); the
 * state is recorded at every sample (out: n_samp values, out[0] = y0).
 *
 * A sample step of length h whose travel h max|v| inv_len exceeds max_len is split into
 * ceil(travel / max_len) equal sub-steps, the inputs linear on each half of the sample step
 * (as calib.tractor_trailer.discovery.model builds them in numpy; the same arithmetic). reset_at: n_reset
 * increasing sample indices (>= 1) at which the state is set to reset_val; the step that ends
 * there is not integrated (its result would be replaced). Returns 0.
 */
static double half_stage(const double *x, double u)
{
    return u <= 0.5 ? x[0] + (x[1] - x[0]) * 2.0 * u : x[1] + (x[2] - x[1]) * (2.0 * u - 1.0);
}

int logcal_rk4_hitch_half(int64_t n_samp, const double *th, const double *kappa,
                          const double *v, double p0, double p1, double p2, double inv_len,
                          double max_len, double y0, int64_t n_reset, const int64_t *reset_at,
                          const double *reset_val, double *out)
{
    double y = y0;
    int64_t ridx = 0;
    out[0] = y;
    for (int64_t s = 0; s + 1 < n_samp; s++) {
        const int64_t done = s + 1;
        while (ridx < n_reset && reset_at[ridx] < done) {
            ridx++;
        }
        if (ridx < n_reset && reset_at[ridx] == done) {
            y = reset_val[ridx];
            out[done] = y;
            continue;
        }
        const double *k = kappa + 2 * s, *w = v + 2 * s;
        const double h = th[2 * s + 2] - th[2 * s];
        const double a0 = fabs(w[0]), am = fabs(w[1]), a1 = fabs(w[2]);
        double top = a0 >= am ? a0 : am;
        top = top >= a1 ? top : a1;
        const double travel = h * top * inv_len;
        const int64_t n = travel > max_len ? (int64_t)ceil(travel / max_len) : 1;
        if (n == 1) {
            const double u0 = w[0] * k[0], um = w[1] * k[1], u1 = w[2] * k[2];
            const double k1 = rate(y, u0, w[0], p0, p1, p2);
            const double k2 = rate(y + 0.5 * h * k1, um, w[1], p0, p1, p2);
            const double k3 = rate(y + 0.5 * h * k2, um, w[1], p0, p1, p2);
            const double k4 = rate(y + h * k3, u1, w[2], p0, p1, p2);
            y = y + h * (k1 + 2.0 * (k2 + k3) + k4) / 6.0;
        } else {
            const double hs = h / (double)n;
            for (int64_t j = 0; j < n; j++) {
                const double f0 = (double)j / (double)n;
                const double fm = ((double)j + 0.5) / (double)n;
                const double f1 = (double)(j + 1) / (double)n;
                const double v0 = half_stage(w, f0), vm = half_stage(w, fm), v1 = half_stage(w, f1);
                const double u0 = v0 * half_stage(k, f0), um = vm * half_stage(k, fm);
                const double u1 = v1 * half_stage(k, f1);
                const double k1 = rate(y, u0, v0, p0, p1, p2);
                const double k2 = rate(y + 0.5 * hs * k1, um, vm, p0, p1, p2);
                const double k3 = rate(y + 0.5 * hs * k2, um, vm, p0, p1, p2);
                const double k4 = rate(y + hs * k3, u1, v1, p0, p1, p2);
                y = y + hs * (k1 + 2.0 * (k2 + k3) + k4) / 6.0;
            }
        }
        out[done] = y;
    }
    return 0;
}

/* y[0] given; y[k+1] = a[k] y[k] + u[k] for k < n - 1. */
int logcal_lag_recursion(int64_t n, const double *a, const double *u, double *y)
{
    for (int64_t k = 0; k + 1 < n; k++) {
        y[k + 1] = a[k] * y[k] + u[k];
    }
    return 0;
}

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_hitch_rk4",
                                    "C loops of calib.tractor_trailer.models.hitch_rk4 (called via ctypes).",
                                    -1, NULL};

PyMODINIT_FUNC PyInit__hitch_rk4(void) { return PyModule_Create(&module); }
