/* The step driver: one MPM step as thesis Algorithm 1 (DESIGN §3), and the choice of dt.
 *
 *   dt      min(max_dt, cfl dx / max particle speed, elastic_cfl dx / wave speed (explicit), the
 *           Newton rule (implicit: implicit_dt_limit)), landing exactly on the target time
 *           (sm_world_next_dt, sm_world_advance); a step refused by the CFL check or by an
 *           unconverged Newton solve is retried at half the dt;
 *   2       bin particles by grid block (grid/bin_dim.c);
 *   3       P2G: mass, momentum, internal force (transfer/p2g_dim.c);
 *   4-5     grid update v* = v^n + dt (f/m + g) (integrate/explicit_dim.c) or the implicit solve
 *           (integrate/implicit_dim.c); collisions -> v-bar, friction -> v-tilde
 *           (collide/grid_collide_dim.c);
 *   6       G2P: v, B from v-tilde; x, F^E-hat from v-bar (transfer/g2p_dim.c);
 *   7       plasticity and hardening, then tau for the next P2G (material/plasticity_dim.c);
 *   8       emitters add particles (particles/emit.c).
 * On MPI ranks the exchange of particles comes before 2 (dist/exchange.c); an explicit step
 * overlaps it with 2-3 for the rank's inner blocks (exchange below, dist/overlap.c).
 * The health checks (health.c) run before the step, after the grid update and at its end. Each
 * stage gets its own argument struct, made here from the world (*_io below): exactly the arrays
 * it reads and writes, named for what they hold (grid.h's lifetime table). Every stage is timed
 * into stage_seconds (Box2D's b2Profile). */
#include <math.h>
#include <string.h>

#include "core/team.h"
#include "core/timer.h"
#include "integrate/health.h"
#include "world/world.h"

static sm_step_ctx step_ctx(const sm_world *w, double dt) {
    sm_step_ctx c;
    memset(&c, 0, sizeof c);
    c.dt = dt;
    c.dx = (sm_real)w->def.dx;
    c.inv_dx = (sm_real)w->inv_dx;
    c.pos_dx = w->def.dx;
    c.pos_inv_dx = w->inv_dx;
    for (int a = 0; a < 3; a++) {
        c.lo[a] = (sm_real)w->def.domain_min[a];
        c.pos_lo[a] = w->def.domain_min[a];
        c.gravity[a] = (sm_real)w->def.gravity[a];
        c.cells[a] = w->cells[a];
    }
    c.stencil = w->def.kernel == SM_KERNEL_CUBIC ? 4 : 3;
    c.transfer = (int)w->def.transfer;
    c.flip_ratio = (sm_real)w->def.flip_ratio;
    c.threads = w->threads;
    return c;
}

/* Adds the seconds since *t to stage s and restarts the clock. */
static void lap(sm_world *w, sm_stage s, double *t) {
    const double now = sm_seconds();
    w->stage_seconds[s] += now - *t;
    *t = now;
}

/* ---- The stages' arguments, from the world ---------------------------------------------- */

/* The particles this rank updates: all of them, or a distributed world's own (the ghosts follow). */
static size_t owned(const sm_world *w) { return w->dist ? sm_dist_owned(w) : w->p.n; }

static sm_grid_colliders grid_colliders(const sm_world *w) {
    sm_grid_colliders gc = {w->colliders, w->ncolliders + w->nwalls, w->def.static_friction_sticks,
                            w->gate_live ? w->gate : NULL};
    return gc;
}

static sm_p2g_io p2g_io(sm_world *w, int with_force) {
    const sm_particles *P = &w->p;
    sm_p2g_io io = {P->n, P->x, P->v, P->B, P->tau, P->vol0, P->mat, w->mats, &w->bins, w->cache.data, with_force,
                    sm_grid_p2g_arrays(&w->grid), NULL, {NULL, NULL, NULL}};
    return io;
}

static sm_grid_update_io grid_update_io(sm_world *w) {
    sm_grid_update_io io = {&w->grid, sm_grid_p2g_arrays(&w->grid), sm_grid_vel_arrays(&w->grid), grid_colliders(w)};
    return io;
}

static sm_implicit_io implicit_io(sm_world *w) {
    const sm_particles *P = &w->p;
    sm_implicit_io io;
    memset(&io, 0, sizeof io);
    io.sys.n = P->n;
    io.sys.x = P->x;
    io.sys.F = P->F;
    io.sys.vol0 = P->vol0;
    io.sys.alpha = P->alpha;
    io.sys.mat = P->mat;
    io.sys.mats = w->mats;
    io.sys.bins = &w->bins;
    io.sys.grid = &w->grid;
    io.sys.colliders = grid_colliders(w);
    io.sys.ws = &w->imp;
    io.sys.cache = w->cache.data;
    io.in = sm_grid_p2g_arrays(&w->grid);
    io.out = sm_grid_vel_arrays(&w->grid);
    io.newton_tolerance = w->def.newton_tolerance;
    io.newton_max_iterations = w->def.newton_max_iterations;
    io.gmres_max_iterations = w->def.gmres_max_iterations;
    io.gmres_tolerance = w->def.gmres_tolerance;
    io.precondition = w->def.gmres_preconditioner;
    for (int i = 0; i < w->nmats; i++) io.wave_speed = fmax(io.wave_speed, w->mats[i].wave_speed);
    io.stats = &w->newton;
    return io;
}

static sm_g2p_io g2p_io(sm_world *w) {
    sm_particles *P = &w->p;
    const sm_grid_vel vel = sm_grid_vel_arrays(&w->grid);
    sm_g2p_io io = {P->n, P->x, P->v, P->B, P->F, &w->bins, w->cache.data, vel.vn, vel.vbar, vel.vtilde,
                    w->colliders, w->ncolliders, w->def.particle_projection, owned(w)};
    return io;
}

static sm_plasticity_io plasticity_io(sm_world *w, size_t first) {
    sm_particles *P = &w->p;
    sm_plasticity_io io = {first, owned(w), P->F, P->alpha, P->q, P->tau, P->mat, w->mats, w->threads};
    return io;
}

/* ---- The stages ------------------------------------------------------------------------- */

static sm_status binning_out_of_memory(sm_world *w) {
    return sm_world_fail(w, SM_ERR_NOMEM, "step %llu: out of memory for the grid and the particle sort",
                         (unsigned long long)w->steps + 1);
}

/* 2. Bin particles by grid block; the transfer caches for the threads. */
static sm_status bin_particles(sm_world *w, const sm_step_ctx *c) {
    if (w->stages->bin(&w->bins, &w->p, &w->grid, c) != SM_OK ||
        sm_transfer_cache_reserve(&w->cache, w->dim, c->threads > 0 ? c->threads : 1) != SM_OK)
        return binning_out_of_memory(w);
    return SM_OK;
}

/* 2. The particles from `first` on binned too (a distributed step's arrivals, grid/bin.h). */
static sm_status bin_more(sm_world *w, const sm_step_ctx *c, size_t first) {
    return w->stages->bin_more(&w->bins, &w->p, &w->grid, c, first) == SM_OK ? SM_OK : binning_out_of_memory(w);
}

/* 3. P2G of the blocks in `lists` (NULL: all), their side slots in `side` (NULL: none); the
 * implicit integrator computes forces in its solve. */
static void p2g(sm_world *w, const sm_step_ctx *c, const sm_block_lists *lists, const sm_grid_p2g *side) {
    sm_p2g_io io = p2g_io(w, w->def.integrator != SM_INTEGRATOR_IMPLICIT);
    io.lists = lists;
    if (side) io.side = *side;
    w->stages->p2g(&io, c);
}

/* The blocks of colour col of `lists`. */
static sm_block_lists one_colour(const sm_block_lists *lists, int col) {
    sm_block_lists one = *lists;
    for (int k = 0; k <= 8; k++) one.offset[k] = lists->offset[k <= col ? col : col + 1];
    return one;
}

/* 3. P2G of the inner blocks while the exchange's messages travel: a colour at a time, letting
 * MPI move them in between. */
static void p2g_while_exchanging(sm_world *w, const sm_step_ctx *c, const sm_block_lists *inner,
                                 const sm_grid_p2g *side) {
    for (int col = 0; col < 8; col++) {
        if (inner->offset[col] == inner->offset[col + 1]) continue;
        const sm_block_lists one = one_colour(inner, col);
        p2g(w, c, &one, side);
        sm_dist_progress(w);
    }
}

/* 3. P2G of the other blocks (NULL: all), each colour after the inner blocks' side slots of that
 * colour (dist/overlap.c). */
static void p2g_after_exchange(sm_world *w, const sm_step_ctx *c, const sm_block_lists *outer) {
    if (!outer) {
        p2g(w, c, NULL, NULL);
        return;
    }
    for (int col = 0; col < 8; col++) {
        sm_dist_replay(w, col);
        const sm_block_lists one = one_colour(outer, col);
        if (outer->offset[col] < outer->offset[col + 1]) p2g(w, c, &one, NULL);
    }
}

/* A step refused before anything outside the grid moved (the CFL check, an unconverged implicit
 * solve): the world stays usable and sm_world_next_dt offers at most half the refused dt. */
static void refuse_step(sm_world *w, double dt) {
    w->step_refused = 1;
    w->dt_cap = 0.5 * dt;
}

/* 4-5. Grid velocities v-bar, v-tilde (and v^n for FLIP): explicit update or implicit solve. */
/* An implicit step above this fraction of max_dt whose Newton solve does not converge is refused
 * (retried at half the dt); at or below it, it is taken and counted as unconverged. */
#define SM_IMPLICIT_REJECT_FRACTION (1.0 / 1024)

/* 4. The contact gate of this step's nodes (collide/grid_collide.h) into w->gate, unless
 * def.contact_gap is infinite or no collider separates. */
static sm_status contact_gate(sm_world *w, const sm_step_ctx *c) {
    w->gate_live = 0;
    int separating = 0;
    for (int b = 0; b < w->ncolliders + w->nwalls; b++) separating |= w->colliders[b].def.mode == SM_COLLIDE_SEPARATE;
    if (!separating || isinf(w->def.contact_gap)) return SM_OK;
    const size_t nodes = w->grid.nactive * (size_t)w->grid.block_nodes;
    if (nodes > w->gate_cap) {
        const size_t cap = w->grid.cap * (size_t)w->grid.block_nodes; /* grows as the grid's storage */
        uint8_t *g = sm_realloc(w->gate, cap);
        if (!g) return sm_world_fail(w, SM_ERR_NOMEM, "contact gate: out of memory for %zu grid nodes", nodes);
        w->gate = g;
        w->gate_cap = cap;
    }
    const sm_contact_gate_io io = {w->p.n, w->p.x, w->p.v, &w->bins, &w->grid, grid_colliders(w),
                                   w->def.contact_gap * w->def.dx, w->gate};
    w->stages->contact_gate(&io, c);
    w->gate_live = 1;
    return SM_OK;
}

static sm_status grid_velocities(sm_world *w, const sm_step_ctx *c) {
    const sm_status gated = contact_gate(w, c);
    if (gated != SM_OK) return gated;
    if (w->def.integrator != SM_INTEGRATOR_IMPLICIT) {
        const sm_grid_update_io io = grid_update_io(w);
        w->grid_finite = w->stages->grid_update(&io, c);
        return SM_OK;
    }
    w->grid_finite = 0;
    sm_implicit_io io = implicit_io(w);
    io.may_reject = c->dt > SM_IMPLICIT_REJECT_FRACTION * w->def.max_dt;
    if (w->dist) { /* the halo plan fails on every rank or none */
        const sm_status plan = sm_dist_halo_plan(w, &io.sys.ranks);
        if (plan != SM_OK) return plan;
    }
    const sm_status st = w->stages->implicit_solve(&io, c);
    if (st == SM_ERR_NOMEM)
        return sm_world_fail(w, SM_ERR_NOMEM, "implicit integrator: out of memory for %zu grid nodes",
                             w->grid.nactive * (size_t)w->grid.block_nodes);
    if (st != SM_OK)
        return sm_world_fail(w, st, "step %llu (t = %.6g s, dt = %.3g s): the implicit solve diverged (residual %g)",
                             (unsigned long long)w->steps + 1, w->time, c->dt, w->newton.last_norm);
    if (!w->newton.last_converged && io.may_reject) { /* only the grid has changed */
        refuse_step(w, c->dt);
        return sm_world_fail(w, SM_ERR_NUMERICAL,
                             "step %llu (t = %.6g s): Newton did not converge in %d iterations at dt = %.3g s (residual "
                             "%.3g m/s^2); the world is intact: retry with a smaller dt",
                             (unsigned long long)w->steps + 1, w->time, w->def.newton_max_iterations, c->dt,
                             w->newton.last_residual);
    }
    return SM_OK;
}

/* 6. G2P, with its counters and the health flags. */
static void g2p(sm_world *w, const sm_step_ctx *c) {
    const sm_g2p_io io = g2p_io(w);
    sm_g2p_stats st;
    w->stages->g2p(&io, c, &st);
    w->clamped += st.clamped;
    w->projected += st.projected;
    w->step_vmax2 = st.vmax2;
    w->step_bad = st.bad;
}

/* 7. Plasticity of particles [first, n). */
static void plasticity(sm_world *w, size_t first) {
    const sm_plasticity_io io = plasticity_io(w, first);
    if (w->stages->plasticity(&io)) w->step_bad = 1;
}

void sm_world_init_stress(sm_world *w, size_t first) { plasticity(w, first); }

/* ---- The step --------------------------------------------------------------------------- */

/* A distributed world's ranks take the same branch: a check that fails on one rank fails on all,
 * a refusal on one (and none failing) is a refusal on all. `refused`: this rank's check refused. */
static sm_status agree(sm_world *w, double dt, sm_status st, int *refused) {
    if (!w->dist) return st;
    const int mine = st == SM_OK ? 0 : (*refused ? 1 : 2);
    const int worst = sm_dist_max_int(w, mine);
    if (worst == mine) return st;
    *refused = worst == 1;
    if (*refused) refuse_step(w, dt);
    return sm_world_fail(w, SM_ERR_NUMERICAL, "step %llu (t = %.6g s): another rank's check %s the step",
                         (unsigned long long)w->steps + 1, w->time, *refused ? "refused" : "failed");
}

/* A grid or end-of-step check, agreed between the ranks. */
static sm_status agreed(sm_world *w, double dt, sm_status st) {
    int refused = 0;
    return agree(w, dt, st, &refused);
}

/* Before anything moves: finite state and the CFL bound. A CFL violation alone leaves the world
 * usable (w->step_refused; the caller may retry with a smaller dt); non-finite state stops it. */
static sm_status check_start(sm_world *w, double dt) {
    const double t = sm_seconds();
    int too_fast = 0;
    sm_status st = w->p.n > 0 ? sm_health_check_start(w, dt, &too_fast) : SM_OK;
    if (st != SM_OK && too_fast) refuse_step(w, dt);
    st = agree(w, dt, st, &too_fast);
    w->stage_seconds[SM_STAGE_CHECKS] += sm_seconds() - t;
    if (st != SM_OK && !too_fast) w->failed = 1;
    return st;
}

/* Runs a stage that can fail, times it into stage_seconds[stage]; a failure stops the world, a
 * refusal (refuse_step) leaves it usable (the stage has written the message). */
#define STAGE(w, t, stage, call)          \
    do {                                  \
        const sm_status st_ = (call);     \
        lap((w), (stage), (t));           \
        if (st_ != SM_OK) {               \
            if (!(w)->step_refused)       \
                (w)->failed = 1;          \
            return st_;                   \
        }                                 \
    } while (0)

/* MPI: the exchange, and with it (*binned) the binning and P2G (2-3) when the step overlaps
 * them (dist/overlap.c): the particles this rank kept binned and its inner blocks scattered
 * while the messages travel, then the arrivals binned as a second batch and the other blocks
 * scattered. */
static sm_status exchange(sm_world *w, const sm_step_ctx *c, double *t, int *binned) {
    int overlap = 0;
    STAGE(w, t, SM_STAGE_EXCHANGE, sm_dist_exchange_begin(w, &overlap));
    const size_t kept = w->p.n;
    *binned = overlap && kept > 0;
    if (*binned) {
        const sm_status st = bin_particles(w, c);
        lap(w, SM_STAGE_SORT, t);
        if (st != SM_OK) { /* the messages are received all the same: no rank is left waiting */
            w->failed = 1;
            sm_dist_exchange_finish(w);
            return st;
        }
        sm_grid_p2g side;
        const sm_block_lists *inner = sm_dist_inner_blocks(w, &side);
        if (inner) p2g_while_exchanging(w, c, inner, &side);
        lap(w, SM_STAGE_P2G, t);
    }
    STAGE(w, t, SM_STAGE_EXCHANGE, sm_dist_exchange_finish(w));
    if (*binned) {
        STAGE(w, t, SM_STAGE_SORT, bin_more(w, c, kept));
        p2g_after_exchange(w, c, sm_dist_outer_blocks(w, kept));
        lap(w, SM_STAGE_P2G, t);
    }
    return SM_OK;
}

/* The particle stages of Algorithm 1 (what a step does when there are particles), after the
 * pre-step check. */
static sm_status step_particles(sm_world *w, const sm_step_ctx *c) {
    double t = sm_seconds();
    int binned = 0;
    if (w->dist) { /* migration, ghosts */
        const sm_status st = exchange(w, c, &t, &binned);
        if (st != SM_OK) return st;
    }
    /* Always on one rank; a distributed rank may hold none (and skips the stages), except in an
     * implicit step: its solve is collective, every rank takes part (with no grid if need be). */
    const int any = w->p.n > 0 || (w->dist && w->def.integrator == SM_INTEGRATOR_IMPLICIT);
    if (any) {
        if (!binned) {
            STAGE(w, &t, SM_STAGE_SORT, bin_particles(w, c)); /* 2 */
            p2g(w, c, NULL, NULL);                            /* 3 */
            lap(w, SM_STAGE_P2G, &t);
        }
        STAGE(w, &t, SM_STAGE_GRID, grid_velocities(w, c)); /* 4-5 */
    }
    STAGE(w, &t, SM_STAGE_CHECKS, agreed(w, c->dt, any ? sm_health_check_grid(w, c->dt) : SM_OK));
    if (any) {
        g2p(w, c); /* 6 */
        lap(w, SM_STAGE_G2P, &t);
        plasticity(w, 0); /* 7 */
        lap(w, SM_STAGE_PLASTICITY, &t);
    }
    STAGE(w, &t, SM_STAGE_CHECKS, agreed(w, c->dt, any ? sm_health_check_end(w, c->dt) : SM_OK));
    if (w->dist) sm_dist_end_step(w); /* the ghosts dropped */
    return SM_OK;
}

static void colliders_begin_step(sm_world *w, double dt) {
    for (int i = 0; i < w->ncolliders; i++) sm_collider_begin_step(&w->colliders[i], w->time, dt);
}

static void colliders_end_step(sm_world *w) {
    for (int i = 0; i < w->ncolliders; i++) sm_collider_end_step(&w->colliders[i]);
}

static void advance_clock(sm_world *w, double dt) {
    w->time += dt;
    w->steps++;
    w->last_dt = dt;
    if (dt < w->min_dt) w->min_dt = dt;
    if (dt > w->max_dt) w->max_dt = dt;
}

sm_status sm_world_step(sm_world *w, double dt) {
    if (w->failed)
        return sm_world_fail(w, SM_ERR_NUMERICAL, "the world stopped after a numerical failure at step %llu; create a new one",
                             (unsigned long long)w->steps);
    w->step_refused = 0;
    if (!(dt > 0) || !isfinite(dt)) return sm_world_fail(w, SM_ERR_INVALID, "step: dt must be > 0, got %g", dt);
    if (w->governed) w->threads = sm_governor_threads(&w->gov);
    const double t_start = sm_seconds();
    if (w->p.n > 0 || w->dist) {
        const sm_status st = check_start(w, dt);
        if (st != SM_OK) return st;
    }
    const sm_step_ctx c = step_ctx(w, dt);
    colliders_begin_step(w, dt);                      /* poses at t^n and t^n+1 */
    if (w->p.n > 0 || w->dist) {
        const sm_status st = step_particles(w, &c);   /* 2-7 */
        if (st != SM_OK) return st;
    }
    colliders_end_step(w);
    if (w->nemitters > 0) {                           /* 8 */
        const sm_status st = sm_world_run_emitters(w, w->time, w->time + dt);
        if (st != SM_OK) return st;
    }
    advance_clock(w, dt);
    w->dt_cap = INFINITY;
    if (w->governed) sm_governor_record(&w->gov, sm_seconds() - t_start, w->p.n);
    return SM_OK;
}

int sm_world_step_refused(const sm_world *w) { return w && !w->failed && w->step_refused; }

/* ---- Time step choice ------------------------------------------------------------------- */

double sm_world_time(const sm_world *w) { return w->time; }

typedef struct speed_job {
    const sm_real *v;
    int d;
    _Atomic double m2;
} speed_job;

static void speed_range(void *arg, long lo, long hi) {
    speed_job *job = arg;
    const int d = job->d;
    double m2 = 0;
    for (long p = lo; p < hi; p++) {
        double s = 0;
        for (int a = 0; a < d; a++) s += (double)job->v[p * d + a] * (double)job->v[p * d + a];
        if (s > m2) m2 = s;
    }
    sm_team_max(&job->m2, m2);
}

static double max_particle_speed(const sm_world *w) {
    if (!w->dirty) return sqrt(w->step_vmax2); /* measured by the last G2P */
    speed_job job = {w->p.v, w->dim, 0};
    sm_team_for(w->threads, (long)w->p.n, speed_range, &job);
    return sqrt(atomic_load(&job.m2));
}

/* The implicit step-size rule: from the last step's dt and its Newton iterations (both in the
 * checkpoint, so a resumed run chooses the same dt). A step whose Newton solve does not converge
 * is refused and retried at half its dt (grid_velocities); after a fast solve the dt may double,
 * after a slower one grow by a quarter, after a slow one it stays. */
#define IMPLICIT_FAST_NEWTON 3
#define IMPLICIT_SLOW_NEWTON 8
static double implicit_dt_limit(const sm_world *w) {
    const int it = w->newton.last_iterations;
    if (w->steps == 0 || it == 0 || !(w->last_dt > 0)) return INFINITY;
    if (it <= IMPLICIT_FAST_NEWTON) return 2.0 * w->last_dt;
    if (it <= IMPLICIT_SLOW_NEWTON) return 1.25 * w->last_dt;
    return w->last_dt;
}

double sm_world_next_dt(sm_world *w, double t_end) {
    double t0 = sm_seconds();
    double dt = w->def.max_dt;
    double vmax = max_particle_speed(w);
    if (w->dist) vmax = sm_dist_max(w, vmax); /* exact: the same dt on every rank */
    if (vmax > 0) dt = fmin(dt, w->def.cfl * w->def.dx / vmax);
    if (w->def.elastic_cfl > 0 && w->def.integrator == SM_INTEGRATOR_EXPLICIT) {
        double c = 0;
        for (int i = 0; i < w->nmats; i++) c = fmax(c, w->mats[i].wave_speed);
        if (c > 0) dt = fmin(dt, w->def.elastic_cfl * w->def.dx / c);
    }
    if (w->def.integrator == SM_INTEGRATOR_IMPLICIT) dt = fmin(dt, implicit_dt_limit(w));
    dt = fmin(dt, w->dt_cap); /* after a step refused by the CFL check or by Newton */
    double remaining = t_end - w->time;
    if (remaining > 0) {
        if (dt >= remaining * (1 - 1e-12)) dt = remaining;
        else if (dt > 0.5 * remaining) dt = 0.5 * remaining; /* no sliver step at the frame end */
    }
    w->stage_seconds[SM_STAGE_DT] += sm_seconds() - t0;
    return dt;
}

/* A step that the CFL check refused is retried with half the dt (w->dt_cap, which
 * sm_world_next_dt respects), up to this many times in a row (2^-60: a speed beyond any the
 * controller could have missed by rounding). */
#define SM_CFL_RETRIES 60

/* A time step below this fraction of max_dt means the speeds ran away (an unstable run: the
 * controller follows them down to dt = 0 and the run never ends): a numerical failure. */
#define SM_RUNAWAY_DT_FRACTION 1e-9

static sm_status runaway(sm_world *w, double dt) {
    w->failed = 1;
    return sm_world_fail(w, SM_ERR_NUMERICAL,
                         "step %llu at t = %.9g s: runaway speeds: the fastest particle moves at %.3g m/s, so the "
                         "CFL time step is %.3g s (below %g of max_dt): the run is unstable (lower E, elastic_cfl "
                         "or max_dt, or use the implicit integrator)",
                         (unsigned long long)w->steps, w->time, max_particle_speed(w), dt, SM_RUNAWAY_DT_FRACTION);
}

/* Whether the caller's interrupt asks to stop before the next step (sm_world_set_interrupt);
 * agreed over the ranks of a distributed world (collective: every rank asks at the same step). */
static int interrupt_now(const sm_world *w) {
    if (!w->interrupt) return 0;
    const int mine = w->interrupt(w->interrupt_user) != 0;
    return w->dist ? sm_dist_max_int(w, mine) : mine;
}

sm_status sm_world_advance(sm_world *w, double t_end) {
    if (!isfinite(t_end)) return sm_world_fail(w, SM_ERR_INVALID, "advance: end time must be finite");
    int retries = 0;
    w->interrupted = 0;
    while (w->time < t_end) {
        /* Only between taken steps: after a refusal the dt cap is state a checkpoint lacks. */
        if (retries == 0 && interrupt_now(w)) {
            w->interrupted = 1;
            return SM_OK;
        }
        const double dt = sm_world_next_dt(w, t_end);
        const int last = (dt == t_end - w->time);
        if (!last && !(dt >= SM_RUNAWAY_DT_FRACTION * w->def.max_dt)) return runaway(w, dt);
        const sm_status st = sm_world_step(w, dt);
        if (st != SM_OK && w->step_refused && retries < SM_CFL_RETRIES) {
            retries++;
            continue;
        }
        if (st != SM_OK) return st;
        retries = 0;
        if (last) w->time = t_end; /* exactly, without rounding drift */
    }
    return SM_OK;
}

void sm_world_set_interrupt(sm_world *w, int (*poll)(void *user), void *user) {
    w->interrupt = poll;
    w->interrupt_user = user;
}

int sm_world_interrupted(const sm_world *w) { return w->interrupted; }

/* ---- Test hooks: single stages ---------------------------------------------------------- */

double sm_world_debug_implicit_jvp(sm_world *w, double dt, uint64_t seed, double vscale, double h) {
    const sm_step_ctx c = step_ctx(w, dt);
    if (bin_particles(w, &c) != SM_OK) return INFINITY;
    const sm_p2g_io pio = p2g_io(w, 0);
    w->stages->p2g(&pio, &c);
    const sm_implicit_io io = implicit_io(w);
    return w->stages->implicit_jvp_check(&io, &c, seed, vscale, h);
}

void sm_world_debug_transfer_roundtrip(sm_world *w, sm_transfer_totals *t) {
    sm_step_ctx c = step_ctx(w, 0.0);
    for (int a = 0; a < 3; a++) c.gravity[a] = 0;
    sm_world_particle_totals(w, &t->mass[0], t->mom[0], t->ang[0]);
    if (bin_particles(w, &c) != SM_OK) return;
    const sm_p2g_io pio = p2g_io(w, 0);
    w->stages->p2g(&pio, &c);
    /* v^n = mv/m, and v-bar = v-tilde = v^n: no force, no gravity, no collision. */
    const sm_grid *g = &w->grid;
    const sm_grid_p2g in = sm_grid_p2g_arrays(g);
    const sm_grid_vel out = sm_grid_vel_arrays(g);
    const size_t d = (size_t)w->dim, nn = g->nactive * (size_t)g->block_nodes;
    for (size_t ni = 0; ni < nn; ni++)
        for (size_t a = 0; a < d; a++) {
            const sm_real v = in.mass[ni] > 0 ? in.momentum[ni * d + a] / in.mass[ni] : 0;
            if (out.vn) out.vn[ni * d + a] = v;
            out.vbar[ni * d + a] = out.vtilde[ni * d + a] = v;
        }
    sm_world_grid_totals(w, &t->mass[1], t->mom[1], t->ang[1]);
    g2p(w, &c);
    sm_world_particle_totals(w, &t->mass[2], t->mom[2], t->ang[2]);
}
