/* Colliders acting on grid velocities (thesis §3.6.3-3.6.4, Algorithms 3 and 7): the rule for
 * one node, written once and used by both integrators.
 *
 * For a node at x_i with v* (the velocity before collisions):
 *   GRID_COLLISIONS (sm_collide_node): user colliders, then the domain walls -> the collided
 *     velocity and the contact records; the collision impulse per unit mass is dv = collided - v*;
 *   FRICTION (sm_friction_node): v-tilde = FRICTION(v-bar, dv), v-bar being the collided velocity
 *     (explicit) or the implicit solve's solution (Algorithm 5, line 5);
 *   friction moves the material (def.static_friction_sticks, the name from when it applied to the
 *     static regime only): at a node with contacts v-bar = v-tilde too, sticking or slipping, so
 *     that positions do not creep along the surface (static) and F integrates the velocity the
 *     momentum keeps (sliding; with the pre-friction v-bar the contact can feed a vibration of the
 *     body: grid_collide_dim.c, node_friction). 0: v-bar stays the pre-friction velocity
 *     (thesis §3.6.5). */
#ifndef SM_COLLIDE_GRID_COLLIDE_H
#define SM_COLLIDE_GRID_COLLIDE_H

#include "collide/collide.h"
#include "core/step_ctx.h"
#include "grid/grid.h"

/* The colliders as the grid sees them. */
typedef struct sm_grid_colliders {
    const sm_collider *cols; /* user colliders, then the domain walls */
    int count;
    int static_sticks;       /* def.static_friction_sticks: v-bar = v-tilde at nodes with contacts */
} sm_grid_colliders;

#ifdef SM_DIM
/* Explicit grid update's collision pass over live block `slot` (stage 5): every node with mass
 * holds v* in vbar on entry; leaves v-bar in vbar and v-tilde in vtilde. Returns at once when no
 * collider can reach the block this step (vmax2: the square of the block's largest |v*|). */
void SM_FN(sm_grid_collide_block)(const sm_grid_colliders *gc, const sm_grid *g, const sm_step_ctx *c, size_t slot,
                                  double vmax2, const sm_real *mass, sm_real *vbar, sm_real *vtilde);

/* GRID_COLLISIONS of a grid vector z (nodes 0 .. nodes-1, in place) for the nodes with mass,
 * recording each node's contacts in rec[] (count 0 and no sticky collider for massless nodes). */
void SM_FN(sm_grid_collide_vector)(const sm_grid_colliders *gc, const sm_grid *g, const sm_step_ctx *c,
                                   const sm_real *mass, size_t nodes, sm_real *z, sm_node_contact *rec);

/* The implicit step's final friction (Algorithm 5, lines 3-5), per node: dv = vcollided - vstar
 * (vcollided = GRID_COLLISIONS(vstar), whose contacts are rec), then the rule above from
 * v-bar = solution; writes v-bar and v-tilde. Nodes without mass must have no contacts
 * (sm_grid_collide_vector records none). */
void SM_FN(sm_grid_friction_after_solve)(const sm_grid_colliders *gc, const sm_grid *g, const sm_step_ctx *c,
                                         size_t nodes, const sm_node_contact *rec,
                                         const sm_real *solution, const sm_real *vstar, const sm_real *vcollided,
                                         sm_real *vbar, sm_real *vtilde);
#endif

#endif
