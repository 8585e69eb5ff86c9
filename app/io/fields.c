/* The frame writers' per-particle fields; see fields.h. */
#include "app/io/fields.h"

/* det F for a dim x dim row-major F, in double. */
static double det(const sm_real *F, int d) {
    if (d == 2) return (double)F[0] * F[3] - (double)F[1] * F[2];
    return (double)F[0] * ((double)F[4] * F[8] - (double)F[5] * F[7]) - (double)F[1] * ((double)F[3] * F[8] - (double)F[5] * F[6]) +
           (double)F[2] * ((double)F[3] * F[7] - (double)F[4] * F[6]);
}

void sm_out_particle_get(const sm_world *w, const sm_particles_view *pv, size_t i, sm_out_particle *r) {
    const int d = pv->dim;
    for (int a = 0; a < 3; a++) {
        r->x[a] = a < d ? (float)pv->x[i * (size_t)d + (size_t)a] : 0.0f;
        r->v[a] = a < d ? (float)pv->v[i * (size_t)d + (size_t)a] : 0.0f;
    }
    r->material = pv->material[i];
    r->q = (float)pv->q[i];
    r->friction_angle = (float)sm_world_particle_friction_angle(w, i);
    r->Je = (float)det(pv->F + i * (size_t)d * (size_t)d, d);
    r->volume = (float)pv->vol0[i];
}
