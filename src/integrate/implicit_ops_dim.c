/* The operators of the implicit solve (implicit_solver.h), compiled for SM_DIM = 2 and 3.
 *
 * Thesis §3.6.2.2, Algorithms 5, 6, 8, Appendix A.5. Unknowns: grid velocities z on the nodes of
 * the live blocks (nodes without mass held at zero). With
 *   F_p(z) = (I + dt sum_i z_i grad w_ip^T) F_p^n,
 *   G_p(z) = V0 Y(F_p(z)) F_p^nT        (Y: first Piola stress of the Drucker-Prager projected F,
 *                                        material/implicit.h),
 * the residual of Algorithm 5 is
 *   y_i(z) = z_i - v_i^n - dt g + (dt / m_i) sum_p G_p(z) grad w_ip,
 * evaluated at collided velocities and pruned (sticky rows zeroed, contact normals removed: the
 * projection P). Its derivative, TIMES_DIFF (Algorithm 6), is
 *   J dz = P(dz' + (dt^2/m) sum_p apply_p(sum_i dz'_i grad w_ip^T) grad w_ip),  dz' = P dz,
 * with apply_p from Algorithm 8's per-particle precompute (sm_implicit_apply). FORCE_INCREMENT_VEL
 * gives v* = v^n + dt g - (dt/m) sum_p G_p(z) grad w_ip.
 * Dot products are mass-weighted, summed per live block in node order and then exactly over the
 * blocks (math/xsum.h): bitwise the same for any thread count and, across MPI ranks (each
 * summing the blocks it owns, sm_imp_ranks), for any rank count. The passes over the particles
 * (gather, per-particle matrix, scatter) are implicit_pass_dim.c. */
#include "core/dim.h"

#include <string.h>

#include "core/team.h"
#include "integrate/implicit_solver.h"

/* The operands of a pass over grid blocks or nodes (sm_team_for's argument). */
typedef struct ops_job {
    const sm_implicit_sys *s;
    const sm_real *a, *b;
    sm_real *y;
    int prune;
    double dtg2;
} ops_job;

/* Each block's mass-weighted a . b into ws->partial. */
static void dot_blocks(void *arg, long lo, long hi) {
    const ops_job *job = arg;
    const sm_implicit_ws *ws = job->s->ws;
    const sm_real *a = job->a, *b = job->b;
    for (long t = lo; t < hi; t++) {
        double sum = 0;
        for (size_t l = (size_t)t * BN; l < (size_t)(t + 1) * BN; l++) {
            double m = (double)ws->mass[l];
            if (!(m > 0)) continue;
            for (int k = 0; k < D; k++) sum += m * (double)a[l * D + k] * (double)b[l * D + k];
        }
        ws->partial[t] = sum;
    }
}

double SM_FN(sm_imp_dot)(const sm_implicit_sys *s, const sm_real *a, const sm_real *b) {
    ops_job job = {.s = s, .a = a, .b = b};
    sm_team_for(s->c->threads, (long)s->grid->nactive, dot_blocks, &job);
    return SM_FN(sm_imp_block_sum)(s);
}

double SM_FN(sm_imp_block_sum)(const sm_implicit_sys *s) {
    const sm_imp_ranks *r = s->ranks;
    sm_xsum acc;
    sm_xsum_init(&acc);
    for (size_t t = 0; t < s->grid->nactive; t++)
        if (!r || r->owned[t]) sm_xsum_add(&acc, s->ws->partial[t]);
    if (r) r->sum(r->ctx, &acc);
    return sm_xsum_value(&acc);
}

/* Refreshes v's blocks owned by other ranks (a distributed solve) before a gather reads it. */
static void refresh(const sm_implicit_sys *s, sm_real *v) {
    if (s->ranks) s->ranks->refresh(s->ranks->ctx, v);
}

void SM_FN(sm_imp_forces)(const sm_implicit_sys *s, sm_real *z, int pre) {
    refresh(s, z);
    SM_FN(sm_imp_particle_pass)(s, pre ? SM_IMP_PASS_PRECOMPUTE : SM_IMP_PASS_FORCE, z, s->ws->force);
}

void SM_FN(sm_imp_collide)(const sm_implicit_sys *s, sm_real *z) {
    SM_FN(sm_grid_collide_vector)(&s->colliders, s->grid, s->c, s->ws->mass, s->nodes, z, s->ws->contact);
}

/* Removes contact k of rec (PRUNE_COLLISIONS). */
static void forget_contact(sm_node_contact *rec, int k) {
    for (int j = k; j + 1 < rec->count; j++) {
        rec->stick[j] = rec->stick[j + 1];
        rec->body[j] = rec->body[j + 1];
        memcpy(rec->n[j], rec->n[j + 1], sizeof rec->n[j]);
    }
    rec->count--;
}

static void project_nodes(void *arg, long lo, long hi) {
    const ops_job *job = arg;
    const sm_implicit_sys *s = job->s;
    sm_implicit_ws *ws = s->ws;
    const sm_collider *cols = s->colliders.cols;
    sm_real *y = job->y;
    const int prune = job->prune;
    for (long l = lo; l < hi; l++) {
        sm_node_contact *rec = &ws->contact[l];
        sm_real *v = y + l * D;
        if (!(ws->mass[l] > 0) || rec->sticky >= 0) {
            for (int a = 0; a < D; a++) v[a] = 0;
            continue;
        }
        for (int k = 0; k < rec->count; k++) {
            const double *nrm = rec->n[k];
            double vn = 0;
            for (int a = 0; a < D; a++) vn += (double)v[a] * nrm[a];
            /* A separating contact whose residual points away (y . n < 0) is forgotten first. */
            if (prune && (cols[rec->body[k]].def.mode == SM_COLLIDE_SEPARATE || rec->stick[k]) && vn < 0) {
                forget_contact(rec, k);
                k--;
                continue;
            }
            for (int a = 0; a < D; a++) v[a] = (sm_real)((double)v[a] - vn * nrm[a]);
        }
    }
}

void SM_FN(sm_imp_project)(const sm_implicit_sys *s, sm_real *y, int prune) {
    ops_job job = {.s = s, .y = y, .prune = prune};
    sm_team_for(s->c->threads, (long)s->nodes, project_nodes, &job);
}

void SM_FN(sm_imp_residual)(const sm_implicit_sys *s, const sm_real *z, sm_real *y) {
    const sm_implicit_ws *ws = s->ws;
    const sm_real dt = (sm_real)s->c->dt;
    const sm_real *g = s->c->gravity;
    for (size_t l = 0; l < s->nodes; l++) {
        sm_real m = ws->mass[l];
        for (int a = 0; a < D; a++)
            y[l * D + a] = m > 0 ? z[l * D + a] - ws->vn[l * D + a] - dt * g[a] + dt / m * ws->force[l * D + a] : 0;
    }
}

void SM_FN(sm_imp_force_increment)(const sm_implicit_sys *s, sm_real *z, sm_real *vstar) {
    SM_FN(sm_imp_forces)(s, z, 0);
    SM_FN(sm_imp_vstar)(s, vstar);
}

void SM_FN(sm_imp_vstar)(const sm_implicit_sys *s, sm_real *vstar) {
    const sm_implicit_ws *ws = s->ws;
    const sm_real dt = (sm_real)s->c->dt;
    const sm_real *g = s->c->gravity;
    for (size_t l = 0; l < s->nodes; l++)
        for (int a = 0; a < D; a++)
            vstar[l * D + a] = ws->mass[l] > 0 ? ws->vn[l * D + a] + dt * g[a] - dt / ws->mass[l] * ws->force[l * D + a] : 0;
}

static void term_scale_blocks(void *arg, long lo, long hi) {
    const ops_job *job = arg;
    const sm_implicit_ws *ws = job->s->ws;
    const sm_real *z = job->a;
    const double dt = job->s->c->dt, dtg2 = job->dtg2;
    for (long t = lo; t < hi; t++) {
        double sum = 0;
        for (size_t l = (size_t)t * BN; l < (size_t)(t + 1) * BN; l++) {
            const double m = (double)ws->mass[l];
            if (!(m > 0)) continue;
            double q = dtg2;
            for (int k = 0; k < D; k++) {
                const double f = dt / m * (double)ws->force[l * D + k];
                q += (double)z[l * D + k] * (double)z[l * D + k] + (double)ws->vn[l * D + k] * (double)ws->vn[l * D + k] + f * f;
            }
            sum += m * q;
        }
        ws->partial[t] = sum;
    }
}

double SM_FN(sm_imp_term_scale2)(const sm_implicit_sys *s, const sm_real *z) {
    double g2 = 0;
    for (int a = 0; a < D; a++) g2 += (double)s->c->gravity[a] * (double)s->c->gravity[a];
    const double dt = s->c->dt;
    ops_job job = {.s = s, .a = z, .dtg2 = dt * dt * g2};
    sm_team_for(s->c->threads, (long)s->grid->nactive, term_scale_blocks, &job);
    return SM_FN(sm_imp_block_sum)(s);
}

double SM_FN(sm_imp_residual_norm2)(const sm_implicit_sys *s, sm_real *z, sm_real *y, int pre) {
    SM_FN(sm_imp_forces)(s, z, pre);
    SM_FN(sm_imp_residual)(s, z, y);
    SM_FN(sm_imp_project)(s, y, 1);
    return SM_FN(sm_imp_dot)(s, y, y);
}

void SM_FN(sm_imp_times_diff)(const sm_implicit_sys *s, const sm_real *x, sm_real *out, sm_real *px) {
    sm_implicit_ws *ws = s->ws;
    memcpy(px, x, s->nodes * D * sizeof(sm_real));
    SM_FN(sm_imp_project)(s, px, 0);
    refresh(s, px); /* P x: other ranks' contacts project their blocks */
    SM_FN(sm_imp_particle_pass)(s, SM_IMP_PASS_HESSIAN, px, out);
    const sm_real dt2 = (sm_real)(s->c->dt * s->c->dt);
    for (size_t l = 0; l < s->nodes; l++) {
        sm_real m = ws->mass[l];
        for (int a = 0; a < D; a++) out[l * D + a] = m > 0 ? px[l * D + a] + dt2 / m * out[l * D + a] : 0;
    }
    SM_FN(sm_imp_project)(s, out, 0);
}
