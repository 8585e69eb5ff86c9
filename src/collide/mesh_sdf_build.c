/* Building the narrow-band signed distance field of a mesh (layout in mesh_sdf_internal.h).
 *
 * Node values: phi_i = clamp(s(x_i) d(x_i), -b, b) with
 *   d(x) = min over the mesh's primitives of the exact point-primitive distance (bvh.c, a bounded
 *          search: only primitives closer than the band half-width b matter), and
 *   s(x)  = -1 inside, +1 outside, by the definition's rule:
 *     winding:   w(x) >= 1/2 inside (w the generalised winding number, bvh.c); for a surface whose
 *                signed volume V = (1/6) sum_t a.(b x c) (2D: (1/2) sum_s a x b) is negative, the
 *                solid is the complement: s = +1 where -w >= 1/2, -1 elsewhere (a container).
 *                Why the winding number: it is exact for closed surfaces, degrades gracefully on
 *                small holes (w stays near 1 inside, the 1/2 level closes the hole), and handles
 *                several overlapping closed parts (w = 2 in the overlap) and non-manifold edges,
 *                where pseudo-normals give wrong signs behind the hidden parts.
 *     one-sided: the side of the angle-weighted pseudo-normal of the closest feature
 *                (mesh_normals.c): exact for closed manifolds, and well defined on open sheets.
 *   Sign propagation (winding rule): no surface point is closer to x_i than d(x_i), so every
 *   point of the open ball B(x_i, d(x_i)) has the sign of x_i. A node whose already computed
 *   neighbour one spacing h away has |phi| > 1.001 h takes that neighbour's sign; only the nodes
 *   within about h of the surface evaluate w. (The 1.001 covers float storage of phi.)
 *
 * Which bricks are stored: a brick is a candidate if the distance from its centre to the mesh is
 * at most b + (its half diagonal 4 h sqrt(dim)) -- a superset of the bricks with a node closer
 * than b. A candidate whose nodes are all +b (or all -b) is dropped again: its interpolant is the
 * constant the table gives anyway. A brick position that is not stored takes the sign of its
 * lowest corner, a coarse node (exact d and s); that corner is also node 0 of the brick, whose
 * sign is copied from the coarse node, so a dropped brick and the table agree bit for bit.
 * Neighbouring stored and unstored bricks agree on their common face (all of its nodes are at
 * least b away from the surface), so the field is continuous everywhere.
 *
 * Lipschitz bound of the interpolant: inside a cell the derivative along axis k is a multilinear
 * blend of the cell's edge differences along k, so |d phi / d x_k| <= max_edges |Delta_k| / h and
 * |grad phi| <= sqrt(sum_k (max |Delta_k| / h)^2). The maximum over all stored cells bounds the
 * field's Lipschitz constant (clamped regions have zero gradient and the field is continuous).
 *
 * Parallel build: coarse nodes, candidate tests and bricks are computed in OpenMP loops in which
 * every item is a pure function of its index; the compaction, numbering, sums and maxima are
 * serial. The bytes do not depend on the number of threads. */
#include <stdio.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "collide/bvh.h"
#include "collide/mesh_normals.h"
#include "collide/mesh_sdf_internal.h"
#include "core/timer.h"

#define COPY_MARGIN 1.001

typedef struct build_ctx {
    const sm_mesh_sdf_def *def;
    struct sm_mesh_sdf *f;
    sm_bvh bvh;
    sm_mesh_normals normals; /* one-sided rule only */
    int container;
    int64_t o[3];            /* lattice index of the field's node 0 (origin = o h) */
} build_ctx;

sm_mesh_sdf_def sm_mesh_sdf_def_default(void) {
    sm_mesh_sdf_def d;
    memset(&d, 0, sizeof d);
    d.dim = 3;
    d.sign = SM_MESH_SIGN_WINDING;
    return d;
}

static sm_status fail(char *err, size_t errlen, sm_status st, const char *msg) {
    if (err && errlen) snprintf(err, errlen, "%s", msg);
    return st;
}

/* Checks the definition and computes the bounds of the referenced vertices. */
static sm_status check_def(const sm_mesh_sdf_def *d, double lo[3], double hi[3], char *err, size_t errlen) {
    char msg[160];
    if (d->dim != 2 && d->dim != 3) return fail(err, errlen, SM_ERR_INVALID, "mesh field: dim must be 2 or 3");
    if (!d->vertices || !d->elements || d->element_count == 0 || d->vertex_count == 0)
        return fail(err, errlen, SM_ERR_INVALID, "mesh field: no elements");
    if (d->element_count >= (size_t)UINT32_MAX / 4)
        return fail(err, errlen, SM_ERR_INVALID, "mesh field: too many elements");
    if (!(d->spacing > 0.0) || !isfinite(d->spacing))
        return fail(err, errlen, SM_ERR_INVALID, "mesh field: spacing must be positive");
    if (!(d->band >= d->spacing) || !isfinite(d->band))
        return fail(err, errlen, SM_ERR_INVALID, "mesh field: band must be at least the spacing");
    if (d->sign != SM_MESH_SIGN_WINDING && d->sign != SM_MESH_SIGN_ONE_SIDED)
        return fail(err, errlen, SM_ERR_INVALID, "mesh field: unknown sign rule");
    for (int k = 0; k < 3; k++) {
        lo[k] = HUGE_VAL;
        hi[k] = -HUGE_VAL;
    }
    for (size_t e = 0; e < d->element_count * (size_t)d->dim; e++) {
        uint32_t v = d->elements[e];
        if (v >= d->vertex_count) {
            snprintf(msg, sizeof msg, "mesh field: element %zu uses vertex %u of %zu", e / (size_t)d->dim, v,
                     d->vertex_count);
            return fail(err, errlen, SM_ERR_INVALID, msg);
        }
        for (int k = 0; k < d->dim; k++) {
            double x = d->vertices[3 * (size_t)v + (size_t)k];
            if (!isfinite(x)) {
                snprintf(msg, sizeof msg, "mesh field: vertex %u is not finite", v);
                return fail(err, errlen, SM_ERR_INVALID, msg);
            }
            lo[k] = fmin(lo[k], x);
            hi[k] = fmax(hi[k], x);
        }
    }
    return SM_OK;
}

/* Lattice placement: node indices o .. o + 8 nb cover the bounds grown by b + h on every side. */
static sm_status layout(build_ctx *C, const double lo[3], const double hi[3], char *err, size_t errlen) {
    const sm_mesh_sdf_def *d = C->def;
    struct sm_mesh_sdf *f = C->f;
    const double h = d->spacing, margin = d->band + h;
    double cells = 1.0;
    for (int k = 0; k < 3; k++) {
        if (k >= d->dim) {
            C->o[k] = 0;
            f->nb[k] = 1;
            continue;
        }
        double a = floor((lo[k] - margin) / h), z = ceil((hi[k] + margin) / h);
        double nbk = ceil((z - a) / SM_SDF_BRICK);
        cells *= nbk;
        if (!(fabs(a) < 4e18) || !(cells <= (double)SM_SDF_MAX_TABLE)) {
            char msg[200];
            snprintf(msg, sizeof msg, "mesh field: the mesh spans too many bricks of %g spacing (at most %zu); use a "
                     "coarser spacing", h, SM_SDF_MAX_TABLE);
            return fail(err, errlen, SM_ERR_INVALID, msg);
        }
        C->o[k] = (int64_t)a;
        f->nb[k] = (int)nbk;
    }
    f->dim = d->dim;
    f->h = h;
    f->band = d->band;
    for (int k = 0; k < 3; k++) f->origin[k] = (double)C->o[k] * h;
    return SM_OK;
}

/* Position of lattice node i (field indices, from node 0). Every caller uses this one formula,
 * so a coarse node and the brick node at the same place have the same coordinates. */
static void node_pos(const build_ctx *C, const int64_t i[3], double x[3]) {
    for (int k = 0; k < 3; k++) x[k] = k < C->def->dim ? (double)(C->o[k] + i[k]) * C->def->spacing : 0.0;
}

/* -1 inside the solid, +1 outside, at x; hit: the closest primitive within the band, if any. */
static double point_sign(const build_ctx *C, const double x[3], const sm_bvh_hit *hit) {
    if (C->def->sign == SM_MESH_SIGN_ONE_SIDED) {
        sm_bvh_hit h;
        if (!hit || hit->slot < 0) {
            sm_bvh_closest(&C->bvh, x, HUGE_VAL, -1, &h);
            hit = &h;
        }
        return sm_mesh_normals_side(&C->normals, C->def->elements, hit, x);
    }
    double w = sm_bvh_winding(&C->bvh, x);
    int in_surface = (C->container ? -w : w) >= 0.5;
    return (in_surface != C->container) ? -1.0 : 1.0;
}

/* Exact signed distance at coarse node (i, j, k) (brick corners). */
static float coarse_value(const build_ctx *C, int64_t i, int64_t j, int64_t k) {
    int64_t n[3] = {i * SM_SDF_BRICK, j * SM_SDF_BRICK, k * SM_SDF_BRICK};
    double x[3];
    node_pos(C, n, x);
    sm_bvh_hit hit;
    sm_bvh_closest(&C->bvh, x, HUGE_VAL, -1, &hit);
    return (float)(point_sign(C, x, &hit) * sqrt(hit.d2));
}

static void compute_coarse(build_ctx *C, int threads) {
    struct sm_mesh_sdf *f = C->f;
    const long nx = f->nb[0] + 1, ny = f->nb[1] + 1, n = (long)sm_sdf_coarse_size(f);
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads)
    for (long c = 0; c < n; c++) f->coarse[c] = coarse_value(C, c % nx, (c / nx) % ny, c / (nx * ny));
}

/* Brick position b (table order) -> its lattice cell coordinates. */
static void brick_coords(const struct sm_mesh_sdf *f, size_t b, int64_t bc[3]) {
    bc[0] = (int64_t)(b % (size_t)f->nb[0]);
    bc[1] = (int64_t)(b / (size_t)f->nb[0] % (size_t)f->nb[1]);
    bc[2] = (int64_t)(b / ((size_t)f->nb[0] * (size_t)f->nb[1]));
}

/* 1 if the centre of brick position b is within b + half diagonal of the surface. */
static int brick_is_candidate(const build_ctx *C, size_t b) {
    int64_t bc[3], n[3];
    brick_coords(C->f, b, bc);
    for (int k = 0; k < 3; k++) n[k] = bc[k] * SM_SDF_BRICK + SM_SDF_BRICK / 2;
    double x[3], r = C->def->band + 0.5 * SM_SDF_BRICK * C->def->spacing * sqrt((double)C->def->dim);
    node_pos(C, n, x);
    sm_bvh_hit hit;
    sm_bvh_closest(&C->bvh, x, r * r * (1.0 + 1e-9), -1, &hit);
    return hit.slot >= 0;
}

/* The sign of node l (brick-local, index li) copied from an already computed neighbour, or 0. */
static double neighbour_sign(const float *out, const int l[3], size_t li, int dim, double h) {
    size_t stride = 1;
    for (int k = 0; k < dim; k++, stride *= SM_SDF_BN) {
        if (l[k] == 0) continue;
        float v = out[li - stride];
        if (fabs((double)v) > COPY_MARGIN * h) return v < 0.0f ? -1.0 : 1.0;
    }
    return 0.0;
}

/* Computes the 9^dim node values of brick position b into out; returns 1 if the brick is needed
 * (a node in the band, or nodes of both signs), and counts its band nodes. */
static int compute_brick(const build_ctx *C, size_t b, float *out, size_t *band_nodes) {
    const struct sm_mesh_sdf *f = C->f;
    const int dim = C->def->dim, nz = dim == 3 ? SM_SDF_BN : 1;
    const double band = C->def->band, h = C->def->spacing;
    const float fb = (float)band;
    int64_t bc[3];
    brick_coords(f, b, bc);
    long warm = -1;
    int needed = 0;
    size_t li = 0;
    for (int lz = 0; lz < nz; lz++)
        for (int ly = 0; ly < SM_SDF_BN; ly++)
            for (int lx = 0; lx < SM_SDF_BN; lx++, li++) {
                const int l[3] = {lx, ly, lz};
                int64_t n[3] = {bc[0] * SM_SDF_BRICK + lx, bc[1] * SM_SDF_BRICK + ly, bc[2] * SM_SDF_BRICK + lz};
                double x[3];
                node_pos(C, n, x);
                sm_bvh_hit hit;
                sm_bvh_closest(&C->bvh, x, band * band, warm, &hit);
                double d = band, s = 0.0;
                if (hit.slot >= 0) {
                    d = sqrt(hit.d2);
                    warm = hit.slot;
                }
                if (C->def->sign == SM_MESH_SIGN_WINDING) {
                    if (li == 0) {
                        size_t ci = (size_t)bc[0] + (size_t)(f->nb[0] + 1) * ((size_t)bc[1] + (size_t)(f->nb[1] + 1) * (size_t)bc[2]);
                        s = f->coarse[ci] < 0.0f ? -1.0 : 1.0;
                    } else {
                        s = neighbour_sign(out, l, li, dim, h);
                    }
                }
                if (s == 0.0) s = point_sign(C, x, &hit);
                out[li] = (float)(s * d);
                if (fabsf(out[li]) < fb) (*band_nodes)++;
                if (fabsf(out[li]) < fb || (out[li] < 0.0f) != (out[0] < 0.0f)) needed = 1;
            }
    return needed;
}

/* Lipschitz bound of the interpolant over one brick (see the header comment). */
static double brick_lipschitz(const float *v, int dim, double inv_h) {
    const size_t s[3] = {1, SM_SDF_BN, SM_SDF_BN * SM_SDF_BN};
    const int nz = dim == 3 ? SM_SDF_BRICK : 1;
    double worst = 0.0;
    for (int cz = 0; cz < nz; cz++)
        for (int cy = 0; cy < SM_SDF_BRICK; cy++)
            for (int cx = 0; cx < SM_SDF_BRICK; cx++) {
                const float *c = v + (size_t)cx + s[1] * (size_t)cy + s[2] * (size_t)cz;
                double sum = 0.0;
                for (int k = 0; k < dim; k++) {
                    double m = 0.0; /* max over the cell's edges along k */
                    for (int e = 0; e < (dim == 3 ? 4 : 2); e++) {
                        int a1 = (k + 1) % dim, a2 = (k + 2) % dim;
                        size_t off = (size_t)(e & 1) * s[a1] + (dim == 3 ? (size_t)(e >> 1) * s[a2] : 0);
                        m = fmax(m, fabs((double)c[off + s[k]] - (double)c[off]));
                    }
                    sum += m * m;
                }
                worst = fmax(worst, sqrt(sum) * inv_h);
            }
    return worst;
}

/* Signed volume (3D) or area (2D) enclosed by the elements. */
static double signed_volume(const sm_mesh_sdf_def *d) {
    double v = 0.0;
    for (size_t e = 0; e < d->element_count; e++) {
        const uint32_t *p = d->elements + e * (size_t)d->dim;
        const double *a = d->vertices + 3 * (size_t)p[0], *b = d->vertices + 3 * (size_t)p[1];
        if (d->dim == 2) {
            v += 0.5 * (a[0] * b[1] - a[1] * b[0]);
        } else {
            const double *c = d->vertices + 3 * (size_t)p[2];
            v += (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
                  a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
        }
    }
    return v;
}

static int build_threads(const sm_mesh_sdf_def *d) {
#ifdef _OPENMP
    return d->threads > 0 ? d->threads : omp_get_max_threads();
#else
    (void)d;
    return 1;
#endif
}

/* Candidate bricks, computed in parallel into scratch, then compacted in table order. */
static sm_status compute_bricks(build_ctx *C, int threads) {
    struct sm_mesh_sdf *f = C->f;
    const size_t nt = sm_sdf_table_size(f), bn = f->brick_nodes;
    unsigned char *cand = sm_malloc(nt);
    if (!cand) return SM_ERR_NOMEM;
#pragma omp parallel for schedule(dynamic, 64) num_threads(threads)
    for (long b = 0; b < (long)nt; b++) cand[b] = (unsigned char)brick_is_candidate(C, (size_t)b);
    size_t ncand = 0;
    for (size_t b = 0; b < nt; b++) ncand += cand[b];
    size_t *list = sm_malloc((ncand ? ncand : 1) * sizeof *list);
    float *vals = sm_malloc((ncand ? ncand : 1) * bn * sizeof(float));
    if (!list || !vals) {
        free(cand), free(list), free(vals);
        return SM_ERR_NOMEM;
    }
    for (size_t b = 0, c = 0; b < nt; b++)
        if (cand[b]) list[c++] = b;
    /* No OpenMP reductions here or below (clang's need a global lock symbol the shared library
     * would export): per-item results are combined serially. */
    uint16_t *nodes = sm_malloc((ncand ? ncand : 1) * sizeof *nodes);
    if (!nodes) {
        free(cand), free(list), free(vals);
        return SM_ERR_NOMEM;
    }
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (long c = 0; c < (long)ncand; c++) {
        size_t n = 0;
        cand[list[c]] = (unsigned char)(1 + compute_brick(C, list[c], vals + (size_t)c * bn, &n));
        nodes[c] = (uint16_t)n; /* at most 9^3 */
    }
    size_t band_nodes = 0;
    for (size_t c = 0; c < ncand; c++) band_nodes += nodes[c];
    free(nodes);
    /* Numbering and compaction (serial, table order); unstored positions take the coarse sign. */
    size_t kept = 0;
    for (size_t b = 0, c = 0; b < nt; b++) {
        if (cand[b] == 2) {
            memmove(vals + kept * bn, vals + c * bn, bn * sizeof(float));
            f->table[b] = (int32_t)kept++;
        } else {
            int64_t bc[3];
            brick_coords(f, b, bc);
            size_t ci = (size_t)bc[0] + (size_t)(f->nb[0] + 1) * ((size_t)bc[1] + (size_t)(f->nb[1] + 1) * (size_t)bc[2]);
            f->table[b] = f->coarse[ci] < 0.0f ? SM_SDF_INSIDE : SM_SDF_OUTSIDE;
        }
        if (cand[b]) c++;
    }
    free(cand);
    free(list);
    f->nbricks = kept;
    f->bricks = kept ? sm_realloc(vals, kept * bn * sizeof(float)) : NULL;
    if (!kept) free(vals);
    if (kept && !f->bricks) {
        free(vals);
        return SM_ERR_NOMEM;
    }
    f->stats.candidate_bricks = ncand;
    f->stats.band_nodes = band_nodes;
    return SM_OK;
}

/* The largest per-brick bound; -1 if out of memory. */
static double field_lipschitz(const struct sm_mesh_sdf *f, int threads) {
    double *per = sm_malloc((f->nbricks ? f->nbricks : 1) * sizeof(double)), worst = 0.0;
    if (!per) return -1.0;
#pragma omp parallel for schedule(static) num_threads(threads)
    for (long b = 0; b < (long)f->nbricks; b++) per[b] = brick_lipschitz(f->bricks + (size_t)b * f->brick_nodes, f->dim, f->inv_h);
    for (size_t b = 0; b < f->nbricks; b++) worst = fmax(worst, per[b]);
    free(per);
    return worst;
}

static sm_status build_field(build_ctx *C, int threads, char *err, size_t errlen) {
    const sm_mesh_sdf_def *d = C->def;
    struct sm_mesh_sdf *f = C->f;
    sm_status st = sm_bvh_build(&C->bvh, d->dim, d->vertices, d->vertex_count, d->elements, d->element_count);
    if (st == SM_OK && d->sign == SM_MESH_SIGN_ONE_SIDED)
        st = sm_mesh_normals_build(&C->normals, d->dim, d->vertices, d->vertex_count, d->elements, d->element_count);
    f->table = sm_malloc(sm_sdf_table_size(f) * sizeof(int32_t));
    f->coarse = sm_malloc(sm_sdf_coarse_size(f) * sizeof(float));
    if (st != SM_OK || !f->table || !f->coarse) return fail(err, errlen, SM_ERR_NOMEM, "mesh field: out of memory");
    compute_coarse(C, threads);
    if (compute_bricks(C, threads) != SM_OK) return fail(err, errlen, SM_ERR_NOMEM, "mesh field: out of memory");
    f->stats.lipschitz = field_lipschitz(f, threads);
    if (f->stats.lipschitz < 0.0) return fail(err, errlen, SM_ERR_NOMEM, "mesh field: out of memory");
    return SM_OK;
}

sm_status sm_mesh_sdf_build(const sm_mesh_sdf_def *def, sm_mesh_sdf **out, char *err, size_t errlen) {
    const double t0 = sm_seconds();
    *out = NULL;
    double lo[3], hi[3];
    sm_status st = check_def(def, lo, hi, err, errlen);
    if (st != SM_OK) return st;
    build_ctx C;
    memset(&C, 0, sizeof C);
    C.def = def;
    C.f = sm_calloc(1, sizeof *C.f);
    if (!C.f) return fail(err, errlen, SM_ERR_NOMEM, "mesh field: out of memory");
    struct sm_mesh_sdf *f = C.f;
    st = layout(&C, lo, hi, err, errlen);
    if (st == SM_OK) {
        f->stats.volume = signed_volume(def);
        C.container = def->sign == SM_MESH_SIGN_WINDING && f->stats.volume < 0.0;
        f->stats.container = C.container;
        sm_mesh_sdf_finish_layout(f);
        st = build_field(&C, build_threads(def), err, errlen);
    }
    sm_bvh_free(&C.bvh);
    sm_mesh_normals_free(&C.normals);
    if (st != SM_OK) {
        sm_mesh_sdf_destroy(f);
        return st;
    }
    f->stats.elements = def->element_count;
    f->stats.vertices = def->vertex_count;
    f->stats.bricks = f->nbricks;
    sm_mesh_sdf_finish_layout(f); /* bytes now that the bricks are known */
    f->stats.seconds = sm_seconds() - t0;
    *out = f;
    return SM_OK;
}
