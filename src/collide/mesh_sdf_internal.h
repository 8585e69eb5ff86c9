/* The mesh signed distance field's storage, shared by the build/query (mesh_sdf.c) and the
 * serialisation (mesh_sdf_io.c).
 *
 * Lattice: node i (integer, per axis) sits at origin + i h. Cells [i, i+1) are grouped in bricks
 * of 8 cells per axis; a brick stores its own 9 nodes per axis (9^3 = 729 floats, the faces
 * shared with a neighbour are stored twice), so interpolation never looks outside one brick.
 * A dense coarse table has one entry per brick position: the index of a stored brick, or
 * SM_SDF_OUTSIDE / SM_SDF_INSIDE for a brick with no node in the band (value +band / -band).
 * Coarse nodes, one per brick corner ((nb + 1) per axis), hold the exact signed distance there:
 * the fallback gradient beyond the band. */
#ifndef SM_COLLIDE_MESH_SDF_INTERNAL_H
#define SM_COLLIDE_MESH_SDF_INTERNAL_H

#include "collide/mesh_sdf.h"

#define SM_SDF_BRICK_BITS 3
#define SM_SDF_BRICK 8 /* cells per brick and axis */
#define SM_SDF_BN 9    /* nodes per brick and axis */
#define SM_SDF_OUTSIDE (-1)
#define SM_SDF_INSIDE (-2)
#define SM_SDF_MAX_TABLE ((size_t)1 << 26) /* brick positions at the most (256 MiB of table) */

struct sm_mesh_sdf {
    int dim;
    double h, inv_h, band;
    double origin[3];       /* position of lattice node 0 */
    int nb[3];              /* table size (bricks per axis); 1 in z for 2D */
    int ncells[3];          /* lattice cells per axis: 8 nb (0 in z for 2D) */
    int32_t *table;         /* nb[0] nb[1] nb[2] entries, x fastest */
    float *coarse;          /* (nb[0]+1) (nb[1]+1) (nb[2]+1 or 1) coarse node distances */
    size_t nbricks;
    size_t brick_nodes;     /* 9^dim */
    float *bricks;          /* nbricks x brick_nodes, x fastest inside a brick */
    float far_value;        /* beyond the table: +band, or -band for a container */
    sm_mesh_sdf_stats stats;
};

static inline size_t sm_sdf_table_size(const struct sm_mesh_sdf *f) {
    return (size_t)f->nb[0] * (size_t)f->nb[1] * (size_t)f->nb[2];
}

static inline size_t sm_sdf_coarse_size(const struct sm_mesh_sdf *f) {
    return (size_t)(f->nb[0] + 1) * (size_t)(f->nb[1] + 1) * (size_t)(f->dim == 3 ? f->nb[2] + 1 : 1);
}

/* Fills the derived fields (inv_h, ncells, brick_nodes, far_value, stats.bytes/table) from dim, h,
 * band, nb and stats.container. */
void sm_mesh_sdf_finish_layout(struct sm_mesh_sdf *f);

#endif
