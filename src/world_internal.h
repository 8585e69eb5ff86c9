/* The world's internal layout, shared by world.c and the dimension-generic stages
 * (src/integrate/step_dim.c, compiled once per dimension). Not part of the public API. */
#ifndef SM_WORLD_INTERNAL_H
#define SM_WORLD_INTERNAL_H

#include "collide/collide.h"
#include "core/common.h"
#include "grid/grid.h"
#include "material/implicit.h"
#include "particles/particles.h"

/* A material with everything the hot loops need precomputed. */
typedef struct sm_material_rt {
    sm_material_def def;
    sm_real mu, lambda;     /* Lame parameters, Pa */
    sm_real density;        /* kg/m^3: a particle's mass is density * vol0 */
    int plastic;            /* 1 for sand */
    int hardening;          /* 1: alpha follows q through (3.79)-(3.80) */
    double h0, h1, h2, h3;  /* radians (h2 dimensionless) */
    sm_real alpha0;         /* alpha at q = 0 (fixed angle or hardening start) */
    double wave_speed;      /* sqrt((lambda + 2 mu)/rho), m/s */
} sm_material_rt;

/* A particle block: the particles whose stencil starts in grid block `key`. They touch nodes
 * 4 b .. 4 b + 6 per axis only, i.e. the live grid blocks b + {0,1}^d: gslot[c] with
 * c = (ci << 2 | cj << 1 | ck) in 3D, (ci << 1 | cj) in 2D (SM_NO_SLOT outside the domain). */
typedef struct sm_pblock {
    uint64_t key;
    uint32_t start, end;    /* positions in perm */
    uint32_t gslot[8];
} sm_pblock;

/* Transfer cache of one particle block: 8^d nodes (2^d grid blocks) of SM_LANES values. */
#define SM_LANES 8
#define SM_CACHE_SIDE 8

/* An emitter and its bookkeeping. */
typedef struct sm_emitter {
    sm_emitter_def def;
    double bmin[3], bmax[3];  /* sampling box */
    double particle_mass;     /* kg */
    double owed;              /* mass due but not yet emitted, kg */
    uint64_t emitted;         /* particles emitted so far */
} sm_emitter;

/* Workspace of the implicit integrator, grown as needed. Vectors hold d values per node of the
 * live grid blocks, in grid node order. */
typedef struct sm_implicit_ws {
    size_t ncap;                /* capacity in nodes of the compact vectors */
    sm_real *mass, *vn, *z, *y, *dz, *tmp, *force, *krylov; /* krylov: (K+1) vectors */
    int kcap;                   /* Krylov vectors allocated */
    sm_node_contact *rec;       /* GRID_COLLISIONS records per compact node */
    size_t pcap;                /* particle capacity */
    sm_implicit_particle *pp;   /* per-particle precompute (Algorithm 8) */
    sm_real *G;                 /* per-particle force matrices V0 Y(F) F^nT */
    double *partial;            /* per-live-block partial sums (deterministic dot products) */
    size_t partial_cap;
} sm_implicit_ws;
void sm_implicit_ws_free(sm_implicit_ws *ws);

/* Per-step context (DESIGN §3): what the stages need, so the world holds no per-step scratch. */
typedef struct sm_step_ctx {
    double dt;
    sm_real dx, inv_dx;
    sm_real lo[3];          /* domain_min as sm_real */
    sm_real gravity[3];
    int threads;
} sm_step_ctx;

/* Function table of one dimension (filled by step_dim.c for SM_DIM = 2 and 3). */
typedef struct sm_dim_ops {
    int dim;
    /* Bin particles by grid block: fills w->perm, the particle blocks, their colour lists and the
     * live grid blocks (zeroed); reorders particle storage when that pays. */
    sm_status (*sort)(sm_world *w, const sm_step_ctx *c);
    /* P2G: mass, momentum (APIC/PIC/FLIP), internal force from tau; with_force = 0 skips stress. */
    void (*p2g)(sm_world *w, const sm_step_ctx *c, int with_force);
    /* Grid update v* = v + dt (f/m + g), colliders and walls (v-bar), friction (v-tilde). */
    void (*grid_update)(sm_world *w, const sm_step_ctx *c);
    /* The implicit replacement of grid_update (Algorithm 5): after a P2G without force, solves for
     * v-bar with Newton-GMRES and leaves v^n, v-bar, v-tilde where grid_update does. */
    sm_status (*implicit_grid)(sm_world *w, const sm_step_ctx *c);
    /* Test hook: relative error of TIMES_DIFF against finite differences of the residual. */
    double (*implicit_jvp_check)(sm_world *w, const sm_step_ctx *c, uint64_t seed, double vscale, double h);
    /* Returns the index of a node with a non-finite velocity, or -1. */
    long (*grid_check)(const sm_world *w);
    /* G2P: v, B from v-tilde; x, F^E-hat from v-bar. */
    void (*g2p)(sm_world *w, const sm_step_ctx *c);
    /* Plasticity and hardening (Algorithm 2), then tau for the next step. */
    void (*plasticity)(sm_world *w, const sm_step_ctx *c, size_t first);
    /* Elastic energy sum V0 psi(F^E). */
    double (*elastic_energy)(const sm_world *w);
    /* Grid totals (mass, momentum, angular momentum about the origin) of the current grid
     * velocities `which` (0: v^n after P2G, 1: v-tilde) — used by tests. */
    void (*grid_totals)(const sm_world *w, int which, double *mass, double mom[3], double ang[3]);
} sm_dim_ops;

extern const sm_dim_ops sm_dim_ops_2d;
extern const sm_dim_ops sm_dim_ops_3d;

struct sm_world {
    sm_world_def def;
    int dim;
    const sm_dim_ops *ops;
    double inv_dx;
    int cells[3];           /* cells per axis (1 along z in 2D) */

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

    sm_grid grid;

    /* Binning (step_dim.c sort), grown as needed, never shrunk. Particles are binned by the grid
     * block holding their stencil's first node ("particle blocks"). */
    uint32_t *perm;         /* particle indices grouped by particle block (stable) */
    size_t perm_cap;
    sm_pblock *pb;          /* this step's non-empty particle blocks, ascending key */
    size_t npb, pb_cap;
    sm_block_hash pb_hash;  /* key -> index in pb */
    uint32_t *pb_scratch;   /* sort scratch: per-thread counts and cursors, ranks */
    size_t pb_scratch_cap;
    uint64_t *sort_keys;    /* sort scratch: (key, index) pairs of blocks */
    size_t sort_keys_cap;
    uint32_t *color_blocks; /* particle blocks grouped by colour */
    size_t color_cap;
    uint32_t color_count[8], color_offset[9];
    sm_real *cache;         /* per-thread transfer caches (64-byte aligned) */
    size_t cache_cap;       /* values */
    int cache_threads;
    uint64_t reorders;      /* times the particle storage was reordered by block */

    /* Time and statistics. */
    double time;
    uint64_t steps;
    double last_dt, min_dt, max_dt;
    double stage_seconds[SM_STAGE_COUNT];
    uint64_t clamped;
    double step_vmax2;      /* largest particle speed^2 after the last G2P */
    int step_bad;           /* the last step produced a non-finite particle value */
    int dirty;              /* particles changed outside a step since the last G2P: scan them */
    uint64_t projected;
    sm_implicit_ws imp;
    uint64_t newton_total, gmres_total, newton_unconverged;
    int newton_last;
    double newton_hist[64];  /* residual (m/s^2) of each Newton step of the last implicit step */
    double newton_last_residual;
    int threads;
    int failed;             /* a numerical failure stopped the world */

    char err[512];
};

/* Sets the world's message (printf style) and returns status. */
sm_status sm_world_fail(sm_world *w, sm_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Runs the emitters for the step [t0, t1]. */
sm_status sm_world_run_emitters(sm_world *w, double t0, double t1);

/* Mass of particle p. */
static inline sm_real sm_particle_mass(const sm_material_rt *mats, const sm_particles *P, size_t p) {
    return mats[P->mat[p]].density * P->vol0[p];
}

/* Computes tau (Kirchhoff stress) for particles [first, n) from their F (one SVD each). */
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

#endif
