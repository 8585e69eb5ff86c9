/* Particle storage: structure of arrays, grown geometrically. */
#include <string.h>

#include "world_internal.h"

static int grow(void **ptr, size_t elem, size_t n) {
    void *q = sm_realloc(*ptr, elem * n);
    if (!q) return 0;
    *ptr = q;
    return 1;
}

sm_status sm_particles_reserve(sm_particles *p, int dim, size_t n) {
    if (n <= p->cap) return SM_OK;
    /* Exactly n when a large batch arrives (seeding); 25% headroom for trickles (emitters). */
    size_t cap = p->cap + p->cap / 4;
    if (cap < n) cap = n;
    if (cap < 1024) cap = 1024;
    size_t d = (size_t)dim, dd = d * d;
    int ok = grow((void **)&p->x, sizeof(sm_real) * d, cap) && grow((void **)&p->v, sizeof(sm_real) * d, cap) &&
             grow((void **)&p->B, sizeof(sm_real) * dd, cap) && grow((void **)&p->F, sizeof(sm_real) * dd, cap) &&
             grow((void **)&p->tau, sizeof(sm_real) * SM_NTAU(d), cap) &&
             grow((void **)&p->vol0, sizeof(sm_real), cap) && grow((void **)&p->q, sizeof(sm_real), cap) &&
             grow((void **)&p->alpha, sizeof(sm_real), cap) && grow((void **)&p->mat, sizeof(uint16_t), cap);
    if (!ok) return SM_ERR_NOMEM;
    p->cap = cap;
    return SM_OK;
}

void sm_particles_free(sm_particles *p) {
    free(p->x);
    free(p->v);
    free(p->B);
    free(p->F);
    free(p->tau);
    free(p->vol0);
    free(p->q);
    free(p->alpha);
    free(p->mat);
    memset(p, 0, sizeof *p);
}
