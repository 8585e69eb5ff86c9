/* The public mesh field handle (sandmpm.h): an sm_mesh_sdf (mesh_sdf.h; equations in mesh_sdf.c
 * and mesh_sdf_build.c) with a reference count, so that colliders can share one field and keep it
 * while the caller lets go of its own reference. */
#include <stdio.h>

#include "collide/mesh_field.h"
#include "collide/mesh_sdf_internal.h"

sm_mesh_field_def sm_mesh_field_def_default(void) { return sm_mesh_sdf_def_default(); }

/* Wraps sdf (taken over) in a handle with one reference; NULL (sdf destroyed) if out of memory. */
sm_mesh_field *sm_mesh_field_wrap(sm_mesh_sdf *sdf) {
    sm_mesh_field *m = sm_calloc(1, sizeof *m);
    if (!m) {
        sm_mesh_sdf_destroy(sdf);
        return NULL;
    }
    m->refs = 1;
    m->sdf = sdf;
    m->stats = *sm_mesh_sdf_stats_get(sdf);
    double r2 = 0;
    for (int k = 0; k < 3; k++) {
        double lo = k < sdf->dim ? sdf->origin[k] : 0, hi = lo + (k < sdf->dim ? sdf->ncells[k] * sdf->h : 0);
        m->stats.lo[k] = lo;
        m->stats.hi[k] = hi;
        double e = fmax(fabs(lo), fabs(hi));
        r2 += e * e;
    }
    m->radius = sqrt(r2);
    return m;
}

sm_status sm_mesh_field_create(const sm_mesh_field_def *def, sm_mesh_field **out, char *err, size_t errlen) {
    if (!out) return SM_ERR_INVALID;
    *out = NULL;
    if (!def) {
        if (err && errlen) snprintf(err, errlen, "mesh field: definition is NULL");
        return SM_ERR_INVALID;
    }
    sm_mesh_sdf *sdf = NULL;
    sm_status st = sm_mesh_sdf_build(def, &sdf, err, errlen);
    if (st != SM_OK) return st;
    if (!(*out = sm_mesh_field_wrap(sdf))) {
        if (err && errlen) snprintf(err, errlen, "mesh field: out of memory");
        return SM_ERR_NOMEM;
    }
    return SM_OK;
}

sm_status sm_mesh_field_deserialize(const void *buf, size_t n, sm_mesh_field **out, char *err, size_t errlen) {
    if (!out) return SM_ERR_INVALID;
    *out = NULL;
    sm_mesh_sdf *sdf = NULL;
    sm_status st = sm_mesh_sdf_deserialize(buf, n, &sdf, err, errlen);
    if (st != SM_OK) return st;
    if (!(*out = sm_mesh_field_wrap(sdf))) {
        if (err && errlen) snprintf(err, errlen, "mesh field: out of memory");
        return SM_ERR_NOMEM;
    }
    return SM_OK;
}

sm_mesh_field *sm_mesh_field_retain(sm_mesh_field *f) {
    SM_ASSERT(f && f->refs > 0);
    f->refs++;
    return f;
}

void sm_mesh_field_release(sm_mesh_field *f) {
    if (!f) return;
    SM_ASSERT(f->refs > 0);
    if (--f->refs > 0) return;
    if (f->anim) sm_mesh_anim_destroy(f->anim); /* owns every frame's field, f->sdf included */
    else sm_mesh_sdf_destroy(f->sdf);
    free(f);
}

const sm_mesh_field_stats *sm_mesh_field_get_stats(const sm_mesh_field *f) { return &f->stats; }

double sm_mesh_field_distance(const sm_mesh_field *f, const double x[3], double grad[3]) {
    return sm_mesh_sdf_distance(f->sdf, x, grad);
}

size_t sm_mesh_field_serialize(const sm_mesh_field *f, void *buf, size_t cap) {
    return sm_mesh_sdf_serialize(f->sdf, buf, cap);
}

double sm_mesh_field_extent(const sm_mesh_field *m) {
    return m->stats.container ? INFINITY : m->radius;
}
