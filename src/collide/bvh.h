/* Bounding volume hierarchy over a triangle mesh (3D) or a segment outline (2D), built once, for
 * the two queries a mesh signed distance needs: the closest primitive to a point (within a bound)
 * and the generalised winding number at a point (exact near, dipole far). See bvh.c. */
#ifndef SM_COLLIDE_BVH_H
#define SM_COLLIDE_BVH_H

#include "collide/mesh_geom.h"
#include "core/common.h"

#define SM_BVH_LEAF 4 /* primitives per leaf at the most */

typedef struct sm_bvh_node {
    double lo[3], hi[3]; /* bounds of the node's primitives */
    uint32_t start;      /* leaf: first primitive (tree order); inner: right child (left = this + 1) */
    uint32_t count;      /* leaf: number of primitives (1..SM_BVH_LEAF); inner: 0 */
} sm_bvh_node;

/* Far-field (dipole) summary of a node, for the winding number. */
typedef struct sm_bvh_far {
    double n[3];   /* sum of the primitives' area vectors (3D: (b-a)x(c-a)/2; 2D: (e_y, -e_x)) */
    double c[3];   /* centre: the primitives' centroids weighted by |area vector| */
    double r;      /* radius: every point of the node's box is within r of c */
    double weight; /* sum of |area vector| */
} sm_bvh_far;

typedef struct sm_bvh {
    int dim;             /* 3: triangles, 2: segments (z = 0) */
    size_t nprims, nnodes;
    sm_bvh_node *nodes;  /* depth first; nodes[0] is the root */
    sm_bvh_far *far;     /* one per node */
    double *pv;          /* primitive vertices in tree order: nprims * dim * 3 */
    uint32_t *id;        /* tree order -> input primitive index */
    unsigned char *flat; /* per primitive (tree order): 1 if degenerate (zero area / length) */
    double beta;         /* far-field criterion: |p - c| > beta r (default 2) */
} sm_bvh;

/* Builds the tree over nprims primitives of dim vertex indices each (prims), vertices given as
 * 3 doubles each (z ignored in 2D). Indices must be < nverts (asserted). SM_OK or SM_ERR_NOMEM. */
sm_status sm_bvh_build(sm_bvh *t, int dim, const double *verts, size_t nverts, const uint32_t *prims, size_t nprims);

/* Frees what sm_bvh_build allocated (a zeroed or freed tree is fine). */
void sm_bvh_free(sm_bvh *t);

typedef struct sm_bvh_hit {
    double d2;                /* squared distance to the closest primitive found */
    long slot;                /* its tree-order index, -1 if none was closer than the bound */
    uint32_t prim;            /* its input index */
    double q[3];              /* closest point */
    double bary[3];           /* barycentric coordinates of q on the primitive */
    sm_simplex_region region; /* where q lies on it */
} sm_bvh_hit;

/* The closest primitive to p among those closer than sqrt(bound2) (HUGE_VAL: no bound). warm: a
 * tree-order index to try first (a neighbouring point's answer), or -1; it only speeds the
 * search up. On return hit->slot < 0 if nothing is closer than the bound (hit->d2 = bound2). */
void sm_bvh_closest(const sm_bvh *t, const double p[3], double bound2, long warm, sm_bvh_hit *hit);

/* Generalised winding number at p: about 1 inside a closed outward-oriented surface, 0 outside. */
double sm_bvh_winding(const sm_bvh *t, const double p[3]);

/* The vertices of primitive `slot` (tree order): dim pointers to 3 doubles. */
static inline const double *sm_bvh_vertex(const sm_bvh *t, size_t slot, int k) {
    return t->pv + (slot * (size_t)t->dim + (size_t)k) * 3;
}

#endif
