/* Signed SVD of 2x2 and 3x3 matrices, F = U diag(sigma) V^T (row-major), U and V rotations.
 *
 * Method (own code; only published facts are used):
 *
 * 3x3 -- the scheme of McAdams, Selle, Tamstorf, Teran and Sifakis, "Computing the Singular Value
 * Decomposition of 3x3 matrices with minimal branching and elementary floating point
 * operations" (Univ. of Wisconsin-Madison, CS Tech. Report 1690, 2011), with exact instead of
 * approximate rotations and one extra clean-up step:
 *   1. Scale F by 1/max|F_ij| so that F^T F can neither overflow nor underflow.
 *   2. Cyclic Jacobi eigen-decomposition of the symmetric A = F^T F = V L V^T: a fixed number of
 *      sweeps over the pairs (0,1), (0,2), (1,2). Each rotation is the exact Jacobi rotation with
 *      the stable small root t = tan(theta), |t| <= 1, and the updates a_pp - t a_pq,
 *      a_qq + t a_pq (Golub & Van Loan, "Matrix Computations", sec. 8.5; Rutishauser). A pivot
 *      below eps sqrt(a_pp a_qq) is skipped (the relative threshold of Demmel & Veselic, "Jacobi's
 *      method is more accurate than QR", 1992), so near-rotations do not pick up noise.
 *   3. B = F V; order the columns of B (and V) by decreasing norm with a 3-comparator network.
 *      An odd permutation negates the last column of both, so det V stays +1 and B = F V.
 *   4. Givens QR of B: B = Q R. Q is a product of rotations (det +1), R_00 and R_11 come out
 *      >= 0, so det F is carried by R_22: this is how McAdams et al. obtain the signed SVD.
 *      As the columns of R come from F v_j, not from the eigenvalues of F^T F, the small singular
 *      values are accurate to O(eps ||F||) absolutely (not O(sqrt(eps) ||F||)).
 *   5. Clean-up (ours): once the Jacobi iteration has converged, R_01 and R_02 are
 *      O(eps ||F||), but R_12 ~ (V^T A V)_12 / sigma_1 is only O(eps ||F||^2 / sigma_1), which is
 *      large when sigma_1 and sigma_2 are both small (e.g. sigma = (1, 1e-8, 5e-9): their
 *      eigenvectors in F^T F are not resolved). So the trailing 2x2 block of R is diagonalised
 *      with the 2x2 SVD below and folded into U and V. This makes the result backward stable:
 *      ||F - U S V^T|| = O(eps ||F||) for every F.
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
 * Control flow: fixed sweep count, no data-dependent jumps except one rarely taken branch for
 * all-subnormal input; comparisons become min/max, integer selects or arithmetic blends.
 * Cost: dominated by the 12 sequential Jacobi rotations (2 sqrt + 2 div each, on the critical
 * path), then the 3 Givens rotations and the 2x2 SVD. */
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

/* Cyclic Jacobi sweeps on F^T F. Measured (tens of millions of random, graded, clustered and
 * near-rotation matrices, plus an adversarial search): 3 sweeps leave errors up to ~1e-5 in double
 * and ~100 eps in float; 4 sweeps reach full accuracy (<= 11 eps) in both; 5 change nothing. */
#ifndef SM_SVD_SWEEPS
#define SM_SVD_SWEEPS 4
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

/* One Jacobi rotation of the symmetric 3x3 A in the plane (p, q) (r is the third index; arp, arq
 * are A_rp, A_rq), accumulated into the columns p, q of V (row-major). */
static inline void svd3_jacobi(sm_real *app, sm_real *aqq, sm_real *apq, sm_real *arp,
                               sm_real *arq, sm_real V[9], int p, int q) {
    sm_real t = svd_jacobi_t(*app, *apq, *aqq);
    sm_real c = SVD_ONE / sm_sqrt(SVD_ONE + t * t);
    sm_real s = t * c;
    sm_real rp = *arp, rq = *arq;
    *app -= t * *apq;
    *aqq += t * *apq;
    *apq = 0;
    *arp = c * rp - s * rq;
    *arq = s * rp + c * rq;
    for (int k = 0; k < 3; k++) {
        sm_real vp = V[3 * k + p], vq = V[3 * k + q];
        V[3 * k + p] = c * vp - s * vq;
        V[3 * k + q] = s * vp + c * vq;
    }
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

void sm_svd3(const sm_real F[9], sm_real U[9], sm_real sigma[3], sm_real V[9]) {
    sm_real G[9], W[9], B[9], R[9];
    sm_real scale = svd_normalize(F, G, 9);

    /* A = G^T G, then A = W diag W^T by cyclic Jacobi. */
    sm_real a00 = G[0] * G[0] + G[3] * G[3] + G[6] * G[6];
    sm_real a11 = G[1] * G[1] + G[4] * G[4] + G[7] * G[7];
    sm_real a22 = G[2] * G[2] + G[5] * G[5] + G[8] * G[8];
    sm_real a01 = G[0] * G[1] + G[3] * G[4] + G[6] * G[7];
    sm_real a02 = G[0] * G[2] + G[3] * G[5] + G[6] * G[8];
    sm_real a12 = G[1] * G[2] + G[4] * G[5] + G[7] * G[8];
    for (int i = 0; i < 9; i++) W[i] = (i % 4 == 0) ? SVD_ONE : 0;
    for (int sweep = 0; sweep < SM_SVD_SWEEPS; sweep++) {
        svd3_jacobi(&a00, &a11, &a01, &a02, &a12, W, 0, 1);
        svd3_jacobi(&a00, &a22, &a02, &a01, &a12, W, 0, 2);
        svd3_jacobi(&a11, &a22, &a12, &a01, &a02, W, 1, 2);
        /* Once every off-diagonal entry is below the skip threshold of svd_jacobi_t, the remaining
         * sweeps would apply identity rotations only: stopping changes no bit of the result. MPM's
         * F^E is close to a rotation, so this usually ends after one or two sweeps. */
        if (a01 * a01 <= SVD_EPS2 * a00 * a11 && a02 * a02 <= SVD_EPS2 * a00 * a22 && a12 * a12 <= SVD_EPS2 * a11 * a22)
            break;
    }

    /* B = G W and its squared column norms. */
    sm_real n0 = 0, n1 = 0, n2 = 0;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            B[3 * i + j] = G[3 * i] * W[j] + G[3 * i + 1] * W[3 + j] + G[3 * i + 2] * W[6 + j];
        n0 += B[3 * i] * B[3 * i];
        n1 += B[3 * i + 1] * B[3 * i + 1];
        n2 += B[3 * i + 2] * B[3 * i + 2];
    }

    /* Column order by decreasing norm: a 3-comparator network on indices (integer selects, no
     * jumps), then one gather. An odd permutation negates the last column of V and B. */
    int i0 = 0, i1 = 1, i2 = 2, odd = 0, sw, ti;
    sm_real tn;
    sw = n1 > n0, ti = i0, i0 = sw ? i1 : i0, i1 = sw ? ti : i1, odd ^= sw;
    tn = n0, n0 = SM_MAX(n0, n1), n1 = SM_MIN(tn, n1);
    sw = n2 > n1, ti = i1, i1 = sw ? i2 : i1, i2 = sw ? ti : i2, odd ^= sw;
    n1 = SM_MAX(n1, n2);
    sw = n1 > n0, ti = i0, i0 = sw ? i1 : i0, i1 = sw ? ti : i1, odd ^= sw;
    sm_real sg = SVD_ONE - 2 * (sm_real)odd;
    for (int k = 0; k < 3; k++) {
        R[3 * k] = B[3 * k + i0];
        R[3 * k + 1] = B[3 * k + i1];
        R[3 * k + 2] = sg * B[3 * k + i2];
        V[3 * k] = W[3 * k + i0];
        V[3 * k + 1] = W[3 * k + i1];
        V[3 * k + 2] = sg * W[3 * k + i2];
    }

    /* R = Q^T B by Givens rotations; U accumulates Q. R_00, R_11 >= 0. */
    for (int i = 0; i < 9; i++) U[i] = (i % 4 == 0) ? SVD_ONE : 0;
    svd3_givens(R, U, 0, 1, 0);
    svd3_givens(R, U, 0, 2, 0);
    svd3_givens(R, U, 1, 2, 1);

    /* Clean-up of the trailing 2x2 block: R[1:3][1:3] = Ub diag(sb) Vb^T. */
    sm_real Ub[4], Vb[4], sb[2];
    svd2_core(R[4], R[5], R[7], R[8], Ub, sb, Vb);
    for (int k = 0; k < 3; k++) {
        sm_real u1 = U[3 * k + 1], u2 = U[3 * k + 2];
        U[3 * k + 1] = u1 * Ub[0] + u2 * Ub[2];
        U[3 * k + 2] = u1 * Ub[1] + u2 * Ub[3];
        sm_real v1 = V[3 * k + 1], v2 = V[3 * k + 2];
        V[3 * k + 1] = v1 * Vb[0] + v2 * Vb[2];
        V[3 * k + 2] = v1 * Vb[1] + v2 * Vb[3];
    }

    /* R_00 >= sb[0] >= |sb[1]| up to rounding: with the Jacobi iteration converged, R_00 < sb[0]
     * only when sigma_0 ~ sigma_1 to the last bits. Sorting just the values then moves the
     * reconstruction by |R_00 - sb[0]|, a rounding-level amount, and makes the order exact. */
    sm_real s0 = R[0], s1 = sb[0];
    sm_real hi = SM_MAX(s0, s1), mid = SM_MIN(s0, s1);
    sigma[0] = hi * scale;
    sigma[1] = mid * scale;
    sigma[2] = svd_copysign(SM_MIN(sm_fabs(sb[1]), mid), sb[1]) * scale;
}
