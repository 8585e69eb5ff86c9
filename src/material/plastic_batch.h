/* Plasticity of SM_PLASTIC_LANES particles at once (structure of arrays), for SIMD.
 *
 * Per lane l this computes what the scalar functions of material.h give:
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

/* A material's parameters as the lanes take them (sm_plastic_lanes_set_params). */
typedef struct sm_plastic_params {
    sm_real mu, lambda;     /* Lame parameters, Pa (mu > 0 where plastic) */
    sm_real h0, h1, h2, h3; /* hardening (3.79), radians except h2 */
    int32_t plastic;        /* 0: elastic only (no projection) */
    int32_t hardening;      /* 1: alpha follows q */
    int32_t fit;            /* sm_cone_fit of the hardening alpha (0: the thesis's, 3.80) */
} sm_plastic_params;

/* Packing: the one way particles enter and leave the lanes (the world's plasticity stage,
 * material/plasticity_dim.c, and bench/svd_bench.c). d = 2 or 3; with a constant d the loops
 * unroll. */

/* Lane l takes the parameters *p; NULL: padding (an undeformed elastic particle: mu = 1, the
 * rest 0). */
static inline __attribute__((always_inline)) void sm_plastic_lanes_set_params(sm_plastic_lanes *b, int l,
                                                                              const sm_plastic_params *p) {
    static const sm_plastic_params pad = {1, 0, 0, 0, 0, 0, 0, 0, 0};
    if (!p) p = &pad;
    b->mu[l] = p->mu;
    b->lambda[l] = p->lambda;
    b->h0[l] = p->h0;
    b->h1[l] = p->h1;
    b->h2[l] = p->h2;
    b->h3[l] = p->h3;
    b->plastic[l] = p->plastic;
    b->hardening[l] = p->hardening;
    b->fit[l] = p->fit;
}

/* Lane l takes a particle's state: F^E (d*d values, row-major), alpha, q; F == NULL: padding
 * (F = I, alpha = q = 0). */
static inline __attribute__((always_inline)) void sm_plastic_lanes_load(sm_plastic_lanes *b, int d, int l,
                                                                        const sm_real *F, sm_real alpha, sm_real q) {
    for (int k = 0; k < d * d; k++) b->F[k][l] = F ? F[k] : (k % (d + 1) == 0) ? 1 : 0;
    b->alpha[l] = F ? alpha : 0;
    b->q[l] = F ? q : 0;
}

/* Lane l's results: the projected F^E (d*d values), alpha, q, and the Kirchhoff stress as
 * SM_NSYM(d) values (xx, yy, zz, xy, xz, yz; 2D: xx, yy, xy). Returns 0 * every F and tau value,
 * summed: NaN iff one of them is not finite. */
static inline __attribute__((always_inline)) sm_real sm_plastic_lanes_store(const sm_plastic_lanes *b, int d, int l,
                                                                            sm_real *F, sm_real *alpha, sm_real *q,
                                                                            sm_real *tau) {
    static const int sym2[3] = {0, 3, 1}, sym3[6] = {0, 4, 8, 1, 2, 5}; /* row-major index of each */
    sm_real z = 0;
    for (int k = 0; k < d * d; k++) {
        F[k] = b->F[k][l];
        z += 0 * b->F[k][l];
    }
    *alpha = b->alpha[l];
    *q = b->q[l];
    for (int k = 0; k < SM_NSYM(d); k++) {
        const int e = d == 3 ? sym3[k] : sym2[k];
        tau[k] = b->tau[e][l];
        z += 0 * b->tau[e][l];
    }
    return z;
}

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
