/* Lane-parallel plasticity (see plastic_batch.h).
 *
 * Every function below is straight-line code on scalars (selects instead of branches), forced
 * inline into loops `for (l = 0; l < SM_PLASTIC_LANES; l++)` over the structure-of-arrays batch,
 * which gcc/clang -O3 turn into SIMD code (one lane per vector element). No reductions across
 * lanes, so each lane's bits depend on its own inputs only.
 *
 * Elementary functions (own code; textbook methods):
 *   log x: x = 2^k m, m in [sqrt(1/2), sqrt(2)) by integer operations on the representation,
 *          log m = 2 atanh f, f = (m - 1)/(m + 1), |f| <= 0.172, by its Taylor series (terms to
 *          f^23 in double, f^11 in float), k ln 2 in two parts (Cody & Waite).
 *   exp x: x = k ln 2 + r, |r| <= ln2 / 2 (two-part ln 2), Taylor series of e^r to r^13 (double)
 *          or r^7 (float), times 2^k built from bits.
 *   sin x: x = k pi/2 + r (two- or three-part pi/2), |r| <= pi/4, Taylor series of sin r and
 *          cos r, quadrant by select.
 * Measured errors (tests/test_plastic_batch.c): <= 2 ulp in float, <= ~1e-16 relative in double.
 *
 * Build: compile this file with -fno-math-errno (the top-level CMake sets it as a source property),
 * else gcc keeps the errno branch of sqrt and vectorises nothing; results are the same either way.
 *
 * SVD: the method of src/math/svd.c (Jacobi sweeps with Pade-approximate quaternion rotations on
 * F^T F, Givens QR, 2x2 clean-up), written without any branch: a fixed number of sweeps
 * (SM_PLASTIC_SWEEPS), the column sort as selects, QR and clean-up always done. */
#include "material/plastic_batch.h"

#include <float.h>
#include <string.h>

#include "material/material.h"

#define L SM_PLASTIC_LANES
#define INL static inline __attribute__((always_inline))
#define ONE SM_R(1.0)

#if SM_DOUBLE
typedef uint64_t ubits;
typedef int64_t ibits;
#define MANT_BITS 52
#define EXP_BIAS 1023
#define SQRTHALF_BITS 0x3fe6a09e667f3bcdULL
#define REAL_MIN DBL_MIN
#define NUDGE 1e-150
#define LN2_HI 6.93147180369123816490e-01
#define LN2_LO 1.90821492927058770002e-10
#define EXP_LIM 700.0
#define PIO2_1 1.57079632673412561417e+00
#define PIO2_2 6.07710050650619224932e-11
#define PIO2_3 0.0
#define lcopysign copysign
#define ROUND_MAGIC 6755399441055744.0 /* 1.5 * 2^52: (x + M) - M rounds to an integer */
#ifndef SM_PLASTIC_SWEEPS
#define SM_PLASTIC_SWEEPS 6
#endif
#else
typedef uint32_t ubits;
typedef int32_t ibits;
#define MANT_BITS 23
#define EXP_BIAS 127
#define SQRTHALF_BITS 0x3f3504f3U
#define REAL_MIN FLT_MIN
#define NUDGE 1e-18f
#define LN2_HI 0.693359375f
#define LN2_LO (-2.12194440e-4f)
#define EXP_LIM 87.0f
#define PIO2_1 1.5703125f
#define PIO2_2 4.837512969970703125e-4f
#define PIO2_3 7.54978995489188216e-8f
#define lcopysign copysignf
#define ROUND_MAGIC 12582912.0f /* 1.5 * 2^23 */
#ifndef SM_PLASTIC_SWEEPS
#define SM_PLASTIC_SWEEPS 5
#endif
#endif

/* ------------------------------------------------------------------------------------------ */
/* Elementary functions                                                                          */

INL sm_real from_bits(ubits u) {
    sm_real x;
    memcpy(&x, &u, sizeof x);
    return x;
}
INL ubits to_bits(sm_real x) {
    ubits u;
    memcpy(&u, &x, sizeof u);
    return u;
}

/* log x for positive normal x (NaN/Inf propagate through the final + (x - x)). */
INL sm_real lane_log(sm_real x) {
    ubits u = to_bits(x);
    ibits k = (ibits)(u - (ubits)SQRTHALF_BITS) >> MANT_BITS; /* arithmetic shift */
    sm_real m = from_bits(u - ((ubits)k << MANT_BITS));
    sm_real f = (m - ONE) / (m + ONE), s = f * f;
#if SM_DOUBLE
    sm_real p = 0.08695652173913043;
    p = p * s + 0.09523809523809523;
    p = p * s + 0.10526315789473684;
    p = p * s + 0.11764705882352941;
    p = p * s + 0.13333333333333333;
    p = p * s + 0.15384615384615385;
    p = p * s + 0.18181818181818182;
    p = p * s + 0.2222222222222222;
    p = p * s + 0.2857142857142857;
    p = p * s + 0.4;
    p = p * s + 0.6666666666666666;
#else
    sm_real p = 0.18181818f;
    p = p * s + 0.22222222f;
    p = p * s + 0.28571429f;
    p = p * s + 0.4f;
    p = p * s + 0.66666667f;
#endif
    sm_real kf = (sm_real)k;
    sm_real lm = 2 * f + f * (s * p);
    return kf * LN2_HI + (lm + kf * LN2_LO) + (x - x);
}

/* e^x; x is clamped to +-EXP_LIM (NaN propagates). */
INL sm_real lane_exp(sm_real x) {
    sm_real xc = x > EXP_LIM ? EXP_LIM : x;
    xc = xc < -EXP_LIM ? -EXP_LIM : xc;
    /* nearest integer by the magic-number addition (floor() is not vectorised without
     * -fno-trapping-math); |argument| < 2^22 here */
    sm_real kf = (xc * SM_R(1.44269504088896340736) + ROUND_MAGIC) - ROUND_MAGIC;
    sm_real r = (xc - kf * LN2_HI) - kf * LN2_LO;
#if SM_DOUBLE
    sm_real p = 1.6059043836821613e-10;
    p = p * r + 2.08767569878681e-09;
    p = p * r + 2.505210838544172e-08;
    p = p * r + 2.755731922398589e-07;
    p = p * r + 2.7557319223985893e-06;
    p = p * r + 2.48015873015873e-05;
    p = p * r + 0.0001984126984126984;
    p = p * r + 0.001388888888888889;
    p = p * r + 0.008333333333333333;
    p = p * r + 0.041666666666666664;
    p = p * r + 0.16666666666666666;
    p = p * r + 0.5;
#else
    sm_real p = 1.98412698e-4f;
    p = p * r + 1.38888889e-3f;
    p = p * r + 8.33333333e-3f;
    p = p * r + 4.16666667e-2f;
    p = p * r + 0.16666667f;
    p = p * r + 0.5f;
#endif
    sm_real er = ONE + (r + (r * r) * p);
    ibits k = (ibits)kf;
    sm_real two_k = from_bits((ubits)(k + EXP_BIAS) << MANT_BITS);
    return er * two_k + (x - x);
}

/* sin x for |x| up to ~1e4. */
INL sm_real lane_sin(sm_real x) {
    sm_real kf = (x * SM_R(0.63661977236758134308) + ROUND_MAGIC) - ROUND_MAGIC;
    sm_real r = ((x - kf * PIO2_1) - kf * PIO2_2) - kf * PIO2_3;
    sm_real z = r * r;
#if SM_DOUBLE
    sm_real ps = -7.647163731819816e-13;
    ps = ps * z + 1.6059043836821613e-10;
    ps = ps * z - 2.505210838544172e-08;
    ps = ps * z + 2.7557319223985893e-06;
    ps = ps * z - 0.0001984126984126984;
    ps = ps * z + 0.008333333333333333;
    ps = ps * z - 0.16666666666666666;
    sm_real pc = 4.779477332387385e-14;
    pc = pc * z - 1.1470745597729725e-11;
    pc = pc * z + 2.08767569878681e-09;
    pc = pc * z - 2.755731922398589e-07;
    pc = pc * z + 2.48015873015873e-05;
    pc = pc * z - 0.001388888888888889;
    pc = pc * z + 0.041666666666666664;
#else
    sm_real ps = 2.75573192e-6f;
    ps = ps * z - 1.98412698e-4f;
    ps = ps * z + 8.33333333e-3f;
    ps = ps * z - 0.16666667f;
    sm_real pc = -2.75573192e-7f;
    pc = pc * z + 2.48015873e-5f;
    pc = pc * z - 1.38888889e-3f;
    pc = pc * z + 4.16666667e-2f;
#endif
    sm_real sn = r + r * (z * ps);
    sm_real cs = (ONE - SM_R(0.5) * z) + (z * z) * pc;
    ibits k = (ibits)kf;
    sm_real v = (k & 1) ? cs : sn;
    return (k & 2) ? -v : v;
}

void sm_lanes_log(const sm_real *x, sm_real *y) {
    for (int l = 0; l < L; l++) y[l] = lane_log(x[l]);
}
void sm_lanes_exp(const sm_real *x, sm_real *y) {
    for (int l = 0; l < L; l++) y[l] = lane_exp(x[l]);
}
void sm_lanes_sin(const sm_real *x, sm_real *y) {
    for (int l = 0; l < L; l++) y[l] = lane_sin(x[l]);
}

/* ------------------------------------------------------------------------------------------ */
/* Branch-free SVD                                                                               */

/* Rotation taking (a, b) to (r, 0), r >= 0 (a nudged away from 0: (0, 0) gives (+-1, 0)). */
INL void lane_givens(sm_real a, sm_real b, sm_real *c, sm_real *s) {
    a += lcopysign(NUDGE, a);
    sm_real ri = ONE / sm_sqrt(a * a + b * b);
    *c = a * ri;
    *s = b * ri;
}

/* Exact Jacobi tangent for [[p, q], [q, r]] (as svd_jacobi_t in svd.c). */
INL sm_real lane_jacobi_t(sm_real p, sm_real q, sm_real r) {
    sm_real d = r - p;
    sm_real h = sm_sqrt(d * d + 4 * q * q);
    sm_real t = (2 * q * lcopysign(ONE, d)) / (sm_fabs(d) + h + REAL_MIN);
    return q * q > (SM_EPS * SM_EPS) * p * r ? t : 0;
}

/* 2x2 signed SVD of [[a, b], [c, d]] (entries O(1)): U = [[uc, us], [-us, uc]],
 * V = [[vc, vs], [-vs, vc]], s0 >= |s1|, sign(s1) = sign(ad - bc). */
INL void lane_svd2(sm_real a, sm_real b, sm_real c, sm_real d, sm_real *uc, sm_real *us,
                   sm_real *s0, sm_real *s1, sm_real *vc, sm_real *vs) {
    sm_real rc, rs;
    lane_givens(a + d, c - b, &rc, &rs);
    sm_real s00 = rc * a + rs * c, s11 = rc * d - rs * b;
    sm_real s01 = SM_R(0.5) * ((rc * b + rs * d) + (rc * c - rs * a));
    sm_real t = lane_jacobi_t(s00, s01, s11);
    sm_real wc = ONE / sm_sqrt(ONE + t * t), ws = t * wc;
    sm_real l0 = s00 - t * s01, l1 = s11 + t * s01;
    int m = l1 > l0;
    sm_real c2 = m ? ws : wc, s2 = m ? -wc : ws;
    sm_real hi = m ? l1 : l0, lo = m ? l0 : l1;
    sm_real alo = sm_fabs(lo);
    lo = lcopysign(alo < hi ? alo : hi, lo);
    *uc = rc * c2 + rs * s2;
    *us = rc * s2 - rs * c2;
    *vc = c2;
    *vs = s2;
    *s0 = hi;
    *s1 = lo;
}

/* G = F / max|F_ij| (1 / REAL_MIN for zero or subnormal input); returns the scale. */
INL sm_real lane_normalize(const sm_real *F, sm_real *G, int n) {
    sm_real m = 0;
    for (int i = 0; i < n; i++) {
        sm_real a = sm_fabs(F[i]);
        m = a > m ? a : m;
    }
    sm_real inv = ONE / (m > REAL_MIN ? m : REAL_MIN);
    for (int i = 0; i < n; i++) G[i] = F[i] * inv;
    return m > REAL_MIN ? m : REAL_MIN;
}

#define C8 SM_R(0.92387953251128675613)
#define S8 SM_R(0.38268343236508977173)

/* Pade-approximate Jacobi rotation in the plane (p, q), quaternion accumulated (see svd.c). */
INL void lane_rot(sm_real *app, sm_real *aqq, sm_real *apq, sm_real *arp, sm_real *arq,
                  sm_real *arr, sm_real *qw, sm_real *qa, sm_real *qb, sm_real *qr, sm_real sgn) {
    /* qr: quaternion component on the rotation axis r; (qa, qb): the other two, in the order that
     * makes (a, b, r) cyclic. */
    sm_real d = *aqq - *app, b = *apq;
    sm_real dd = d * d, bb = b * b;
    int ap = SM_R(0.5) * bb < dd;
    sm_real ch = 4 * dd + 5 * bb, sh = 2 * b * d;
    sm_real tau = sh / (ap ? ch : ONE);
    sm_real c1 = ap ? ONE : C8;
    sm_real s1 = ap ? tau : lcopysign(S8, b * d);
    sm_real cc = c1 * c1, ss = s1 * s1;
    sm_real c = cc - ss, s = 2 * c1 * s1, m = cc + ss;
    sm_real a = *app, e = *aqq;
    sm_real c2 = c * c, s2 = s * s, cs = c * s;
    *app = (c2 * a + s2 * e) - 2 * cs * b;
    *aqq = (s2 * a + c2 * e) + 2 * cs * b;
    *apq = cs * (a - e) + (c2 - s2) * b;
    sm_real rp = *arp, rq = *arq;
    *arp = m * (c * rp - s * rq);
    *arq = m * (s * rp + c * rq);
    *arr = (m * m) * *arr;
    /* q <- q (c1 + h e_r), h = sgn s1: (w, v)(c, h e) = (w c - h v_r, c v + w h e + h v x e);
     * v x e_r = (v_b, -v_a) in the (a, b) components for cyclic (a, b, r). */
    sm_real h = sgn * s1;
    sm_real w = *qw, va = *qa, vb = *qb, vr = *qr;
    *qw = w * c1 - h * vr;
    *qr = w * h + c1 * vr;
    *qa = c1 * va + h * vb;
    *qb = c1 * vb - h * va;
}

INL void lane_swap(int sw, sm_real *x, sm_real *y) {
    sm_real a = *x, b = *y;
    *x = sw ? b : a;
    *y = sw ? a : b;
}

/* Givens rotation on rows i, j of B zeroing B[j][k] (B[i][k] >= 0); U <- U G^T. */
INL void lane_givens_step(sm_real B[9], sm_real U[9], int i, int j, int k) {
    sm_real c, sn;
    lane_givens(B[3 * i + k], B[3 * j + k], &c, &sn);
    for (int m = 0; m < 3; m++) {
        sm_real bi = B[3 * i + m], bj = B[3 * j + m];
        B[3 * i + m] = c * bi + sn * bj;
        B[3 * j + m] = c * bj - sn * bi;
        sm_real ui = U[3 * m + i], uj = U[3 * m + j];
        U[3 * m + i] = c * ui + sn * uj;
        U[3 * m + j] = c * uj - sn * ui;
    }
}

/* The 3x3 signed SVD F = U diag(s) V^T in stages, each a loop over the lanes with a straight-line
 * body (gcc vectorises innermost loops only): */

/* Work arrays of the Jacobi stage. */
typedef struct svd_work {
    sm_real G[9][L];
    sm_real a00[L], a11[L], a22[L], a01[L], a02[L], a12[L];
    sm_real w[L], x[L], y[L], z[L];
    sm_real scale[L];
} svd_work;

/* Stage 1: G = F / max|F_ij|, A = G^T G, quaternion = 1. */
INL void svd3_stage_init(const sm_plastic_lanes *b, svd_work *k) {
    for (int l = 0; l < L; l++) {
        sm_real F[9], G[9];
        for (int e = 0; e < 9; e++) F[e] = b->F[e][l];
        k->scale[l] = lane_normalize(F, G, 9);
        for (int e = 0; e < 9; e++) k->G[e][l] = G[e];
        k->a00[l] = G[0] * G[0] + G[3] * G[3] + G[6] * G[6];
        k->a11[l] = G[1] * G[1] + G[4] * G[4] + G[7] * G[7];
        k->a22[l] = G[2] * G[2] + G[5] * G[5] + G[8] * G[8];
        k->a01[l] = G[0] * G[1] + G[3] * G[4] + G[6] * G[7];
        k->a02[l] = G[0] * G[2] + G[3] * G[5] + G[6] * G[8];
        k->a12[l] = G[1] * G[2] + G[4] * G[5] + G[7] * G[8];
        k->w[l] = 1, k->x[l] = 0, k->y[l] = 0, k->z[l] = 0;
    }
}

/* Stage 2: one Jacobi sweep. */
INL void svd3_stage_sweep(svd_work *k) {
    for (int l = 0; l < L; l++) {
        sm_real a00 = k->a00[l], a11 = k->a11[l], a22 = k->a22[l];
        sm_real a01 = k->a01[l], a02 = k->a02[l], a12 = k->a12[l];
        sm_real w = k->w[l], x = k->x[l], y = k->y[l], z = k->z[l];
        lane_rot(&a00, &a11, &a01, &a02, &a12, &a22, &w, &x, &y, &z, -1); /* axis 2: (x, y, z) */
        lane_rot(&a00, &a22, &a02, &a01, &a12, &a11, &w, &z, &x, &y, 1);  /* axis 1: (z, x, y) */
        lane_rot(&a11, &a22, &a12, &a01, &a02, &a00, &w, &y, &z, &x, -1); /* axis 0: (y, z, x) */
        k->a00[l] = a00, k->a11[l] = a11, k->a22[l] = a22;
        k->a01[l] = a01, k->a02[l] = a02, k->a12[l] = a12;
        k->w[l] = w, k->x[l] = x, k->y[l] = y, k->z[l] = z;
    }
}

/* Stage 3 (per lane, inlined into the final loop): V from the quaternion, B = G V, column sort,
 * Givens QR, 2x2 clean-up. */
INL void svd3_finish(const svd_work *k, int l, sm_real U[9], sm_real s[3], sm_real V[9]) {
    sm_real G[9], B[9];
    for (int e = 0; e < 9; e++) G[e] = k->G[e][l];
    sm_real w = k->w[l], x = k->x[l], y = k->y[l], z = k->z[l];
    sm_real ww = w * w, xx = x * x, yy = y * y, zz = z * z;
    sm_real xy = x * y, xz = x * z, yz = y * z, wx = w * x, wy = w * y, wz = w * z;
    sm_real in = ONE / ((ww + xx) + (yy + zz));
    V[0] = ((ww + xx) - (yy + zz)) * in, V[1] = 2 * (xy - wz) * in, V[2] = 2 * (xz + wy) * in;
    V[3] = 2 * (xy + wz) * in, V[4] = ((ww - xx) + (yy - zz)) * in, V[5] = 2 * (yz - wx) * in;
    V[6] = 2 * (xz - wy) * in, V[7] = 2 * (yz + wx) * in, V[8] = ((ww - xx) - (yy - zz)) * in;

    sm_real n0 = 0, n1 = 0, n2 = 0;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            B[3 * i + j] = G[3 * i] * V[j] + G[3 * i + 1] * V[3 + j] + G[3 * i + 2] * V[6 + j];
        n0 += B[3 * i] * B[3 * i];
        n1 += B[3 * i + 1] * B[3 * i + 1];
        n2 += B[3 * i + 2] * B[3 * i + 2];
    }
    /* Sort the columns by decreasing norm (selects); odd permutation: negate the last column. */
    int odd = 0, sw;
    sw = n1 > n0, odd ^= sw;
    lane_swap(sw, &n0, &n1);
    for (int c = 0; c < 3; c++) lane_swap(sw, &B[3 * c], &B[3 * c + 1]), lane_swap(sw, &V[3 * c], &V[3 * c + 1]);
    sw = n2 > n1, odd ^= sw;
    lane_swap(sw, &n1, &n2);
    for (int c = 0; c < 3; c++) lane_swap(sw, &B[3 * c + 1], &B[3 * c + 2]), lane_swap(sw, &V[3 * c + 1], &V[3 * c + 2]);
    sw = n1 > n0, odd ^= sw;
    for (int c = 0; c < 3; c++) lane_swap(sw, &B[3 * c], &B[3 * c + 1]), lane_swap(sw, &V[3 * c], &V[3 * c + 1]);
    for (int c = 0; c < 3; c++) {
        B[3 * c + 2] = odd ? -B[3 * c + 2] : B[3 * c + 2];
        V[3 * c + 2] = odd ? -V[3 * c + 2] : V[3 * c + 2];
    }

    /* Givens QR: B = Q R, U = Q. */
    for (int i = 0; i < 9; i++) U[i] = (i % 4 == 0) ? ONE : 0;
    lane_givens_step(B, U, 0, 1, 0);
    lane_givens_step(B, U, 0, 2, 0);
    lane_givens_step(B, U, 1, 2, 1);
    /* Trailing 2x2 block clean-up. */
    sm_real uc, us, vc, vs, sb0, sb1;
    lane_svd2(B[4], B[5], B[7], B[8], &uc, &us, &sb0, &sb1, &vc, &vs);
    for (int c = 0; c < 3; c++) {
        sm_real u1 = U[3 * c + 1], u2 = U[3 * c + 2];
        U[3 * c + 1] = u1 * uc - u2 * us;
        U[3 * c + 2] = u1 * us + u2 * uc;
        sm_real v1 = V[3 * c + 1], v2 = V[3 * c + 2];
        V[3 * c + 1] = v1 * vc - v2 * vs;
        V[3 * c + 2] = v1 * vs + v2 * vc;
    }
    sm_real r0 = B[0], scale = k->scale[l];
    sm_real hi = r0 > sb0 ? r0 : sb0, mid = r0 > sb0 ? sb0 : r0;
    sm_real a2 = sm_fabs(sb1);
    s[0] = hi * scale;
    s[1] = mid * scale;
    s[2] = lcopysign(a2 < mid ? a2 : mid, sb1) * scale;
}

/* ------------------------------------------------------------------------------------------ */
/* Return mapping, hardening, stress                                                             */

#define FLOOR SM_SIGMA_FLOOR
#define SQRT_2_3 SM_R(0.81649658092772603273)

/* alpha of the hardened friction angle, sin(phi) = sp, for cone fit `fit` (sm_cone_fit) in d
 * dimensions: sm_dp_alpha_fit (material.c) as selects. The thesis's fit (0) is computed exactly as
 * before the fits existed; cos(phi) = sqrt(1 - sp^2) (phi < 90 degrees), kept away from 0. */
INL sm_real lane_alpha_fit(int d, int32_t fit, sm_real sp) {
    const sm_real r2d = SM_R(1.41421356237309504880) / (sm_real)d; /* sqrt(2) / d */
    sm_real tc = SQRT_2_3 * 2 * sp / (3 - sp);
    sm_real ps = r2d * sp;
    sm_real ins = SQRT_2_3 * sp / sm_sqrt(3 + sp * sp);
    sm_real c2 = 1 - sp * sp;
    sm_real ss = r2d * sp / sm_sqrt(c2 > SM_EPS ? c2 : SM_EPS);
    return fit == SM_CONE_PLANE_STRAIN ? ps : fit == SM_CONE_INSCRIBED ? ins : fit == SM_CONE_SIMPLE_SHEAR ? ss : tc;
}

/* The plasticity of one lane given its SVD (d = 2 or 3). sn: projected singular values;
 * tau: principal Kirchhoff stresses; returns 1 if F must be rebuilt (case 2 or 3). */
INL int lane_project(int d, const sm_real *s, sm_real *alpha, sm_real *q, sm_real mu,
                     sm_real lambda, sm_real h0, sm_real h1, sm_real h2, sm_real h3, int plastic,
                     int hardening, int32_t fit, sm_real *sn, sm_real *tau) {
    sm_real eps[3], dev[3], H[3];
    sm_real tr = 0, emax = 0, devmax = 0, ne = 0, nd = 0;
    for (int i = 0; i < d; i++) {
        sm_real c = s[i] < FLOOR ? FLOOR : s[i];
        eps[i] = lane_log(c);
        tr += eps[i];
    }
    sm_real mean = tr / (sm_real)d;
    for (int i = 0; i < d; i++) {
        dev[i] = eps[i] - mean;
        sm_real ae = sm_fabs(eps[i]), ad = sm_fabs(dev[i]);
        emax = ae > emax ? ae : emax;
        devmax = ad > devmax ? ad : devmax;
        ne += eps[i] * eps[i];
        nd += dev[i] * dev[i];
    }
    int zero_dev = devmax <= SM_R(2.0) * (sm_real)d * SM_EPS * emax;
    int case2 = tr > 0; /* tension alone goes to the tip; a zero deviator under compression is case 1 */
    sm_real ndev = sm_sqrt(nd);
    sm_real kappa = ((sm_real)d * lambda + 2 * mu) / (2 * mu) * tr * *alpha;
    sm_real dgamma = ndev + kappa;
    int case1 = (plastic == 0) | ((case2 == 0) & ((dgamma <= 0) | zero_dev)); /* bitwise: no jumps */
    case2 = case2 & (case1 == 0);
    int case3 = (case1 == 0) & (case2 == 0);
    sm_real sc = -kappa / (ndev > 0 ? ndev : ONE);
    for (int i = 0; i < d; i++) H[i] = mean + sc * dev[i];
    sm_real tr2 = 0, e2[3], ex_[3];
    for (int i = 0; i < d; i++) {
        sm_real ex = lane_exp(H[i]);
        ex_[i] = ex;
        sn[i] = case1 ? s[i] : case2 ? ONE : ex;
        /* eps of the result: log(max(sn, floor)) without a second log (rounding-level change) */
        sm_real lh = ex < FLOOR ? SM_R(-9.21034037197618273607) : H[i];
        e2[i] = case1 ? eps[i] : case2 ? 0 : lh;
        tr2 += e2[i];
    }
    for (int i = 0; i < d; i++) {
        sm_real t = 2 * mu * e2[i] + lambda * tr2;
        sm_real tf = t * (sn[i] / FLOOR); /* computed unconditionally: selects only */
        /* sn < FLOOR, case by case: a comparison of a select would become a select of masks,
         * which gcc 12 cannot vectorise with AVX-512 mask registers */
        int small = (case1 & (s[i] < FLOOR)) | (case3 & (ex_[i] < FLOOR));
        tau[i] = small ? tf : t;
    }
    sm_real nrm = sm_sqrt(ne); /* unconditional: a select, not a branch */
    sm_real dq = case2 ? nrm : case3 ? dgamma : 0;
    int harden = (hardening != 0) & ((case2 & (nrm > 0)) | (case3 & (dgamma > 0)));
    sm_real qn = *q + dq;
    sm_real phi = h0 + (h1 * qn - h3) * lane_exp(-h2 * qn);
    sm_real sp = lane_sin(phi);
    sm_real an = lane_alpha_fit(d, fit, sp);
    *q = harden ? qn : *q;
    *alpha = harden ? an : *alpha;
    return case1 == 0;
}

/* Per-lane results of the SVD and of the return mapping, between the stages. */
typedef struct lane_state {
    sm_real U[9][L], V[9][L], s[3][L], sn[3][L], t[3][L];
    int32_t rebuild[L];
} lane_state;

/* Return mapping + hardening + principal stresses for all lanes (d = 2, 3). */
INL void stage_project(int d, sm_plastic_lanes *b, lane_state *st) {
    for (int l = 0; l < L; l++) {
        sm_real s[3], sn[3], t[3];
        for (int i = 0; i < d; i++) s[i] = st->s[i][l];
        sm_real alpha = b->alpha[l], q = b->q[l];
        st->rebuild[l] = lane_project(d, s, &alpha, &q, b->mu[l], b->lambda[l], b->h0[l], b->h1[l], b->h2[l],
                                      b->h3[l], b->plastic[l] != 0, b->hardening[l] != 0, b->fit[l], sn, t);
        b->alpha[l] = alpha;
        b->q[l] = q;
        for (int i = 0; i < d; i++) st->sn[i][l] = sn[i], st->t[i][l] = t[i];
    }
}

/* F = U diag(sn) V^T where rebuilt, tau = U diag(t) U^T. */
INL void stage_output(int d, sm_plastic_lanes *b, const lane_state *st) {
    for (int l = 0; l < L; l++) {
        int rb = st->rebuild[l] != 0;
        for (int i = 0; i < d; i++)
            for (int j = 0; j < d; j++) {
                sm_real f = 0, tt = 0;
                for (int k = 0; k < d; k++) {
                    f += st->U[d * i + k][l] * st->sn[k][l] * st->V[d * j + k][l];
                    tt += st->U[d * i + k][l] * st->t[k][l] * st->U[d * j + k][l];
                }
                sm_real f0 = b->F[d * i + j][l];
                b->F[d * i + j][l] = rb ? f : f0;
                b->tau[d * i + j][l] = tt;
            }
    }
}

void sm_plastic_lanes3(sm_plastic_lanes *b) {
    svd_work k;
    lane_state st;
    svd3_stage_init(b, &k);
    for (int sweep = 0; sweep < SM_PLASTIC_SWEEPS; sweep++) svd3_stage_sweep(&k);
    for (int l = 0; l < L; l++) {
        sm_real U[9], V[9], s[3];
        svd3_finish(&k, l, U, s, V);
        for (int e = 0; e < 9; e++) st.U[e][l] = U[e], st.V[e][l] = V[e];
        for (int i = 0; i < 3; i++) st.s[i][l] = s[i];
    }
    stage_project(3, b, &st);
    stage_output(3, b, &st);
}

void sm_plastic_lanes2(sm_plastic_lanes *b) {
    lane_state st;
    for (int l = 0; l < L; l++) {
        sm_real F[4], G[4], uc, us, vc, vs, s0, s1;
        for (int e = 0; e < 4; e++) F[e] = b->F[e][l];
        sm_real scale = lane_normalize(F, G, 4);
        lane_svd2(G[0], G[1], G[2], G[3], &uc, &us, &s0, &s1, &vc, &vs);
        st.s[0][l] = s0 * scale;
        st.s[1][l] = s1 * scale;
        st.U[0][l] = uc, st.U[1][l] = us, st.U[2][l] = -us, st.U[3][l] = uc;
        st.V[0][l] = vc, st.V[1][l] = vs, st.V[2][l] = -vs, st.V[3][l] = vc;
    }
    stage_project(2, b, &st);
    stage_output(2, b, &st);
}
