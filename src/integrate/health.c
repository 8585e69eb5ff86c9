/* Numerical health checks of the step and their messages (health.h). */
#include "integrate/health.h"

/* The CFL check lets speeds pass up to |v|^2 dt^2 <= (1 + SM_CFL_SLACK) dx^2: the controller's
 * dt = cfl dx / vmax with cfl = 1 lands on the bound itself, and vmax comes from the last G2P in
 * sm_real (float sums in the float build), so without a slack rounding rejects the controller's
 * own choice (issue 12). 1e-5 on the square is 5e-6 of a cell: far above the rounding of a float
 * sum of squares (~1e-7), far below anything the stencil notices. */
#define SM_CFL_SLACK 1e-5

/* First particle with non-finite state, or (if dt > 0) one that would move more than one cell in
 * dt. *fast says which. */
static long first_bad_particle(const sm_world *w, double dt, int *fast) {
    const int d = w->dim, dd = d * d;
    const sm_particles *P = &w->p;
    const double lim2 = dt > 0 ? (w->def.dx / dt) * (w->def.dx / dt) * (1 + SM_CFL_SLACK) : INFINITY;
    *fast = 0;
    const size_t n = w->dist ? sm_dist_owned(w) : P->n; /* a ghost's F^E is its owner's to check */
    for (size_t p = 0; p < n; p++) {
        int ok = 1;
        double s2 = 0;
        for (int a = 0; a < d; a++) {
            ok &= isfinite(P->x[p * d + a]) && isfinite(P->v[p * d + a]);
            s2 += (double)P->v[p * d + a] * (double)P->v[p * d + a];
        }
        for (int k = 0; k < dd; k++) ok &= isfinite(P->F[p * dd + k]);
        for (int k = 0; k < SM_NTAU(d); k++) ok &= isfinite(P->tau[p * SM_NTAU(d) + k]);
        if (!ok) return (long)p;
        if (s2 > lim2) {
            *fast = 1;
            return (long)p;
        }
    }
    return -1;
}

/* |v| of particle p without overflow. */
static double particle_speed(const sm_world *w, long p) {
    const int d = w->dim;
    double vm = 0, s2 = 0;
    for (int a = 0; a < d; a++) vm = fmax(vm, fabs((double)w->p.v[p * d + a]));
    for (int a = 0; a < d; a++) s2 += ((double)w->p.v[p * d + a] / vm) * ((double)w->p.v[p * d + a] / vm);
    s2 *= vm * vm;
    if (!isfinite(s2)) s2 = vm * vm * (double)d;
    return isfinite(s2) ? sqrt(s2) : vm;
}

sm_status sm_health_check_start(sm_world *w, double dt, int *too_fast) {
    int fast = 0;
    long p = -1;
    *too_fast = 0;
    if (w->dirty || w->step_vmax2 * dt * dt > w->def.dx * w->def.dx * (1 + SM_CFL_SLACK))
        p = first_bad_particle(w, dt, &fast);
    if (p < 0) return SM_OK;
    if (fast) {
        *too_fast = 1;
        const double speed = particle_speed(w, p);
        return sm_world_fail(w, SM_ERR_NUMERICAL,
                             "step %llu (t = %.6g s): particle %ld (material %d) moves at %.3g m/s, %.3g cells in "
                             "dt = %.3g s; more than one cell per step breaks the method (CFL): the step was not "
                             "taken; use a smaller dt or sm_world_advance",
                             (unsigned long long)w->steps + 1, w->time, p, (int)w->p.mat[p], speed,
                             speed * dt / w->def.dx, dt);
    }
    return sm_world_fail(w, SM_ERR_NUMERICAL,
                         "step %llu (t = %.6g s): particle %ld (material %d) enters the step with a non-finite "
                         "position, velocity or deformation gradient",
                         (unsigned long long)w->steps + 1, w->time, p, (int)w->p.mat[p]);
}

/* First node whose v-bar or v-tilde is not finite, or -1. */
/* The first node with a non-finite velocity; a distributed world checks only the blocks its own
 * particles read (the outer edge of its ghost layer is incomplete: dist/dist.h). */
static long first_bad_node(const sm_world *w) {
    const sm_grid *g = &w->grid;
    const sm_grid_vel vel = sm_grid_vel_arrays(g);
    const size_t per_block = (size_t)g->block_nodes * (size_t)g->dim;
    for (size_t s = 0; s < g->nactive; s++) {
        if (w->dist && !sm_dist_block_complete(w, g->key[s])) continue;
        for (size_t k = s * per_block; k < (s + 1) * per_block; k++)
            if (!isfinite(vel.vtilde[k]) || !isfinite(vel.vbar[k])) return (long)(k / (size_t)g->dim);
    }
    return -1;
}

sm_status sm_health_check_grid(sm_world *w, double dt) {
    if (w->grid_finite) return SM_OK; /* the grid update tested every velocity it wrote */
    const long bad = first_bad_node(w);
    if (bad < 0) return SM_OK;
    int ijk[3];
    sm_grid_node_coords(&w->grid, (size_t)bad, ijk);
    /* Name the particle nearest to that node: the likely source. */
    const int d = w->dim;
    double best = INFINITY, speed = 0;
    long bp = -1;
    for (size_t p = 0; p < w->p.n; p++) {
        double r2 = 0, s2 = 0;
        for (int a = 0; a < d; a++) {
            double xa = w->def.domain_min[a] + ijk[a] * w->def.dx - (double)w->p.x[p * d + a];
            r2 += xa * xa;
            s2 += (double)w->p.v[p * d + a] * (double)w->p.v[p * d + a];
        }
        if (r2 < best) {
            best = r2;
            bp = (long)p;
            speed = sqrt(s2);
        }
    }
    return sm_world_fail(w, SM_ERR_NUMERICAL,
                         "step %llu (t = %.6g s, dt = %.3g s): grid node (%d, %d, %d) got a non-finite velocity; "
                         "nearest particle %ld (material %d, speed %.3g m/s); particle state is that of the last good step",
                         (unsigned long long)w->steps + 1, w->time, dt, ijk[0], ijk[1], ijk[2], bp,
                         bp >= 0 ? (int)w->p.mat[bp] : -1, speed);
}

sm_status sm_health_check_end(sm_world *w, double dt) {
    long p = -1;
    if (w->step_bad) {
        int fast;
        p = first_bad_particle(w, 0, &fast);
        if (p < 0) p = 0; /* cannot happen: the flag comes from a non-finite value */
    }
    w->dirty = 0;
    if (p < 0) return SM_OK;
    return sm_world_fail(w, SM_ERR_NUMERICAL,
                         "step %llu (t = %.6g s, dt = %.3g s): particle %ld (material %d) has a non-finite position, "
                         "velocity or deformation gradient",
                         (unsigned long long)w->steps + 1, w->time, dt, p, (int)w->p.mat[p]);
}
