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
#include "grid/bin.h"
#include "grid/grid.h"

/* The colliders as the grid sees them. */
typedef struct sm_grid_colliders {
    const sm_collider *cols; /* user colliders, then the domain walls */
    int count;
    int static_sticks;       /* def.static_friction_sticks: v-bar = v-tilde at nodes with contacts */
    const uint8_t *gate;     /* per node of the live blocks, the contact gate (below); NULL: every
                                collider acts on every node (def.contact_gap infinite) */
} sm_grid_colliders;

/* The contact gate (def.contact_gap): a separating collider acts on a grid node only where there
 * is material near it. Bit sm_gate_bit(b) (collide.h) of gate[node] is set when a particle whose
 * stencil holds the node lies within `gap` of collider b at the end of the step as it moves now
 * (phi_b at pose 1 of x_p + dt v^n_p). A node's mass reaches 1.5 dx (quadratic) or 2 dx (cubic)
 * beyond the particles; without the gate those nodes meet a wall while the material is still up
 * to that far from it, and their contact stops it there. With the gate (0.35) every case of the
 * incline benchmark is within 1e-3 at fine steps, but a block resting on a grid-aligned plane at
 * the elastic time step slid farther than without it, hence off by default (docs/validation.md
 * section 6). Sticky and slip colliders bind the material at their nodes (Algorithm 7) and are not
 * gated.
 *
 * The gate is an OR over particles, so it does not depend on their order, the thread count or
 * (with ghosts, dist.h) the rank count. */
typedef struct sm_contact_gate_io {
    size_t n;              /* particles (with MPI: owned, then ghosts) */
    const double *x;       /* positions, n * d */
    const sm_real *v;      /* velocities v^n, n * d */
    const sm_bins *bins;   /* this step's binning (every particle binned) */
    const sm_grid *grid;
    sm_grid_colliders colliders;
    double gap;            /* m: contact_gap dx */
    uint8_t *gate;         /* out: per node of the live blocks */
} sm_contact_gate_io;

#ifdef SM_DIM
/* Fills io->gate (every node of the live blocks: zeroed, then opened where material is near). A
 * particle moves at most cfl dx <= dx in the step (the start-of-step check refuses a dt that
 * would move one further), which bounds where a particle block's particles can be. */
void SM_FN(sm_contact_gate)(const sm_contact_gate_io *io, const sm_step_ctx *c);

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
