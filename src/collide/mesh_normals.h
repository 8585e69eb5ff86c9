/* Angle-weighted pseudo-normals of a mesh's faces, edges and vertices (Baerentzen & Aanaes 2005),
 * for the one-sided sign rule of an open surface: the side of the closest feature's pseudo-normal.
 * See mesh_normals.c. */
#ifndef SM_COLLIDE_MESH_NORMALS_H
#define SM_COLLIDE_MESH_NORMALS_H

#include "collide/bvh.h"

typedef struct sm_mesh_normals {
    int dim;
    double *face;   /* per primitive (input order): unit normal, 3 doubles */
    double *edge;   /* 3D, per triangle: pseudo-normals of edges ab, bc, ca, 9 doubles */
    double *vertex; /* per vertex: pseudo-normal, 3 doubles */
} sm_mesh_normals;

/* Builds the normals of nprims primitives (dim indices each) over nverts vertices (3 doubles
 * each). SM_OK or SM_ERR_NOMEM. */
sm_status sm_mesh_normals_build(sm_mesh_normals *m, int dim, const double *verts, size_t nverts,
                                const uint32_t *prims, size_t nprims);

void sm_mesh_normals_free(sm_mesh_normals *m);

/* +1 if p is on the outer side of the closest feature in hit ((p - q) . n >= 0), else -1. */
double sm_mesh_normals_side(const sm_mesh_normals *m, const uint32_t *prims, const sm_bvh_hit *hit, const double p[3]);

#endif
