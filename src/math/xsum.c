/* Exact sums of doubles: the fixed-point accumulator of xsum.h. */
#include "math/xsum.h"

#include <math.h>
#include <string.h>

enum { XS_NAN = SM_XSUM_DIGITS, XS_PINF, XS_NINF };
#define DIGIT_MASK 0xffffffffULL
#define RADIX 4294967296.0 /* 2^32 */

void sm_xsum_init(sm_xsum *s) { memset(s, 0, sizeof *s); }

void sm_xsum_normalize(sm_xsum *s) {
    for (int k = 0; k + 1 < SM_XSUM_DIGITS; k++) {
        const int64_t v = s->w[k];
        const int64_t low = (int64_t)((uint64_t)v & DIGIT_MASK);
        s->w[k] = low;
        s->w[k + 1] += (v - low) / (int64_t)RADIX; /* exact: v - low is a multiple of 2^32 */
    }
    s->pending = 0;
}

void sm_xsum_add(sm_xsum *s, double x) {
    if (x != x) {
        s->w[XS_NAN]++;
        return;
    }
    if (isinf(x)) {
        s->w[x > 0 ? XS_PINF : XS_NINF]++;
        return;
    }
    if (x == 0) return;
    int e;
    const double m = frexp(x, &e);                    /* x = m 2^e, 0.5 <= |m| < 1 */
    const int64_t mant = (int64_t)ldexp(m, 53);       /* exact: x = mant 2^(e - 53) */
    const uint64_t u = (uint64_t)(mant < 0 ? -mant : mant);
    const int pos = e - 53 + SM_XSUM_BIAS, k = pos >> 5, sh = pos & 31;
    const uint64_t a = (u & DIGIT_MASK) << sh, b = (u >> 32) << sh; /* < 2^63, < 2^52 */
    const int64_t d0 = (int64_t)(a & DIGIT_MASK), d1 = (int64_t)((a >> 32) + (b & DIGIT_MASK)), d2 = (int64_t)(b >> 32);
    if (mant < 0) {
        s->w[k] -= d0;
        s->w[k + 1] -= d1;
        s->w[k + 2] -= d2;
    } else {
        s->w[k] += d0;
        s->w[k + 1] += d1;
        s->w[k + 2] += d2;
    }
    if (++s->pending >= (int64_t)1 << 30) sm_xsum_normalize(s);
}

void sm_xsum_merge(sm_xsum *s, const sm_xsum *o) {
    for (int k = 0; k < SM_XSUM_WORDS; k++) s->w[k] += o->w[k];
    s->pending += o->pending + 1;
    if (s->pending >= (int64_t)1 << 30) sm_xsum_normalize(s);
}

double sm_xsum_value(const sm_xsum *in) {
    if (in->w[XS_NAN] > 0 || (in->w[XS_PINF] > 0 && in->w[XS_NINF] > 0)) return NAN;
    if (in->w[XS_PINF] > 0) return INFINITY;
    if (in->w[XS_NINF] > 0) return -INFINITY;
    sm_xsum s = *in;
    sm_xsum_normalize(&s);
    double sign = 1;
    if (s.w[SM_XSUM_DIGITS - 1] < 0) { /* negative: the magnitude's digits */
        for (int k = 0; k < SM_XSUM_DIGITS; k++) s.w[k] = -s.w[k];
        sm_xsum_normalize(&s);
        sign = -1;
    }
    int h = SM_XSUM_DIGITS - 1;
    while (h >= 0 && s.w[h] == 0) h--;
    if (h < 0) return 0.0;
    double r = 0;
    const int low = h >= 2 ? h - 2 : 0;
    for (int k = h; k >= low; k--) r = r * RADIX + (double)s.w[k];
    return sign * ldexp(r, 32 * low - SM_XSUM_BIAS);
}
