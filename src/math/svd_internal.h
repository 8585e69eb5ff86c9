/* What the 2x2 (svd.c) and the 3x3 (svd3.c) SVD share: the precision's constants, branch-free
 * selects, the exact 2x2 Jacobi rotation and the Givens rotation (inline), and the 2x2 core and
 * the normalisation that the 3x3's rare paths call. Only svd.c and svd3.c include it. */
#ifndef SM_MATH_SVD_INTERNAL_H
#define SM_MATH_SVD_INTERNAL_H

#include "math/svd.h"

#include <float.h>
#include <stdint.h>
#include <string.h>

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

/* Bound on the Jacobi sweeps of sm_svd3: 3 SM_SVD_SWEEPS + 1 rotations at most (the loop stops
 * much earlier: see sm_svd3). */
#ifndef SM_SVD_SWEEPS
#define SM_SVD_SWEEPS 8
#endif

#define SVD_ONE SM_R(1.0)
#define SVD_HALF SM_R(0.5)
#define SVD_EPS2 (SM_EPS * SM_EPS)

/* Branch-free select: m ? a : b for m in {0, 1} (exact for finite a, b). Written as arithmetic
 * because compilers turn floating-point ?: into jumps, and these comparisons are unpredictable. */
static inline sm_real svd_sel(sm_real m, sm_real a, sm_real b) { return m * a + (SVD_ONE - m) * b; }

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

/* G = F / s with s = max |F_ij| (returned; 0 for the zero matrix, then G = 0): svd.c. */
sm_real sm_svd_normalize(const sm_real *F, sm_real *G, int n);
/* 2x2 signed SVD of [[a, b], [c, d]] whose entries are O(1) or smaller (already scaled):
 * U = [[U[0], U[1]], [U[2], U[3]]] and V rotations; s[0] >= |s[1]|, s[0] >= 0,
 * sign(s[1]) = sign(ad - bc) (svd.c). */
void sm_svd2_core(sm_real a, sm_real b, sm_real c, sm_real d, sm_real U[4], sm_real s[2], sm_real V[4]);

#endif
