/*
 * Shared by the project's compiled loops that evaluate sin and cos over many independent
 * values (calib/tractor_trailer/_predicted_rows.c, calib/tractor_trailer/models/_hitch_rk4.c).
 *
 * sin and cos: Cody-Waite reduction by pi/2 (pi/2 split in three parts of 33, 33 and 53 bits,
 * so that q * part is exact for |q| < 2^20) and Taylor polynomials on |r| <= pi/4 (terms to
 * r^15 for sin, r^16 for cos: the first omitted terms are below 7e-17), written without
 * branches so that the compiler vectorises loops that call it. Accurate to a few units in the
 * last place for |angle| <= 1e5 rad; callers check their angles' range (or keep libm beyond).
 */
#ifndef LOGCAL_SINCOS_H
#define LOGCAL_SINCOS_H

#include <stdint.h>
#include <string.h>

/* One build per instruction-set level, chosen when the library is loaded (gcc on x86-64
 * Linux); elsewhere one portable build. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define LOGCAL_CLONES \
    __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define LOGCAL_CLONES
#endif

static const double PIO2_1 = 1.57079632673412561417e+00; /* first 33 bits of pi/2 */
static const double PIO2_2 = 6.07710050630396597660e-11; /* next 33 bits */
static const double PIO2_3 = 2.02226624871116645580e-21; /* pi/2 - PIO2_1 - PIO2_2 */
static const double TWO_OVER_PI = 6.36619772367581382433e-01;
static const double ROUNDER = 6755399441055744.0; /* 1.5 * 2^52: x + R - R rounds x */

static inline void sin_cos(double x, double *s_out, double *c_out)
{
    double q = (x * TWO_OVER_PI + ROUNDER) - ROUNDER;
    double r = x - q * PIO2_1;
    r -= q * PIO2_2;
    r -= q * PIO2_3;
    double z = r * r;
    double sp = -1.0 / 1307674368000.0; /* -1/15! */
    sp = sp * z + 1.0 / 6227020800.0;
    sp = sp * z - 1.0 / 39916800.0;
    sp = sp * z + 1.0 / 362880.0;
    sp = sp * z - 1.0 / 5040.0;
    sp = sp * z + 1.0 / 120.0;
    sp = sp * z - 1.0 / 6.0;
    double s = r + r * z * sp;
    double cp = 1.0 / 20922789888000.0; /* 1/16! */
    cp = cp * z - 1.0 / 87178291200.0;
    cp = cp * z + 1.0 / 479001600.0;
    cp = cp * z - 1.0 / 3628800.0;
    cp = cp * z + 1.0 / 40320.0;
    cp = cp * z - 1.0 / 720.0;
    cp = cp * z + 1.0 / 24.0;
    double c = 1.0 - 0.5 * z + z * z * cp;
    /* q is integral; clamped (and NaN sent to 0) so that the conversion is defined for any x
     * (the result is meaningless beyond |x| = 1e5 and NaN for a NaN x either way) */
    double qc = q == q ? (q > 1e9 ? 1e9 : (q < -1e9 ? -1e9 : q)) : 0.0;
    uint64_t quadrant = (uint64_t)(int64_t)qc;
    /* the quadrant's swap and signs as bit masks rather than branches: loops vectorise */
    uint64_t sb, cb;
    memcpy(&sb, &s, sizeof sb);
    memcpy(&cb, &c, sizeof cb);
    const uint64_t swap = (uint64_t)0 - (quadrant & 1);
    uint64_t s2 = (sb & ~swap) | (cb & swap);
    uint64_t c2 = (cb & ~swap) | (sb & swap);
    s2 ^= (quadrant & 2) << 62;
    c2 ^= ((quadrant + 1) & 2) << 62;
    memcpy(s_out, &s2, sizeof s2);
    memcpy(c_out, &c2, sizeof c2);
}

#endif
