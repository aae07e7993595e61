/*
 * Compiled walk of logtools.readers.flat_json (its docstring says why it is hand-written).
 *
 * The functions are plain C called through ctypes; the module init at the end exists only so
 * that setuptools builds this file as an ordinary extension module (a file Python can locate).
 *
 * logcal_flat_json: every JSON message of a channel against one skeleton, the first message's
 * tokens (whitespace outside strings removed) cut at each number; the numbers go to columns.
 * Any other difference (a key, a constant string, a literal, the nesting) stops the walk at
 * that message; the caller then decodes the channel another way.
 *
 * logcal_json_number: one JSON number token to (kind, int64, double), for the tests.
 *
 * Numbers are correctly rounded (the value of float(text) / json.loads): up to 19 significant
 * digits and a decimal exponent |e| <= 27, m * 10^e or m / 10^e is one rounding of the exact
 * value to the 64-bit significand of the x87 long double (10^27 = 2^27 * 5^27 and 5^27 < 2^64:
 * the power is exact). Rounding that to double is then the correctly rounded result unless the
 * long double lies exactly on a midpoint between two doubles: a midpoint has 54 significant
 * bits, so it is a long double, and rounding to 64 bits never carries a value across a
 * representable point; only a value rounded onto the midpoint itself can be resolved the wrong
 * way. Those (the 11 low bits within one unit of 10000000000b), more digits, larger exponents
 * and results below DBL_MIN (subnormals) go to strtod, which glibc rounds correctly; the token
 * is copied and NUL-terminated, and strtod must consume all of it (a locale with a decimal
 * comma would not: the message is then reported as not matching).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#if LDBL_MANT_DIG == 64 && (defined(__x86_64__) || defined(__i386__))
#define HAVE_X87_FAST_PATH 1
static const long double POW10[28] = {
    1e0L,  1e1L,  1e2L,  1e3L,  1e4L,  1e5L,  1e6L,  1e7L,  1e8L,  1e9L,
    1e10L, 1e11L, 1e12L, 1e13L, 1e14L, 1e15L, 1e16L, 1e17L, 1e18L, 1e19L,
    1e20L, 1e21L, 1e22L, 1e23L, 1e24L, 1e25L, 1e26L, 1e27L};
#else
#define HAVE_X87_FAST_PATH 0
#endif

enum { NUM_BAD = 0, NUM_INT = 1, NUM_FLOAT = 2, NUM_NONFINITE = 3, NUM_BIGINT = 4 };

/* messages ahead whose first bytes are requested early: a channel's messages lie scattered
 * among the other channels' in the decompressed chunks, so without it the walk waits on
 * memory more than it parses (1 M messages, 5 channels: 0.12 s -> 0.05 s; 16 and 2 lines
 * measured best of 8/16/32/64 and first/last/next lines) */
#define PREFETCH_AHEAD 16

#define TOKEN_MAX 64 /* longer number tokens are copied to the heap for strtod */

static int slow_double(const uint8_t *from, const uint8_t *to, double *out)
{
    char local[TOKEN_MAX];
    const size_t len = (size_t)(to - from);
    char *text = len < TOKEN_MAX ? local : malloc(len + 1);
    if (text == NULL) {
        return 0;
    }
    memcpy(text, from, len);
    text[len] = '\0';
    char *stop = NULL;
    *out = strtod(text, &stop);
    const int whole = stop == text + len;
    if (text != local) {
        free(text);
    }
    return whole;
}

/*
 * When the 8 bytes at p are all decimal digits: *m = *m * 10^8 + their value, and 1. The bytes
 * are read as one little-endian word: the first digit is the lowest byte; neighbours are
 * combined into 2-, 4-, then 8-digit values, each step in lanes too wide to carry over.
 */
static inline int eight_digits(const uint8_t *p, const uint8_t *end, uint64_t *m)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    if (end - p < 8) {
        return 0;
    }
    uint64_t v;
    memcpy(&v, p, sizeof v);
    const uint64_t high = 0xF0F0F0F0F0F0F0F0ULL, threes = 0x3030303030303030ULL;
    /* every byte 0x30..0x3F, and still below 0x40 after adding 6: '0'..'9' */
    if ((v & high) != threes || ((v + 0x0606060606060606ULL) & high) != threes) {
        return 0;
    }
    v -= threes;
    v = (v * 10 + (v >> 8)) & 0x00FF00FF00FF00FFULL;      /* 4 lanes of 2 digits */
    v = (v * 100 + (v >> 16)) & 0x0000FFFF0000FFFFULL;    /* 2 lanes of 4 digits */
    v = (v * 10000 + (v >> 32)) & 0x00000000FFFFFFFFULL;  /* 8 digits */
    *m = *m * 100000000ULL + v;
    return 1;
#else
    (void)p;
    (void)end;
    (void)m;
    return 0;
#endif
}

/*
 * Parse the JSON number (or NaN, Infinity, -Infinity) starting at *pp, strictly by the JSON
 * grammar. Returns NUM_INT (no '.', 'e', 'E'; *iv holds it, *dv too), NUM_FLOAT, NUM_NONFINITE,
 * NUM_BIGINT (an integer beyond int64) or NUM_BAD; advances *pp past the token.
 */
static int parse_number(const uint8_t **pp, const uint8_t *end, int64_t *iv, double *dv)
{
    const uint8_t *p = *pp, *const from = p;
    int neg = 0;
    if (p < end && *p == '-') {
        neg = 1;
        p++;
    }
    if (p >= end) {
        return NUM_BAD;
    }
    if (*p == 'I' || *p == 'N') {
        const char *word = *p == 'I' ? "Infinity" : "NaN";
        const size_t wl = strlen(word);
        if ((size_t)(end - p) < wl || memcmp(p, word, wl) != 0 || (neg && *p == 'N')) {
            return NUM_BAD;
        }
        *dv = *p == 'N' ? (double)NAN : (neg ? -(double)INFINITY : (double)INFINITY);
        *pp = p + wl;
        return NUM_NONFINITE;
    }
    uint64_t m = 0;
    int digits = 0, many = 0;
    int64_t exp10 = 0;
    if (*p == '0') {
        p++;
    } else if (*p >= '1' && *p <= '9') {
        for (;;) {
            if (m != 0 && digits <= 11 && eight_digits(p, end, &m)) {
                digits += 8;
                p += 8;
                continue;
            }
            if (p >= end || *p < '0' || *p > '9') {
                break;
            }
            if (digits < 19) {
                m = m * 10 + (uint64_t)(*p - '0');
                digits++;
            } else {
                many = 1;
                exp10++;
            }
            p++;
        }
    } else {
        return NUM_BAD;
    }
    int integral = 1;
    if (p < end && *p == '.') {
        integral = 0;
        p++;
        const uint8_t *first = p;
        for (;;) {
            if (m != 0 && digits <= 11 && eight_digits(p, end, &m)) {
                digits += 8;
                exp10 -= 8;
                p += 8;
                continue;
            }
            if (p >= end || *p < '0' || *p > '9') {
                break;
            }
            if (m == 0 && *p == '0') {
                exp10--;
            } else if (digits < 19) {
                m = m * 10 + (uint64_t)(*p - '0');
                digits++;
                exp10--;
            } else {
                many = 1;
            }
            p++;
        }
        if (p == first) {
            return NUM_BAD;
        }
    }
    if (p < end && (*p == 'e' || *p == 'E')) {
        integral = 0;
        p++;
        int eneg = 0;
        if (p < end && (*p == '+' || *p == '-')) {
            eneg = *p == '-';
            p++;
        }
        const uint8_t *first = p;
        int64_t e = 0;
        while (p < end && *p >= '0' && *p <= '9') {
            if (e < 100000) {
                e = e * 10 + (*p - '0');
            }
            p++;
        }
        if (p == first) {
            return NUM_BAD;
        }
        exp10 += eneg ? -e : e;
    }
    *pp = p;
    if (integral) {
        /* an integer: exact in int64 when it fits (digits counts all of them, none dropped) */
        if (many || (m > (uint64_t)INT64_MAX + (uint64_t)neg)) {
            return NUM_BIGINT;
        }
        *iv = neg ? (int64_t)(0 - m) : (int64_t)m;
        *dv = (double)*iv;
        return NUM_INT;
    }
    if (m == 0 && !many) {
        *dv = neg ? -0.0 : 0.0;
        return NUM_FLOAT;
    }
#if HAVE_X87_FAST_PATH
    if (!many && exp10 >= -27 && exp10 <= 27) {
        const long double x = exp10 >= 0 ? (long double)m * POW10[exp10]
                                         : (long double)m / POW10[-exp10];
        uint64_t bits;
        memcpy(&bits, &x, sizeof bits); /* the x87 significand, integer bit included */
        const uint64_t low = bits & 0x7FF;
        if ((low < 0x3FF || low > 0x401) && x >= (long double)DBL_MIN) {
            const double d = (double)x;
            *dv = neg ? -d : d;
            return isinf(d) ? NUM_NONFINITE : NUM_FLOAT;
        }
    }
#endif
    double d;
    if (!slow_double(from, p, &d)) {
        return NUM_BAD;
    }
    *dv = d;
    return isfinite(d) ? NUM_FLOAT : NUM_NONFINITE;
}

static inline const uint8_t *skip_space(const uint8_t *p, const uint8_t *end)
{
    while (p < end && (*p == ' ' || *p == '\n' || *p == '\r' || *p == '\t')) {
        p++;
    }
    return p;
}

typedef union {
    int64_t i;
    double d;
} value_t;

/*
 * Match one segment of the skeleton (the tokens between two numbers, whitespace removed) at p:
 * whitespace is allowed between tokens, strings must match byte for byte (escapes included).
 * Returns the position after it, or NULL.
 */
static const uint8_t *match_tokens(const uint8_t *p, const uint8_t *end, const uint8_t *s,
                                   const uint8_t *skel_end)
{
    uint8_t prev = 0;
    while (s < skel_end) {
        const uint8_t c = *s++;
        if (!(c >= 'a' && c <= 'z' && prev >= 'a' && prev <= 'z')) {
            p = skip_space(p, end); /* between tokens; not inside true, false, null */
        }
        prev = c;
        if (p >= end || *p != c) {
            return NULL;
        }
        p++;
        if (c == '"') { /* a string: byte for byte to its closing quote */
            for (;;) {
                if (s >= skel_end || p >= end || *p != *s) {
                    return NULL;
                }
                const uint8_t d = *s++;
                p++;
                if (d == '\\') {
                    if (s >= skel_end || p >= end || *p != *s) {
                        return NULL;
                    }
                    s++;
                    p++;
                } else if (d == '"') {
                    break;
                }
            }
        }
    }
    return p;
}

/*
 * buffer, starts, lengths, n: the messages (buffer[starts[i] : starts[i] + lengths[i]]).
 * n_numbers: numbers in every message; the text around them is n_numbers + 1 segments:
 * tokens, tokens_end: the segments of the skeleton (the first message's tokens between two
 *   numbers, whitespace outside strings removed); segment j is tokens[tokens_end[j - 1] :
 *   tokens_end[j]] (from 0 for j = 0).
 * verbatim, verbatim_end: the same segments as the first message wrote them (whitespace kept):
 *   a message that repeats one exactly is past it by one comparison.
 * column: per number, its output column or -1 (not kept: beyond the array items kept).
 * out: [n_columns][n] values; a column holds int64 while every value in it so far was an
 *   integer (isint[k] == 1), double from the first other value on (the earlier ones converted).
 * isint: per number, 1 on entry; left 1 when every value was written as an integer.
 * nonfinite: per number, 0 on entry; set to 1 when a value was NaN or +-Infinity (or overflowed).
 * Returns n when every message matched; else the index of the first that did not (a different
 *   structure, invalid JSON, an integer beyond int64).
 */
int64_t logcal_flat_json(const uint8_t *buffer, int64_t buffer_len, const int64_t *starts,
                         const int64_t *lengths, int64_t n, int64_t n_numbers,
                         const uint8_t *tokens, const int64_t *tokens_end,
                         const uint8_t *verbatim, const int64_t *verbatim_end,
                         const int64_t *column, value_t *out, uint8_t *isint, uint8_t *nonfinite)
{
    for (int64_t i = 0; i < n; i++) {
        const int64_t start = starts[i], len = lengths[i];
        if (start < 0 || len < 0 || start > buffer_len || len > buffer_len - start) {
            return i;
        }
        if (i + PREFETCH_AHEAD < n) { /* its first two cache lines (enough for most) */
            const int64_t a = starts[i + PREFETCH_AHEAD];
            if (a >= 0 && a < buffer_len - 64) {
                __builtin_prefetch(buffer + a);
                __builtin_prefetch(buffer + a + 64);
            }
        }
        const uint8_t *p = buffer + start, *const end = p + len;
        for (int64_t k = 0;; k++) {
            const int64_t v0 = k ? verbatim_end[k - 1] : 0, vlen = verbatim_end[k] - v0;
            if (end - p >= vlen && memcmp(p, verbatim + v0, (size_t)vlen) == 0) {
                p += vlen;
            } else {
                const int64_t t0 = k ? tokens_end[k - 1] : 0;
                p = match_tokens(p, end, tokens + t0, tokens + tokens_end[k]);
                if (p == NULL) {
                    return i;
                }
            }
            if (k == n_numbers) {
                break;
            }
            p = skip_space(p, end);
            int64_t iv = 0;
            double dv = 0.0;
            const int kind = parse_number(&p, end, &iv, &dv);
            if (kind == NUM_BAD || kind == NUM_BIGINT) {
                return i;
            }
            const int64_t col = column[k];
            value_t *const dst = col >= 0 ? out + col * n : NULL;
            if (kind != NUM_INT && isint[k]) {
                isint[k] = 0;
                if (dst != NULL) {
                    for (int64_t r = 0; r < i; r++) {
                        dst[r].d = (double)dst[r].i;
                    }
                }
            }
            if (kind == NUM_NONFINITE) {
                nonfinite[k] = 1;
            }
            if (dst != NULL) {
                if (isint[k]) {
                    dst[i].i = iv;
                } else {
                    dst[i].d = dv;
                }
            }
        }
        if (skip_space(p, end) != end) {
            return i;
        }
    }
    return n;
}

/* One number token (the whole of text): its kind (see parse_number), int64 and double. */
int logcal_json_number(const uint8_t *text, int64_t len, int64_t *iv, double *dv)
{
    const uint8_t *p = text;
    const int kind = parse_number(&p, text + len, iv, dv);
    return p == text + len ? kind : NUM_BAD;
}

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_flat_json",
                                    "C walk of logtools.readers.flat_json (called via ctypes).",
                                    -1, NULL};

PyMODINIT_FUNC PyInit__flat_json(void) { return PyModule_Create(&module); }
