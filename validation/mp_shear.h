/* Steady simple shear of one material point, with the step's own kinematics and return mapping:
 * the check of the effective friction mu_eff = d alpha / sqrt(2) (docs/validation.md, "What the
 * friction angle means"), used by tests/test_cone_fit.c and validation/analytic.c.
 *
 * Each step, as in the MPM step (thesis Algorithm 1, G2P then plasticity):
 *   F^E <- (I + dt grad v) F^E,   grad v = gamma_dot e_x (x) e_y   (v_x = gamma_dot y)
 *   F^E = U Sigma V^T (sm_svd2/3),  Sigma <- PROJECT(Sigma, alpha) (Algorithm 2),  F^E = U Sigma V^T
 * starting from an isotropic compression F^E = exp(-e0) I (pressure p0 = (d lambda + 2 mu) e0 / d
 * in Kirchhoff stress); simple shear and the plastic flow both keep the volume, so the pressure
 * stays. After a shear strain gamma_total the Kirchhoff stress tau = U diag(tau_i) U^T (3.70) gives
 *   mu_sim = tau_xy / (-tau_yy), and tau_yy, tau_xx, tau_zz to compare with -p.
 * Needs material/material.h and math/svd.h. */
#ifndef SM_VALIDATION_MP_SHEAR_H
#define SM_VALIDATION_MP_SHEAR_H

#include <math.h>

typedef struct mp_shear_result {
    double mu;           /* tau_xy / (-tau_yy) at the end */
    double tau_xx, tau_yy, tau_xy, tau_zz; /* Kirchhoff stress at the end, Pa (tau_zz: 0 in 2D) */
    double pressure;     /* -tr(tau)/d at the end */
} mp_shear_result;

static inline void mp_shear_run(int d, double alpha, double mu_lame, double lambda_lame, double e0,
                                double dgamma, double gamma_total, mp_shear_result *out) {
    sm_real F[9] = {0}, U[9], V[9], s[3], sn[3], t[3];
    for (int i = 0; i < d; i++) F[i * d + i] = (sm_real)exp(-e0);
    long steps = (long)ceil(gamma_total / dgamma);
    for (long n = 0; n < steps; n++) {
        /* F <- (I + dgamma e_x e_y^T) F: row x gains dgamma times row y */
        for (int j = 0; j < d; j++) F[0 * d + j] += (sm_real)dgamma * F[1 * d + j];
        if (d == 3)
            sm_svd3(F, U, s, V);
        else
            sm_svd2(F, U, s, V);
        sm_real dq;
        sm_dp_project(d, s, (sm_real)alpha, (sm_real)mu_lame, (sm_real)lambda_lame, sn, &dq);
        sm_material_udvt(d, U, sn, V, F);
    }
    if (d == 3)
        sm_svd3(F, U, s, V);
    else
        sm_svd2(F, U, s, V);
    sm_hencky_tau(d, s, (sm_real)mu_lame, (sm_real)lambda_lame, t);
    double T[9] = {0};
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++)
            for (int k = 0; k < d; k++) T[i * d + j] += (double)U[i * d + k] * (double)t[k] * (double)U[j * d + k];
    out->tau_xx = T[0];
    out->tau_xy = T[1];
    out->tau_yy = T[d + 1];
    out->tau_zz = d == 3 ? T[8] : 0;
    out->pressure = -(T[0] + T[d + 1] + (d == 3 ? T[8] : 0)) / d;
    out->mu = out->tau_xy / -out->tau_yy;
}

#endif
