/* The frame writers' per-particle fields and their order; see fields.h. */
#include <stdlib.h>

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
    r->id = pv->id[i];
}

static int cmp_u64(const void *a, const void *b) {
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Ids that are not 0..n-1: sort (id, index) pairs, the index breaking ties. */
static size_t *sorted_order(const sm_particles_view *pv, size_t *order) {
    uint64_t *key = malloc((pv->n ? pv->n : 1) * sizeof *key);
    if (!key) {
        free(order);
        return NULL;
    }
    for (size_t i = 0; i < pv->n; i++) key[i] = (uint64_t)pv->id[i] << 32 | (uint64_t)(uint32_t)i;
    qsort(key, pv->n, sizeof *key, cmp_u64);
    for (size_t k = 0; k < pv->n; k++) order[k] = (size_t)(key[k] & 0xffffffffu);
    free(key);
    return order;
}

size_t *sm_out_id_order(const sm_particles_view *pv) {
    const size_t n = pv->n;
    size_t *order = malloc((n ? n : 1) * sizeof *order);
    if (!order) return NULL;
    for (size_t k = 0; k < n; k++) order[k] = SIZE_MAX;
    for (size_t i = 0; i < n; i++) {
        const uint32_t id = pv->id[i];
        if (id >= n || order[id] != SIZE_MAX) return sorted_order(pv, order);
        order[id] = i;
    }
    return order;
}

void sm_out_to_z_up(sm_out_particle *r) {
    const float y = r->x[1], vy = r->v[1];
    r->x[1] = -r->x[2], r->x[2] = y;
    r->v[1] = -r->v[2], r->v[2] = vy;
}
