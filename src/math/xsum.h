/* Exact sums of doubles (the implicit solve's inner products, integrate/implicit_ops_dim.c): a
 * fixed-point accumulator wide enough for every finite double, so that a sum is the same bits in
 * any order -- over threads, over blocks, over MPI ranks (dist/halo.c adds the ranks'
 * accumulators word by word with MPI_SUM).
 *
 * Representation: sum = sum_k d[k] 2^(32 k - SM_XSUM_BIAS) with int64 digits. A double
 * x = m 2^(e-53) (m an integer, |m| < 2^53, e = frexp's exponent, -1073 <= e <= 1024) lands at
 * bit position e - 53 + SM_XSUM_BIAS >= 0 and adds to three digits, each by less than 2^32; so
 * 2^30 additions cannot overflow a digit, and sm_xsum_add normalises (carries every digit into
 * [0, 2^32), the top one signed) before that many. NaN and infinities are counted apart:
 * the value is NaN if any NaN was added or both infinities, else the infinity added.
 *
 * sm_xsum_value: the exact sum rounded to a double from its top 96 bits (within one unit in the
 * last place: three roundings of a 96-bit integer and a scaling), a function of the exact sum
 * alone, never of the order of the additions. */
#ifndef SM_MATH_XSUM_H
#define SM_MATH_XSUM_H

#include <stdint.h>

#define SM_XSUM_BIAS 1126                     /* 1073 + 53: the smallest double's bit at position 0 */
#define SM_XSUM_DIGITS 70                     /* positions up to 2240 > 2097 + 85 + carries */
#define SM_XSUM_WORDS (SM_XSUM_DIGITS + 3)    /* digits, then the counts of NaN, +inf, -inf */

typedef struct sm_xsum {
    int64_t w[SM_XSUM_WORDS];                 /* what MPI adds: digits and counts */
    int64_t pending;                          /* additions since the last normalisation */
} sm_xsum;

void sm_xsum_init(sm_xsum *s);
void sm_xsum_add(sm_xsum *s, double x);
/* Carries every digit but the top one into [0, 2^32) (the value unchanged). */
void sm_xsum_normalize(sm_xsum *s);
/* s += o (both normalised or with few pending additions). */
void sm_xsum_merge(sm_xsum *s, const sm_xsum *o);
double sm_xsum_value(const sm_xsum *s);

#endif
