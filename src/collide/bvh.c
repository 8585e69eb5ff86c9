/* Bounding volume hierarchy over mesh primitives (triangles in 3D, segments in 2D).
 *
 * Build: top down; a node's primitives are split at the median of their centroids along the
 * longest axis of the centroids' bounds (a k-th element selection with the total order
 * (centroid, input index), so the tree is a function of the input alone), until at most
 * SM_BVH_LEAF remain. Median splits keep the depth at log2(n / SM_BVH_LEAF) + 1. The primitives'
 * vertices are copied in tree order so a leaf reads one contiguous run.
 *
 * Closest primitive: branch and bound. A node is opened only if the squared distance from p to
 * its box, d_box^2 = sum_k max(lo_k - p_k, 0, p_k - hi_k)^2, is below the best squared distance
 * so far (initially the caller's bound, or the distance to a warm-start primitive); the nearer
 * child is visited first. The answer is the exact minimum over all primitives.
 *
 * Winding number (Jacobson, Kavan & Sorkine-Hornung 2013, generalised winding number;
 * hierarchical evaluation after Barill et al. 2018, "Fast winding numbers for soups and clouds"):
 *   3D: w(p) = (1/4 pi) sum_t Omega_t(p), 2D: w(p) = (1/2 pi) sum_s theta_s(p)
 * (mesh_geom.c). A node whose centre c is farther than beta r from p (r: radius of the node's box
 * about c) contributes its dipole term instead of its primitives' exact sum:
 *   3D: Omega ~= N . (c - p) / |c - p|^3,   2D: theta ~= N . (c - p) / |c - p|^2,
 * with N the sum of the area vectors (3D: (b-a) x (c-a) / 2, 2D: the edge turned clockwise,
 * (e_y, -e_x)) and c the |area vector|-weighted mean of the centroids. The monopole term is zero
 * (a surface carries no net "charge"); for a flat node the next term cancels too, so the error is
 * small wherever the surface is smooth at the node's scale. The nodes are visited in a fixed order,
 * so the sum has the same bits on every run. Degenerate primitives (zero area) subtend no angle. */
#include "collide/bvh.h"

#include <string.h>

#define STACK_MAX 128

typedef struct builder {
    sm_bvh *t;
    const double *verts;
    const uint32_t *prims;
    double *cen;   /* centroid per input primitive */
    uint32_t *idx; /* input indices, permuted into tree order */
} builder;

static int key_less(const builder *B, uint32_t i, uint32_t j, int axis) {
    double a = B->cen[3 * (size_t)i + (size_t)axis], b = B->cen[3 * (size_t)j + (size_t)axis];
    return a < b || (a == b && i < j);
}

/* Reorders v[0..n) so that v[k] is the element of rank k and everything before it is smaller
 * (Hoare's selection with a median-of-three pivot; keys are distinct under the total order). */
static void select_kth(const builder *B, uint32_t *v, long n, long k, int axis) {
    long lo = 0, hi = n - 1;
    while (hi > lo) {
        long mid = lo + (hi - lo) / 2;
        uint32_t s;
#define SWAP(x, y) (s = v[x], v[x] = v[y], v[y] = s)
        if (key_less(B, v[mid], v[lo], axis)) SWAP(mid, lo);
        if (key_less(B, v[hi], v[lo], axis)) SWAP(hi, lo);
        if (key_less(B, v[hi], v[mid], axis)) SWAP(hi, mid);
        uint32_t pivot = v[mid];
        long i = lo, j = hi;
        while (i <= j) {
            while (key_less(B, v[i], pivot, axis)) i++;
            while (key_less(B, pivot, v[j], axis)) j--;
            if (i <= j) {
                SWAP(i, j);
                i++;
                j--;
            }
        }
#undef SWAP
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return;
    }
}

static void box_empty(double lo[3], double hi[3]) {
    for (int k = 0; k < 3; k++) {
        lo[k] = HUGE_VAL;
        hi[k] = -HUGE_VAL;
    }
}

static void box_add(double lo[3], double hi[3], const double p[3]) {
    for (int k = 0; k < 3; k++) {
        lo[k] = p[k] < lo[k] ? p[k] : lo[k];
        hi[k] = p[k] > hi[k] ? p[k] : hi[k];
    }
}

/* Builds the subtree over idx[first..last); returns its node index. */
static uint32_t build_node(builder *B, uint32_t first, uint32_t last) {
    sm_bvh *t = B->t;
    uint32_t self = (uint32_t)t->nnodes++;
    sm_bvh_node *nd = &t->nodes[self];
    double clo[3], chi[3];
    box_empty(nd->lo, nd->hi);
    box_empty(clo, chi);
    for (uint32_t i = first; i < last; i++) {
        const uint32_t *pr = B->prims + (size_t)B->idx[i] * (size_t)t->dim;
        for (int k = 0; k < t->dim; k++) box_add(nd->lo, nd->hi, B->verts + 3 * (size_t)pr[k]);
        box_add(clo, chi, B->cen + 3 * (size_t)B->idx[i]);
    }
    if (last - first <= SM_BVH_LEAF) {
        nd->start = first;
        nd->count = last - first;
        return self;
    }
    int axis = 0;
    for (int k = 1; k < t->dim; k++)
        if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
    uint32_t mid = first + (last - first) / 2;
    select_kth(B, B->idx + first, (long)(last - first), (long)(mid - first), axis);
    build_node(B, first, mid);
    uint32_t right = build_node(B, mid, last);
    nd = &t->nodes[self]; /* (no reallocation happens, but keep the pointer fresh) */
    nd->start = right;
    nd->count = 0;
    return self;
}

/* Area vector, weight and centroid of primitive `slot` (tree order). */
static void prim_moments(const sm_bvh *t, size_t slot, double n[3], double *weight, double cen[3]) {
    const double *a = sm_bvh_vertex(t, slot, 0), *b = sm_bvh_vertex(t, slot, 1);
    if (t->dim == 3) {
        const double *c = sm_bvh_vertex(t, slot, 2);
        double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ac[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        n[0] = 0.5 * (ab[1] * ac[2] - ab[2] * ac[1]);
        n[1] = 0.5 * (ab[2] * ac[0] - ab[0] * ac[2]);
        n[2] = 0.5 * (ab[0] * ac[1] - ab[1] * ac[0]);
        for (int k = 0; k < 3; k++) cen[k] = (a[k] + b[k] + c[k]) / 3.0;
    } else {
        n[0] = b[1] - a[1];
        n[1] = -(b[0] - a[0]);
        n[2] = 0.0;
        for (int k = 0; k < 3; k++) cen[k] = 0.5 * (a[k] + b[k]);
    }
    *weight = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

/* Far-field summaries, children before parents (nodes are depth first: reverse order works). */
static void build_far(sm_bvh *t) {
    for (size_t i = t->nnodes; i-- > 0;) {
        const sm_bvh_node *nd = &t->nodes[i];
        sm_bvh_far *f = &t->far[i];
        double n[3] = {0, 0, 0}, c[3] = {0, 0, 0}, w = 0.0;
        if (nd->count > 0) {
            for (uint32_t s = nd->start; s < nd->start + nd->count; s++) {
                double ns[3], ws, cs[3];
                prim_moments(t, s, ns, &ws, cs);
                for (int k = 0; k < 3; k++) {
                    n[k] += ns[k];
                    c[k] += ws * cs[k];
                }
                w += ws;
            }
        } else {
            const sm_bvh_far *l = &t->far[i + 1], *r = &t->far[nd->start];
            for (int k = 0; k < 3; k++) {
                n[k] = l->n[k] + r->n[k];
                c[k] = l->weight * l->c[k] + r->weight * r->c[k];
            }
            w = l->weight + r->weight;
        }
        for (int k = 0; k < 3; k++) c[k] = w > 0.0 ? c[k] / w : 0.5 * (nd->lo[k] + nd->hi[k]);
        double r2 = 0.0;
        for (int k = 0; k < 3; k++) {
            double e = fmax(fabs(nd->lo[k] - c[k]), fabs(nd->hi[k] - c[k]));
            r2 += e * e;
        }
        memcpy(f->n, n, sizeof n);
        memcpy(f->c, c, sizeof c);
        f->r = sqrt(r2);
        f->weight = w;
    }
}

void sm_bvh_free(sm_bvh *t) {
    void *owned[] = {t->nodes, t->far, t->pv, t->id, t->flat};
    for (size_t i = 0; i < sizeof owned / sizeof owned[0]; i++) free(owned[i]);
    memset(t, 0, sizeof *t);
}

/* 1 if primitive `slot` has no area (3D, sm_triangle_is_flat) or no length (2D). */
static int prim_is_flat(const sm_bvh *t, size_t slot) {
    const double *a = sm_bvh_vertex(t, slot, 0), *b = sm_bvh_vertex(t, slot, 1);
    if (t->dim == 3) return sm_triangle_is_flat(a, b, sm_bvh_vertex(t, slot, 2));
    return a[0] == b[0] && a[1] == b[1];
}

sm_status sm_bvh_build(sm_bvh *t, int dim, const double *verts, size_t nverts, const uint32_t *prims, size_t nprims) {
    (void)nverts; /* checked by SM_ASSERT below only */
    SM_ASSERT(dim == 2 || dim == 3);
    SM_ASSERT(nprims > 0 && nprims < (size_t)UINT32_MAX / 2);
    memset(t, 0, sizeof *t);
    t->dim = dim;
    t->nprims = nprims;
    t->beta = 2.0;
    builder B = {t, verts, prims, sm_malloc(nprims * 3 * sizeof(double)), sm_malloc(nprims * sizeof(uint32_t))};
    t->nodes = sm_malloc(2 * nprims * sizeof *t->nodes);
    t->far = sm_malloc(2 * nprims * sizeof *t->far);
    t->pv = sm_malloc(nprims * (size_t)dim * 3 * sizeof(double));
    t->id = sm_malloc(nprims * sizeof(uint32_t));
    t->flat = sm_malloc(nprims);
    if (!B.cen || !B.idx || !t->nodes || !t->far || !t->pv || !t->id || !t->flat) {
        free(B.cen);
        free(B.idx);
        sm_bvh_free(t);
        return SM_ERR_NOMEM;
    }
    for (size_t i = 0; i < nprims; i++) {
        double *c = B.cen + 3 * i;
        c[0] = c[1] = c[2] = 0.0;
        for (int k = 0; k < dim; k++) {
            uint32_t v = prims[i * (size_t)dim + (size_t)k];
            SM_ASSERT(v < nverts);
            for (int a = 0; a < dim; a++) c[a] += verts[3 * (size_t)v + (size_t)a] / dim;
        }
        B.idx[i] = (uint32_t)i;
    }
    build_node(&B, 0, (uint32_t)nprims);
    for (size_t s = 0; s < nprims; s++) {
        t->id[s] = B.idx[s];
        for (int k = 0; k < dim; k++) {
            const double *v = verts + 3 * (size_t)prims[(size_t)B.idx[s] * (size_t)dim + (size_t)k];
            double *dst = t->pv + (s * (size_t)dim + (size_t)k) * 3;
            dst[0] = v[0];
            dst[1] = v[1];
            dst[2] = dim == 3 ? v[2] : 0.0;
        }
        t->flat[s] = (unsigned char)prim_is_flat(t, s);
    }
    if (dim == 2)
        for (size_t i = 0; i < t->nnodes; i++) t->nodes[i].lo[2] = t->nodes[i].hi[2] = 0.0;
    build_far(t);
    free(B.cen);
    free(B.idx);
    return SM_OK;
}

static double box_dist2(const sm_bvh_node *nd, const double p[3]) {
    double s = 0.0;
    for (int k = 0; k < 3; k++) {
        double e = nd->lo[k] - p[k] > 0.0 ? nd->lo[k] - p[k] : p[k] - nd->hi[k] > 0.0 ? p[k] - nd->hi[k] : 0.0;
        s += e * e;
    }
    return s;
}

/* Tests primitive `slot` against the best hit so far; replaces it if strictly closer. */
static void test_prim(const sm_bvh *t, const double p[3], size_t slot, sm_bvh_hit *hit) {
    double q[3], bary[3] = {0, 0, 0}, d2;
    sm_simplex_region region;
    if (t->dim == 3) {
        const double *a = sm_bvh_vertex(t, slot, 0), *b = sm_bvh_vertex(t, slot, 1), *c = sm_bvh_vertex(t, slot, 2);
        d2 = t->flat[slot] ? sm_closest_on_triangle(p, a, b, c, q, bary, &region)
                           : sm_closest_on_proper_triangle(p, a, b, c, q, bary, &region);
    } else
        d2 = sm_closest_on_segment(p, sm_bvh_vertex(t, slot, 0), sm_bvh_vertex(t, slot, 1), q, bary, &region);
    if (d2 < hit->d2) {
        hit->d2 = d2;
        hit->slot = (long)slot;
        hit->prim = t->id[slot];
        memcpy(hit->q, q, sizeof q);
        memcpy(hit->bary, bary, sizeof bary);
        hit->region = region;
    }
}

void sm_bvh_closest(const sm_bvh *t, const double p[3], double bound2, long warm, sm_bvh_hit *hit) {
    hit->d2 = bound2;
    hit->slot = -1;
    if (warm >= 0) test_prim(t, p, (size_t)warm, hit);
    uint32_t stack[STACK_MAX];
    double sd2[STACK_MAX];
    int top = 0;
    stack[top] = 0;
    sd2[top++] = box_dist2(&t->nodes[0], p);
    while (top > 0) {
        top--;
        if (!(sd2[top] < hit->d2)) continue;
        const sm_bvh_node *nd = &t->nodes[stack[top]];
        if (nd->count > 0) {
            for (uint32_t s = nd->start; s < nd->start + nd->count; s++) test_prim(t, p, s, hit);
            continue;
        }
        uint32_t l = stack[top] + 1, r = nd->start;
        double dl = box_dist2(&t->nodes[l], p), dr = box_dist2(&t->nodes[r], p);
        SM_ASSERT(top + 2 <= STACK_MAX);
        if (dl <= dr) { /* nearer child on top (popped first) */
            stack[top] = r, sd2[top++] = dr;
            stack[top] = l, sd2[top++] = dl;
        } else {
            stack[top] = l, sd2[top++] = dl;
            stack[top] = r, sd2[top++] = dr;
        }
    }
}

/* Exact angle subtended by primitive `slot` at p (0 for a degenerate one). */
static double prim_angle(const sm_bvh *t, const double p[3], size_t slot) {
    if (t->flat[slot]) return 0.0;
    if (t->dim == 3)
        return sm_solid_angle(p, sm_bvh_vertex(t, slot, 0), sm_bvh_vertex(t, slot, 1), sm_bvh_vertex(t, slot, 2));
    return sm_segment_angle(p, sm_bvh_vertex(t, slot, 0), sm_bvh_vertex(t, slot, 1));
}

double sm_bvh_winding(const sm_bvh *t, const double p[3]) {
    uint32_t stack[STACK_MAX];
    int top = 0;
    double sum = 0.0;
    stack[top++] = 0;
    while (top > 0) {
        uint32_t i = stack[--top];
        const sm_bvh_node *nd = &t->nodes[i];
        const sm_bvh_far *f = &t->far[i];
        double d[3] = {f->c[0] - p[0], f->c[1] - p[1], t->dim == 3 ? f->c[2] - p[2] : 0.0};
        double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if (r2 > t->beta * t->beta * f->r * f->r) {
            double nd_ = f->n[0] * d[0] + f->n[1] * d[1] + f->n[2] * d[2];
            sum += t->dim == 3 ? nd_ / (r2 * sqrt(r2)) : nd_ / r2;
        } else if (nd->count > 0) {
            for (uint32_t s = nd->start; s < nd->start + nd->count; s++) sum += prim_angle(t, p, s);
        } else {
            SM_ASSERT(top + 2 <= STACK_MAX);
            stack[top++] = nd->start;
            stack[top++] = i + 1;
        }
    }
    return sum / (t->dim == 3 ? 4.0 * SM_PI : 2.0 * SM_PI);
}
