/* Material model: Hencky-strain St. Venant–Kirchhoff elasticity, Drucker–Prager return mapping and
 * hardening, all as pure functions of the singular values Sigma = diag(s_1..s_d) of F^E.
 *
 * Equations (Klár 2016 thesis; eps = ln Sigma, the principal Hencky strain, (3.62)):
 *   Lamé:        mu = E / (2 (1 + nu)),  lambda = E nu / ((1 + nu)(1 - 2 nu))
 *   (3.71)       psi = mu tr(eps^2) + lambda/2 (tr eps)^2
 *   Alg. 4       ENERGY_DERIVATIVE: dpsi/ds_i = (2 mu eps_i + lambda tr eps) / s_i,
 *                P = U diag(dpsi/ds) V^T for F = U Sigma V^T
 *   (3.70)       tau_i = dpsi/deps_i = s_i dpsi/ds_i = 2 mu eps_i + lambda tr eps
 *                (principal Kirchhoff stress: P F^T = U diag(tau) U^T)
 *   (3.68),(3.70) yield  y = ||dev tau|| + alpha tr tau = 2 mu ||dev eps|| + alpha (d lambda + 2 mu) tr eps
 *   (3.66)       dev A = A - tr(A)/d I
 *   (3.76)       dgamma = ||dev eps||_F + (d lambda + 2 mu)/(2 mu) tr(eps) alpha
 *   (3.75),(3.77) case III: H = eps - dgamma dev(eps)/||dev eps||_F, Sigma_new = exp(H)
 *   Alg. 2       PROJECT: case II (tr eps > 0 or dev eps = 0): Sigma_new = I, dq = ||eps||_F;
 *                case I (dgamma <= 0): unchanged, dq = 0; case III: dq = dgamma  (§3.5.3)
 *   (3.79)       phi_F = h0 + (h1 q - h3) exp(-h2 q)
 *   (3.80)       alpha = sqrt(2/3) 2 sin(phi_F) / (3 - sin(phi_F))
 *                (the square root covers only 2/3, as in Algorithm 2 line 9; the extracted text of
 *                (3.80) misplaces it)
 *
 * Cone fits (sm_cone_fit; not in the thesis, which has only (3.80); derivation in
 * docs/validation.md). With the deviatoric flow of case III, steady simple shear has
 * dev tau parallel to the shear rate, so ||dev tau|| = sqrt(2) |tau_xy| and tr tau = -d p:
 *   mu_eff = tau_xy / p = d alpha / sqrt(2)  (3D: 3 alpha/sqrt 2, 2D: sqrt(2) alpha)
 * and, with s = sin(phi), c = sqrt(2/3):
 *   triaxial compression (3.80)  alpha = 2 c s / (3 - s)           (any d)
 *   plane strain                 alpha = sqrt(2) s / d             (mu_eff = s)
 *   inscribed                    alpha = c s / sqrt(3 + s^2)       (any d)
 *   simple shear                 alpha = sqrt(2) tan(phi) / d      (mu_eff = tan phi)
 *
 * Case III is evaluated in the algebraically identical form
 *   H = tr(eps)/d I + (1 - dgamma/||dev eps||) dev eps,
 *   1 - dgamma/||dev eps|| = -(d lambda + 2 mu) tr(eps) alpha / (2 mu ||dev eps||),
 * so that the result lies on the cone (y = 0) to rounding and its deviator is exactly parallel to
 * the trial one.
 *
 * Inverted/degenerate F: see SM_SIGMA_FLOOR in material.h. */
#include "material/material.h"

#include <math.h>

/* Raise singular values to the floor. Written so that NaN propagates instead of being hidden. */
static void clamp_sigma(int d, const sm_real *sigma, sm_real *c) {
    for (int i = 0; i < d; i++) c[i] = sigma[i] < SM_SIGMA_FLOOR ? SM_SIGMA_FLOOR : sigma[i];
}

/* eps = ln(max(sigma, floor)); returns tr eps. */
static sm_real hencky_strain(int d, const sm_real *sigma, sm_real *c, sm_real *eps) {
    clamp_sigma(d, sigma, c);
    sm_real tr = 0;
    for (int i = 0; i < d; i++) {
        eps[i] = sm_log(c[i]);
        tr += eps[i];
    }
    return tr;
}

static sm_real norm_d(int d, const sm_real *v) {
    sm_real s = 0;
    for (int i = 0; i < d; i++) s += v[i] * v[i];
    return sm_sqrt(s);
}

void sm_lame(double E, double nu, double *mu, double *lambda) {
    SM_ASSERT(mu != NULL && lambda != NULL);
    *mu = E / (2.0 * (1.0 + nu));
    *lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
}

sm_real sm_hencky_psi(int d, const sm_real *sigma, sm_real mu, sm_real lambda) {
    SM_ASSERT(d == 2 || d == 3);
    sm_real c[3], eps[3];
    sm_real tr = hencky_strain(d, sigma, c, eps);
    sm_real sq = 0;
    for (int i = 0; i < d; i++) sq += eps[i] * eps[i];
    return mu * sq + SM_R(0.5) * lambda * tr * tr;
}

void sm_hencky_dpsi(int d, const sm_real *sigma, sm_real mu, sm_real lambda, sm_real *out) {
    SM_ASSERT(d == 2 || d == 3);
    sm_real c[3], eps[3];
    sm_real tr = hencky_strain(d, sigma, c, eps);
    for (int i = 0; i < d; i++) out[i] = (2 * mu * eps[i] + lambda * tr) / c[i];
}

void sm_hencky_tau(int d, const sm_real *sigma, sm_real mu, sm_real lambda, sm_real *tau) {
    SM_ASSERT(d == 2 || d == 3);
    sm_real c[3], eps[3];
    sm_real tr = hencky_strain(d, sigma, c, eps);
    for (int i = 0; i < d; i++) {
        sm_real t = 2 * mu * eps[i] + lambda * tr;
        /* below the floor: s_i dpsi/ds_i with dpsi held at the floor, so that
         * U diag(tau) U^T = P F^T holds for an inverted F too */
        tau[i] = sigma[i] < SM_SIGMA_FLOOR ? t * (sigma[i] / SM_SIGMA_FLOOR) : t;
    }
}

sm_real sm_dp_yield(int d, const sm_real *sigma, sm_real alpha, sm_real mu, sm_real lambda) {
    SM_ASSERT(d == 2 || d == 3);
    sm_real c[3], eps[3], dev[3];
    sm_real tr = hencky_strain(d, sigma, c, eps);
    for (int i = 0; i < d; i++) dev[i] = eps[i] - tr / (sm_real)d;
    return 2 * mu * norm_d(d, dev) + alpha * ((sm_real)d * lambda + 2 * mu) * tr;
}

int sm_dp_project(int d, const sm_real *sigma, sm_real alpha, sm_real mu, sm_real lambda,
                  sm_real *out, sm_real *dq) {
    SM_ASSERT(d == 2 || d == 3);
    SM_ASSERT(mu > 0);
    sm_real c[3], eps[3], dev[3];
    sm_real tr = hencky_strain(d, sigma, c, eps);
    sm_real mean = tr / (sm_real)d;
    sm_real emax = 0, devmax = 0;
    for (int i = 0; i < d; i++) {
        dev[i] = eps[i] - mean;
        emax = SM_MAX(emax, sm_fabs(eps[i]));
        devmax = SM_MAX(devmax, sm_fabs(dev[i]));
    }
    if (tr > 0) { /* case II: tension, tip of the cone */
        *dq = norm_d(d, eps);
        for (int i = 0; i < d; i++) out[i] = 1;
        return 2;
    }
    /* "dev eps = 0": computing dev from d logarithms rounds to a few ulps of max|eps_i| even for an
     * exactly hydrostatic Sigma, so a deviator at or below 2 d SM_EPS max|eps_i| is zero. Under
     * compression (tr <= 0) that is a point on the cone's axis, inside it (case I): Algorithm 2's
     * "dev eps = 0 -> tip" would send Sigma = 0.99 I to Sigma = 1 while 0.99 I plus any measurable
     * deviator stays put (issue 12). */
    int zero_dev = devmax <= SM_R(2.0) * (sm_real)d * SM_EPS * emax;
    sm_real ndev = norm_d(d, dev);
    sm_real kappa = ((sm_real)d * lambda + 2 * mu) / (2 * mu) * tr * alpha; /* <= 0 for alpha >= 0 */
    sm_real dgamma = ndev + kappa;
    if (zero_dev || dgamma <= 0) { /* case I: inside the cone; the input is kept as it is (even inverted) */
        *dq = 0;
        for (int i = 0; i < d; i++) out[i] = sigma[i];
        return 1;
    }
    /* case III: back to the cone along -dev(eps). ||dev H|| = ndev - dgamma = -kappa. */
    sm_real scale = -kappa / ndev;
    for (int i = 0; i < d; i++) out[i] = sm_exp(mean + scale * dev[i]);
    *dq = dgamma;
    return 3;
}

double sm_dp_alpha(double phi_rad) {
    double s = sin(phi_rad);
    return sqrt(2.0 / 3.0) * 2.0 * s / (3.0 - s);
}

double sm_dp_alpha_fit(double phi_rad, int fit, int d) {
    if (d != 2 && d != 3) return NAN;
    double s = sin(phi_rad);
    switch (fit) {
    case SM_CONE_TRIAXIAL_COMPRESSION: return sm_dp_alpha(phi_rad);
    case SM_CONE_PLANE_STRAIN: return sqrt(2.0) * s / d;
    case SM_CONE_INSCRIBED: return sqrt(2.0 / 3.0) * s / sqrt(3.0 + s * s);
    case SM_CONE_SIMPLE_SHEAR: return sqrt(2.0) * tan(phi_rad) / d;
    default: return NAN;
    }
}

double sm_dp_phi_for_alpha(double alpha, int fit, int d) {
    if ((d != 2 && d != 3) || !(alpha >= 0)) return NAN;
    const double c2 = 2.0 / 3.0;
    double s;
    switch (fit) {
    case SM_CONE_TRIAXIAL_COMPRESSION: s = 3 * alpha / (2 * sqrt(c2) + alpha); break;
    case SM_CONE_PLANE_STRAIN: s = alpha * d / sqrt(2.0); break;
    case SM_CONE_INSCRIBED: s = alpha * alpha < c2 ? sqrt(3 * alpha * alpha / (c2 - alpha * alpha)) : 2; break;
    case SM_CONE_SIMPLE_SHEAR: return atan(alpha * d / sqrt(2.0));
    default: return NAN;
    }
    return s < 1 ? asin(s) : NAN;
}

static const double DEG_PER_RAD = 180.0 / SM_PI;

double sm_cone_alpha(double degrees, sm_cone_fit fit, int dim) {
    return sm_dp_alpha_fit(degrees / DEG_PER_RAD, (int)fit, dim);
}

double sm_effective_friction(double alpha, int dim) {
    return (dim == 2 || dim == 3) ? alpha * dim / sqrt(2.0) : NAN;
}

double sm_friction_angle_for_effective_friction(double mu, sm_cone_fit fit, int dim) {
    if ((dim != 2 && dim != 3) || !(mu >= 0) || !isfinite(mu)) return NAN;
    return sm_dp_phi_for_alpha(mu * sqrt(2.0) / dim, (int)fit, dim) * DEG_PER_RAD;
}

double sm_hardening_phi(double q, double h0, double h1, double h2, double h3) {
    return h0 + (h1 * q - h3) * exp(-h2 * q);
}

void sm_material_udvt(int d, const sm_real *U, const sm_real *diag, const sm_real *V, sm_real *out) {
    SM_ASSERT(d == 2 || d == 3);
    sm_real r[9];
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            sm_real s = 0;
            for (int k = 0; k < d; k++) s += U[i * d + k] * diag[k] * V[j * d + k];
            r[i * d + j] = s;
        }
    for (int i = 0; i < d * d; i++) out[i] = r[i];
}

void sm_hencky_piola(int d, const sm_real *U, const sm_real *sigma, const sm_real *V, sm_real mu,
                     sm_real lambda, sm_real *P) {
    sm_real g[3];
    sm_hencky_dpsi(d, sigma, mu, lambda, g);
    sm_material_udvt(d, U, g, V, P);
}
