/* Signed SVD of 2x2 and 3x3 matrices, F = U diag(sigma) V^T (row-major), U and V rotations.
 *
 * Method (own code; only published facts are used):
 *
 * 3x3 -- after McAdams, Selle, Tamstorf, Teran and Sifakis, "Computing the Singular Value
 * Decomposition of 3x3 matrices with minimal branching and elementary floating point operations"
 * (Univ. of Wisconsin-Madison, CS Tech. Report 1690, 2011), with our own rotation formula, QR and
 * clean-up (see the functions for details):
 *   1. F is used as is when max|F_ij| is in [SVD_LO, SVD_HI], else scaled by 1/max (rare branch).
 *   2. Cyclic Jacobi sweeps on A = F^T F with approximate rotations accumulated in a quaternion:
 *      the half-angle tangent comes from a [1/2] Pade approximant (no sqrt; convergence of order
 *      5 near the end), +-pi/4 rotations when the diagonal entries are nearly equal; the
 *      rotations are applied unnormalised (A and the quaternion pick up positive factors only).
 *      The sweeps stop when every off-diagonal entry is <= eps * max diagonal (typically 3-5
 *      sweeps in double, 2-4 in float; at most SM_SVD_SWEEPS).
 *   3. V from the quaternion, B = F V, columns sorted by norm (odd permutation: last column
 *      negated so det V = +1).
 *   4. QR of B: u0 = b0/|b0|, u2 = b0 x b1 / |.|, u1 = u2 x u0 (a rotation by construction; R_22
 *      carries the sign of det F); Givens rotations instead if b1 is ~parallel to b0 or ~0
 *      (rank <= 1, rare branch).
 *   5. The trailing 2x2 block is diagonalised by the 2x2 SVD below only when its off-diagonal
 *      exceeds eps * R_00 (needed when sigma_1 and sigma_2 are both tiny). R_01, R_02 are
 *      O(eps R_00) after step 2 and dropped: backward stable, ||F - U S V^T|| = O(eps ||F||).
 * Measured (tests/test_svd.c -v): reconstruction <= 5.5 eps, orthogonality <= 6.7 eps, sigma
 * within 8 eps ||F|| of the exact one, double and float.
 *
 * 2x2 -- symmetrise, then diagonalise (the 2x2 step of the two-sided Jacobi SVD; Brent, Luk and
 * Van Loan 1985; Golub & Van Loan sec. 8.6): the rotation R with
 * tan(phi) = (f10 - f01) / (f00 + f11) makes S = R^T F symmetric with trace S >= 0 (R is the
 * rotation of the polar decomposition when det F > 0); one exact Jacobi rotation W then gives
 * S = W diag(l0, l1) W^T. With l0 >= l1 and l0 + l1 = trace S >= 0 we get l0 >= |l1| and
 * sign(l1) = sign(det F), so U = R W, V = W, sigma = (l0, l1). No trigonometric functions.
 *
 * Signed convention (last singular value negative for inverted elements): Irving, Teran and
 * Fedkiw, "Invertible Finite Elements for Robust Simulation of Large Deformation" (SCA 2004).
 *
 * Control flow: the sweep loop's early exit and the two rare branches above; everything else is
 * selects/arithmetic blends (unpredictable comparisons must not become jumps). */
#include "math/svd.h"

#include <float.h>

#if SM_DOUBLE
#define SVD_REAL_MIN DBL_MIN
#define SVD_PRESCALE 0x1p60
#define SVD_NUDGE 1e-150 /* see svd_givens_cs; its square is still a normal number */
#define svd_copysign copysign
#else
#define SVD_REAL_MIN FLT_MIN
#define SVD_PRESCALE 0x1p30f
#define SVD_NUDGE 1e-18f
#define svd_copysign copysignf
#endif

/* Maximum number of Jacobi sweeps of sm_svd3 (the loop stops earlier on convergence; on 10^5
 * random matrices the most needed was 6 in double and 5 in float). */
#ifndef SM_SVD_SWEEPS
#define SM_SVD_SWEEPS 8
#endif

#define SVD_ONE SM_R(1.0)
#define SVD_HALF SM_R(0.5)
#define SVD_EPS2 (SM_EPS * SM_EPS)

/* Branch-free select: m ? a : b for m in {0, 1} (exact for finite a, b). Written as arithmetic
 * because compilers turn floating-point ?: into jumps, and these comparisons are unpredictable. */
static inline sm_real svd_sel(sm_real m, sm_real a, sm_real b) { return m * a + (SVD_ONE - m) * b; }

/* G = F / s with s = max |F_ij| (returned; 0 for the zero matrix, then G = 0). */
static sm_real svd_normalize(const sm_real *F, sm_real *G, int n) {
    sm_real m = 0;
    for (int i = 0; i < n; i++) m = SM_MAX(m, sm_fabs(F[i]));
    if (m < SVD_REAL_MIN) {
        /* Zero or subnormal (rare): 1/m would overflow, so go through an exact power-of-two
         * prescale. */
        sm_real inv = m > 0 ? SVD_ONE / (m * SVD_PRESCALE) : 0;
        for (int i = 0; i < n; i++) G[i] = (F[i] * SVD_PRESCALE) * inv;
        return m;
    }
    sm_real inv = SVD_ONE / m;
    for (int i = 0; i < n; i++) G[i] = F[i] * inv;
    return m;
}

/* Exact Jacobi rotation for the symmetric 2x2 [[p, q], [q, r]]: returns t = tan(theta), |t| <= 1,
 * such that with c = 1/sqrt(1+t^2), s = t c, J = [[c, s], [-s, c]], J^T A J is diagonal with
 * diagonal (p - t q, r + t q). t = 2q sign(r-p) / (|r-p| + sqrt((r-p)^2 + 4q^2)) is the stable
 * small root. t = 0 when q is negligible relative to the diagonal, |q| <= eps sqrt(p r) (the
 * threshold of de Rijk / Demmel-Veselic), which also covers q = 0; this keeps near-rotations from
 * picking up rounding noise. The denominator is bumped by REAL_MIN only to make 0/0 impossible. */
static inline sm_real svd_jacobi_t(sm_real p, sm_real q, sm_real r) {
    sm_real d = r - p;
    sm_real h = sm_sqrt(d * d + 4 * q * q);
    sm_real keep = (sm_real)(q * q > SVD_EPS2 * p * r);
    return keep * (2 * q * svd_copysign(SVD_ONE, d)) / (sm_fabs(d) + h + SVD_REAL_MIN);
}

/* Cosine and sine of the rotation taking (a, b) to (r, 0) with r >= 0: c = a/r, s = b/r. The pivot
 * is pushed away from zero by SVD_NUDGE (in its own direction) so that (0, 0) gives (+-1, 0)
 * without a branch; on our O(1)-scaled matrices this changes nothing above 1e-150 (double) /
 * 1e-18 (float) absolute, far below the rounding errors. */
static inline void svd_givens_cs(sm_real a, sm_real b, sm_real *c, sm_real *s) {
    a += svd_copysign(SVD_NUDGE, a);
    sm_real rinv = SVD_ONE / sm_sqrt(a * a + b * b);
    *c = a * rinv;
    *s = b * rinv;
}

/* 2x2 signed SVD of [[a, b], [c, d]] whose entries are O(1) or smaller (already scaled).
 * U = [[U[0], U[1]], [U[2], U[3]]] and V are rotations; s[0] >= |s[1]|, s[0] >= 0,
 * sign(s[1]) = sign(ad - bc). */
static void svd2_core(sm_real a, sm_real b, sm_real c, sm_real d, sm_real U[4], sm_real s[2],
                      sm_real V[4]) {
    /* Symmetrising rotation R = [[rc, -rs], [rs, rc]]: S = R^T F symmetric with trace S >= 0. */
    sm_real rc, rs;
    svd_givens_cs(a + d, c - b, &rc, &rs);
    sm_real s00 = rc * a + rs * c;
    sm_real s11 = rc * d - rs * b;
    sm_real s01 = SVD_HALF * ((rc * b + rs * d) + (rc * c - rs * a));

    /* Diagonalise S = W diag(l0, l1) W^T, W = [[wc, ws], [-ws, wc]]. */
    sm_real t = svd_jacobi_t(s00, s01, s11);
    sm_real wc = SVD_ONE / sm_sqrt(SVD_ONE + t * t);
    sm_real ws = t * wc;
    sm_real l0 = s00 - t * s01;
    sm_real l1 = s11 + t * s01;

    /* Order l0 >= l1; then l0 >= |l1| because l0 + l1 = trace S >= 0. Swapping the columns of W
     * and negating the new second one is W -> W [[0, -1], [1, 0]], i.e. (wc, ws) -> (ws, -wc). */
    sm_real m = (sm_real)(l1 > l0);
    sm_real c2 = svd_sel(m, ws, wc), s2 = svd_sel(m, -wc, ws);
    sm_real hi = SM_MAX(l0, l1), lo = SM_MIN(l0, l1);
    /* When trace S ~ 0, |lo| can exceed hi by the last rounding: clamp (an ulp-sized change). */
    lo = svd_copysign(SM_MIN(sm_fabs(lo), hi), lo);

    /* U = R W, a rotation by the difference of the angles. */
    sm_real uc = rc * c2 + rs * s2, us = rc * s2 - rs * c2;
    U[0] = uc, U[1] = us, U[2] = -us, U[3] = uc;
    V[0] = c2, V[1] = s2, V[2] = -s2, V[3] = c2;
    s[0] = hi;
    s[1] = lo;
}

void sm_svd2(const sm_real F[4], sm_real U[4], sm_real sigma[2], sm_real V[4]) {
    sm_real G[4];
    sm_real scale = svd_normalize(F, G, 4);
    svd2_core(G[0], G[1], G[2], G[3], U, sigma, V);
    sigma[0] *= scale;
    sigma[1] *= scale;
}

/* ---- 3x3 ---------------------------------------------------------------------------------- */

/* Quaternion (w, x, y, z), unnormalised, times the rotation about axis r by the half-angle
 * (ch, sh) (also unnormalised): q <- q (ch + sg sh e_r), sg = +-1. */
static inline void svd_quat_mul_axis(sm_real *q, int r, sm_real ch, sm_real sh) {
    sm_real w = q[0], v0 = q[1], v1 = q[2], v2 = q[3];
    /* (w, v) (c, s e) = (w c - s v.e, w s e + c v + s v x e) */
    if (r == 0) {
        q[0] = w * ch - sh * v0;
        q[1] = w * sh + ch * v0;
        q[2] = ch * v1 + sh * v2;
        q[3] = ch * v2 - sh * v1;
    } else if (r == 1) {
        q[0] = w * ch - sh * v1;
        q[1] = ch * v0 - sh * v2;
        q[2] = w * sh + ch * v1;
        q[3] = ch * v2 + sh * v0;
    } else {
        q[0] = w * ch - sh * v2;
        q[1] = ch * v0 + sh * v1;
        q[2] = ch * v1 - sh * v0;
        q[3] = w * sh + ch * v2;
    }
}

#define SVD_C8 SM_R(0.92387953251128675613) /* cos(pi/8) */
#define SVD_S8 SM_R(0.38268343236508977173) /* sin(pi/8) */
#define SVD_PADE_X SM_R(0.5)                 /* Pade rotation when 0.5 a_pq^2 < (a_qq - a_pp)^2 */

/* One approximate Jacobi rotation of the symmetric A in the plane (p, q), r the third index
 * (arr = A_rr, arp = A_rp, arq = A_rq), accumulated into the quaternion quat.
 *
 * The rotation J (J_pp = J_qq = cos t, J_pq = -J_qp = sin t) that zeroes A_pq has
 * tan 2t = x = 2 a_pq / (a_qq - a_pp); its quaternion has the half angle t/2 with
 * tan(t/2) = tan(atan(x) / 4) = x/4 - 5 x^3 / 64 + O(x^5). We use the [1/2] Pade approximant
 * x/4 / (1 + 5 x^2 / 16), homogeneous in (a_qq - a_pp, a_pq): (ch, sh) ~ (4 d^2 + 5 b^2, 2 b d),
 * with relative error O(x^4), so the sweeps converge with order 5 once the pivots are small.
 * For large |x| (nearly equal diagonal entries) the rotation is by +-pi/4 (half angle pi/8), as
 * in McAdams et al. 2011. Neither needs a square root; one division keeps (1, tau) normalised
 * to within a factor 1.1. The rotation is applied unnormalised: with c = ch^2 - sh^2,
 * s = 2 ch sh, m = ch^2 + sh^2, the matrix [[c, s], [-s, c]] (and m on the r axis) is m times a
 * rotation, so A is updated up to the positive factor m^2 -- harmless, as only ratios of its
 * entries matter -- and the quaternion up to the factor sqrt(m), removed at the end. */
static inline void svd3_rot(sm_real *app, sm_real *aqq, sm_real *apq, sm_real *arp, sm_real *arq,
                            sm_real *arr, sm_real *quat, int r, sm_real sgn) {
    sm_real d = *aqq - *app, b = *apq;
    sm_real dd = d * d, bb = b * b;
    sm_real ap = (sm_real)(SVD_PADE_X * bb < dd), fb = SVD_ONE - ap;
    sm_real ch = 4 * dd + 5 * bb, sh = 2 * b * d;
    sm_real tau = sh / (ap * ch + fb); /* no 0/0: ch > 0 when ap = 1 */
    sm_real c1 = ap + fb * SVD_C8;
    sm_real s1 = ap * tau + fb * svd_copysign(SVD_S8, b * d);
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
    svd_quat_mul_axis(quat, r, c1, sgn * s1);
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

/* |F_ij| within [SVD_LO, SVD_HI] needs no scaling: the Pade numerators (degree 4 in F) neither
 * overflow nor lose the relevant bits to underflow. */
#if SM_DOUBLE
#define SVD_LO 0x1p-100
#define SVD_HI 0x1p100
#else
#define SVD_LO 0x1p-8f
#define SVD_HI 0x1p8f
#endif

void sm_svd3(const sm_real F[9], sm_real U[9], sm_real sigma[3], sm_real V[9]) {
    sm_real G[9], W[9], R[9];
    sm_real mx = 0, scale = 1;
    for (int i = 0; i < 9; i++) mx = SM_MAX(mx, sm_fabs(F[i]));
    if (mx >= SVD_LO && mx <= SVD_HI) {
        for (int i = 0; i < 9; i++) G[i] = F[i];
    } else {
        scale = svd_normalize(F, G, 9); /* rare: huge, tiny, zero (or NaN) input */
    }

    /* A = G^T G = W diag W^T by Jacobi sweeps; W from the accumulated quaternion. */
    sm_real a00 = G[0] * G[0] + G[3] * G[3] + G[6] * G[6];
    sm_real a11 = G[1] * G[1] + G[4] * G[4] + G[7] * G[7];
    sm_real a22 = G[2] * G[2] + G[5] * G[5] + G[8] * G[8];
    sm_real a01 = G[0] * G[1] + G[3] * G[4] + G[6] * G[7];
    sm_real a02 = G[0] * G[2] + G[3] * G[5] + G[6] * G[8];
    sm_real a12 = G[1] * G[2] + G[4] * G[5] + G[7] * G[8];
    sm_real quat[4] = {1, 0, 0, 0};
    for (int sweep = 0; sweep < SM_SVD_SWEEPS; sweep++) {
        svd3_rot(&a00, &a11, &a01, &a02, &a12, &a22, quat, 2, -1);
        svd3_rot(&a00, &a22, &a02, &a01, &a12, &a11, quat, 1, 1);
        svd3_rot(&a11, &a22, &a12, &a01, &a02, &a00, quat, 0, -1);
        /* Converged when every off-diagonal entry is below eps times the largest eigenvalue:
         * then the columns of B = G W are orthogonal to rounding relative to ||G||, which is all
         * that the QR step below needs (the trailing 2x2 block is finished exactly there). */
        sm_real lim = SM_MAX(a00, SM_MAX(a11, a22)) * SM_EPS;
        if (SM_MAX(sm_fabs(a01), SM_MAX(sm_fabs(a02), sm_fabs(a12))) <= lim) break;
    }
    sm_real qn;
    {
        sm_real w = quat[0], x = quat[1], y = quat[2], z = quat[3];
        sm_real ww = w * w, xx = x * x, yy = y * y, zz = z * z;
        sm_real xy = x * y, xz = x * z, yz = y * z, wx = w * x, wy = w * y, wz = w * z;
        qn = (ww + xx) + (yy + zz); /* W = qn V */
        W[0] = (ww + xx) - (yy + zz), W[1] = 2 * (xy - wz), W[2] = 2 * (xz + wy);
        W[3] = 2 * (xy + wz), W[4] = (ww - xx) + (yy - zz), W[5] = 2 * (yz - wx);
        W[6] = 2 * (xz - wy), W[7] = 2 * (yz + wx), W[8] = (ww - xx) - (yy - zz);
    }
    sm_real iqn = SVD_ONE / qn;

    /* B = G W (= qn G V) and its squared column norms. */
    sm_real B[9], n0 = 0, n1 = 0, n2 = 0;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            B[3 * i + j] = G[3 * i] * W[j] + G[3 * i + 1] * W[3 + j] + G[3 * i + 2] * W[6 + j];
        n0 += B[3 * i] * B[3 * i];
        n1 += B[3 * i + 1] * B[3 * i + 1];
        n2 += B[3 * i + 2] * B[3 * i + 2];
    }

    /* Column order by decreasing norm: a 3-comparator network on indices, then one gather. An odd
     * permutation negates the last column of V and B, so that det V stays +1. */
    int i0 = 0, i1 = 1, i2 = 2, odd = 0, sw, ti;
    sm_real tn;
    sw = n1 > n0, ti = i0, i0 = sw ? i1 : i0, i1 = sw ? ti : i1, odd ^= sw;
    tn = n0, n0 = SM_MAX(n0, n1), n1 = SM_MIN(tn, n1);
    sw = n2 > n1, ti = i1, i1 = sw ? i2 : i1, i2 = sw ? ti : i2, odd ^= sw;
    n1 = SM_MAX(n1, n2);
    sw = n1 > n0, ti = i0, i0 = sw ? i1 : i0, i1 = sw ? ti : i1, odd ^= sw;
    tn = n0, n0 = SM_MAX(n0, n1), n1 = SM_MIN(tn, n1);
    sm_real sg = SVD_ONE - 2 * (sm_real)odd;
    for (int k = 0; k < 3; k++) {
        R[3 * k] = B[3 * k + i0];
        R[3 * k + 1] = B[3 * k + i1];
        R[3 * k + 2] = sg * B[3 * k + i2];
        V[3 * k] = W[3 * k + i0] * iqn;
        V[3 * k + 1] = W[3 * k + i1] * iqn;
        V[3 * k + 2] = sg * W[3 * k + i2] * iqn;
    }

    /* QR of the (nearly orthogonal) columns b0, b1, b2 of R: u0 = b0 / |b0|, u2 = b0 x b1 / |.|,
     * u1 = u2 x u0, so U = [u0 u1 u2] is a rotation and U^T B is upper triangular up to rounding
     * (u1.b0 = u2.b0 = u2.b1 = 0), with R_00, R_11 > 0 and the sign of det F in R_22. Accurate
     * while b0 and b1 are far from parallel, which the converged Jacobi guarantees unless
     * |b1| / |b0| is ~eps or below (rank <= 1): then Givens rotations (zero-safe) instead. */
    sm_real cx = R[3] * R[7] - R[6] * R[4];
    sm_real cy = R[6] * R[1] - R[0] * R[7];
    sm_real cz = R[0] * R[4] - R[3] * R[1];
    sm_real nc = cx * cx + cy * cy + cz * cz;
    sm_real r00, r01, r02, r11, r12, r21, r22;
    if (nc > SVD_HALF * n0 * n1 && n1 > n0 * (SM_EPS * SM_EPS * SM_EPS)) {
        sm_real i0n = SVD_ONE / sm_sqrt(n0), icn = SVD_ONE / sm_sqrt(nc);
        sm_real u0[3] = {R[0] * i0n, R[3] * i0n, R[6] * i0n};
        sm_real u2[3] = {cx * icn, cy * icn, cz * icn};
        sm_real u1[3] = {u2[1] * u0[2] - u2[2] * u0[1], u2[2] * u0[0] - u2[0] * u0[2],
                         u2[0] * u0[1] - u2[1] * u0[0]};
        r00 = n0 * i0n;
        r01 = u0[0] * R[1] + u0[1] * R[4] + u0[2] * R[7];
        r02 = u0[0] * R[2] + u0[1] * R[5] + u0[2] * R[8];
        r11 = u1[0] * R[1] + u1[1] * R[4] + u1[2] * R[7];
        r12 = u1[0] * R[2] + u1[1] * R[5] + u1[2] * R[8];
        r21 = u2[0] * R[1] + u2[1] * R[4] + u2[2] * R[7];
        r22 = u2[0] * R[2] + u2[1] * R[5] + u2[2] * R[8];
        for (int k = 0; k < 3; k++) U[3 * k] = u0[k], U[3 * k + 1] = u1[k], U[3 * k + 2] = u2[k];
    } else {
        for (int i = 0; i < 9; i++) U[i] = (i % 4 == 0) ? SVD_ONE : 0;
        svd3_givens(R, U, 0, 1, 0);
        svd3_givens(R, U, 0, 2, 0);
        svd3_givens(R, U, 1, 2, 1);
        r00 = R[0], r01 = R[1], r02 = R[2], r11 = R[4], r12 = R[5], r21 = R[7], r22 = R[8];
    }
    (void)r01, (void)r02; /* O(eps r00) after convergence: dropped */

    /* Clean-up of the trailing 2x2 block [[r11, r12], [r21, r22]] when it is not diagonal to
     * rounding relative to r00: r12 ~ A_12 / sigma_1 can be large when sigma_1 and sigma_2 are
     * both tiny (their vectors are not resolved by the Jacobi sweeps on F^T F). */
    sm_real s0 = r00, s1, s2;
    if (sm_fabs(r12) + sm_fabs(r21) > SM_EPS * r00) {
        sm_real Ub[4], Vb[4], sb[2];
        svd2_core(r11, r12, r21, r22, Ub, sb, Vb);
        for (int k = 0; k < 3; k++) {
            sm_real u1 = U[3 * k + 1], u2 = U[3 * k + 2];
            U[3 * k + 1] = u1 * Ub[0] + u2 * Ub[2];
            U[3 * k + 2] = u1 * Ub[1] + u2 * Ub[3];
            sm_real v1 = V[3 * k + 1], v2 = V[3 * k + 2];
            V[3 * k + 1] = v1 * Vb[0] + v2 * Vb[2];
            V[3 * k + 2] = v1 * Vb[1] + v2 * Vb[3];
        }
        s1 = sb[0], s2 = sb[1];
    } else {
        s1 = r11, s2 = r22;
    }

    /* Order: s0 >= s1 >= |s2| holds up to rounding; make it exact (an ulp-sized change). */
    sm_real k = scale * iqn;
    sm_real hi = SM_MAX(s0, s1), mid = SM_MIN(s0, s1);
    sigma[0] = hi * k;
    sigma[1] = mid * k;
    sigma[2] = svd_copysign(SM_MIN(sm_fabs(s2), mid), s2) * k;
}
