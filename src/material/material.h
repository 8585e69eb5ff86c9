/* Material models as pure functions of singular values and parameters (DESIGN §2).
 *
 * Hencky-strain St. Venant–Kirchhoff energy (thesis 3.71), its derivatives, the Drucker–Prager
 * return mapping PROJECT (Algorithm 2, 3.62–3.77) and hardening (3.78–3.80). Dimension d is 2 or 3
 * and passed at run time; singular values are arrays of d entries. */
#ifndef SM_MATERIAL_H
#define SM_MATERIAL_H

#include "core/common.h"

/* Robustness policy for inverted or degenerate F (the signed SVD gives sigma_d <= 0 when
 * det F <= 0): every function below first raises each singular value to at least
 * SM_SIGMA_FLOOR, s_c = max(s, floor), and evaluates the formulas at s_c. So nothing returns
 * NaN/Inf for finite input (NaN input stays NaN):
 *  - psi and the yield function are those of s_c (psi stays >= 0);
 *  - dpsi/dsigma is held at its value at the floor: a compressive, restoring stress that pushes an
 *    inverted direction back up (the slope of psi continued linearly below the floor; below the
 *    floor dpsi is therefore not the derivative of the clamped psi, which is flat there);
 *  - tau_i = s_i dpsi/dsigma_i with the signed s_i, so U diag(tau) U^T = P F^T stays exact;
 *  - sm_dp_project computes eps = ln s_c. Case 1 returns the input unchanged (even an inverted
 *    one); cases 2 and 3 return positive singular values, i.e. they also remove an inversion. */
#define SM_SIGMA_FLOOR SM_R(1e-4)

/* Lame parameters from Young's modulus and Poisson ratio. */
void sm_lame(double E, double nu, double *mu, double *lambda);

/* psi(Sigma) = mu tr((ln Sigma)^2) + lambda/2 (tr ln Sigma)^2  (3.71). sigma_i below the floor:
 * see SM_SIGMA_FLOOR. */
sm_real sm_hencky_psi(int d, const sm_real *sigma, sm_real mu, sm_real lambda);

/* ENERGY_DERIVATIVE (Algorithm 4): dpsi/dsigma_i = (2 mu ln s_i + lambda tr ln Sigma) / s_i. */
void sm_hencky_dpsi(int d, const sm_real *sigma, sm_real mu, sm_real lambda, sm_real *out);

/* Principal Kirchhoff stress tau_i = 2 mu ln s_i + lambda tr ln Sigma  (3.70), = s_i dpsi/dsigma_i,
 * so that P F^T = U diag(tau) U^T (below the floor: see SM_SIGMA_FLOOR). */
void sm_hencky_tau(int d, const sm_real *sigma, sm_real mu, sm_real lambda, sm_real *tau);

/* Drucker–Prager yield function in principal strain space:
 * y = 2 mu ||dev eps|| + alpha (d lambda + 2 mu) tr eps, with eps = ln Sigma.
 * y <= 0 is admissible (with tr eps <= 0). Same sign convention as (3.76) scaled by 2 mu. */
sm_real sm_dp_yield(int d, const sm_real *sigma, sm_real alpha, sm_real mu, sm_real lambda);

/* PROJECT(Sigma, alpha) of Algorithm 2. Writes the projected singular values to out (may alias
 * sigma) and the hardening increment to *dq. Returns the case: 1 (inside, unchanged),
 * 2 (tension, tr eps > 0: tip of the cone, out = 1, dq = ||eps||), 3 (projected onto the cone).
 * A zero deviator (max|dev eps_i| <= 2 d SM_EPS max|eps_i|, the rounding level of computing
 * dev eps) under compression (tr eps <= 0) lies on the cone's axis: case 1. Algorithm 2 sends it
 * to the tip; that made the map jump there (0.99 I -> I, while 0.99 I plus a 1e-9 deviator stays),
 * issue 12. Only tension goes to the tip. */
int sm_dp_project(int d, const sm_real *sigma, sm_real alpha, sm_real mu, sm_real lambda,
                  sm_real *out, sm_real *dq);

/* alpha = sqrt(2/3) * 2 sin(phi) / (3 - sin(phi)) (3.80), phi in radians. */
double sm_dp_alpha(double phi_rad);

/* alpha for friction angle phi (radians) with cone fit `fit` (an sm_cone_fit) in dimension d; NaN
 * for an unknown fit or d (the fits: material.c's header comment). */
double sm_dp_alpha_fit(double phi_rad, int fit, int d);

/* The inverse: phi in radians in [0, pi/2) with sm_dp_alpha_fit(phi, fit, d) = alpha (>= 0); NaN if
 * the fit cannot reach alpha (or bad arguments). */
double sm_dp_phi_for_alpha(double alpha, int fit, int d);

/* Hardening friction angle (3.79), everything in radians except h2: h0 + (h1 q - h3) exp(-h2 q). */
double sm_hardening_phi(double q, double h0, double h1, double h2, double h3);

/* out = U diag(diag) V^T for d x d row-major U, V (d = 2, 3). out may alias U or V. */
void sm_material_udvt(int d, const sm_real *U, const sm_real *diag, const sm_real *V, sm_real *out);

/* First Piola-Kirchhoff stress P = U diag(dpsi/dsigma) V^T of F = U diag(sigma) V^T (d x d,
 * row-major), with the floor policy above. P may alias U or V. */
void sm_hencky_piola(int d, const sm_real *U, const sm_real *sigma, const sm_real *V, sm_real mu,
                     sm_real lambda, sm_real *P);

#endif
