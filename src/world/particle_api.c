/* The particle API of the world: adding particles (checked: finite, 2 cells inside the
 * domain), the read-only view and the writable velocities, per-particle queries, the bytes per
 * particle. Storage is particles/particles.h's. */
#include <string.h>

#include "world/world.h"

sm_status sm_world_reserve_particles(sm_world *w, size_t n) {
    if (w->def.max_particles && n > w->def.max_particles)
        return sm_world_fail(w, SM_ERR_INVALID, "particles: %zu would exceed max_particles = %zu", n, w->def.max_particles);
    if (n > 0x7fffffffu) return sm_world_fail(w, SM_ERR_INVALID, "particles: at most %u supported", 0x7fffffffu);
    if (sm_particles_reserve(&w->p, w->dim, n) != SM_OK)
        return sm_world_fail(w, SM_ERR_NOMEM, "out of memory for %zu particles", n);
    if (sm_bins_reserve_perm(&w->bins, w->p.cap) != SM_OK) return sm_world_fail(w, SM_ERR_NOMEM, "out of memory");
    return SM_OK;
}

sm_status sm_world_add_particles(sm_world *w, size_t n, const double *positions, const double *velocities,
                                 int material, double ppc) {
    if (material < 0 || material >= w->nmats)
        return sm_world_fail(w, SM_ERR_INVALID, "material: unknown id %d (%d defined)", material, w->nmats);
    if (!(ppc > 0) || !isfinite(ppc)) return sm_world_fail(w, SM_ERR_INVALID, "ppc: must be > 0, got %g", ppc);
    if (n == 0) return SM_OK;
    const int d = w->dim;
    const double lo_margin = 2.0 * w->def.dx;
    for (size_t i = 0; i < n; i++) {
        for (int a = 0; a < d; a++) {
            double x = positions[i * 3 + a];
            double lo = w->def.domain_min[a] + lo_margin, hi = w->def.domain_max[a] - lo_margin;
            if (!isfinite(x) || x < lo || x > hi)
                return sm_world_fail(w, SM_ERR_INVALID,
                                     "particle %zu: position %c = %g is outside the usable domain [%g, %g] (2 cells inside the walls)",
                                     i, "xyz"[a], x, lo, hi);
            if (velocities && !isfinite(velocities[i * 3 + a]))
                return sm_world_fail(w, SM_ERR_INVALID, "particle %zu: velocity is not finite", i);
        }
    }
    if (w->next_id + n > 0x7fffffffu)
        return sm_world_fail(w, SM_ERR_INVALID, "particles: ids past %u not supported (%llu given out)", 0x7fffffffu,
                             (unsigned long long)w->next_id);
    unsigned char *kept = NULL; /* w->keep's answer per particle, asked once each */
    size_t nkept = n;
    if (w->keep) {
        if (!(kept = sm_malloc(n))) return sm_world_fail(w, SM_ERR_NOMEM, "out of memory for %zu particles", n);
        nkept = 0;
        for (size_t i = 0; i < n; i++) nkept += kept[i] = w->keep(w->keep_user, positions + i * 3) != 0;
    }
    size_t first = w->p.n;
    sm_status st = sm_world_reserve_particles(w, first + nkept);
    if (st != SM_OK) {
        free(kept);
        return st;
    }
    const sm_material_rt *m = &w->mats[material];
    double vol0 = pow(w->def.dx, d) / ppc;
    sm_particles *P = &w->p;
    sm_particles_init_rest(P, d, first, nkept);
    size_t p = first;
    for (size_t i = 0; i < n; i++) {
        const uint64_t id = w->next_id++; /* a particle not kept still takes its id */
        if (kept && !kept[i]) continue;
        for (int a = 0; a < d; a++) {
            P->x[p * d + a] = positions[i * 3 + a];
            P->v[p * d + a] = velocities ? (sm_real)velocities[i * 3 + a] : 0;
        }
        P->vol0[p] = (sm_real)vol0;
        P->alpha[p] = m->alpha0;
        P->mat[p] = (uint16_t)material;
        P->id[p] = (uint32_t)id;
        p++;
    }
    free(kept);
    P->n = first + nkept;
    if (w->dist) sm_dist_adopt(w, first); /* every rank added them: each keeps its blocks' */
    w->dirty = 1;
    return SM_OK;
}

double sm_world_particle_mass(const sm_world *w, size_t i) {
    if (i >= w->p.n) return 0;
    return (double)sm_particle_mass(w->mats, &w->p, i);
}

void sm_world_particles(const sm_world *w, sm_particles_view *o) {
    o->n = w->p.n;
    o->id = w->p.id;
    o->dim = w->dim;
    o->x = w->p.x;
    o->v = w->p.v;
    o->B = w->p.B;
    o->F = w->p.F;
    o->vol0 = w->p.vol0;
    o->q = w->p.q;
    o->alpha = w->p.alpha;
    o->material = w->p.mat;
}

sm_real *sm_world_particle_velocities(sm_world *w) {
    w->dirty = 1; /* the caller may change them: the next step checks every particle */
    return w->p.v;
}

double sm_world_particle_friction_angle(const sm_world *w, size_t i) {
    if (i >= w->p.n) return 0;
    return sm_hardening_friction_angle(&w->mats[w->p.mat[i]].def, (double)w->p.q[i]);
}

size_t sm_particle_bytes(int dim) {
    size_t d = (size_t)dim;
    /* Every particle field (particles.h); the sort's permutation; the sparse grid's share: about 1.5 nodes per cell of material (live blocks reach one block beyond
     * the particles), at 4 particles per cell or more, of 1 + 2d values each (3d with FLIP). */
    size_t grid = (size_t)(1.5 / 4 * (double)(sizeof(sm_real) * (1 + 2 * d)) + 0.5);
    return sm_particles_packed_size(dim) + sizeof(uint32_t) + grid;
}
