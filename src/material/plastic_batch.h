/* Plasticity of SM_PLASTIC_LANES particles at once (structure of arrays), for SIMD.
 *
 * Per lane l this computes exactly what the scalar plasticity stage of step_dim.c computes:
 *   F = U diag(s) V^T (signed SVD);
 *   if plastic: s' = PROJECT(s, alpha) (sm_dp_project: cases 1, 2, 3, same floor policy);
 *               if case != 1: F = U diag(s') V^T;
 *                             if hardening and dq > 0: q += dq,
 *                                alpha = sm_dp_alpha_fit(sm_hardening_phi(q, h0, h1, h2, h3), fit, d);
 *   tau = U diag(sm_hencky_tau(s')) U^T.
 * with its own branch-free SVD (same method as sm_svd3/sm_svd2, fixed sweep count) and its own
 * log/exp/sin polynomials, so the results agree with the scalar path to a few rounding errors,
 * not bitwise. Every lane goes through the same element-wise operations (no cross-lane
 * reductions, no data-dependent control flow), so a particle's result does not depend on its lane
 * or on the other particles of the batch: bitwise reproducible for any batching / thread count.
 *
 * Layout: element e of particle l is F[e][l]. 3D: F, tau are 3x3 row-major in e = 0..8.
 * 2D: e = 0..3 (2x2 row-major); entries 4..8 are ignored/untouched. All fields are per lane, so
 * one batch can mix materials. Padding lanes (a partial last batch): fill them with any finite
 * valid particle, e.g. F = I, alpha = q = 0, mu = 1, lambda = 0, plastic = hardening = fit = 0 (or a
 * copy of lane 0), and ignore their outputs. mu must be > 0 in plastic lanes, as for
 * sm_dp_project.
 *
 * The struct is 64-byte aligned (declare it as a local or static; with malloc use
 * aligned_alloc(64, ...)). */
#ifndef SM_PLASTIC_BATCH_H
#define SM_PLASTIC_BATCH_H

#include "core/common.h"

#if SM_DOUBLE
#define SM_PLASTIC_LANES 8 /* one AVX-512 register of doubles */
#else
#define SM_PLASTIC_LANES 16 /* one AVX-512 register of floats */
#endif

typedef struct sm_plastic_lanes {
    _Alignas(64) sm_real F[9][SM_PLASTIC_LANES]; /* in: trial F^E; out: projected F^E */
    _Alignas(64) sm_real tau[9][SM_PLASTIC_LANES]; /* out: Kirchhoff stress U diag(tau) U^T */
    _Alignas(64) sm_real alpha[SM_PLASTIC_LANES];  /* in/out: Drucker-Prager alpha */
    _Alignas(64) sm_real q[SM_PLASTIC_LANES];      /* in/out: hardening state */
    _Alignas(64) sm_real mu[SM_PLASTIC_LANES];     /* Lame parameters */
    _Alignas(64) sm_real lambda[SM_PLASTIC_LANES];
    _Alignas(64) sm_real h0[SM_PLASTIC_LANES]; /* hardening (3.79), radians except h2 */
    _Alignas(64) sm_real h1[SM_PLASTIC_LANES];
    _Alignas(64) sm_real h2[SM_PLASTIC_LANES];
    _Alignas(64) sm_real h3[SM_PLASTIC_LANES];
    _Alignas(64) int32_t plastic[SM_PLASTIC_LANES];   /* 0: elastic only (no projection) */
    _Alignas(64) int32_t hardening[SM_PLASTIC_LANES]; /* 1: alpha follows q */
    _Alignas(64) int32_t fit[SM_PLASTIC_LANES];       /* sm_cone_fit of the hardening alpha */
} sm_plastic_lanes;

/* 3D: F[0..8] 3x3. */
void sm_plastic_lanes3(sm_plastic_lanes *b);
/* 2D: F[0..3] 2x2; tau[0..3]. */
void sm_plastic_lanes2(sm_plastic_lanes *b);

/* Lane-wise elementary functions used above (exposed for the tests): y[l] = f(x[l]) for
 * l < SM_PLASTIC_LANES. log: x > 0 normal; exp: |x| < 80 (float) / 700 (double); sin: |x| < 1e4. */
void sm_lanes_log(const sm_real *x, sm_real *y);
void sm_lanes_exp(const sm_real *x, sm_real *y);
void sm_lanes_sin(const sm_real *x, sm_real *y);

#endif
