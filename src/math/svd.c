/* Signed SVD of 2x2 and 3x3 matrices, F = U diag(sigma) V^T (row-major), U and V rotations: the
 * 2x2 here, the 3x3 in svd3.c (its method and measured speed and errors at its top), what both
 * share in svd_internal.h.
 *
 * Method (own code; only published facts are used):
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
 * Control flow: the exit of the sweeps, the +-pi/4 case of a rotation (a jump that is nearly
 * always predicted after the first sweep) and rare branches (prescaling, rank <= 1, clean-up);
 * elsewhere selects/arithmetic blends (unpredictable comparisons must not become jumps). Same
 * inputs give the same bits on a given build (fused multiply-adds are used where the target has
 * them, so different -march builds may differ in the last bits). */#include "math/svd_internal.h"

/* G = F / s with s = max |F_ij| (returned; 0 for the zero matrix, then G = 0). */
sm_real sm_svd_normalize(const sm_real *F, sm_real *G, int n) {
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

/* 2x2 signed SVD of [[a, b], [c, d]] whose entries are O(1) or smaller (already scaled).
 * U = [[U[0], U[1]], [U[2], U[3]]] and V are rotations; s[0] >= |s[1]|, s[0] >= 0,
 * sign(s[1]) = sign(ad - bc). */
void sm_svd2_core(sm_real a, sm_real b, sm_real c, sm_real d, sm_real U[4], sm_real s[2], sm_real V[4]) {
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
    sm_real scale = sm_svd_normalize(F, G, 4);
    sm_svd2_core(G[0], G[1], G[2], G[3], U, sigma, V);
    sigma[0] *= scale;
    sigma[1] *= scale;
}
