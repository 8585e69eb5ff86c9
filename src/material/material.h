/* Material models as pure functions of singular values and parameters (DESIGN §2).
 *
 * Hencky-strain St. Venant–Kirchhoff energy (thesis 3.71), its derivatives, the Drucker–Prager
 * return mapping PROJECT (Algorithm 2, 3.62–3.77) and hardening (3.78–3.80). Dimension d is 2 or 3
 * and passed at run time; singular values are arrays of d entries. */
#ifndef SM_MATERIAL_H
#define SM_MATERIAL_H

#include "core/common.h"

/* Lame parameters from Young's modulus and Poisson ratio. */
void sm_lame(double E, double nu, double *mu, double *lambda);

/* psi(Sigma) = mu tr((ln Sigma)^2) + lambda/2 (tr ln Sigma)^2  (3.71). sigma_i > 0. */
sm_real sm_hencky_psi(int d, const sm_real *sigma, sm_real mu, sm_real lambda);

/* ENERGY_DERIVATIVE (Algorithm 4): dpsi/dsigma_i = (2 mu ln s_i + lambda tr ln Sigma) / s_i. */
void sm_hencky_dpsi(int d, const sm_real *sigma, sm_real mu, sm_real lambda, sm_real *out);

/* Principal Kirchhoff stress tau_i = 2 mu ln s_i + lambda tr ln Sigma  (3.70). */
void sm_hencky_tau(int d, const sm_real *sigma, sm_real mu, sm_real lambda, sm_real *tau);

/* Drucker–Prager yield function in principal strain space:
 * y = 2 mu ||dev eps|| + alpha (d lambda + 2 mu) tr eps, with eps = ln Sigma.
 * y <= 0 is admissible (with tr eps <= 0). Same sign convention as (3.76) scaled by 2 mu. */
sm_real sm_dp_yield(int d, const sm_real *sigma, sm_real alpha, sm_real mu, sm_real lambda);

/* PROJECT(Sigma, alpha) of Algorithm 2. Writes the projected singular values to out (may alias
 * sigma) and the hardening increment to *dq. Returns the case: 1 (inside, unchanged),
 * 2 (tension or zero deviator: tip of the cone, out = 1), 3 (projected onto the cone). */
int sm_dp_project(int d, const sm_real *sigma, sm_real alpha, sm_real mu, sm_real lambda,
                  sm_real *out, sm_real *dq);

/* alpha = sqrt(2/3) * 2 sin(phi) / (3 - sin(phi)) (3.80), phi in radians. */
double sm_dp_alpha(double phi_rad);

/* Hardening friction angle (3.79), everything in radians except h2: h0 + (h1 q - h3) exp(-h2 q). */
double sm_hardening_phi(double q, double h0, double h1, double h2, double h3);

#endif
