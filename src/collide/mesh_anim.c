/* Animated mesh fields (issue 15; docs/mesh-fields.md "Animated meshes"): a sequence of frames of
 * one mesh (same vertices and elements, positions x_k^f for frame f), shown at fps frames/s.
 *
 * Frame time u = t fps; f = floor(u) clamped to [0, F-1], s = u - f (s = 0 outside [0, F-1]):
 *   phi(x, t) = (1 - s) phi_f(x) + s phi_{f+1}(x)      (each phi_f the frame's field, mesh_sdf.c)
 *   grad      = the same blend of the frames' unit gradients, normalised
 *   v(x, t)   = (1 - s) v_f(x) + s v_{f+1}(x),  v_k(x) = sum_j b_j(x; k) (x_j^{f+1} - x_j^f) fps
 * where b_j(x; k) are the barycentric coordinates of the closest point to x on frame k's
 * triangles (segments in 2D), found by the frame's BVH (bvh.c), over the vertices j of that
 * element: the vertex motion of the interval [f, f+1] is linear, so a rigidly moving mesh gets
 * exactly its velocity. Before frame 0 and after the last frame the mesh rests (v = 0).
 * Velocities are evaluated at query time (the proposal's per-node channel would store the same
 * barycentric blend at the field's nodes); everything is a pure function of (t, x). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "collide/bvh.h"
#include "collide/mesh_field.h"
#include "collide/mesh_sdf_internal.h"

struct sm_mesh_anim {
    int count;             /* frames F >= 2 */
    double fps;
    int dim;
    size_t nverts, nelems;
    uint32_t *elems;       /* nelems * dim, shared by the frames */
    double *verts;         /* F * nverts * 3 */
    sm_mesh_sdf **sdf;     /* F fields */
    sm_bvh *bvh;           /* F trees */
};

void sm_mesh_anim_destroy(sm_mesh_anim *a) {
    if (!a) return;
    for (int f = 0; f < a->count; f++) {
        if (a->sdf) sm_mesh_sdf_destroy(a->sdf[f]);
        if (a->bvh) sm_bvh_free(&a->bvh[f]);
    }
    free(a->sdf);
    free(a->bvh);
    free(a->verts);
    free(a->elems);
    free(a);
}

static sm_status fail(char *err, size_t errlen, sm_status st, const char *msg) {
    if (err && errlen) snprintf(err, errlen, "%s", msg);
    return st;
}

/* Frame f's topology against frame 0's; "" if the same. */
static void topology_check(const sm_mesh_field_def *d, int f, char *msg, size_t n) {
    msg[0] = 0;
    const sm_mesh_field_def *a = &d[0], *b = &d[f];
    if (b->dim != a->dim || b->vertex_count != a->vertex_count || b->element_count != a->element_count) {
        snprintf(msg, n, "mesh animation: frame %d has %zu vertices and %zu elements, frame 0 %zu and %zu: every frame "
                 "must have the first one's topology (the same vertices and elements, moved)",
                 f, b->vertex_count, b->element_count, a->vertex_count, a->element_count);
        return;
    }
    const size_t ne = a->element_count * (size_t)a->dim;
    for (size_t i = 0; i < ne; i++)
        if (a->elements[i] != b->elements[i]) {
            snprintf(msg, n, "mesh animation: frame %d: element %zu uses other vertices than in frame 0 (the frames must "
                     "share one topology)", f, i / (size_t)a->dim);
            return;
        }
}

/* Builds frame f's field and tree. */
static sm_status build_frame(sm_mesh_anim *a, const sm_mesh_field_def *d, int f, char *err, size_t errlen) {
    char msg[512];
    sm_status st = sm_mesh_sdf_build(d, &a->sdf[f], msg, sizeof msg);
    if (st != SM_OK) {
        if (err && errlen) snprintf(err, errlen, "mesh animation: frame %d: %s", f, msg);
        return st;
    }
    memcpy(a->verts + (size_t)f * a->nverts * 3, d->vertices, a->nverts * 3 * sizeof(double));
    st = sm_bvh_build(&a->bvh[f], d->dim, d->vertices, d->vertex_count, d->elements, d->element_count);
    return st == SM_OK ? SM_OK : fail(err, errlen, st, "mesh animation: out of memory");
}

/* The handle's statistics: frame 0's, with the table box, Lipschitz bound and build time over all. */
static void merge_stats(sm_mesh_field *m, const sm_mesh_anim *a) {
    double r2 = 0;
    for (int k = 0; k < 3; k++) {
        for (int f = 1; f < a->count; f++) {
            const sm_mesh_sdf *s = a->sdf[f];
            double lo = k < s->dim ? s->origin[k] : 0, hi = lo + (k < s->dim ? s->ncells[k] * s->h : 0);
            m->stats.lo[k] = fmin(m->stats.lo[k], lo);
            m->stats.hi[k] = fmax(m->stats.hi[k], hi);
        }
        double e = fmax(fabs(m->stats.lo[k]), fabs(m->stats.hi[k]));
        r2 += e * e;
    }
    m->radius = sqrt(r2);
    for (int f = 1; f < a->count; f++) {
        const sm_mesh_field_stats *st = sm_mesh_sdf_stats_get(a->sdf[f]);
        m->stats.lipschitz = fmax(m->stats.lipschitz, st->lipschitz);
        m->stats.seconds += st->seconds;
        m->stats.bytes += st->bytes;
    }
}

sm_status sm_mesh_field_create_animated(const sm_mesh_field_def *frames, int frame_count, double fps,
                                        sm_mesh_field **out, char *err, size_t errlen) {
    if (!out) return SM_ERR_INVALID;
    *out = NULL;
    if (!frames || frame_count < 2) return fail(err, errlen, SM_ERR_INVALID, "mesh animation: needs at least 2 frames");
    if (!(fps > 0) || !isfinite(fps)) return fail(err, errlen, SM_ERR_INVALID, "mesh animation: fps must be > 0");
    char msg[512];
    for (int f = 1; f < frame_count; f++) {
        topology_check(frames, f, msg, sizeof msg);
        if (msg[0]) return fail(err, errlen, SM_ERR_INVALID, msg);
    }
    sm_mesh_anim *a = sm_calloc(1, sizeof *a);
    if (!a) return fail(err, errlen, SM_ERR_NOMEM, "mesh animation: out of memory");
    a->count = frame_count, a->fps = fps, a->dim = frames[0].dim;
    a->nverts = frames[0].vertex_count, a->nelems = frames[0].element_count;
    a->sdf = sm_calloc((size_t)frame_count, sizeof *a->sdf);
    a->bvh = sm_calloc((size_t)frame_count, sizeof *a->bvh);
    a->verts = sm_calloc((size_t)frame_count * a->nverts * 3 + 1, sizeof(double));
    a->elems = sm_calloc(a->nelems * (size_t)a->dim + 1, sizeof(uint32_t));
    sm_status st = a->sdf && a->bvh && a->verts && a->elems ? SM_OK : fail(err, errlen, SM_ERR_NOMEM, "mesh animation: out of memory");
    if (st == SM_OK && frames[0].elements) memcpy(a->elems, frames[0].elements, a->nelems * (size_t)a->dim * sizeof(uint32_t));
    for (int f = 0; f < frame_count && st == SM_OK; f++) st = build_frame(a, &frames[f], f, err, errlen);
    sm_mesh_field *m = st == SM_OK ? sm_mesh_field_wrap(a->sdf[0]) : NULL;
    if (st == SM_OK && !m) {
        a->sdf[0] = NULL; /* destroyed by the wrapper */
        st = fail(err, errlen, SM_ERR_NOMEM, "mesh animation: out of memory");
    }
    if (st != SM_OK) {
        sm_mesh_anim_destroy(a);
        return st;
    }
    m->anim = a;
    merge_stats(m, a);
    *out = m;
    return SM_OK;
}

int sm_mesh_field_frame_count(const sm_mesh_field *f, double *fps) {
    if (fps) *fps = f && f->anim ? f->anim->fps : 0;
    return f && f->anim ? f->anim->count : 1;
}

/* Frame f and fraction s of time t (s = 0 outside the animation); *moving = 1 inside it. */
static int frame_at(const sm_mesh_anim *a, double t, double *s, int *moving) {
    const double u = t * a->fps;
    *moving = 0;
    *s = 0;
    if (!(u > 0)) return 0;
    if (!(u < a->count - 1)) return a->count - 1;
    const int f = (int)floor(u);
    *s = u - f;
    *moving = 1;
    return f;
}

double sm_mesh_anim_local(const sm_mesh_field *m, double t, const double p[3], double g[3]) {
    if (!m->anim) return sm_mesh_sdf_distance(m->sdf, p, g);
    double gl[3];
    if (!g) g = gl;
    const sm_mesh_anim *a = m->anim;
    double s;
    int moving;
    const int f = frame_at(a, t, &s, &moving);
    double phi = sm_mesh_sdf_distance(a->sdf[f], p, g);
    if (!(s > 0)) return phi;
    double g1[3];
    const double phi1 = sm_mesh_sdf_distance(a->sdf[f + 1], p, g1);
    double n2 = 0, gb[3];
    for (int k = 0; k < 3; k++) {
        gb[k] = (1 - s) * g[k] + s * g1[k];
        n2 += gb[k] * gb[k];
    }
    if (n2 > 0)
        for (int k = 0; k < 3; k++) g[k] = gb[k] / sqrt(n2);
    return (1 - s) * phi + s * phi1;
}

/* v_k(p): frame k's closest element's barycentric blend of the vertex velocities of interval f. */
static void frame_velocity(const sm_mesh_anim *a, int k, int f, const double p[3], double v[3]) {
    sm_bvh_hit hit;
    sm_bvh_closest(&a->bvh[k], p, HUGE_VAL, -1, &hit);
    v[0] = v[1] = v[2] = 0;
    if (hit.slot < 0) return;
    const double *x0 = a->verts + (size_t)f * a->nverts * 3, *x1 = x0 + a->nverts * 3;
    for (int j = 0; j < a->dim; j++) {
        const size_t vi = a->elems[(size_t)hit.prim * (size_t)a->dim + (size_t)j];
        for (int c = 0; c < 3; c++) v[c] += hit.bary[j] * (x1[3 * vi + c] - x0[3 * vi + c]) * a->fps;
    }
}

void sm_mesh_anim_velocity(const sm_mesh_field *m, double t, const double p[3], double v[3]) {
    v[0] = v[1] = v[2] = 0;
    if (!m->anim) return;
    double s;
    int moving;
    const int f = frame_at(m->anim, t, &s, &moving);
    if (!moving) return;
    double v0[3], v1[3] = {0, 0, 0};
    frame_velocity(m->anim, f, f, p, v0);
    if (s > 0) frame_velocity(m->anim, f + 1, f, p, v1);
    for (int c = 0; c < 3; c++) v[c] = (1 - s) * v0[c] + s * v1[c];
}
