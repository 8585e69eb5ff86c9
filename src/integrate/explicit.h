/* The explicit grid update (stages 4-5 of the step, thesis §3.4, (3.92)): grid velocities from
 * P2G's momentum and force, then the colliders. */
#ifndef SM_INTEGRATE_EXPLICIT_H
#define SM_INTEGRATE_EXPLICIT_H

#include "collide/grid_collide.h"

typedef struct sm_grid_update_io {
    const sm_grid *grid;          /* live blocks (geometry) */
    sm_grid_p2g in;               /* P2G's mass, momentum, force (read) */
    sm_grid_vel out;              /* v^n (FLIP only), v-bar, v-tilde (written; grid.h: they take the
                                     storage of momentum and force, node by node after reading) */
    sm_grid_colliders colliders;
} sm_grid_update_io;

/* Returns 1 if every v-bar and v-tilde it wrote is finite (then the grid's health check need not
 * scan them), 0 if one may not be. */
#ifdef SM_DIM
int SM_FN(sm_grid_update)(const sm_grid_update_io *io, const sm_step_ctx *c);
#endif

#endif
