/* The public mesh field handle (sandmpm.h, sm_mesh_field) as the rest of the library sees it:
 * the reference-counted wrapper of an sm_mesh_sdf (mesh_sdf.h). */
#ifndef SM_COLLIDE_MESH_FIELD_H
#define SM_COLLIDE_MESH_FIELD_H

#include "collide/mesh_sdf.h"

typedef struct sm_mesh_anim sm_mesh_anim; /* mesh_anim.c */

struct sm_mesh_field {
    int refs;
    sm_mesh_sdf *sdf;          /* the field (an animated one: frame 0's, owned by anim) */
    sm_mesh_field_stats stats; /* the field's, with lo/hi (its table box; animated: every frame's) */
    double radius; /* largest distance from the mesh frame's origin to a corner of that box, m */
    sm_mesh_anim *anim;        /* NULL for a static field */
};

/* Signed distance in the mesh frame (the query of sm_shape_distance's SM_SHAPE_MESH case). */
static inline double sm_mesh_field_local(const sm_mesh_field *m, const double p[3], double g[3]) {
    return sm_mesh_sdf_distance(m->sdf, p, g);
}

/* The same at time t: an animated field interpolates its two frames about t (mesh_anim.c). */
double sm_mesh_anim_local(const sm_mesh_field *m, double t, const double p[3], double g[3]);

/* Velocity of an animated field's surface at time t near p (mesh frame), m/s; 0 if static. */
void sm_mesh_anim_velocity(const sm_mesh_field *m, double t, const double p[3], double v[3]);

/* Frees an animation's frames (sm_mesh_field_release of an animated field). */
void sm_mesh_anim_destroy(sm_mesh_anim *a);

/* Wraps sdf (taken over) in a handle with one reference; NULL (sdf destroyed) if out of memory. */
sm_mesh_field *sm_mesh_field_wrap(sm_mesh_sdf *sdf);

/* Radius about the shape centre of a ball holding the solid; INFINITY for a container (solid
 * outside the surface). */
double sm_mesh_field_extent(const sm_mesh_field *m);

#endif
