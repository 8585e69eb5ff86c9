/* Angle-weighted pseudo-normals (Baerentzen & Aanaes, "Signed distance computation using the angle
 * weighted pseudonormal", IEEE TVCG 11(3), 2005).
 *
 *   face   n_f = (b - a) x (c - a) / |(b - a) x (c - a)|        (2D segment: (e_y, -e_x) / |e|)
 *   edge   n_e = sum of n_f over the faces that share the edge   (one face on a boundary edge)
 *   vertex n_v = sum over incident faces of alpha_f n_f, alpha_f the face's angle at the vertex
 *                (2D: the plain sum of the two segments' normals)
 * For a closed, manifold, consistently oriented surface and q the closest surface point to p, the
 * theorem of the paper is sign((p - q) . n) = sign of the distance, with n the pseudo-normal of
 * the feature (face interior, edge or vertex) that q lies on. On an open surface the same rule is
 * still well defined: it is the side of the nearest part of the sheet (a one-sided collider). */
#include "collide/mesh_normals.h"

#include <string.h>

static void normalize3(double v[3]) {
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; k++) v[k] = n > 0.0 ? v[k] / n : 0.0;
}

/* Unit normal of primitive i into n. */
static void face_normal(int dim, const double *verts, const uint32_t *pr, double n[3]) {
    const double *a = verts + 3 * (size_t)pr[0], *b = verts + 3 * (size_t)pr[1];
    if (dim == 3) {
        const double *c = verts + 3 * (size_t)pr[2];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        n[0] = u[1] * v[2] - u[2] * v[1];
        n[1] = u[2] * v[0] - u[0] * v[2];
        n[2] = u[0] * v[1] - u[1] * v[0];
    } else {
        n[0] = b[1] - a[1];
        n[1] = a[0] - b[0];
        n[2] = 0.0;
    }
    normalize3(n);
}

/* Interior angle of triangle pr at its corner k. */
static double corner_angle(const double *verts, const uint32_t *pr, int k) {
    const double *o = verts + 3 * (size_t)pr[k], *a = verts + 3 * (size_t)pr[(k + 1) % 3],
                 *b = verts + 3 * (size_t)pr[(k + 2) % 3];
    double u[3] = {a[0] - o[0], a[1] - o[1], a[2] - o[2]}, v[3] = {b[0] - o[0], b[1] - o[1], b[2] - o[2]};
    double uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    return atan2(sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), uv);
}

typedef struct edge_ref {
    uint64_t key;  /* (min vertex << 32) | max vertex */
    uint32_t slot; /* 3 * triangle + local edge */
} edge_ref;

static int edge_cmp(const void *pa, const void *pb) {
    const edge_ref *a = pa, *b = pb;
    if (a->key != b->key) return a->key < b->key ? -1 : 1;
    return a->slot < b->slot ? -1 : a->slot > b->slot;
}

/* Edge pseudo-normals: the triangles that share an undirected edge are found by sorting. */
static sm_status edge_normals(sm_mesh_normals *m, const uint32_t *prims, size_t nt) {
    edge_ref *refs = sm_malloc(3 * nt * sizeof *refs);
    if (!refs) return SM_ERR_NOMEM;
    for (size_t t = 0; t < nt; t++)
        for (int e = 0; e < 3; e++) {
            uint32_t i = prims[3 * t + (size_t)e], j = prims[3 * t + (size_t)(e + 1) % 3];
            uint32_t lo = i < j ? i : j, hi = i < j ? j : i;
            refs[3 * t + (size_t)e] = (edge_ref){((uint64_t)lo << 32) | hi, (uint32_t)(3 * t + (size_t)e)};
        }
    qsort(refs, 3 * nt, sizeof *refs, edge_cmp);
    for (size_t g = 0; g < 3 * nt;) {
        size_t end = g;
        double sum[3] = {0, 0, 0};
        while (end < 3 * nt && refs[end].key == refs[g].key) {
            const double *f = m->face + 3 * (size_t)(refs[end].slot / 3);
            for (int k = 0; k < 3; k++) sum[k] += f[k];
            end++;
        }
        for (size_t r = g; r < end; r++) memcpy(m->edge + 3 * (size_t)refs[r].slot, sum, sizeof sum);
        g = end;
    }
    free(refs);
    return SM_OK;
}

void sm_mesh_normals_free(sm_mesh_normals *m) {
    free(m->face);
    free(m->edge);
    free(m->vertex);
    memset(m, 0, sizeof *m);
}

sm_status sm_mesh_normals_build(sm_mesh_normals *m, int dim, const double *verts, size_t nverts,
                                const uint32_t *prims, size_t nprims) {
    memset(m, 0, sizeof *m);
    m->dim = dim;
    m->face = sm_malloc(3 * nprims * sizeof(double));
    m->vertex = sm_calloc(3 * nverts, sizeof(double));
    m->edge = dim == 3 ? sm_malloc(9 * nprims * sizeof(double)) : NULL;
    if (!m->face || !m->vertex || (dim == 3 && !m->edge)) {
        sm_mesh_normals_free(m);
        return SM_ERR_NOMEM;
    }
    for (size_t t = 0; t < nprims; t++) {
        const uint32_t *pr = prims + t * (size_t)dim;
        double *n = m->face + 3 * t;
        face_normal(dim, verts, pr, n);
        for (int k = 0; k < dim; k++) {
            double w = dim == 3 ? corner_angle(verts, pr, k) : 1.0;
            double *v = m->vertex + 3 * (size_t)pr[k];
            for (int a = 0; a < 3; a++) v[a] += w * n[a];
        }
    }
    if (dim == 3 && edge_normals(m, prims, nprims) != SM_OK) {
        sm_mesh_normals_free(m);
        return SM_ERR_NOMEM;
    }
    return SM_OK;
}

double sm_mesh_normals_side(const sm_mesh_normals *m, const uint32_t *prims, const sm_bvh_hit *hit, const double p[3]) {
    const size_t t = hit->prim;
    const double *n;
    switch (hit->region) {
    case SM_REGION_V0:
    case SM_REGION_V1:
    case SM_REGION_V2:
        n = m->vertex + 3 * (size_t)prims[t * (size_t)m->dim + (size_t)hit->region];
        break;
    case SM_REGION_E0:
    case SM_REGION_E1:
    case SM_REGION_E2:
        n = m->dim == 3 ? m->edge + 9 * t + 3 * (size_t)(hit->region - SM_REGION_E0) : m->face + 3 * t;
        break;
    default:
        n = m->face + 3 * t;
        break;
    }
    double s = 0.0;
    for (int k = 0; k < m->dim; k++) s += (p[k] - hit->q[k]) * n[k];
    return s >= 0.0 ? 1.0 : -1.0;
}
