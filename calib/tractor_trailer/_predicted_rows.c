/*
 * Compiled loop of calib.tractor_trailer.predicted_rows (see its docstring for why it is
 * compiled).
 *
 * The function is plain C called through ctypes; the module init below exists only so that
 * setuptools builds this file as an ordinary extension module (a file Python can locate).
 *
 * logcal_predicted_rows_factors: for the rows w_i [sin(a k_i + b), k_i cos(a k_i + b), k_i],
 * the 3 x 3 R factor of each block of 256 consecutive rows (Householder QR of the block).
 * The caller stacks the block factors and reduces them once more (a tall-skinny QR).
 *
 * sin and cos: calib/tractor_trailer/_sincos.h (branch-free, vectorisable; a few ulp for |angle| <= 1e5 rad;
 * the caller uses numpy beyond: it checks |a| max|k| + |b|).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>

#define BLOCK 256 /* rows per block factor; a multiple of LANES */
#define LANES 8   /* partial sums per reduction, so that the sums vectorise */

#include "_sincos.h"

/* x_j[0..m) = column j of the block's rows; rows m..mp are zero. */
static inline void fill_rows(int64_t m, int64_t mp, const double *restrict kappa,
                             const double *restrict w, double a, double b,
                             double *restrict x0, double *restrict x1, double *restrict x2)
{
    for (int64_t i = 0; i < m; i++) {
        double s, c;
        sin_cos(a * kappa[i] + b, &s, &c);
        double wk = w[i] * kappa[i];
        x0[i] = w[i] * s;
        x1[i] = wk * c;
        x2[i] = wk;
    }
    for (int64_t i = m; i < mp; i++) {
        x0[i] = x1[i] = x2[i] = 0.0;
    }
}

/* sum of x[i] y[i], i < mp (mp a multiple of LANES) */
static inline double dot(int64_t mp, const double *restrict x, const double *restrict y)
{
    double acc[LANES] = {0.0};
    for (int64_t i = 0; i < mp; i += LANES) {
        for (int j = 0; j < LANES; j++) {
            acc[j] += x[i + j] * y[i + j];
        }
    }
    double s = 0.0;
    for (int j = 0; j < LANES; j++) {
        s += acc[j];
    }
    return s;
}

/*
 * One Householder step on column x (rows col..mp, rows above col already zeroed in x and in
 * the later columns): writes R[col][col] and the later columns' row col into R (row-major
 * 3 x 3) and applies the reflection to the later columns y1 (and y2 if not NULL).
 */
static inline void householder(int64_t mp, int col, double *restrict x, double *restrict y1,
                               double *restrict y2, double *R)
{
    double xx = dot(mp, x, x);
    double xy1 = dot(mp, x, y1);
    double xy2 = y2 == NULL ? 0.0 : dot(mp, x, y2);
    double nrm = sqrt(xx);
    if (nrm > 0.0) {
        /* v = x - alpha e_col, |v|^2 = -2 alpha v_col; y -= 2 (v.y) / |v|^2 v */
        double alpha = x[col] > 0.0 ? -nrm : nrm;
        double vcol = x[col] - alpha;
        double vv = -2.0 * alpha * vcol;
        double f1 = 2.0 * (xy1 - alpha * y1[col]) / vv;
        double f2 = y2 == NULL ? 0.0 : 2.0 * (xy2 - alpha * y2[col]) / vv;
        x[col] = vcol;
        for (int64_t i = 0; i < mp; i++) {
            y1[i] -= f1 * x[i];
        }
        if (y2 != NULL) {
            for (int64_t i = 0; i < mp; i++) {
                y2[i] -= f2 * x[i];
            }
        }
        R[4 * col] = alpha;
    } else {
        R[4 * col] = 0.0; /* a zero column: nothing to reflect */
    }
    R[4 * col + 1] = y1[col];
    y1[col] = 0.0;
    if (y2 != NULL) {
        R[4 * col + 2] = y2[col];
        y2[col] = 0.0;
    }
}

/*
 * n rows; kappa: n curvatures; w: n row weights; a, b: the line.
 * out: [ceil(n / 256)][3][3] upper-triangular block factors (row signs arbitrary).
 * Returns 0.
 */
LOGCAL_CLONES
int logcal_predicted_rows_factors(int64_t n, const double *kappa, const double *w, double a,
                                  double b, double *out)
{
    double x0[BLOCK], x1[BLOCK], x2[BLOCK];
    for (int64_t start = 0, blk = 0; start < n; start += BLOCK, blk++) {
        int64_t m = n - start < BLOCK ? n - start : BLOCK;
        int64_t mp = (m + LANES - 1) / LANES * LANES;
        double *R = out + 9 * blk;
        R[3] = R[6] = R[7] = 0.0;
        fill_rows(m, mp, kappa + start, w + start, a, b, x0, x1, x2);
        householder(mp, 0, x0, x1, x2, R);
        householder(mp, 1, x1, x2, NULL, R);
        R[8] = sqrt(dot(mp, x2, x2));
    }
    return 0;
}

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_predicted_rows",
                                    "C loop of calib.tractor_trailer.predicted_rows (ctypes).",
                                    -1, NULL};

PyMODINIT_FUNC PyInit__predicted_rows(void) { return PyModule_Create(&module); }
