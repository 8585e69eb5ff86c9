/* Colliders on grid velocities (grid_collide.h), compiled for SM_DIM = 2 and 3.
 *
 * GRID_COLLISIONS and FRICTION themselves (Algorithms 7 and 3) are collide.c's; this file runs
 * them over grid nodes, in double (grid values are converted at the call), with the one rule
 * that turns a node's collided velocity and contacts into v-bar and v-tilde (node_friction). */
#include "core/dim.h"

#include "collide/grid_collide.h"
#include "core/team.h"

/* Position of grid node ni, m. */
static inline void node_position(const sm_grid *g, const sm_step_ctx *c, size_t ni, double xi[3]) {
    int ijk[3];
    sm_grid_node_coords(g, ni, ijk);
    xi[0] = xi[1] = xi[2] = 0;
    for (int a = 0; a < D; a++) xi[a] = (double)c->lo[a] + (double)ijk[a] * (double)c->dx;
}

/* The rule of grid_collide.h for one node: v holds v-bar on entry (the collided velocity, or the
 * implicit solution), dv the collision impulse, rec the contacts. Writes v-bar and v-tilde.
 * With static_sticks, a node in contact moves (positions, F) with its post-friction velocity,
 * sticking or slipping: friction then changes the deformation as it changes the momentum. With a
 * slipping node's pre-friction v-bar, F integrated a velocity the momentum no longer had, and the
 * contact fed the body's vibration at large steps: test_incline's 2D block at rest on the 30
 * degree plane (held there with mu 2, then mu 0.7) started to vibrate at elastic_cfl 0.65 and 0.7
 * (kinetic energy about its centre of mass from 1e-10 J to 6e-3 J) and slid 29 mm; now it holds
 * (0.05 mm) (2026-12-07, docs/experiments/README.md, incline_vibration.c). */
static inline void node_friction(const sm_grid_colliders *gc, const double xi[3], const sm_node_contact *rec,
                                 const double dv[3], double v[3], sm_real *vbar, sm_real *vtilde) {
    for (int a = 0; a < D; a++) vbar[a] = (sm_real)v[a];
    if (rec->count > 0) {
        sm_friction_node(gc->cols, D, xi, rec, dv, v);
        if (gc->static_sticks)
            for (int a = 0; a < D; a++) vbar[a] = (sm_real)v[a];
    }
    for (int a = 0; a < D; a++) vtilde[a] = (sm_real)v[a];
}

/* Node ni's contact gate (grid_collide.h). */
static inline unsigned node_gate(const sm_grid_colliders *gc, size_t ni) {
    return gc->gate ? gc->gate[ni] : SM_GATE_OPEN;
}

/* Centre of grid block `slot` (m) and its half-diagonal. */
static inline double block_center(const sm_grid *g, const sm_step_ctx *c, size_t slot, double ctr[3]) {
    int bc[3];
    sm_block_coords(g->key[slot], bc);
    ctr[0] = ctr[1] = ctr[2] = 0;
    for (int a = 0; a < D; a++) ctr[a] = (double)c->lo[a] + ((double)(bc[a] << SM_BLOCK_BITS) + 1.5) * (double)c->dx;
    return 1.5 * (double)c->dx * sqrt((double)D);
}

/* 1 if collider b cannot act on any node of a block with centre ctr and half-diagonal R whose
 * nodes move at most `reach` (m) in the step, contact tolerance included: its signed distance,
 * at both poses, exceeds lip (R + reach). Analytic signed distances are 1-Lipschitz
 * (tests/test_collide.c checks it), a mesh field lip-Lipschitz (collide.h), so the bound at the
 * centre covers every node. */
static inline int collider_far(const sm_collider *cb, const double ctr[3], double R, double reach) {
    const double bound = cb->lip * (R + reach);
    return sm_collider_phi(cb, D, 0, ctr, NULL) > bound && sm_collider_phi(cb, D, 1, ctr, NULL) > bound;
}

/* The colliders that may act on the block, in order, into near[] (at most cap; returns -1 if
 * more may act, then all are visited). A node's collision result is the same with the others
 * left out: they neither stick nor project it, nor record a contact. */
static inline int near_colliders(const sm_collider *cols, int ncol, const double ctr[3], double R, double reach,
                                 int *near, int cap) {
    int n = 0;
    for (int b = 0; b < ncol; b++) {
        if (collider_far(&cols[b], ctr, R, reach)) continue;
        if (n == cap) return -1;
        near[n++] = b;
    }
    return n;
}

void SM_FN(sm_grid_collide_block)(const sm_grid_colliders *gc, const sm_grid *g, const sm_step_ctx *c, size_t slot,
                                  double vmax2, const sm_real *mass, sm_real *vbar, sm_real *vtilde) {
    const size_t bn = (size_t)g->block_nodes;
    double ctr[3];
    const double R = block_center(g, c, slot, ctr);
    const double reach = c->dt * sqrt(vmax2) + 1e-6 * (1.0 + fabs(ctr[0]) + fabs(ctr[1]) + fabs(ctr[2]) + R);
    enum { NEAR_CAP = 32 };
    int near[NEAR_CAP];
    const int nnear = near_colliders(gc->cols, gc->count, ctr, R, reach, near, NEAR_CAP);
    if (nnear == 0) return;
    for (size_t ni = slot * bn; ni < (slot + 1) * bn; ni++) {
        if (!(mass[ni] > 0)) continue;
        double vstar[3] = {0, 0, 0}, v[3] = {0, 0, 0}, xi[3], dv[3];
        node_position(g, c, ni, xi);
        for (int a = 0; a < D; a++) v[a] = vstar[a] = (double)vbar[ni * D + a];
        sm_node_contact rec;
        const unsigned gate = node_gate(gc, ni);
        /* The far colliders are left out while the node moves no faster than the bound assumed
         * (a collider that speeds it up hands it to the full pass, from v* again). */
        if (nnear < 0 || sm_collide_node_among(gc->cols, near, nnear, D, xi, c->dt, vmax2, gate, v, &rec)) {
            for (int a = 0; a < D; a++) v[a] = vstar[a];
            (void)sm_collide_node_among(gc->cols, NULL, gc->count, D, xi, c->dt, INFINITY, gate, v, &rec);
        }
        for (int a = 0; a < 3; a++) dv[a] = v[a] - vstar[a];
        node_friction(gc, xi, &rec, dv, v, vbar + ni * D, vtilde + ni * D);
    }
}

/* The operands of a pass over the nodes (sm_team_for's argument). */
typedef struct nodes_job {
    const sm_grid_colliders *gc;
    const sm_grid *g;
    const sm_step_ctx *c;
    const sm_real *mass, *solution, *vstar, *vcollided;
    sm_real *z, *vbar, *vtilde;
    sm_node_contact *rec;
} nodes_job;

static void collide_nodes(void *arg, long lo, long hi) {
    const nodes_job *job = arg;
    const sm_grid_colliders *gc = job->gc;
    const sm_real *mass = job->mass;
    sm_real *z = job->z;
    for (long l = lo; l < hi; l++) {
        sm_node_contact *r = &job->rec[l];
        r->sticky = -1;
        r->count = 0;
        if (!(mass[l] > 0)) continue;
        double xi[3], v[3] = {0, 0, 0};
        node_position(job->g, job->c, (size_t)l, xi);
        for (int a = 0; a < D; a++) v[a] = (double)z[l * D + a];
        (void)sm_collide_node_among(gc->cols, NULL, gc->count, D, xi, job->c->dt, INFINITY, node_gate(gc, (size_t)l), v, r);
        for (int a = 0; a < D; a++) z[l * D + a] = (sm_real)v[a];
    }
}

void SM_FN(sm_grid_collide_vector)(const sm_grid_colliders *gc, const sm_grid *g, const sm_step_ctx *c,
                                   const sm_real *mass, size_t nodes, sm_real *z, sm_node_contact *rec) {
    nodes_job job = {.gc = gc, .g = g, .c = c, .mass = mass, .z = z, .rec = rec};
    sm_team_for(c->threads, (long)nodes, collide_nodes, &job);
}

static void friction_nodes(void *arg, long lo, long hi) {
    const nodes_job *job = arg;
    const sm_node_contact *rec = job->rec;
    for (long l = lo; l < hi; l++) {
        double v[3] = {0, 0, 0}, dv[3] = {0, 0, 0}, xi[3] = {0, 0, 0};
        for (int a = 0; a < D; a++) {
            v[a] = (double)job->solution[l * D + a];
            dv[a] = (double)job->vcollided[l * D + a] - (double)job->vstar[l * D + a];
        }
        if (rec[l].count > 0) node_position(job->g, job->c, (size_t)l, xi); /* (massless nodes have no contacts) */
        node_friction(job->gc, xi, &rec[l], dv, v, job->vbar + l * D, job->vtilde + l * D);
    }
}

void SM_FN(sm_grid_friction_after_solve)(const sm_grid_colliders *gc, const sm_grid *g, const sm_step_ctx *c,
                                         size_t nodes, const sm_node_contact *rec,
                                         const sm_real *solution, const sm_real *vstar, const sm_real *vcollided,
                                         sm_real *vbar, sm_real *vtilde) {
    nodes_job job = {.gc = gc, .g = g, .c = c, .solution = solution, .vstar = vstar, .vcollided = vcollided,
                     .vbar = vbar, .vtilde = vtilde, .rec = (sm_node_contact *)rec};
    sm_team_for(c->threads, (long)nodes, friction_nodes, &job);
}
