/* Diagnostics of the world: particle and grid totals (mass, momentum, angular momentum), energies,
 * the step statistics, the state hash. */
#include <string.h>

#include "core/team.h"
#include "material/material.h"
#include "math/svd.h"
#include "world/world.h"

void sm_world_particle_totals(const sm_world *w, double *mass, double mom[3], double ang[3]) {
    const int d = w->dim, dd = d * d;
    const sm_particles *P = &w->p;
    *mass = 0;
    for (int a = 0; a < 3; a++) mom[a] = ang[a] = 0;
    const int apic = (w->def.transfer == SM_TRANSFER_APIC);
    for (size_t p = 0; p < P->n; p++) {
        double m = (double)sm_particle_mass(w->mats, P, p);
        double x[3] = {0, 0, 0}, v[3] = {0, 0, 0}, B[9] = {0};
        for (int a = 0; a < d; a++) {
            x[a] = (double)P->x[p * d + a];
            v[a] = (double)P->v[p * d + a];
        }
        if (apic)
            for (int a = 0; a < d; a++)
                for (int e = 0; e < d; e++) B[a * 3 + e] = (double)P->B[p * dd + a * d + e];
        *mass += m;
        for (int a = 0; a < 3; a++) mom[a] += m * v[a];
        /* L_p = m (x x v) + m eps_abc B_cb (APIC's affine part, derived from P2G of (3.87)). */
        ang[0] += m * (x[1] * v[2] - x[2] * v[1] + B[2 * 3 + 1] - B[1 * 3 + 2]);
        ang[1] += m * (x[2] * v[0] - x[0] * v[2] + B[0 * 3 + 2] - B[2 * 3 + 0]);
        ang[2] += m * (x[0] * v[1] - x[1] * v[0] + B[1 * 3 + 0] - B[0 * 3 + 1]);
    }
}

void sm_world_grid_totals(const sm_world *w, double *mass, double mom[3], double ang[3]) {
    const sm_grid *g = &w->grid;
    const sm_real *vel = sm_grid_vel_arrays(g).vtilde;
    const int d = w->dim;
    const size_t nn = g->nactive * (size_t)g->block_nodes;
    *mass = 0;
    for (int a = 0; a < 3; a++) mom[a] = ang[a] = 0;
    for (size_t ni = 0; ni < nn; ni++) {
        double m = (double)g->mass[ni];
        if (!(m > 0)) continue;
        int ijk[3];
        sm_grid_node_coords(g, ni, ijk);
        double x[3] = {0, 0, 0}, mv[3] = {0, 0, 0};
        for (int a = 0; a < d; a++) {
            x[a] = w->def.domain_min[a] + ijk[a] * w->def.dx;
            mv[a] = m * (double)vel[ni * (size_t)d + (size_t)a];
        }
        *mass += m;
        for (int a = 0; a < 3; a++) mom[a] += mv[a];
        ang[0] += x[1] * mv[2] - x[2] * mv[1];
        ang[1] += x[2] * mv[0] - x[0] * mv[2];
        ang[2] += x[0] * mv[1] - x[1] * mv[0];
    }
}

/* Sum of V0 psi(F^E) (Hencky energy (3.71) of each particle's elastic deformation). The particles'
 * energies (an SVD each) are computed a chunk at a time on the step's threads, then summed in
 * particle order: the serial loop's sum, bit for bit. */
enum { ENERGY_CHUNK = 2048 };

typedef struct energy_job {
    const sm_world *w;
    size_t first;
    double *e; /* e[k]: particle first + k's V0 psi */
} energy_job;

static void particle_energies(void *arg, long lo, long hi) {
    const energy_job *job = arg;
    const sm_particles *P = &job->w->p;
    const int d = job->w->dim, dd = d * d;
    for (long k = lo; k < hi; k++) {
        const size_t p = job->first + (size_t)k;
        const sm_material_rt *m = &job->w->mats[P->mat[p]];
        sm_real U[9], V[9], s[3];
        if (d == 2) sm_svd2(P->F + p * (size_t)dd, U, s, V);
        else sm_svd3(P->F + p * (size_t)dd, U, s, V);
        job->e[k] = (double)P->vol0[p] * (double)sm_hencky_psi(d, s, m->law.mu, m->law.lambda);
    }
}

static double elastic_energy(const sm_world *w) {
    const size_t n = w->p.n;
    double e = 0, chunk[ENERGY_CHUNK];
    for (size_t first = 0; first < n; first += ENERGY_CHUNK) {
        const size_t cnt = n - first < ENERGY_CHUNK ? n - first : ENERGY_CHUNK;
        energy_job job = {w, first, chunk};
        sm_team_for(w->threads, (long)cnt, particle_energies, &job); /* the last step's threads */
        for (size_t k = 0; k < cnt; k++) e += chunk[k];
    }
    return e;
}

/* A distributed world's totals over the ranks (collective): the sums of each rank's partial sums
 * in rank order (the same bits on every rank; within rounding of one process's sums, whose order
 * is its storage order), the largest speed and stage times, the particle and event counts. */
static void over_ranks(const sm_world *w, sm_diagnostics *o, double com[3], double *vmax2) {
    double v[14] = {o->total_mass, o->momentum[0], o->momentum[1], o->momentum[2], o->angular_momentum[0],
                    o->angular_momentum[1], o->angular_momentum[2], o->kinetic_energy, com[0], com[1], com[2],
                    o->elastic_energy, (double)o->particles, 0};
    sm_dist_sum_n(w, v, 13);
    o->total_mass = v[0];
    for (int a = 0; a < 3; a++) o->momentum[a] = v[1 + a], o->angular_momentum[a] = v[4 + a], com[a] = v[8 + a];
    o->kinetic_energy = v[7];
    o->elastic_energy = v[11];
    o->particles = (size_t)v[12]; /* exact below 2^53 */
    *vmax2 = sm_dist_max(w, *vmax2);
    sm_dist_max_n(w, o->stage_seconds, SM_STAGE_COUNT);
    double events[2] = {(double)w->clamped, (double)w->projected};
    sm_dist_sum_n(w, events, 2);
    o->clamped_particles = (uint64_t)events[0];
    o->projected_particles = (uint64_t)events[1];
}

void sm_world_diagnostics(const sm_world *w, sm_diagnostics *o) {
    memset(o, 0, sizeof *o);
    const int d = w->dim;
    const sm_particles *P = &w->p;
    o->particles = P->n;
    sm_world_particle_totals(w, &o->total_mass, o->momentum, o->angular_momentum);
    double ke = 0, vmax2 = 0, com[3] = {0, 0, 0};
    for (size_t p = 0; p < P->n; p++) {
        double s = 0;
        for (int a = 0; a < d; a++) {
            double va = (double)P->v[p * d + a];
            s += va * va;
            com[a] += (double)sm_particle_mass(w->mats, P, p) * (double)P->x[p * d + a];
        }
        ke += 0.5 * (double)sm_particle_mass(w->mats, P, p) * s;
        if (s > vmax2) vmax2 = s;
    }
    o->kinetic_energy = ke;
    o->elastic_energy = P->n ? elastic_energy(w) : 0;
    for (int s = 0; s < SM_STAGE_COUNT; s++) o->stage_seconds[s] = w->stage_seconds[s];
    o->clamped_particles = w->clamped;
    o->projected_particles = w->projected;
    if (w->dist) over_ranks(w, o, com, &vmax2);
    o->max_speed = sqrt(vmax2);
    for (int a = 0; a < 3; a++) o->center_of_mass[a] = o->total_mass > 0 ? com[a] / o->total_mass : 0;
    o->steps = w->steps;
    o->time = w->time;
    o->last_dt = w->last_dt;
    o->min_dt = isfinite(w->min_dt) ? w->min_dt : 0;
    o->max_dt = w->max_dt;
    o->threads = w->governed ? sm_governor_threads(&w->gov) : w->threads;
    o->thread_switches = w->gov.switches;
    o->newton_iterations = w->newton.newton_total;
    o->gmres_iterations = w->newton.gmres_total;
    o->last_newton_iterations = w->newton.last_iterations;
    o->last_newton_residual = w->newton.last_residual;
    o->newton_unconverged = w->newton.unconverged;
    o->newton_rejected = w->newton.rejected;
    o->newton_floor_stops = w->newton.floor_stops;
}

void sm_world_reset_step_stats(sm_world *w) {
    w->min_dt = INFINITY;
    w->max_dt = 0;
}

uint64_t sm_world_state_hash(const sm_world *w) { return sm_particles_hash(&w->p, w->dim); }

uint64_t sm_world_id_hash(const sm_world *w) {
    if (w->dist) return sm_dist_id_hash(w);
    return sm_particles_hash_by_id(&w->p, w->dim);
}

