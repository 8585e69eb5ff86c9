/* The explicit grid update (explicit.h), compiled for SM_DIM = 2 and 3.
 *
 *   v^n_i = (mv)_i / m_i,   v*_i = v^n_i + dt (f_i / m_i + g)        (3.92)
 * then, per node with mass, GRID_COLLISIONS and FRICTION (collide/grid_collide.h) give v-bar and
 * v-tilde; where no collider can reach a block this step, v-bar = v-tilde = v*. Nodes without
 * mass get zero velocities. Blocks are independent: a static split over the threads. Each block's
 * velocities are then tested for a non-finite value (the grid's health check, health.h). */
#include "core/dim.h"

#include "core/team.h"
#include "integrate/explicit.h"

/* 0 * every velocity of block b, summed: NaN iff one is not finite (the grid's health check,
 * folded into the pass that wrote them while they are in cache). */
static sm_real block_nonfinite(const sm_real *vbar, const sm_real *vtilde, size_t b, size_t bn) {
    sm_real z = 0;
    for (size_t k = b * bn * D; k < (b + 1) * bn * D; k++) z += 0 * vbar[k] + 0 * vtilde[k];
    return z;
}

typedef struct update_job {
    const sm_grid_update_io *io;
    const sm_step_ctx *c;
    atomic_int bad;
} update_job;

/* v^n, v* (into v-bar and v-tilde: their values where no collider acts), then the colliders, for
 * blocks [lo, hi). */
static void update_blocks(void *arg, long lo, long hi) {
    update_job *job = arg;
    const sm_grid_update_io *io = job->io;
    const sm_step_ctx *c = job->c;
    const sm_grid *g = io->grid;
    const size_t bn = (size_t)g->block_nodes;
    const sm_real dtr = (sm_real)c->dt;
    const sm_real *mass = io->in.mass, *momentum = io->in.momentum, *force = io->in.force;
    sm_real *vn_out = io->out.vn, *vbar = io->out.vbar, *vtilde = io->out.vtilde;
    int bad = 0;
    for (size_t b = (size_t)lo; b < (size_t)hi; b++) {
        double vmax2 = 0; /* the largest |v*| */
        for (size_t ni = b * bn; ni < (b + 1) * bn; ni++) {
            sm_real m = mass[ni];
            sm_real inv_m = m > 0 ? SM_R(1.0) / m : 0;
            sm_real s2 = 0;
            for (int a = 0; a < D; a++) {
                sm_real vn = momentum[ni * D + a] * inv_m;
                sm_real vs = m > 0 ? vn + dtr * (force[ni * D + a] * inv_m + c->gravity[a]) : 0;
                if (vn_out) vn_out[ni * D + a] = vn;
                vbar[ni * D + a] = vs;
                vtilde[ni * D + a] = vs;
                s2 += vs * vs;
            }
            if ((double)s2 > vmax2) vmax2 = (double)s2;
        }
        SM_FN(sm_grid_collide_block)(&io->colliders, g, c, b, vmax2, mass, vbar, vtilde);
        const sm_real z = block_nonfinite(vbar, vtilde, b, bn);
        bad |= z != 0 || z != z;
    }
    if (bad) atomic_store_explicit(&job->bad, 1, memory_order_relaxed);
}

int SM_FN(sm_grid_update)(const sm_grid_update_io *io, const sm_step_ctx *c) {
    update_job job = {io, c, 0};
    sm_team_for(c->threads, (long)io->grid->nactive, update_blocks, &job);
    return !atomic_load(&job.bad);
}
