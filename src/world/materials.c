/* The world's materials: the defaults, the checks of a definition (the library's limits, usable
 * without a world) and what the step precomputes per material (material/material_rt.h). */
#include <string.h>

#include "material/material.h"
#include "world/world.h"

sm_material_def sm_material_def_sand(void) {
    sm_material_def m;
    memset(&m, 0, sizeof m);
    m.kind = SM_MATERIAL_SAND;
    m.density = 2200;
    m.youngs_modulus = 3.537e5;
    m.poisson_ratio = 0.3;
    m.hardening = 1;
    m.friction_angle = 30;
    m.h0 = 35;
    m.h1 = 9;
    m.h2 = 0.2;
    m.h3 = 10;
    return m;
}

sm_material_def sm_material_def_elastic(void) {
    sm_material_def m;
    memset(&m, 0, sizeof m);
    m.kind = SM_MATERIAL_ELASTIC;
    m.density = 1000;
    m.youngs_modulus = 1e5;
    m.poisson_ratio = 0.3;
    return m;
}

static const double DEG = SM_PI / 180.0;

double sm_hardening_friction_angle(const sm_material_def *m, double q) {
    if (m->kind != SM_MATERIAL_SAND) return 0;
    if (!m->hardening) return m->friction_angle;
    return sm_hardening_phi(q, m->h0 * DEG, m->h1 * DEG, m->h2, m->h3 * DEG) / DEG;
}

double sm_alpha_from_friction_angle(double degrees) { return sm_dp_alpha(degrees * DEG); }

/* phi_F(q) = h0 + (h1 q - h3) exp(-h2 q) (3.79, degrees; h_i >= 0, h0 > h3 checked before) must
 * stay in [0, 90) over q >= 0, or the cone inverts (alpha < 0) or opens past the half-space.
 * phi_F(0) = h0 - h3 > 0 is its minimum and phi_F -> h0 < 90 as q -> inf (h2 > 0). With h1 > 0
 * it has one maximum: dphi/dq = exp(-h2 q) (h1 - h2 (h1 q - h3)) = 0 at q* = 1/h2 + h3/h1, where
 * phi_F(q*) = h0 + (h1/h2) exp(-(1 + h2 h3/h1)). With h2 = 0 and h1 > 0, phi_F = h0 - h3 + h1 q grows
 * without bound (35/9/0/10 reaches 205 degrees at q = 20). With h1 = 0 phi_F rises from h0 - h3
 * towards h0. */
static sm_status hardening_peak_check(const sm_material_def *m, char *err, size_t errlen) {
    if (!(m->h1 > 0)) return SM_OK;
    if (!(m->h2 > 0))
        return sm_check_fail(err, errlen,
                             "hardening: with h2 = 0 and h1 > 0, phi_F = h0 - h3 + h1 q grows without bound (90 degrees "
                             "at q = %.4g); give h2 > 0 so that it peaks below 90",
                             (90 - m->h0 + m->h3) / m->h1);
    const double qpeak = 1 / m->h2 + m->h3 / m->h1;
    const double peak = m->h0 + (m->h1 / m->h2) * exp(-(1 + m->h2 * m->h3 / m->h1));
    if (!(peak < 90))
        return sm_check_fail(err, errlen,
                             "hardening: phi_F = h0 + (h1 q - h3) exp(-h2 q) peaks at %.4g degrees at q = %.4g "
                             "(h0 + (h1/h2) exp(-(1 + h2 h3/h1))); must stay below 90: lower h1 or raise h2",
                             peak, qpeak);
    return SM_OK;
}

sm_status sm_material_def_check(const sm_material_def *m, char *err, size_t errlen) {
    if (!m) return sm_check_fail(err, errlen, "material definition is NULL");
    if (m->kind != SM_MATERIAL_SAND && m->kind != SM_MATERIAL_ELASTIC)
        return sm_check_fail(err, errlen, "material kind: unknown value %d", (int)m->kind);
    if (!(m->density > 0) || !isfinite(m->density))
        return sm_check_fail(err, errlen, "density: must be > 0, got %g", m->density);
    if (!(m->youngs_modulus > 0) || !isfinite(m->youngs_modulus))
        return sm_check_fail(err, errlen, "E: must be > 0, got %g", m->youngs_modulus);
    if (!(m->poisson_ratio > -1 && m->poisson_ratio < 0.5))
        return sm_check_fail(err, errlen, "nu: must be in (-1, 0.5), got %g", m->poisson_ratio);
    if (m->kind == SM_MATERIAL_SAND) {
        if ((unsigned)m->cone_fit > (unsigned)SM_CONE_SIMPLE_SHEAR)
            return sm_check_fail(err, errlen, "cone_fit: unknown value %d", (int)m->cone_fit);
        if (m->hardening) {
            const double h[4] = {m->h0, m->h1, m->h2, m->h3};
            for (int i = 0; i < 4; i++)
                if (!isfinite(h[i]) || h[i] < 0)
                    return sm_check_fail(err, errlen, "h%d: must be finite and >= 0, got %g", i, h[i]);
            if (!(m->h0 > m->h3))
                return sm_check_fail(err, errlen, "hardening: need h0 > h3 (thesis §3.5.3), got h0 = %g, h3 = %g", m->h0, m->h3);
            if (!(m->h0 < 90))
                return sm_check_fail(err, errlen, "h0: must be < 90 degrees (phi_F tends to h0), got %g", m->h0);
            const sm_status st = hardening_peak_check(m, err, errlen);
            if (st != SM_OK) return st;
        } else if (!(m->friction_angle >= 0 && m->friction_angle < 90)) {
            return sm_check_fail(err, errlen, "friction_angle: must be in [0, 90) degrees, got %g", m->friction_angle);
        }
    }
    return SM_OK;
}

sm_status sm_world_add_material(sm_world *w, const sm_material_def *m, int *id) {
    if (id) *id = -1;
    if (sm_material_def_check(m, w->err, sizeof w->err) != SM_OK) return SM_ERR_INVALID;
    if (w->nmats >= 65535) return sm_world_fail(w, SM_ERR_INVALID, "too many materials (65535)");
    if (w->nmats == w->mats_cap) {
        int cap = w->mats_cap ? 2 * w->mats_cap : 4;
        sm_material_rt *q = sm_realloc(w->mats, (size_t)cap * sizeof *q);
        if (!q) return sm_world_fail(w, SM_ERR_NOMEM, "out of memory");
        w->mats = q;
        w->mats_cap = cap;
    }
    sm_material_rt *r = &w->mats[w->nmats];
    memset(r, 0, sizeof *r);
    r->def = *m;
    double mu, lambda;
    sm_lame(m->youngs_modulus, m->poisson_ratio, &mu, &lambda);
    /* Hardening parameters in radians (h2 dimensionless), in double for alpha0, as sm_real for
     * the lanes. */
    const double h0 = m->h0 * DEG, h1 = m->h1 * DEG, h2 = m->h2, h3 = m->h3 * DEG;
    sm_plastic_params *law = &r->law;
    law->mu = (sm_real)mu;
    law->lambda = (sm_real)lambda;
    law->plastic = (m->kind == SM_MATERIAL_SAND);
    law->hardening = law->plastic && m->hardening;
    law->h0 = (sm_real)h0;
    law->h1 = (sm_real)h1;
    law->h2 = (sm_real)h2;
    law->h3 = (sm_real)h3;
    law->fit = (int32_t)m->cone_fit;
    r->density = (sm_real)m->density;
    if (law->plastic)
        r->alpha0 = (sm_real)sm_dp_alpha_fit(law->hardening ? sm_hardening_phi(0, h0, h1, h2, h3) : m->friction_angle * DEG,
                                             law->fit, w->dim);
    r->wave_speed = sqrt((lambda + 2 * mu) / m->density);
    if (id) *id = w->nmats;
    w->nmats++;
    return SM_OK;
}

