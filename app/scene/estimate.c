/* Checks after validation, where the whole scene is known: objects and emitters against the
 * domain, --set keys the scene never read, and the estimates of particles and memory. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app/scene/scene_internal.h"

/* Bounding box of a bounded shape (box, sphere, cylinder; not inside-out); 0 if unbounded. */
static int shape_bbox(const sm_shape *sh, int dim, double lo[3], double hi[3]) {
    if (sh->inside_out || sh->kind == SM_SHAPE_HALFSPACE) return 0;
    double r[3] = {0, 0, 0};
    if (sh->kind == SM_SHAPE_SPHERE) {
        r[0] = r[1] = r[2] = sh->radius;
    } else {
        /* rotated extents: |R| h */
        double h[3];
        if (sh->kind == SM_SHAPE_BOX) memcpy(h, sh->half_extent, sizeof h);
        else h[0] = h[2] = sh->radius, h[1] = sh->half_height;
        const double *q = sh->rotation;
        double w = q[0], x = q[1], y = q[2], z = q[3];
        double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) r[a] += fabs(R[a][b]) * h[b];
    }
    for (int a = 0; a < 3; a++) {
        lo[a] = a < dim ? sh->center[a] - r[a] : 0;
        hi[a] = a < dim ? sh->center[a] + r[a] : 0;
    }
    return 1;
}

/* The usable region (domain rounded up to whole cells, less 2 dx on each side) where the library
 * seeds and emits. */
static void usable_region(const sm_world_def *d, double lo[3], double hi[3]) {
    for (int a = 0; a < 3; a++) lo[a] = hi[a] = 0;
    for (int a = 0; a < d->dim; a++) {
        double cells = ceil((d->domain_max[a] - d->domain_min[a]) / d->dx - 1e-9);
        lo[a] = d->domain_min[a] + 2 * d->dx;
        hi[a] = d->domain_min[a] + cells * d->dx - 2 * d->dx;
    }
}

sm_status sc_finish_load(sm_scene *s, char *err, size_t errlen) {
    sm_world_def *d = &s->def;
    char msg[256];
    if (sm_world_def_check(d, msg, sizeof msg) != SM_OK) /* validation checked it: not reached */
        return sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s: %s", s->path, msg);
    size_t grid = sm_world_def_grid_bytes(d);
    double lo[3], hi[3];
    usable_region(d, lo, hi);
    const int dim = d->dim;
    double cell = pow(d->dx, dim), est = 0;
    for (int i = 0; i < s->nobj; i++) {
        scene_object *o = &s->objs[i];
        double blo[3], bhi[3];
        if (shape_bbox(&o->shape, dim, blo, bhi)) {
            for (int a = 0; a < dim; a++)
                if (!(bhi[a] > lo[a] && blo[a] < hi[a]))
                    return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                                    "%s: objects[%d].shape: outside the domain along %c (the shape spans %g .. %g; "
                                    "particles go in %g .. %g, 2 cells inside the domain)",
                                    s->path, i + 1, "xyz"[a], blo[a], bhi[a], lo[a], hi[a]);
        }
        /* Sample only where the shape (and its clip) can be: the library's estimate samples a 64^d
           lattice of the box it is given, so a small shape in a large domain needs a tight box. */
        double slo[3], shi[3];
        memcpy(slo, lo, sizeof slo);
        memcpy(shi, hi, sizeof shi);
        for (int k = 0; k < 1 + o->has_clip; k++)
            if (shape_bbox(k ? &o->clip : &o->shape, dim, blo, bhi))
                for (int a = 0; a < dim; a++) {
                    slo[a] = fmax(slo[a], blo[a]);
                    shi[a] = fmin(shi[a], bhi[a]);
                }
        double vol = sm_shape_volume_estimate(&o->shape, o->has_clip ? &o->clip : NULL, dim, slo, shi);
        est += vol / cell * o->seed.ppc;
    }
    double emitted = 0;
    for (int i = 0; i < s->nemit; i++) {
        sm_emitter_def *e = &s->emits[i];
        if (!(sm_shape_volume_estimate(&e->shape, NULL, dim, lo, hi) > 0))
            return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                            "%s: emitters[%d].shape: outside the domain (particles are emitted only in the part of the "
                            "shape at least 2 cells inside the domain's walls)",
                            s->path, i + 1);
        double t = fmin(e->stop, s->set.end_time) - e->start;
        if (t > 0) emitted += e->rate * t / (s->mats[e->material].density * cell / e->ppc);
    }
    for (int i = 0; i < s->nparams; i++)
        if (!s->params[i].used) {
            const char *sug = sc_closest(s->params[i].key, (const char *const *)s->read_keys, s->nread);
            char hint[200] = "";
            if (sug) snprintf(hint, sizeof hint, " (did you mean \"%s\"?)", sug);
            return sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s: --set %s=%s: the scene does not use params.%s%s", s->path,
                            s->params[i].key, s->params[i].value, s->params[i].key, hint);
        }
    s->set.estimated_particles = (size_t)llround(est);
    s->set.estimated_emitted = (size_t)llround(emitted);
    double bytes = (double)grid + (est + emitted) * (double)sm_particle_bytes(dim);
    s->set.estimated_bytes = bytes > 1e18 ? (size_t)-1 : (size_t)bytes;
    return SM_OK;
}
