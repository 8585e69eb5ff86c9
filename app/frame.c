/* Frames: allocation and frames from a world; see frame.h. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/frame.h"
#include "app/io/fields.h"

void sm_frame_free(sm_frame *f) {
    if (!f) return;
    free(f->x);
    free(f->v);
    free(f->q);
    free(f->volume);
    free(f->material);
    free(f->id);
    memset(f, 0, sizeof *f);
}

sm_status sm_frame_alloc(sm_frame *f, size_t n, int want_volume, int want_id) {
    size_t m = n ? n : 1;
    if (m > SIZE_MAX / (3 * sizeof(float))) return SM_ERR_NOMEM;
    f->n = n;
    f->x = calloc(3 * m, sizeof(float));
    f->v = calloc(3 * m, sizeof(float));
    f->q = calloc(m, sizeof(float));
    f->material = calloc(m, sizeof(uint16_t));
    if (want_volume) f->volume = calloc(m, sizeof(float));
    if (want_id) f->id = calloc(m, sizeof(uint32_t));
    if (!f->x || !f->v || !f->q || !f->material || (want_volume && !f->volume) || (want_id && !f->id))
        return SM_ERR_NOMEM;
    return SM_OK;
}

sm_status sm_frame_from_world(const sm_world *w, sm_frame *f, char *err, size_t errlen) {
    memset(f, 0, sizeof *f);
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    size_t *order = sm_out_id_order(&pv);
    if (!order || sm_frame_alloc(f, pv.n, 1, 1) != SM_OK) {
        free(order);
        sm_frame_free(f);
        if (err && errlen) snprintf(err, errlen, "out of memory for a frame of %zu particles", pv.n);
        return SM_ERR_NOMEM;
    }
    const int d = pv.dim;
    f->dim = d;
    for (size_t k = 0; k < pv.n; k++) { /* k: id order, as the frame files (app/io/fields.h) */
        const size_t i = order[k];
        for (int a = 0; a < d; a++) {
            f->x[3 * k + (size_t)a] = (float)pv.x[i * (size_t)d + (size_t)a];
            f->v[3 * k + (size_t)a] = (float)pv.v[i * (size_t)d + (size_t)a];
        }
        f->q[k] = (float)pv.q[i];
        f->volume[k] = (float)pv.vol0[i];
        f->material[k] = pv.material[i];
        f->id[k] = pv.id[i];
    }
    free(order);
    f->has_velocity = f->has_q = f->has_material = 1;
    const sm_world_def *def = sm_world_get_def(w);
    f->has_domain = 1;
    for (int k = 0; k < 3; k++) {
        f->domain_min[k] = def->domain_min[k];
        f->domain_max[k] = def->domain_max[k];
    }
    if (d == 2) f->domain_min[2] = f->domain_max[2] = 0;
    return SM_OK;
}
