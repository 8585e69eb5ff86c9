/* The per-particle fields the frame writers (PLY, VTK) write, in float: one place that says what
 * a frame file holds for a particle, so that the formats cannot disagree; and the order frames are
 * written in: by stable particle id (sm_particles_view.id), so that vertex k is the same grain in
 * every frame of a run (grains an emitter adds later get larger ids and come after). */
#ifndef SM_APP_IO_FIELDS_H
#define SM_APP_IO_FIELDS_H

#include <stddef.h>
#include <stdint.h>

#include "sandmpm/sandmpm.h"

typedef struct sm_out_particle {
    float x[3], v[3];     /* position (m) and velocity (m/s); z = 0 in 2D */
    uint16_t material;    /* material id */
    float q;              /* hardening state */
    float friction_angle; /* degrees, from q through the material's hardening */
    float Je;             /* det F^E */
    float volume;         /* V0, m^3 (m^2 in 2D) */
    uint32_t id;          /* stable particle id */
} sm_out_particle;

/* The fields of particle i (storage index) of the view pv of world w. */
void sm_out_particle_get(const sm_world *w, const sm_particles_view *pv, size_t i, sm_out_particle *r);

/* Frame files are y-up (sandmpm's axes, the thesis's) unless written z-up (scene outputs.up = "z",
 * for Blender, Houdini's z-up setups, GIS): position and velocity (x, y, z) -> (x, -z, y), a
 * rotation by +90 degrees about x (up stays up, handedness kept). The PLY header says which
 * ("comment up y|z"); its "comment domain" stays in sandmpm's y-up axes. */
void sm_out_to_z_up(sm_out_particle *r);

/* The storage indices of the view's particles in increasing id order: a malloc'd array of pv->n
 * (free it), or NULL if out of memory. O(n) when the ids are 0..n-1 (the library's: no particle is
 * ever removed), else a sort. */
size_t *sm_out_id_order(const sm_particles_view *pv);

#endif
