/* Signed SVD of 2x2 and 3x3 matrices, F = U diag(sigma) V^T (row-major), U and V rotations.
 *
 * Method (own code; only published facts are used):
 *
 * 3x3 -- the scheme of McAdams, Selle, Tamstorf, Teran and Sifakis, "Computing the Singular Value
 * Decomposition of 3x3 matrices with minimal branching and elementary floating point
 * operations" (Univ. of Wisconsin-Madison, CS TR1690, 2011), with exact rather than approximate
 * rotations and one extra clean-up step:
 *   1. Scale F by 1/max|F_ij| so that F^T F can neither overflow nor underflow.
 *   2. Cyclic Jacobi eigen-decomposition of the symmetric A = F^T F = V L V^T, a fixed number of
 *      sweeps over the pairs (0,1), (0,2), (1,2). Each rotation is the exact Jacobi rotation with
 *      the stable small-angle root t = tan(theta), |t| <= 1, and the updates a_pp - t a_pq,
 *      a_qq + t a_pq (Golub & Van Loan, "Matrix Computations", 4th ed., sec. 8.5.2; Rutishauser).
 *   3. B = F V; sort the columns of B (and V) by decreasing norm with a 3-comparator network.
 *      A swap negates one of the two columns so that det V stays +1.
 *   4. Givens QR of B: B = Q R. Q is a product of rotations (det +1), R_00 and R_11 come out
 *      >= 0, so det F is carried by R_22: this is how McAdams et al. obtain the signed SVD.
 *      Because the last columns are not formed from eigenvalues of F^T F but from F v_j directly,
 *      the small singular values are accurate to O(eps ||F||) (not O(sqrt(eps) ||F||)).
 *   5. Clean-up (ours): R_01 and R_02 are O(eps ||F||) once the Jacobi iteration has converged,
 *      but R_12 is only O(eps ||F||^2 / sigma_2), which is large when sigma_2 and sigma_3 are both
 *      small (e.g. sigma = (1, 1e-8, 5e-9): their eigenvectors in F^T F are not resolved).
 *      The trailing 2x2 block of R is therefore diagonalised with the 2x2 SVD below and folded into
 *      U and V. A last comparator on (sigma_0, sigma_1) makes the ordering exact.
 *
 * 2x2 -- symmetrise, then diagonalise (the 2x2 step of two-sided Jacobi SVD, Golub & Van Loan
 * sec. 8.6.3 / Brent-Luk-Van Loan): the rotation R with tan(phi) = (f10 - f01) / (f00 + f11) makes
 * S = R^T F symmetric with trace S >= 0 (R is the rotation of the polar decomposition when
 * det F > 0); one exact Jacobi rotation W then gives S = W diag(l0, l1) W^T. With l0 >= l1 and
 * l0 + l1 = trace S >= 0 we get l0 >= |l1| and sign(l1) = sign(det F), so U = R W, V = W.
 *
 * Signed convention (last singular value negative for inverted elements): Irving, Teran and
 * Fedkiw, "Invertible Finite Elements for Robust Simulation of Large Deformation" (SCA 2004).
 *
 * No data-dependent loops: fixed sweep count, comparisons only as selects, one rarely taken
 * branch for subnormal input. */
#include "math/svd.h"

#include <float.h>

#if SM_DOUBLE
#define SVD_REAL_MIN DBL_MIN
#define SVD_PRESCALE 0x1p60
/* On the scaled matrix (max entry 1), quantities below these are treated as exact zeros: their
 * squares would be denormal, and they are ~1e-130 below the rounding errors anyway. */
#define SVD_TINY 1e-140
#define SVD_TINY2 1e-280
#else
#define SVD_REAL_MIN FLT_MIN
#define SVD_PRESCALE 0x1p30f
#define SVD_TINY 1e-17f
#define SVD_TINY2 1e-34f
#endif

/* Cyclic Jacobi sweeps on F^T F. Convergence is quadratic; measured on millions of random, graded
 * and clustered matrices (see tests/test_svd.c), 4 sweeps reach full float accuracy and 5 reach
 * full double accuracy. */
#ifndef SM_SVD_SWEEPS
#if SM_DOUBLE
#define SM_SVD_SWEEPS 5
#else
#define SM_SVD_SWEEPS 4
#endif
#endif

#define SVD_ONE SM_R(1.0)
#define SVD_EPS2 (SM_EPS * SM_EPS)
#define SVD_HALF SM_R(0.5)

/* G = F / s with s = max |F_ij| (returned; 0 for the zero matrix, then G = 0). */
static sm_real svd_normalize(const sm_real *F, sm_real *G, int n) {
    sm_real m = 0;
    for (int i = 0; i < n; i++) m = SM_MAX(m, sm_fabs(F[i]));
    if (m < SVD_REAL_MIN) {
        /* Zero or subnormal: 1/m would overflow. Go through an exact power-of-two prescale. */
        sm_real inv = m > 0 ? SVD_ONE / (m * SVD_PRESCALE) : 0;
        for (int i = 0; i < n; i++) G[i] = (F[i] * SVD_PRESCALE) * inv;
        return m;
    }
    sm_real inv = SVD_ONE / m;
    for (int i = 0; i < n; i++) G[i] = F[i] * inv;
    return m;
}

/* Exact Jacobi rotation for the symmetric 2x2 [[p, q], [q, r]]: returns t = tan(theta), |t| <= 1,
 * such that with c = 1/sqrt(1+t^2), s = t c, the matrix [[c, s], [-s, c]]^T A [[c, s], [-s, c]]
 * is diagonal, with diagonal (p - t q, r + t q). t = 0 when |q| is negligible. */
static inline sm_real svd_jacobi_t(sm_real p, sm_real q, sm_real r) {
    sm_real d = r - p;
    sm_real h = sm_sqrt(d * d + 4 * q * q);
    /* Skip (t = 0) when q is negligible: below SVD_TINY, or below eps relative to the diagonal
     * (de Rijk's / Demmel-Veselic's threshold; keeps near-rotations from accumulating noise). */
    int ok = (sm_fabs(q) >= SVD_TINY) & (q * q > SVD_EPS2 * p * r);
    sm_real num = ok ? 2 * q : 0;
    sm_real den = ok ? sm_fabs(d) + h : SVD_ONE; /* >= 2|q| > 0 when ok */
    sm_real t = num / den;
    return d < 0 ? -t : t;
}

/* 2x2 signed SVD of [[a, b], [c, d]] whose entries are O(1) or smaller (already scaled).
 * U, V are 2x2 row-major rotations; s[0] >= |s[1]|, s[0] >= 0, sign(s[1]) = sign(ad - bc). */
static void svd2_core(sm_real a, sm_real b, sm_real c, sm_real d, sm_real U[4], sm_real s[2],
                      sm_real V[4]) {
    /* Symmetrising rotation R = [[rc, -rs], [rs, rc]], S = R^T F symmetric, trace S >= 0. */
    sm_real x = a + d, y = c - b;
    sm_real r2 = x * x + y * y;
    int ok = r2 > SVD_TINY2;
    sm_real rinv = SVD_ONE / sm_sqrt(ok ? r2 : SVD_ONE);
    sm_real rc = ok ? x * rinv : (x < 0 ? -SVD_ONE : SVD_ONE);
    sm_real rs = ok ? y * rinv : 0;
    sm_real s00 = rc * a + rs * c;
    sm_real s11 = rc * d - rs * b;
    sm_real s01 = SVD_HALF * ((rc * b + rs * d) + (rc * c - rs * a));

    /* Diagonalise S = W diag(l0, l1) W^T, W = [[wc, ws], [-ws, wc]]. */
    sm_real t = svd_jacobi_t(s00, s01, s11);
    sm_real wc = SVD_ONE / sm_sqrt(SVD_ONE + t * t);
    sm_real ws = t * wc;
    sm_real l0 = s00 - t * s01;
    sm_real l1 = s11 + t * s01;

    /* Order l0 >= l1 (then l0 >= |l1| since l0 + l1 = trace S >= 0). Swapping the columns of W
     * negates the new second one to keep det W = +1. */
    int sw = l1 > l0;
    sm_real w00 = sw ? ws : wc, w01 = sw ? -wc : ws;
    sm_real w10 = sw ? wc : -ws, w11 = sw ? ws : wc;
    sm_real hi = sw ? l1 : l0, lo = sw ? l0 : l1;
    /* Guard the ordering against the last rounding when trace S ~ 0 (|lo| may exceed hi by an ulp). */
    sm_real alo = SM_MIN(sm_fabs(lo), hi);
    lo = lo < 0 ? -alo : alo;

    U[0] = rc * w00 - rs * w10;
    U[1] = rc * w01 - rs * w11;
    U[2] = rs * w00 + rc * w10;
    U[3] = rs * w01 + rc * w11;
    V[0] = w00;
    V[1] = w01;
    V[2] = w10;
    V[3] = w11;
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

/* One Jacobi rotation of the symmetric 3x3 A (full storage) in the plane (p, q), accumulated into
 * the columns p, q of V. */
static inline void svd3_jacobi(sm_real A[9], sm_real V[9], int p, int q) {
    const int r = 3 - p - q;
    sm_real app = A[3 * p + p], aqq = A[3 * q + q], apq = A[3 * p + q];
    sm_real arp = A[3 * r + p], arq = A[3 * r + q];
    sm_real t = svd_jacobi_t(app, apq, aqq);
    sm_real c = SVD_ONE / sm_sqrt(SVD_ONE + t * t);
    sm_real s = t * c;
    A[3 * p + p] = app - t * apq;
    A[3 * q + q] = aqq + t * apq;
    A[3 * p + q] = A[3 * q + p] = 0;
    A[3 * r + p] = A[3 * p + r] = c * arp - s * arq;
    A[3 * r + q] = A[3 * q + r] = s * arp + c * arq;
    for (int k = 0; k < 3; k++) {
        sm_real vp = V[3 * k + p], vq = V[3 * k + q];
        V[3 * k + p] = c * vp - s * vq;
        V[3 * k + q] = s * vp + c * vq;
    }
}

/* If n[j] > n[i], swap columns i and j of B and V (and n), negating the new column j of both so
 * that det V is unchanged and B = F V still holds. */
static inline void svd3_sort_pair(sm_real B[9], sm_real V[9], sm_real n[3], int i, int j) {
    int sw = n[j] > n[i];
    for (int k = 0; k < 3; k++) {
        sm_real bi = B[3 * k + i], bj = B[3 * k + j];
        B[3 * k + i] = sw ? bj : bi;
        B[3 * k + j] = sw ? -bi : bj;
        sm_real vi = V[3 * k + i], vj = V[3 * k + j];
        V[3 * k + i] = sw ? vj : vi;
        V[3 * k + j] = sw ? -vi : vj;
    }
    sm_real ni = n[i], nj = n[j];
    n[i] = sw ? nj : ni;
    n[j] = sw ? ni : nj;
}

/* Givens rotation G on rows i, j of B that zeroes B[j][k] (B[i][k] becomes >= 0); U <- U G^T. */
static inline void svd3_givens(sm_real B[9], sm_real U[9], int i, int j, int k) {
    sm_real a = B[3 * i + k], b = B[3 * j + k];
    sm_real r2 = a * a + b * b;
    int ok = r2 > SVD_TINY2;
    sm_real rinv = SVD_ONE / sm_sqrt(ok ? r2 : SVD_ONE);
    sm_real c = ok ? a * rinv : SVD_ONE;
    sm_real s = ok ? b * rinv : 0;
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
    sm_real G[9], A[9], B[9];
    sm_real scale = svd_normalize(F, G, 9);

    /* A = G^T G. */
    for (int i = 0; i < 3; i++)
        for (int j = i; j < 3; j++) {
            sm_real acc = G[i] * G[j] + G[3 + i] * G[3 + j] + G[6 + i] * G[6 + j];
            A[3 * i + j] = A[3 * j + i] = acc;
        }

    for (int i = 0; i < 9; i++) V[i] = (i % 4 == 0) ? SVD_ONE : 0;
    for (int sweep = 0; sweep < SM_SVD_SWEEPS; sweep++) {
        svd3_jacobi(A, V, 0, 1);
        svd3_jacobi(A, V, 0, 2);
        svd3_jacobi(A, V, 1, 2);
    }

    /* B = G V and its column norms. */
    sm_real n[3] = {0, 0, 0};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            B[3 * i + j] = G[3 * i] * V[j] + G[3 * i + 1] * V[3 + j] + G[3 * i + 2] * V[6 + j];
            n[j] += B[3 * i + j] * B[3 * i + j];
        }
    svd3_sort_pair(B, V, n, 0, 1);
    svd3_sort_pair(B, V, n, 1, 2);
    svd3_sort_pair(B, V, n, 0, 1);

    /* B = Q R; B is overwritten by R, U accumulates Q. */
    for (int i = 0; i < 9; i++) U[i] = (i % 4 == 0) ? SVD_ONE : 0;
    svd3_givens(B, U, 0, 1, 0);
    svd3_givens(B, U, 0, 2, 0);
    svd3_givens(B, U, 1, 2, 1);

    /* Clean-up of the trailing 2x2 block: R[1:3][1:3] = Ub diag(sb) Vb^T. */
    sm_real Ub[4], Vb[4], sb[2];
    svd2_core(B[4], B[5], B[7], B[8], Ub, sb, Vb);
    for (int k = 0; k < 3; k++) {
        sm_real u1 = U[3 * k + 1], u2 = U[3 * k + 2];
        U[3 * k + 1] = u1 * Ub[0] + u2 * Ub[2];
        U[3 * k + 2] = u1 * Ub[1] + u2 * Ub[3];
        sm_real v1 = V[3 * k + 1], v2 = V[3 * k + 2];
        V[3 * k + 1] = v1 * Vb[0] + v2 * Vb[2];
        V[3 * k + 2] = v1 * Vb[1] + v2 * Vb[3];
    }

    /* R_00 >= sb[0] up to rounding; make the order exact (sb[0] >= |sb[1]| already holds). */
    sm_real s0 = B[0], s1 = sb[0];
    int sw = s1 > s0;
    for (int k = 0; k < 3; k++) {
        sm_real u0 = U[3 * k], u1 = U[3 * k + 1];
        U[3 * k] = sw ? u1 : u0;
        U[3 * k + 1] = sw ? -u0 : u1;
        sm_real v0 = V[3 * k], v1 = V[3 * k + 1];
        V[3 * k] = sw ? v1 : v0;
        V[3 * k + 1] = sw ? -v0 : v1;
    }
    sm_real hi = sw ? s1 : s0, mid = sw ? s0 : s1;
    /* After a swap |sb[1]| may exceed the new middle value by an ulp (sigma_0 ~ sigma_1 ~ |sigma_2|). */
    sm_real alo = SM_MIN(sm_fabs(sb[1]), mid);
    sigma[0] = hi * scale;
    sigma[1] = mid * scale;
    sigma[2] = (sb[1] < 0 ? -alo : alo) * scale;
}
