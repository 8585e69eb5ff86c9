/* Brute-force references for the mesh field's tests: the exact distance to a mesh as the minimum
 * over all of its elements, computed with a different algorithm than the library's (projection on
 * the triangle's plane if it falls inside, else the nearest edge), and the exact winding number
 * (every element's angle summed, no hierarchy). */
#ifndef SM_TESTS_MESH_BRUTE_H
#define SM_TESTS_MESH_BRUTE_H

#include <math.h>

#include <stdio.h>

#include "collide/mesh_geom.h"
#include "collide/mesh_sdf.h"
#include "mesh_gen.h"

/* The field definition of a test mesh. */
static inline sm_mesh_sdf_def mesh_field_def(const test_mesh *m, double h, double band, sm_mesh_sign sign, int threads) {
    sm_mesh_sdf_def d = sm_mesh_sdf_def_default();
    d.dim = m->dim;
    d.vertices = m->v;
    d.vertex_count = m->nv;
    d.elements = m->e;
    d.element_count = m->ne;
    d.spacing = h;
    d.band = band;
    d.sign = sign;
    d.threads = threads;
    return d;
}

/* Builds the field of a test mesh; NULL (and the reason on stderr) on failure. */
static inline sm_mesh_sdf *mesh_field_build(const test_mesh *m, double h, double band, sm_mesh_sign sign, int threads) {
    sm_mesh_sdf_def d = mesh_field_def(m, h, band, sign, threads);
    sm_mesh_sdf *f = NULL;
    char err[256] = "";
    if (sm_mesh_sdf_build(&d, &f, err, sizeof err) != SM_OK) fprintf(stderr, "mesh field build failed: %s\n", err);
    return f;
}

static inline double brute_seg_dist(const double p[3], const double a[3], const double b[3]) {
    double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    double l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    double t = l2 > 0 ? (ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]) / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double d[3] = {ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]};
    return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

static inline void brute_cross(const double a[3], const double b[3], double r[3]) {
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double brute_tri_dist(const double p[3], const double a[3], const double b[3], const double c[3]) {
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]}, n[3];
    brute_cross(u, v, n);
    double n2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if (n2 > 0) {
        double s = ((p[0] - a[0]) * n[0] + (p[1] - a[1]) * n[1] + (p[2] - a[2]) * n[2]) / n2;
        double q[3] = {p[0] - s * n[0], p[1] - s * n[1], p[2] - s * n[2]};
        const double *w[3] = {a, b, c};
        int inside = 1;
        for (int e = 0; e < 3 && inside; e++) {
            const double *o = w[e], *t = w[(e + 1) % 3];
            double ed[3] = {t[0] - o[0], t[1] - o[1], t[2] - o[2]}, oq[3] = {q[0] - o[0], q[1] - o[1], q[2] - o[2]}, x[3];
            brute_cross(ed, oq, x);
            if (x[0] * n[0] + x[1] * n[1] + x[2] * n[2] < 0) inside = 0;
        }
        if (inside) return fabs(s) * sqrt(n2);
    }
    return fmin(brute_seg_dist(p, a, b), fmin(brute_seg_dist(p, b, c), brute_seg_dist(p, c, a)));
}

/* Exact unsigned distance from p to mesh m. */
static inline double brute_dist(const test_mesh *m, const double p[3]) {
    double best = HUGE_VAL;
    for (size_t t = 0; t < m->ne; t++) {
        const uint32_t *e = m->e + (size_t)m->dim * t;
        double d = m->dim == 3 ? brute_tri_dist(p, m->v + 3 * e[0], m->v + 3 * e[1], m->v + 3 * e[2])
                               : brute_seg_dist(p, m->v + 3 * e[0], m->v + 3 * e[1]);
        if (d < best) best = d;
    }
    return best;
}

/* Exact generalised winding number of mesh m at p. */
static inline double brute_winding(const test_mesh *m, const double p[3]) {
    double s = 0;
    for (size_t t = 0; t < m->ne; t++) {
        const uint32_t *e = m->e + (size_t)m->dim * t;
        s += m->dim == 3 ? sm_solid_angle(p, m->v + 3 * e[0], m->v + 3 * e[1], m->v + 3 * e[2])
                         : sm_segment_angle(p, m->v + 3 * e[0], m->v + 3 * e[1]);
    }
    return s / (m->dim == 3 ? 4 * 3.14159265358979323846 : 2 * 3.14159265358979323846);
}

/* Signed distance of a closed outward mesh by brute force (inside: winding >= 1/2). */
static inline double brute_sdf(const test_mesh *m, const double p[3]) {
    double d = brute_dist(m, p);
    return brute_winding(m, p) >= 0.5 ? -d : d;
}

#endif
