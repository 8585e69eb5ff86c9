/* The public mesh field handle (sandmpm.h, sm_mesh_field) as the rest of the library sees it:
 * the reference-counted wrapper of an sm_mesh_sdf (mesh_sdf.h). */
#ifndef SM_COLLIDE_MESH_FIELD_H
#define SM_COLLIDE_MESH_FIELD_H

#include "collide/mesh_sdf.h"

struct sm_mesh_field {
    int refs;
    sm_mesh_sdf *sdf;
    sm_mesh_field_stats stats; /* the field's, with lo/hi (its table box) */
    double radius; /* largest distance from the mesh frame's origin to a corner of that box, m */
};

/* Signed distance in the mesh frame (the query of sm_shape_distance's SM_SHAPE_MESH case). */
static inline double sm_mesh_field_local(const sm_mesh_field *m, const double p[3], double g[3]) {
    return sm_mesh_sdf_distance(m->sdf, p, g);
}

/* Radius about the shape centre of a ball holding the solid; INFINITY for a container (solid
 * outside the surface). */
double sm_mesh_field_extent(const sm_mesh_field *m);

#endif
