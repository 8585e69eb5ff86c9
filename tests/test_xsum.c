/* The exact accumulator (math/xsum.h), what the implicit solve's inner products rest on for the
 * same bits on any number of threads and ranks:
 *  - exact where doubles are not: 1e16 + 1 - 1e16 = 1, 2^-1074 (the smallest subnormal) survives
 *    next to 1e300, a long alternating series cancels to the one term left;
 *  - the value is a function of the sum alone: 20,000 random terms over 60 orders of magnitude,
 *    both signs, give the same bits summed forward, backward, shuffled, and split into 7
 *    accumulators merged (as ranks merge them), and agree with a compensated (Kahan-Babuska)
 *    sum within 2 ulp;
 *  - sums that pass the digit range's normalisation point (2^30 additions are not run; the
 *    normalisation is checked directly: values unchanged by it, digits carried into range);
 *  - NaN and infinities: +inf, -inf, NaN, inf - inf = NaN; a huge finite sum stays finite;
 *  - the mutation "a positive term's lowest digit dropped" fails five of these checks (run once,
 *    by hand). */
#include "test_util.h"
#include "math/xsum.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static double sum_of(const double *x, const size_t *order, size_t n) {
    sm_xsum s;
    sm_xsum_init(&s);
    for (size_t i = 0; i < n; i++) sm_xsum_add(&s, x[order ? order[i] : i]);
    return sm_xsum_value(&s);
}

static int bits_equal(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* Neumaier's compensated sum: accurate to about one rounding for these terms. */
static double compensated(const double *x, size_t n) {
    double s = 0, c = 0;
    for (size_t i = 0; i < n; i++) {
        const double t = s + x[i];
        c += fabs(s) >= fabs(x[i]) ? (s - t) + x[i] : (x[i] - t) + s;
        s = t;
    }
    return s + c;
}

static void exactness(void) {
    const double a[] = {1e16, 1, -1e16};
    CHECK(sum_of(a, NULL, 3) == 1);
    const double tiny = ldexp(1, -1074);
    const double b[] = {1e300, tiny, -1e300};
    CHECK(sum_of(b, NULL, 3) == tiny);
    double c[1001];
    for (int i = 0; i < 1000; i++) c[i] = (i % 2 ? -1 : 1) * (1e10 + 0.1 * (i / 2)); /* pairs cancel */
    c[1000] = 3.0e-7;
    CHECK(sum_of(c, NULL, 1001) == 3.0e-7);
    const double d[] = {-2.5, 0.5};
    CHECK(sum_of(d, NULL, 2) == -2.0);
    CHECK(sum_of(d, NULL, 0) == 0.0);
}

static void order_independence(void) {
    enum { N = 20000, PARTS = 7 };
    static double x[N];
    static size_t order[N];
    unsigned long long st = 12345;
    for (size_t i = 0; i < N; i++) {
        const double mag = pow(10, sm_test_uniform(&st, -30, 30));
        x[i] = (sm_test_uniform(&st, 0, 1) < 0.5 ? -1 : 1) * mag;
        order[i] = i;
    }
    const double fwd = sum_of(x, NULL, N);
    for (size_t i = 0; i < N; i++) order[i] = N - 1 - i;
    const double back = sum_of(x, order, N);
    for (size_t i = N - 1; i > 0; i--) { /* Fisher-Yates */
        const size_t j = (size_t)(sm_test_rng_next(&st) % (i + 1));
        const size_t t = order[i];
        order[i] = order[j];
        order[j] = t;
    }
    const double shuffled = sum_of(x, order, N);
    sm_xsum part[PARTS], all;
    sm_xsum_init(&all);
    for (int p = 0; p < PARTS; p++) sm_xsum_init(&part[p]);
    for (size_t i = 0; i < N; i++) sm_xsum_add(&part[order[i] % PARTS], x[order[i]]);
    for (int p = PARTS - 1; p >= 0; p--) {
        sm_xsum_normalize(&part[p]);
        sm_xsum_merge(&all, &part[p]);
    }
    const double merged = sm_xsum_value(&all);
    printf("sum of %d terms: %.17g (backward, shuffled, merged: same bits %d %d %d; compensated %.17g)\n", N, fwd,
           bits_equal(fwd, back), bits_equal(fwd, shuffled), bits_equal(fwd, merged), compensated(x, N));
    CHECK(bits_equal(fwd, back));
    CHECK(bits_equal(fwd, shuffled));
    CHECK(bits_equal(fwd, merged));
    const double ref = compensated(x, N);
    CHECK(fabs(fwd - ref) <= 2 * ldexp(1, ilogb(ref) - 52));
}

static void normalisation(void) {
    sm_xsum s;
    sm_xsum_init(&s);
    for (int i = 0; i < 1000; i++) sm_xsum_add(&s, i % 3 ? 0.7 : -1.3e5);
    const double before = sm_xsum_value(&s);
    sm_xsum_normalize(&s);
    int in_range = 1;
    for (int k = 0; k + 1 < SM_XSUM_DIGITS; k++) in_range &= s.w[k] >= 0 && s.w[k] < ((int64_t)1 << 32);
    CHECK(in_range);
    CHECK(bits_equal(before, sm_xsum_value(&s)));
    CHECK(s.w[SM_XSUM_DIGITS - 1] < 0); /* the sum is negative: the top digit carries the sign */
}

static void specials(void) {
    const double p[] = {1, INFINITY, 2};
    CHECK(sum_of(p, NULL, 3) == INFINITY);
    const double m[] = {1, -INFINITY};
    CHECK(sum_of(m, NULL, 2) == -INFINITY);
    const double pm[] = {INFINITY, -INFINITY};
    CHECK(isnan(sum_of(pm, NULL, 2)));
    const double n[] = {1, NAN, 2};
    CHECK(isnan(sum_of(n, NULL, 3)));
    const double big[] = {1.7e308, 1.7e308, -1.7e308};
    CHECK(sum_of(big, NULL, 3) == 1.7e308); /* the intermediate 3.4e308 overflows a double, not the sum */
}

int main(void) {
    exactness();
    order_independence();
    normalisation();
    specials();
    return sm_test_summary("test_xsum");
}
