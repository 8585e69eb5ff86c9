/* The dimension table: the stages of one step compiled for one dimension (DESIGN §2). The world
 * picks sm_stages_2d or sm_stages_3d once, at creation, from def.dim; the step (step.c) calls
 * the stages through it. Each stage takes the step context and its own argument struct, which
 * holds exactly the arrays it reads and writes (the headers named below say which). */
#ifndef SM_INTEGRATE_STAGES_H
#define SM_INTEGRATE_STAGES_H

#include "collide/grid_collide.h"
#include "integrate/explicit.h"
#include "integrate/implicit_solver.h"
#include "material/plasticity.h"
#include "transfer/transfer.h"

typedef struct sm_stages {
    int dim;
    /* 2. Bin particles by grid block (grid/bin.h). */
    sm_status (*bin)(sm_bins *b, sm_particles *P, sm_grid *g, const sm_step_ctx *c);
    /* 2. A second batch of particles binned (a distributed step's arrivals, grid/bin.h). */
    sm_status (*bin_more)(sm_bins *b, sm_particles *P, sm_grid *g, const sm_step_ctx *c, size_t first);
    /* 3. P2G: mass, momentum and (explicit) force (transfer/transfer.h). */
    void (*p2g)(const sm_p2g_io *io, const sm_step_ctx *c);
    /* 4. Which nodes have material near each separating collider (collide/grid_collide.h). */
    void (*contact_gate)(const sm_contact_gate_io *io, const sm_step_ctx *c);
    /* 4-5. Explicit: v* = v^n + dt (f/m + g), collisions (v-bar), friction (v-tilde)
     * (integrate/explicit.h). */
    int (*grid_update)(const sm_grid_update_io *io, const sm_step_ctx *c);
    /* 4-5. Implicit: Newton-GMRES for v-bar, then collisions and friction as above
     * (integrate/implicit_solver.h). */
    sm_status (*implicit_solve)(const sm_implicit_io *io, const sm_step_ctx *c);
    /* Test hook of the implicit operators (implicit_solver.h). */
    double (*implicit_jvp_check)(const sm_implicit_io *io, const sm_step_ctx *c, uint64_t seed, double vscale, double h);
    /* 6. G2P: v, B from v-tilde; x, F^E-hat from v-bar (transfer/transfer.h). */
    void (*g2p)(const sm_g2p_io *io, const sm_step_ctx *c, sm_g2p_stats *st);
    /* 7. Plasticity and hardening, then tau for the next step (material/plasticity.h); returns 1
     * if a value is not finite. */
    int (*plasticity)(const sm_plasticity_io *io);
} sm_stages;

extern const sm_stages sm_stages_2d;
extern const sm_stages sm_stages_3d;

#endif
