/* Derivatives for implicit integration (thesis §3.6.2.2, Appendix A.5, Algorithms 5, 6, 8).
 *
 * Y(F) = dpsi/dF evaluated at Z(F): the first Piola stress of the *projected* elastic deformation
 * gradient. With the signed SVD F = U Sigma V^T (math/svd.h), Z(F) = U diag(z) V^T where
 * z = PROJECT(sigma, alpha) (sm_dp_project; z = sigma when not plastic), and
 * Y(F) = U diag(y) V^T with y = sm_hencky_dpsi(z). The SM_SIGMA_FLOOR policy of material.h applies
 * unchanged (Y is exactly what the explicit force of Algorithm 4 uses, with b != 0).
 *
 * M = dY/dF is applied as  dY = U [Mhat : (U^T dF V)] V^T  (A.21, A.22) with Mhat the
 * diagonal-space tensor below (derivation at the top of implicit.c).
 *
 * Units / scaling for the integrator (FORCE_INCREMENT_VEL and HESSIAN_TIMES):
 *   F(v)   = (I + dt T) F^n,            T  = sum_i v_i (grad w_ip)^T
 *   G(v)   = V0 Y(F(v)) (F^n)^T          (sm_implicit_force_matrix; the per-particle matrix A_p of
 *                                         Algorithm 4: f_i = -(dt/m_i) sum_p G_p grad w_ip)
 *   apply  = V0 U (Mhat : (U^T T1 Q)) Q^T,  Q = F^n V,  T1 = sum_i z_i (grad w_ip)^T
 *          = (1/dt) dG/dv [z]   (the derivative of G along grid velocities z, DIVIDED by dt)
 * so the Newton operator of TIMES_DIFF (Algorithm 6) is
 *   z_i + (dt^2 / m_i) sum_p apply_p(T1_p) grad w_ip,
 * the derivative of the residual r_i(v) = v_i - v_i^n + (dt/m_i) sum_p G_p(v) grad w_ip
 * (one dt from the force increment, one from F(v); the test checks the 1/dt by differences).
 *
 * All matrices are d x d row-major, d = 2 or 3 at run time. Pure functions, no allocation. */
#ifndef SM_MATERIAL_IMPLICIT_H
#define SM_MATERIAL_IMPLICIT_H

#include "core/common.h"

/* Material of one particle. alpha is the particle's current Drucker–Prager coefficient (3.80). */
typedef struct {
    sm_real mu, lambda; /* Lamé parameters */
    sm_real alpha;      /* Drucker–Prager coefficient, used when plastic != 0 */
    int plastic;        /* 0: Y = dpsi/dF(F), no projection */
} sm_implicit_material;

/* Diagonal-space tensor Mhat (15 distinct entries in 3-D, 6 in 2-D). For A = Mhat : T:
 *   A_ii = sum_j ybar[i*d + j] T_jj                  (ybar = d y / d sigma, d x d, row-major)
 *   A_ij = a[k] T_ij + b[k] T_ji,  A_ji = a[k] T_ji + b[k] T_ij   for the pair k = (i, j), i < j,
 * pairs ordered (0,1) in 2-D and (0,1), (0,2), (1,2) in 3-D; a = (D + S)/2, b = (D - S)/2 with
 * D = (y_i - y_j)/(s_i - s_j), S = (y_i + y_j)/(s_i + s_j) (A.24-A.27). Unused entries are 0. */
typedef struct {
    sm_real ybar[9];
    sm_real a[3];
    sm_real b[3];
} sm_implicit_mhat;

/* What Algorithm 8 stores per particle (33 reals): U, Q = F^n V and V0 * Mhat. */
typedef struct {
    sm_real U[9];
    sm_real Q[9];
    sm_implicit_mhat M; /* already multiplied by V0 */
} sm_implicit_particle;

/* Diagonal space: from the signed singular values sigma of F, the stress y (d entries) and, if
 * mhat != NULL, Mhat. Returns the projection case: 0 (not plastic), 1, 2 or 3 (as sm_dp_project).
 * In case 2 y = 0 and Mhat = 0. */
int sm_implicit_diag(int d, const sm_real *sigma, const sm_implicit_material *mat, sm_real *y,
                     sm_implicit_mhat *mhat);

/* A = Mhat : T (d x d). A must not alias T. */
void sm_implicit_mhat_apply(int d, const sm_implicit_mhat *mhat, const sm_real *T, sm_real *A);

/* Y(F) (first Piola stress of the projected F). Returns the case as sm_implicit_diag. */
int sm_implicit_Y(int d, const sm_real *F, const sm_implicit_material *mat, sm_real *Y);

/* dY = M[dF] = dY/dF (F) applied to dF, computed directly (one SVD per call; for tests and
 * one-off use). Returns the case. Where the projection is not differentiable (case boundaries)
 * this is a one-sided derivative, that of the case sm_dp_project reports at F. */
int sm_implicit_dY(int d, const sm_real *F, const sm_real *dF, const sm_implicit_material *mat,
                   sm_real *dY);

/* FORCE_INCREMENT_VEL particle term: G = V0 Y(F) (F^n)^T with F = F^n + dt T F^n
 * (= (I + dt T) F^n; Fn is the elastic F at the step start). Returns the case. */
int sm_implicit_force_matrix(int d, const sm_real *Fn, sm_real dt, const sm_real *T, sm_real V0,
                             const sm_implicit_material *mat, sm_real *G);

/* PRECOMPUTE of Algorithm 8 for one particle at F = (I + dt T) F^n: stores U, Q = F^n V and
 * V0 Mhat in *p. If G != NULL it also writes the force matrix V0 Y(F) (F^n)^T, bitwise equal to
 * sm_implicit_force_matrix with the same arguments (one SVD for both). Returns the case. */
int sm_implicit_precompute(int d, const sm_real *Fn, sm_real dt, const sm_real *T, sm_real V0,
                           const sm_implicit_material *mat, sm_implicit_particle *p, sm_real *G);

/* HESSIAN_TIMES particle term of Algorithm 6: A = V0 U (Mhat : (U^T T1 Q)) Q^T, which equals
 * (1/dt) d/de [ V0 Y((I + dt (T + e T1)) F^n) (F^n)^T ] at e = 0. See the header comment for the
 * dt^2 / m_i the integrator applies. A may alias T1. */
void sm_implicit_apply(int d, const sm_implicit_particle *p, const sm_real *T1, sm_real *A);

#endif
