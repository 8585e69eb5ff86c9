/* Signed SVD of 3x3 matrices, F = U diag(sigma) V^T (row-major), U and V rotations (math/svd.h);
 * the 2x2, the conventions and what both share: svd.c, svd_internal.h.
 *
 * Method (own code; only published facts are used):
 *
 * 3x3 -- the scheme of McAdams, Selle, Tamstorf, Teran and Sifakis, "Computing the Singular Value
 * Decomposition of 3x3 matrices with minimal branching and elementary floating point operations"
 * (Univ. of Wisconsin-Madison, CS Tech. Report 1690, 2011) -- Jacobi sweeps on A = F^T F with
 * approximate, square-root-free rotations accumulated in a quaternion, then a QR of F V -- with our
 * own rotation formula, stopping rule and finishing step, QR and clean-up (details at the code):
 *   1. F is used as is when ||F||_F is in [SVD_LO, SVD_HI], else scaled by 1/max|F_ij| (rare).
 *   2. Cyclic Jacobi on A, pairs (0,1), (0,2), (1,2): the half-angle tangent from a [1/2] Pade
 *      approximant (+-pi/4 when the diagonal entries are nearly equal), the rotation applied
 *      unnormalised with scale factors read off the exponent bits -- no square root, no division
 *      (A and the quaternion pick up positive factors only).
 *   3. From the fifth rotation on, after each rotation, with e_ij the off-diagonal entries: done
 *      when max|e_ij| <= eps max a_ii, or -- the usual end -- one step of second-order
 *      perturbation theory finishes the eigenvectors once 2 max|e_ij|^3 < eps max a_ii
 *      min|a_ii - a_jj|^2. Rotations per call (2e5 matrices each): random entries 8.3 on average
 *      (at most 14), nearly orthogonal F = R (I + 1e-3 noise) 7.5 (at most 14) in double; 6.4 and
 *      5.6 (at most 11) in float. The sweeps before this revision took 11.5 and 10.7 in double.
 *   4. Columns in decreasing order of the eigenvalues (a signed permutation folded into the
 *      quaternion), V from the quaternion, B = F V.
 *   5. QR of B: u0 = b0/|b0|, u2 = b0 x b1 / |.|, u1 = u2 x u0, formed as
 *      (|b0|^2 b1 - (b0.b1) b0) / (|b0| |b0 x b1|) (a rotation by construction; R_22 carries the
 *      sign of det F). After the sweeps b0, b1 are orthogonal to rounding, so |b0 x b1| is taken
 *      as |b0| |b1|: two square roots and two divisions, independent of each other. R_01, R_02 are
 *      O(eps R_00) and dropped, so ||F - U S V^T|| = O(eps ||F||). Out of line (rare): |b0 x b1|
 *      itself when b0, b1 are not orthogonal to rounding, Givens rotations if b1 is ~parallel to
 *      b0 or ~0 (rank <= 1).
 *   6. The trailing 2x2 block is diagonalised by the 2x2 SVD (svd.c) only when its off-diagonal
 *      exceeds 2 eps R_00 or its diagonal is out of order (needed when sigma_1 and sigma_2 are both
 *      tiny; 0.3% of random F): out of line, on the stored results.
 * Speed (bench/svd_bench, independent calls on 4096 matrices, 2-core AMD EPYC (Zen 5) at ~4.1 GHz,
 * gcc 12 -O3 -march=native, several runs): double 97-99 ns per call on random matrices, 91-93 on
 * nearly orthogonal ones (199-201 and 191-195 before this revision); float 85-86 and 77-78
 * (166-170 and 153-156). Dependent calls (latency): double 115-119 / 109-112 ns, float 101 / 93-94
 * (211-216 / 208-210 and 181 / 167 before). The time is the dependent chain of the rotations,
 * ~30 cycles each; the code is written for it (see svd3_rot). Measured errors (tests/test_svd.c
 * -v, 3x3, worst category): reconstruction <= 6.0 eps (double) / 5.8 eps (float), orthogonality
 * <= 8.0 / 7.7 eps, |det - 1| <= 7.0 / 7.7 eps, sigma within 8.0 / 4.0 eps ||F|| of the exact one
 * (before this revision: 5.5 / 5.5, 6.0 / 6.0, 6.0 / 5.6, 8.0 / 4.0); subnormal F: reconstruction
 * 152 / 96 eps (282 / 162 before), within the test's allowance for the rounding of subnormal
 * outputs. A 20x larger run of the same tests (other seed) gave at most 6.0 / 6.6, 8.0 / 8.8,
 * 8.0 / 8.6, 8.6 / 5.0 eps (before: 6.9 / 6.3, 7.0 / 7.2, 7.0 / 7.0, 9.0 / 4.4). */
#include "math/svd_internal.h"

/* GNU C vector extensions (gcc, clang) keep the bit manipulations below in the floating-point
 * registers and give the quaternion one 4-lane register; the plain-C fallback gives the same
 * results (-DSVD_NO_VECTOR_EXT selects it, for testing). */
#if defined(__GNUC__) && (defined(__SSE2__) || defined(__ARM_NEON)) && !defined(SVD_NO_VECTOR_EXT)
#define SVD_VEC 1
#else
#define SVD_VEC 0
#endif
/* The quaternion as one vector: 32 bytes in double, which needs AVX (else the ABI of such values
 * changes, and gcc says so). */
#if SVD_VEC && (!SM_DOUBLE || defined(__AVX__))
#define SVD_VQUAT 1
#else
#define SVD_VQUAT 0
#endif

#if SM_DOUBLE
typedef uint64_t svd_bits;
#define SVD_RCP2_K 0xBFD0000000000000ull /* x^2 svd_rcp2(x) in [1, 1.185] */
#define SVD_RCP4_K 0x3FB0000000000000ull /* x^4 svd_rcp4(x) in [1, 1.345] */
#else
typedef uint32_t svd_bits;
#define SVD_RCP2_K 0xBE800000u
#define SVD_RCPQ_K 0x4F600000u /* x svd_rcpq(x)^4 in [1, 1.345], x > 0 */
#endif

/* Quaternion (w, x, y, z), unnormalised, times the rotation about axis r by the half-angle
 * (ch, sh) (also unnormalised; -sh if neg): q <- q (ch + sh e_r), i.e. q <- ch q + sh (q e_r) with
 * q i = (-x, w, z, -y), q j = (-y, -z, w, x), q k = (-z, y, -x, w). With GNU vector extensions
 * this is a permutation, a sign flip and two multiplications on one 4-lane vector. */
#if SVD_VQUAT
typedef sm_real svd_quat __attribute__((vector_size(4 * sizeof(sm_real))));
typedef svd_bits svd_quatb __attribute__((vector_size(4 * sizeof(sm_real))));
#define SVD_SIGN ((svd_bits)1 << (8 * sizeof(sm_real) - 1))
static inline svd_quat svd_quat_mul_axis(svd_quat q, int r, sm_real ch, sm_real sh, int neg) {
    const svd_bits S = SVD_SIGN;
    svd_quat p;
    svd_quatb m;
    if (r == 0) {
        p = __builtin_shufflevector(q, q, 1, 0, 3, 2);
        m = (svd_quatb){S, 0, 0, S};
    } else if (r == 1) {
        p = __builtin_shufflevector(q, q, 2, 3, 0, 1);
        m = (svd_quatb){S, S, 0, 0};
    } else {
        p = __builtin_shufflevector(q, q, 3, 2, 1, 0);
        m = (svd_quatb){S, 0, S, 0};
    }
    if (neg) m ^= (svd_quatb){S, S, S, S};
    p = (svd_quat)((svd_quatb)p ^ m);
    return ch * q + sh * p;
}
#define SVD_QUAT_ONE ((svd_quat){1, 0, 0, 0})
#define svd_quat_get(q, i) ((q)[i])
/* q p = p0 q + p1 (q i) + p2 (q j) + p3 (q k). */
static inline svd_quat svd_quat_mul(svd_quat q, const sm_real *p) {
    const svd_bits S = SVD_SIGN;
    svd_quat qi = (svd_quat)((svd_quatb)__builtin_shufflevector(q, q, 1, 0, 3, 2) ^ (svd_quatb){S, 0, 0, S});
    svd_quat qj = (svd_quat)((svd_quatb)__builtin_shufflevector(q, q, 2, 3, 0, 1) ^ (svd_quatb){S, S, 0, 0});
    svd_quat qk = (svd_quat)((svd_quatb)__builtin_shufflevector(q, q, 3, 2, 1, 0) ^ (svd_quatb){S, 0, S, 0});
    return (p[0] * q + p[1] * qi) + (p[2] * qj + p[3] * qk);
}
#else
typedef struct {
    sm_real v[4];
} svd_quat;
static inline svd_quat svd_quat_mul_axis(svd_quat q, int r, sm_real ch, sm_real sh, int neg) {
    sm_real w = q.v[0], v0 = q.v[1], v1 = q.v[2], v2 = q.v[3];
    svd_quat o;
    if (neg) sh = -sh;
    if (r == 0) {
        o.v[0] = w * ch - sh * v0, o.v[1] = w * sh + ch * v0;
        o.v[2] = ch * v1 + sh * v2, o.v[3] = ch * v2 - sh * v1;
    } else if (r == 1) {
        o.v[0] = w * ch - sh * v1, o.v[1] = ch * v0 - sh * v2;
        o.v[2] = w * sh + ch * v1, o.v[3] = ch * v2 + sh * v0;
    } else {
        o.v[0] = w * ch - sh * v2, o.v[1] = ch * v0 + sh * v1;
        o.v[2] = ch * v1 - sh * v0, o.v[3] = w * sh + ch * v2;
    }
    return o;
}
#define SVD_QUAT_ONE ((svd_quat){{1, 0, 0, 0}})
#define svd_quat_get(q, i) ((q).v[i])
/* q p (Hamilton product). */
static inline svd_quat svd_quat_mul(svd_quat q, const sm_real *p) {
    sm_real w = q.v[0], x = q.v[1], y = q.v[2], z = q.v[3];
    svd_quat o;
    o.v[0] = (w * p[0] - x * p[1]) - (y * p[2] + z * p[3]);
    o.v[1] = (w * p[1] + x * p[0]) + (y * p[3] - z * p[2]);
    o.v[2] = (w * p[2] - x * p[3]) + (y * p[0] + z * p[1]);
    o.v[3] = (w * p[3] + x * p[2]) - (y * p[1] - z * p[0]);
    return o;
}
#endif

#define SVD_C8 SM_R(0.92387953251128675613) /* cos(pi/8) */
#define SVD_S8 SM_R(0.38268343236508977173) /* sin(pi/8) */
#define SVD_C4 SM_R(0.70710678118654752440) /* cos(pi/4) */
#if SM_DOUBLE
#define SVD_DD_MIN 0x1p-250 /* on D^2 = 4 d^2: products of order D^8 stay normal */
#else
#define SVD_DD_MIN (4 * FLT_MIN)
#endif

/* Approximate powers x^-2, x^-4 (and, float only, x^-1/4) by one shift and one integer
 * subtraction on the representation (log2 x = k + f for x = 2^k (1 + f) is nearly linear in the
 * bits): exact and deterministic, and used only as positive scale factors (any would do). The
 * left shift drops the sign bit (and the top exponent bit, with the same wrap in the constant),
 * so x may be negative. Valid while the result is a normal number: |x| in [2^-511, 2^511] for
 * x^-2, [2^-255, 2^255] for x^-4 (double). */
#if SVD_VEC
typedef sm_real svd_vr __attribute__((vector_size(16)));
typedef svd_bits svd_vb __attribute__((vector_size(16)));
static inline sm_real svd_bitrcp(sm_real x, svd_bits k, int sh) {
    svd_vr v = {x};
    svd_vr r = (svd_vr)((svd_vb){k} - ((svd_vb)v << sh));
    sm_real o;
    memcpy(&o, &r, sizeof o);
    return o;
}
#if !SM_DOUBLE
static inline sm_real svd_rcpq(sm_real x) {
    svd_vr v = {x};
    svd_vr r = (svd_vr)((svd_vb){SVD_RCPQ_K} - ((svd_vb)v >> 2));
    sm_real o;
    memcpy(&o, &r, sizeof o);
    return o;
}
#endif
#else
static inline sm_real svd_bitrcp(sm_real x, svd_bits k, int sh) {
    svd_bits u;
    memcpy(&u, &x, sizeof u);
    u = k - (u << sh);
    memcpy(&x, &u, sizeof u);
    return x;
}
#if !SM_DOUBLE
static inline sm_real svd_rcpq(sm_real x) {
    svd_bits u;
    memcpy(&u, &x, sizeof u);
    u = SVD_RCPQ_K - (u >> 2);
    memcpy(&x, &u, sizeof u);
    return x;
}
#endif
#endif
#define svd_rcp2(x) svd_bitrcp(x, SVD_RCP2_K, 1)
#define svd_rcp4(x) svd_bitrcp(x, SVD_RCP4_K, 2)

/* Fused multiply-add where the hardware has it (the build turns off contraction, so these are the
 * only ones; the same inputs give the same bits on a given build). */
#if SM_DOUBLE
#if defined(FP_FAST_FMA) || defined(__FMA__)
#define svd_fma fma
#else
#define svd_fma(a, b, c) ((a) * (b) + (c))
#endif
#else
#if defined(FP_FAST_FMAF) || defined(__FMA__)
#define svd_fma fmaf
#else
#define svd_fma(a, b, c) ((a) * (b) + (c))
#endif
#endif

/* The update of A by the (unnormalised) rotation (c, s), c^2 + s^2 = m^2, in the plane (p, q),
 * with D = 2 d = 2 (e - a): z = s d - 2 c b, a' = m^2 a + s z, e' = m^2 e - s z,
 * b' = (c^2 - s^2) b - c s d, (f', g') = m (c f - s g, s f + c g), h' = m^2 h; *Dn = twice the
 * next pair's difference (see svd3_rot). */
static inline void svd3_apply(sm_real c, sm_real s, sm_real m, sm_real a, sm_real e, sm_real b,
                              sm_real f, sm_real g, sm_real h, sm_real D, sm_real *app,
                              sm_real *aqq, sm_real *apq, sm_real *arp, sm_real *arq, sm_real *arr,
                              sm_real *Dn, int next) {
    sm_real mm = m * m, hs = SVD_HALF * s;
    sm_real z2 = svd_fma(SM_R(-4.0) * b, c, s * D); /* 2 z */
    *app = svd_fma(hs, z2, mm * a);
    *aqq = svd_fma(-hs, z2, mm * e);
    if (next == 0)
        *Dn = svd_fma(-s, z2, mm * ((h - a) + (h - a)));
    else if (next == 1)
        *Dn = svd_fma(-s, z2, mm * ((e - h) + (e - h)));
    else
        *Dn = svd_fma(s, z2, mm * ((a - h) + (a - h)));
    *apq = svd_fma(svd_fma(c, c, -(s * s)), b, -((c * hs) * D));
    *arp = m * svd_fma(c, f, -(s * g));
    *arq = m * svd_fma(c, g, s * f);
    *arr = mm * h;
}

/* One approximate Jacobi rotation of the symmetric A in the plane (p, q), r the third index
 * (a = A_pp, e = A_qq, b = A_pq, f = A_rp, g = A_rq, h = A_rr, D = 2 (e - a)), accumulated into
 * the quaternion q. On return *D holds twice the diagonal difference of the next pair in the
 * cycle (0,1) -> (0,2) -> (1,2) -> (0,1): next = 0: h' - a', next = 1: e' - h', 2: a' - h'.
 *
 * The rotation J (J_pp = J_qq = cos t, J_pq = -J_qp = sin t) that zeroes A_pq has
 * tan 2t = x = 4 b / D; its quaternion has the half angle t/2 with
 * tan(t/2) = tan(atan(x) / 4) = x/4 - 5 x^3 / 64 + O(x^5). We use the [1/2] Pade approximant
 * x/4 / (1 + 5 x^2 / 16) = Q / P with P = D^2 + 5 b^2, Q = b D, relative error O(x^4), so the
 * sweeps converge with order 5 once the pivots are small. For large |x| (nearly equal diagonal
 * entries) the rotation is by +-pi/4 (half angle pi/8), as in McAdams et al. 2011. Neither needs
 * a square root or a division. The rotation is applied unnormalised: with (c1, s1) = rc (P, Q)
 * for any positive rc, c = c1^2 - s1^2, s = 2 c1 s1, m = c1^2 + s1^2, the matrix [[c, s], [-s, c]]
 * (and m on the r axis) is m times a rotation, so A is updated up to the positive factor m^2 --
 * harmless, as only ratios of its entries matter -- and the quaternion up to the factor sqrt(m),
 * removed at the end. rc ~ D^-2 (svd_rcp2) keeps c1 in [1, 4.2) (near 1 once the pivots are
 * small): A only grows, by at most ~8.4 bits per rotation, by < 1 bit late.
 *
 * Written for latency (this chain is most of the run time): the next pair's (doubled) difference
 * is formed by a fused multiply-add of its own, so that no addition follows a multiplication on
 * the chain (a multiply-to-add forward costs a cycle more than the operations themselves: 6
 * cycles for mul + add, 4 for a fused multiply-add, measured on Zen 5), and D rather than d
 * travels so that Q = b D is one product. In double,
 * c, s, m and the products with A come straight from P and Q with the scale r2 ~ D^-4
 * (svd_rcp4(D)) taken from D's bits, off the products' chain (intermediates of order D^4, safe
 * within the range SVD_LO..SVD_HI); in float from (c1, s1). The +-pi/4 case is a (rare after
 * the first sweep) jump, not a selection: its condition is then off the chain. */
static inline void svd3_rot(sm_real *app, sm_real *aqq, sm_real *apq, sm_real *arp, sm_real *arq,
                            sm_real *arr, sm_real *Dpq, svd_quat *quat, int r, sm_real sgn, int next,
                            int renorm) {
    sm_real a = *app, e = *aqq, b = *apq, f = *arp, g = *arq, h = *arr, D = *Dpq;
    sm_real bb = b * b, DD = D * D;
    sm_real c1, s1;
    /* Pade unless |x| >= 2 sqrt 2, or D^2 is tiny (then the pair is negligible). */
    if ((bb + bb) + SVD_DD_MIN < DD) {
        sm_real P = svd_fma(SM_R(5.0) * b, b, DD), Q = b * D;
        sm_real rc = svd_rcp2(D);
#if !SM_DOUBLE
        /* float: A grows by m^2 >= 1 per rotation (up to ~30 bits in all); once per sweep the
         * scale also takes the trace T to ~1 (A scales by ~rc^4: rc * T^-1/4). */
        if (renorm) rc *= svd_rcpq(a + e + h);
#else
        (void)renorm;
#endif
        c1 = P * rc;
        s1 = Q * rc;
#if SM_DOUBLE
        /* (c, s, m) = r2 (P^2 - Q^2, 2 P Q, P^2 + Q^2) (c and s themselves are not formed):
         * s z = 2 r2^2 P Q zt with zt = P Q D - 2 (P^2 - Q^2) b; m^2 x, on the chain of the next
         * difference, as (P^2 + Q^2) ((P^2 + Q^2) (r2^2 x)); the other outputs have slack. */
        sm_real r2 = svd_rcp4(D), r4 = r2 * r2, r4x2 = r4 + r4;
        sm_real QQ = Q * Q, PQ = P * Q, PQ2 = PQ + PQ, PQD = PQ * D;
        sm_real pmq = svd_fma(P, P, -QQ), ppq = svd_fma(P, P, QQ);
        sm_real m = ppq * r2, mm = m * m, mr2 = ppq * r4;
        sm_real zt = svd_fma(pmq, SM_R(-2.0) * b, PQD), sz = PQ * r4x2, sz2 = sz + sz;
        *app = svd_fma(sz, zt, mm * a);
        *aqq = svd_fma(-sz, zt, mm * e);
        if (next == 0)
            *Dpq = svd_fma(-sz2, zt, ppq * (ppq * (r4x2 * (h - a))));
        else if (next == 1)
            *Dpq = svd_fma(-sz2, zt, ppq * (ppq * (r4x2 * (e - h))));
        else
            *Dpq = svd_fma(sz2, zt, ppq * (ppq * (r4x2 * (a - h))));
        /* b' = (c^2 - s^2) b - c s d = r2^2 ((P^2 - Q^2)^2 - (2 P Q)^2) b - (P^2 - Q^2) P Q D). */
        *apq = r4 * svd_fma(svd_fma(pmq, pmq, -(PQ2 * PQ2)), b, -(pmq * PQD));
        *arp = mr2 * svd_fma(pmq, f, -(PQ2 * g));
        *arq = mr2 * svd_fma(pmq, g, PQ2 * f);
        *arr = mm * h;
#else
        sm_real ss1 = s1 * s1;
        svd3_apply(svd_fma(c1, c1, -ss1), c1 * (s1 + s1), svd_fma(c1, c1, ss1), a, e, b, f, g, h,
                   D, app, aqq, apq, arp, arq, arr, Dpq, next);
#endif
    } else {
        c1 = SVD_C8;
        s1 = svd_copysign(SVD_S8, b * D);
        svd3_apply(SVD_C4, svd_copysign(SVD_C4, b * D), 1, a, e, b, f, g, h, D, app, aqq, apq, arp,
                   arq, arr, Dpq, next);
    }
    *quat = svd_quat_mul_axis(*quat, r, c1, s1, sgn < 0);
}

/* Givens rotation G on rows i, j of B that zeroes B[j][k] and leaves B[i][k] >= 0; U <- U G^T. */
static inline void svd3_givens(sm_real B[9], sm_real U[9], int i, int j, int k) {
    sm_real c, s;
    svd_givens_cs(B[3 * i + k], B[3 * j + k], &c, &s);
    for (int m = 0; m < 3; m++) {
        sm_real bi = B[3 * i + m], bj = B[3 * j + m];
        B[3 * i + m] = c * bi + s * bj;
        B[3 * j + m] = c * bj - s * bi;
        sm_real ui = U[3 * m + i], uj = U[3 * m + j];
        U[3 * m + i] = c * ui + s * uj;
        U[3 * m + j] = c * uj - s * ui;
    }
}

/* ||F||_F within [SVD_LO, SVD_HI] needs no scaling. In double the rotations form products of
 * order D^4 and the scale ~D^-4 (D ~ A ~ F^2; svd_rcp4 needs |D| <= 2^255); A starts below
 * 3 2^40 and grows by at most ~8.4 bits per rotation (by < 35 bits in all in every experiment).
 * In float A is brought back to a trace ~1 once per sweep. */
#if SM_DOUBLE
#define SVD_LO 0x1p-20
#define SVD_HI 0x1p20
#else
#define SVD_LO 0x1p-8f
#define SVD_HI 0x1p8f
#endif

#if defined(__GNUC__)
#define SVD_COLD __attribute__((noinline, cold))
#else
#define SVD_COLD
#endif

/* The QR of sm_svd3 when b0 and b1 are not nearly orthogonal (the sweeps cannot make them so when
 * |b1| is below ~sqrt(eps) |b0|): with |c| = |b0 x b1| computed; Givens rotations (zero-safe)
 * instead when b1 is nearly parallel to b0 or ~0 (rank <= 1). */
static SVD_COLD void svd3_qr_slow(sm_real b00, sm_real b01, sm_real b02, sm_real b10, sm_real b11,
                                  sm_real b12, sm_real b20, sm_real b21, sm_real b22, sm_real n0,
                                  sm_real n1, sm_real cx, sm_real cy, sm_real cz, sm_real U[9],
                                  sm_real *r00, sm_real *r11, sm_real *r12, sm_real *r21,
                                  sm_real *r22) {
    sm_real nc = (cx * cx + cy * cy) + cz * cz;
    if (nc > SVD_HALF * n0 * n1 && n1 > n0 * (SM_EPS * SM_EPS * SM_EPS)) {
        sm_real s0 = sm_sqrt(n0), sc = sm_sqrt(nc), in0 = SVD_ONE / n0, inc = SVD_ONE / nc;
        sm_real ex = cy * b20 - cz * b10, ey = cz * b00 - cx * b20, ez = cx * b10 - cy * b00;
        sm_real ir0 = s0 * in0, irc = sc * inc, ir0c = ir0 * irc;
        *r00 = s0;
        *r11 = sc * ir0;
        *r12 = ((ex * b02 + ey * b12) + ez * b22) * ir0c;
        *r21 = 0;
        *r22 = ((cx * b02 + cy * b12) + cz * b22) * irc;
        U[0] = b00 * ir0, U[3] = b10 * ir0, U[6] = b20 * ir0;
        U[1] = ex * ir0c, U[4] = ey * ir0c, U[7] = ez * ir0c;
        U[2] = cx * irc, U[5] = cy * irc, U[8] = cz * irc;
        return;
    }
    sm_real R[9] = {b00, b01, b02, b10, b11, b12, b20, b21, b22};
    for (int i = 0; i < 9; i++) U[i] = (i % 4 == 0) ? SVD_ONE : 0;
    svd3_givens(R, U, 0, 1, 0);
    svd3_givens(R, U, 0, 2, 0);
    svd3_givens(R, U, 1, 2, 1);
    *r00 = R[0], *r11 = R[4], *r12 = R[5], *r21 = R[7], *r22 = R[8];
}

/* The clean-up of sm_svd3: the 2x2 SVD of the trailing block, applied to the stored U and V and
 * sigma (output scale iqn scale, applied in this order: scale may be subnormal). */
static SVD_COLD void svd3_fixup(sm_real U[9], sm_real sigma[3], sm_real V[9], sm_real r00,
                                sm_real r11, sm_real r12, sm_real r21, sm_real r22, sm_real iqn,
                                sm_real scale) {
    sm_real Ub[4], Vb[4], sb[2];
    sm_svd2_core(r11, r12, r21, r22, Ub, sb, Vb);
    for (int i = 0; i < 3; i++) {
        sm_real u1 = U[3 * i + 1], u2 = U[3 * i + 2];
        U[3 * i + 1] = u1 * Ub[0] + u2 * Ub[2];
        U[3 * i + 2] = u1 * Ub[1] + u2 * Ub[3];
        sm_real v1 = V[3 * i + 1], v2 = V[3 * i + 2];
        V[3 * i + 1] = v1 * Vb[0] + v2 * Vb[2];
        V[3 * i + 2] = v1 * Vb[1] + v2 * Vb[3];
    }
    sm_real hi = SM_MAX(r00, sb[0]), mid = SM_MIN(r00, sb[0]);
    sigma[0] = (hi * iqn) * scale;
    sigma[1] = (mid * iqn) * scale;
    sigma[2] = (svd_copysign(SM_MIN(sm_fabs(sb[1]), mid), sb[1]) * iqn) * scale;
}

/* gcc only: its superword (SLP) vectoriser packs scalar steps of the sweeps and the QR into
 * vectors with shuffles, and without pre-allocation scheduling the long dependency chains of the
 * sweeps run out of registers (spills); disabling the one and enabling the other (register-
 * pressure aware) was worth ~3% on gcc 12 (svd_bench). Other compilers: no attribute. */
#if defined(__GNUC__) && !defined(__clang__)
#define SVD_OPT __attribute__((optimize("no-tree-slp-vectorize", "schedule-insns", "sched-pressure")))
#else
#define SVD_OPT
#endif

/* One piece (about 180 lines): steps 1-6 of the header comment pass A's six entries, the
 * quaternion and B from one step to the next in registers, and the time is the dependency chain of
 * the rotations (the tuning above is for this function as a whole). The rare paths are out of
 * line already (svd3_qr_slow, svd3_fixup). */
SVD_OPT void sm_svd3(const sm_real F[9], sm_real U[9], sm_real sigma[3], sm_real V[9]) {
    sm_real Gs[9];
    const sm_real *G = F;
    sm_real scale = 1;
    /* A = G^T G = W diag W^T by Jacobi sweeps; W from the accumulated quaternion. F is used as is
     * when the trace of A, ||F||^2, is within [SVD_LO^2, SVD_HI^2] (else scaled by 1 / max|F_ij|:
     * rare, huge, tiny, zero or NaN input). */
#define SVD_ATA(G)                                                                                 \
    a00 = (G[0] * G[0] + G[3] * G[3]) + G[6] * G[6], a11 = (G[1] * G[1] + G[4] * G[4]) + G[7] * G[7], \
    a22 = (G[2] * G[2] + G[5] * G[5]) + G[8] * G[8], a01 = (G[0] * G[1] + G[3] * G[4]) + G[6] * G[7], \
    a02 = (G[0] * G[2] + G[3] * G[5]) + G[6] * G[8], a12 = (G[1] * G[2] + G[4] * G[5]) + G[7] * G[8]
    sm_real a00, a11, a22, a01, a02, a12;
    SVD_ATA(F);
    sm_real tr = (a00 + a11) + a22;
    if (!(tr >= SVD_LO * SVD_LO && tr <= SVD_HI * SVD_HI)) {
        scale = sm_svd_normalize(F, Gs, 9);
        G = Gs;
        SVD_ATA(Gs);
    }
#undef SVD_ATA
    svd_quat quat = SVD_QUAT_ONE;
    sm_real dif = (a11 - a00) + (a11 - a00);
    /* After every rotation (its three outputs are the three off-diagonal entries e_ij of A):
     * - converged when max |e_ij| <= eps max a_ii: then the columns of B = G W are orthogonal to
     *   rounding relative to ||G||, which is all that the QR step below needs (the trailing 2x2
     *   block is finished exactly there);
     * - or finished in one step when 2 max|e_ij|^3 <= eps max a_ii min|a_ii - a_jj|^2: then the
     *   eigenvectors of A are I + K + O(e^3 / gap^2), K from second-order perturbation theory
     *   (below), and the rotation exp(K) leaves off-diagonal entries of at most k e^3 / gap^2, i.e.
     *   k/2 eps max a_ii, where k (the third-order constant) was below 1.8 in every experiment
     *   (random, nearly orthogonal, graded and nearly repeated spectra, finishing much earlier).
     *   On random and on nearly orthogonal F this replaces the last two to three rotations. */
    int finish = 0;
    sm_real i01 = 0, i12 = 0, i20 = 0;
    /* The reciprocals of the diagonal differences, used by the one-step finish, are formed before
     * the test that selects it: they are then under way while that (once per call, hence
     * mispredicted) jump resolves. A zero difference gives an infinity that is not used. */
#define SVD_DONE(conv)                                                                             \
    {                                                                                              \
        sm_real em = SM_MAX(sm_fabs(a01), SM_MAX(sm_fabs(a02), sm_fabs(a12)));                       \
        sm_real am = SM_MAX(a00, SM_MAX(a11, a22));                                                \
        sm_real g01 = a00 - a11, g12 = a11 - a22, g20 = a22 - a00;                                  \
        i01 = SVD_ONE / g01, i12 = SVD_ONE / g12, i20 = SVD_ONE / g20;                              \
        sm_real gm = SM_MIN(sm_fabs(g01), SM_MIN(sm_fabs(g12), sm_fabs(g20)));                     \
        if (em * (em * em) < ((SM_EPS / 2) * am) * (gm * gm)) {                                    \
            finish = 1;                                                                            \
            break;                                                                                 \
        }                                                                                          \
        if ((conv) && em <= SM_EPS * am) break;                                                    \
    }
#define SVD_R1 svd3_rot(&a00, &a11, &a01, &a02, &a12, &a22, &dif, &quat, 2, -1, 0, 1);
#define SVD_R2 svd3_rot(&a00, &a22, &a02, &a01, &a12, &a11, &dif, &quat, 1, 1, 1, 0);
#define SVD_R3 svd3_rot(&a11, &a22, &a12, &a01, &a02, &a00, &dif, &quat, 0, -1, 2, 0);
    /* The first four rotations are not tested (the tests cost a few cycles each, and they hardly
     * ever succeed before: only on (nearly) diagonal F, where the extra rotations are harmless). */
    SVD_R1 SVD_R2 SVD_R3 SVD_R1
    for (int sweep = 1; sweep < SM_SVD_SWEEPS; sweep++) {
        SVD_R2 SVD_DONE(0)
        SVD_R3 SVD_DONE(0)
        SVD_R1 SVD_DONE(1)
    }
#undef SVD_R1
#undef SVD_R2
#undef SVD_R3
#undef SVD_DONE
    if (finish) {
        /* Eigenvectors of A = D + E (E off-diagonal) to second order: v_i = e_i + sum_j K_ji e_j
         * with, for {i, j, k} = {0, 1, 2}, K_ji = (e_ji + e_jk e_ki (d_k - (d_i + d_j) / 2) /
         * ((d_i - d_k) (d_k - d_j))) / (d_i - d_j) - (1/2) K1_jk K1_ki, the last term making K
         * skew (K = exp of a rotation generator to this order). With i_ij = 1 / (d_i - d_j):
         * w3 = K_10 = i01 (e01 + e02 e12 (i12 - i20) / 2), and cyclically. The quaternion
         * (1, w / 2) is that rotation up to O(|w|^3). */
        sm_real h01 = SVD_HALF * a01, h02 = SVD_HALF * a02, h12 = SVD_HALF * a12;
        const sm_real pk[4] = {1, i12 * svd_fma(h02 * h01, i20 - i01, h12),
                               i20 * svd_fma(h01 * h12, i01 - i12, h02),
                               i01 * svd_fma(h12 * h02, i12 - i20, h01)};
        quat = svd_quat_mul(quat, pk);
    }

    /* Columns in decreasing order of the eigenvalues of A (its final diagonal): V P with P a
     * permutation whose last column is negated when it is odd (det V P = +1). P is the rotation of
     * one of six quaternions with entries 0, +-1 (so q p is exact up to one rounding per
     * component, and V P is as orthogonal as V): index m01 + 2 m02 + 4 m12 with mij = (n_j > n_i);
     * two of the eight combinations cannot occur (identity). */
    static const sm_real svd_sortq[8][4] = {
        {1, 0, 0, 0},   /* (0 1 2) */
        {0, 1, 1, 0},   /* (1 0 2), last column negated */
        {1, 0, 0, 0},   /* - */
        {1, 1, 1, 1},   /* (1 2 0) */
        {1, 1, 0, 0},   /* (0 2 1), last column negated */
        {1, 0, 0, 0},   /* - */
        {1, -1, -1, -1}, /* (2 0 1) */
        {1, 0, -1, 0},  /* (2 1 0), last column negated */
    };
    const sm_real *ps = svd_sortq[(a11 > a00) + 2 * (a22 > a00) + 4 * (a22 > a11)];
    quat = svd_quat_mul(quat, ps);

    /* W = qn V from the quaternion (qn = |q|^2). */
    sm_real W[9], qn;
    {
        sm_real w = svd_quat_get(quat, 0), x = svd_quat_get(quat, 1), y = svd_quat_get(quat, 2),
                z = svd_quat_get(quat, 3);
        sm_real ww = w * w, xx = x * x, yy = y * y, zz = z * z;
        sm_real x2 = x + x, y2 = y + y, z2 = z + z;
        sm_real xy = x2 * y, xz = x2 * z, yz = y2 * z, wx = x2 * w, wy = y2 * w, wz = z2 * w;
        qn = (ww + xx) + (yy + zz);
        W[0] = (ww + xx) - (yy + zz), W[1] = xy - wz, W[2] = xz + wy;
        W[3] = xy + wz, W[4] = (ww - xx) + (yy - zz), W[5] = yz - wx;
        W[6] = xz - wy, W[7] = yz + wx, W[8] = (ww - xx) - (yy - zz);
    }
    sm_real iqn = SVD_ONE / qn;
    for (int i = 0; i < 9; i++) V[i] = W[i] * iqn;

    /* B = G W (= qn G V), columns b0, b1, b2. G is read again from memory: its nine entries are
     * then not held in registers through the sweeps (where they would be spilled). */
    const sm_real *Gt = G;
#if defined(__GNUC__)
    __asm__("" : "+r"(Gt));
#endif
    sm_real b00, b01, b02, b10, b11, b12, b20, b21, b22;
    {
        const sm_real h0 = Gt[0], h1 = Gt[1], h2 = Gt[2];
        b00 = (h0 * W[0] + h1 * W[3]) + h2 * W[6], b01 = (h0 * W[1] + h1 * W[4]) + h2 * W[7];
        b02 = (h0 * W[2] + h1 * W[5]) + h2 * W[8];
        const sm_real h3 = Gt[3], h4 = Gt[4], h5 = Gt[5];
        b10 = (h3 * W[0] + h4 * W[3]) + h5 * W[6], b11 = (h3 * W[1] + h4 * W[4]) + h5 * W[7];
        b12 = (h3 * W[2] + h4 * W[5]) + h5 * W[8];
        const sm_real h6 = Gt[6], h7 = Gt[7], h8 = Gt[8];
        b20 = (h6 * W[0] + h7 * W[3]) + h8 * W[6], b21 = (h6 * W[1] + h7 * W[4]) + h8 * W[7];
        b22 = (h6 * W[2] + h7 * W[5]) + h8 * W[8];
    }

    /* QR of the (nearly orthogonal) columns b0, b1, b2: u0 = b0 / |b0|, u2 = c / |c| with
     * c = b0 x b1, u1 = u2 x u0 = e / (|b0| |c|) with e = c x b0 = |b0|^2 b1 - (b0.b1) b0, so
     * U = [u0 u1 u2] is a rotation and U^T B is upper triangular up to rounding
     * (u1.b0 = u2.b0 = u2.b1 = 0), with R_00 = |b0|, R_11 = |c| / |b0| > 0 and the sign of det F in
     * R_22 = c.b2 / |c|. When cos^2 (b0, b1) <= eps / 16 (the rule after the sweeps, unless
     * |b1| < sqrt(eps) |b0|), |c| = |b0| |b1| (1 - cos^2 / 2) is |b0| |b1| to rounding, which takes
     * the roots and reciprocals off the cross product. Otherwise |c| itself; and Givens rotations
     * (zero-safe) when b1 is ~parallel to b0 or |b1| / |b0| is ~eps or below (rank <= 1). R_01,
     * R_02 are O(eps R_00) after the Jacobi sweeps and dropped. */
    sm_real n0 = (b00 * b00 + b10 * b10) + b20 * b20;
    sm_real n1 = (b01 * b01 + b11 * b11) + b21 * b21;
    sm_real g01 = (b00 * b01 + b10 * b11) + b20 * b21;
    sm_real cx = b10 * b21 - b20 * b11, cy = b20 * b01 - b00 * b21, cz = b00 * b11 - b10 * b01;
    sm_real r00, r11, r12, r21, r22;
    if (g01 * g01 <= (SM_EPS / 16) * (n0 * n1) && n1 > n0 * (SM_EPS * SM_EPS * SM_EPS)) {
        sm_real s0 = sm_sqrt(n0), s1 = sm_sqrt(n1), ir0 = SVD_ONE / s0, ir1 = SVD_ONE / s1;
        sm_real ex = svd_fma(n0, b01, -(g01 * b00)), ey = svd_fma(n0, b11, -(g01 * b10)),
                ez = svd_fma(n0, b21, -(g01 * b20));
        sm_real irc = ir0 * ir1, ire = ir0 * irc;
        r00 = s0;
        r11 = s1;
        r12 = ((ex * b02 + ey * b12) + ez * b22) * ire;
        r21 = 0;
        r22 = ((cx * b02 + cy * b12) + cz * b22) * irc;
        U[0] = b00 * ir0, U[3] = b10 * ir0, U[6] = b20 * ir0;
        U[1] = ex * ire, U[4] = ey * ire, U[7] = ez * ire;
        U[2] = cx * irc, U[5] = cy * irc, U[8] = cz * irc;
    } else {
        svd3_qr_slow(b00, b01, b02, b10, b11, b12, b20, b21, b22, n0, n1, cx, cy, cz, U, &r00, &r11,
                     &r12, &r21, &r22);
    }

    /* Order: s0 >= s1 >= |s2| holds up to rounding; make it exact (an ulp-sized change). */
    sm_real hi = SM_MAX(r00, r11), mid = SM_MIN(r00, r11);
    sigma[0] = (hi * iqn) * scale;
    sigma[1] = (mid * iqn) * scale;
    sigma[2] = (svd_copysign(SM_MIN(sm_fabs(r22), mid), r22) * iqn) * scale;
    /* Clean-up of the trailing 2x2 block [[r11, r12], [r21, r22]] when it is not diagonal to
     * rounding relative to r00 (r12 ~ A_12 / sigma_1 can be large when sigma_1 and sigma_2 are
     * both tiny: their vectors are not resolved by the Jacobi sweeps on F^T F), or its diagonal
     * is out of order (the eigenvalues of A below its rounding level may be). Rare: out of line,
     * on the stored results. */
    if (sm_fabs(r12) + sm_fabs(r21) > 2 * SM_EPS * r00 || sm_fabs(r22) > r11)
        svd3_fixup(U, sigma, V, r00, r11, r12, r21, r22, iqn, scale);
}
