/* The world's internal layout: what it owns. Shared by the world's API files (src/world/), the
 * step driver (src/integrate/step.c, health.c), seeding and emitters (src/particles/), and the
 * tests that reach internals. Not part of the public API.
 *
 * Owners of the arrays (docs/architecture.md has the whole table):
 *   particles   p (particles/particles.h: one field list)
 *   binning     bins (grid/bin.h): perm, particle blocks, colours
 *   grid        grid (grid/grid.h): live blocks, mass and the node vectors with their lifetime table
 *   transfer    cache (transfer/transfer.h): per-thread caches of P2G and G2P
 *   implicit    imp (integrate/implicit_solver.h): the solve's workspace and its lifetime table
 * The stages never see this struct: step.c hands each one the arrays it reads and writes. */
#ifndef SM_WORLD_H
#define SM_WORLD_H

#include "collide/collide.h"
#include "dist/dist.h"
#include "core/common.h"
#include "grid/bin.h"
#include "grid/grid.h"
#include "integrate/governor.h"
#include "integrate/implicit_solver.h"
#include "integrate/stages.h"
#include "material/material_rt.h"
#include "particles/particles.h"
#include "transfer/transfer.h"

/* An emitter and its bookkeeping. */
typedef struct sm_emitter {
    sm_emitter_def def;
    double bmin[3], bmax[3];  /* sampling box */
    double particle_mass;     /* kg */
    double owed;              /* mass due but not yet emitted, kg */
    uint64_t emitted;         /* particles emitted so far */
} sm_emitter;

struct sm_world {
    sm_world_def def;
    int dim;
    const sm_stages *stages; /* the 2D or 3D table, chosen at creation */
    double inv_dx;
    int cells[3];            /* cells per axis (1 along z in 2D) */
    int threads;             /* threads of the next (or current) step: def.threads, or the governor's */
    int governed;            /* def.threads = 0: the governor chooses per step (integrate/governor.h) */
    sm_governor gov;

    sm_material_rt *mats;
    int nmats, mats_cap;

    sm_particles p;

    sm_collider *colliders;
    int ncolliders, colliders_cap; /* user colliders [0, ncolliders); the domain walls follow them */
    int nwalls;                    /* 2 dim half-spaces 2 cells inside the domain boundary */

    sm_emitter *emitters;
    int nemitters, emitters_cap;
    double *emit_buf; /* positions then velocities of one emission (6 per particle), grown as needed */
    size_t emit_cap;  /* particles emit_buf holds */

    /* The step's storage, grown as needed, never shrunk: nothing is allocated in a steady state. */
    sm_grid grid;
    sm_bins bins;
    sm_transfer_cache cache;
    sm_implicit_ws imp;
    uint8_t *gate;           /* the contact gate per node of the live blocks (collide/grid_collide.h) */
    size_t gate_cap;         /* nodes gate holds */
    int gate_live;           /* 1: gate holds this step's gate; 0: no gate (every collider acts everywhere) */
    sm_dist *dist;           /* a distributed world's part (dist/dist.h); NULL on one rank */

    /* Time and statistics. */
    double time;
    uint64_t steps;
    double last_dt, min_dt, max_dt;
    double stage_seconds[SM_STAGE_COUNT];
    uint64_t clamped, projected; /* G2P's position clamps and particle projections, in total */
    sm_implicit_stats newton;
    double step_vmax2;      /* largest particle speed^2 after the last G2P */
    int step_bad;           /* the last step produced a non-finite particle value */
    int grid_finite;        /* this step's explicit grid update found every v-bar and v-tilde finite
                               (the grid check then need not scan them); 0: not known */
    int step_refused;       /* the last sm_world_step refused its dt, by the CFL check or an unconverged
                               implicit solve (world intact) */
    double dt_cap;          /* after such a refusal half the refused dt, which sm_world_next_dt
                             * respects until a step is taken; else INFINITY */
    int dirty;              /* particles changed outside a step since the last G2P: scan them */
    int failed;             /* a numerical failure stopped the world */
    uint64_t next_id;       /* the id the next added particle gets (particles.h's field id) */
    int (*keep)(void *user, const double x[3]); /* sm_world_add_particles stores only the particles it
                                                   keeps (ids still count every one); NULL: all.
                                                   A distributed world's seeding (dist/seeding.c) */
    void *keep_user;
    int (*interrupt)(void *user); /* sm_world_set_interrupt: non-zero stops sm_world_advance (not saved) */
    void *interrupt_user;
    int interrupted;        /* the last sm_world_advance returned early for it */

    char err[512];
};

/* A restore that stores only some of a checkpoint's particles (dist/seeding.c: a rank's share).
 * census(x) is called for every particle's position, then cut once (collective across the ranks
 * that restore together: it is called exactly once on every rank, also when the read failed
 * before the particles, with that status; it returns the status the ranks agree on, its message
 * in err), then keep(x) for every particle: the kept are stored, in stream order. */
typedef struct sm_restore_filter {
    void *user;
    void (*census)(void *user, const double x[3]);
    sm_status (*cut)(void *user, sm_status st, char *err, size_t errlen);
    int (*keep)(void *user, const double x[3]);
} sm_restore_filter;

/* sm_world_restore_read through filter (NULL: every particle). */
sm_status sm_world_restore_from(sm_world *w, sm_pread_fn read, void *user, uint64_t len, const sm_restore_filter *filter);

/* Sets the world's message (printf style) and returns status. */
sm_status sm_world_fail(sm_world *w, sm_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Runs the emitters for the step [t0, t1] (particles/emit.c). */
sm_status sm_world_run_emitters(sm_world *w, double t0, double t1);
/* Room for n particles in all (max_particles and the id range checked; particle_api.c). */
sm_status sm_world_reserve_particles(sm_world *w, size_t n);
/* sm_world_save's stream of a world of `total` particles of which w's are those from index
 * `first` on (in the stream's particle order), written through write at their offsets
 * (checkpoint.c): with head set also every byte that is not particle data, else only w's particle
 * data. *bytes: the whole stream's length. The ranks' id slices together write the stream of the
 * whole run (dist/slices.c). */
sm_status sm_world_save_part(const sm_world *w, uint64_t first, uint64_t total, int head, sm_pwrite_fn write, void *user,
                             uint64_t *bytes);

/* Mass of particle p. */
static inline sm_real sm_particle_mass(const sm_material_rt *mats, const sm_particles *P, size_t p) {
    return sm_particle_mass_of(mats, P->mat, P->vol0, p);
}

/* Computes tau (Kirchhoff stress) for particles [first, n) from their F (one SVD each): the
 * plasticity stage on new particles (integrate/step.c). */
void sm_world_init_stress(sm_world *w, size_t first);

/* Test hook: sort + P2G without forces, grid totals, then G2P with dt = 0 (positions unchanged).
 * Reports particle totals before, grid totals, particle totals after. */
typedef struct sm_transfer_totals {
    double mass[3], mom[3][3], ang[3][3]; /* [0] particles before, [1] grid, [2] particles after */
} sm_transfer_totals;
void sm_world_debug_transfer_roundtrip(sm_world *w, sm_transfer_totals *t);

/* Test hook: sorts and rasterises mass (P2G without force), then runs implicit_jvp_check with a
 * time step dt. */
double sm_world_debug_implicit_jvp(sm_world *w, double dt, uint64_t seed, double vscale, double h);

/* Particle totals: mass, momentum, angular momentum (APIC B term included). */
void sm_world_particle_totals(const sm_world *w, double *mass, double mom[3], double ang[3]);
/* Grid totals of the v-tilde velocities (mass, momentum, angular momentum about the origin). */
void sm_world_grid_totals(const sm_world *w, double *mass, double mom[3], double ang[3]);

/* The library's checks (sm_*_def_check): formats the message into err (if not NULL) and returns
 * SM_ERR_INVALID. */
sm_status sm_check_fail(char *err, size_t errlen, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* 1 if the shape is well formed for a dim-D world (finite centre; positive, finite sizes of its
 * kind; a non-zero normal; a unit rotation; a mesh field of that dimension), else 0 with
 * "NAME.field: ..." in err (collider shapes, emitter shapes, seeded shapes and their clips). */
int sm_shape_check(const sm_shape *s, int dim, const char *name, char *err, size_t errlen);

static inline int sm_finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* Threads for a def.threads value (0: OpenMP's default). */
int sm_resolve_threads(int t);

#endif
