/* The transfers between particles and grid (thesis §3.3, §3.6.1, §3.6.5): P2G (stage 3 of the
 * step) and G2P (stage 6), APIC, PIC or FLIP, over the particle blocks of grid/bin.h.
 *
 * Both work through a dense per-thread cache of one particle block's 2^d grid blocks (8^d nodes
 * of SM_LANES values each): P2G accumulates a block's particles into it, then adds it into the
 * grid; G2P gathers the grid into it, then interpolates from it. */
#ifndef SM_TRANSFER_H
#define SM_TRANSFER_H

#include "collide/collide.h"
#include "core/step_ctx.h"
#include "grid/bin.h"
#include "material/material_rt.h"

#define SM_LANES 8       /* values per cached node */
#define SM_CACHE_SIDE 8  /* cached nodes per axis: two grid blocks */

/* The per-thread transfer caches (64-byte aligned), grown as needed. */
typedef struct sm_transfer_cache {
    sm_real *data;
    size_t cap; /* values */
} sm_transfer_cache;

/* Bytes of the caches of `threads` threads in dimension dim. */
size_t sm_transfer_cache_bytes_for(int dim, int threads);
/* Room for `threads` threads' caches. */
sm_status sm_transfer_cache_reserve(sm_transfer_cache *c, int dim, int threads);
void sm_transfer_cache_free(sm_transfer_cache *c);

/* P2G reads particles and writes the grid's mass, momentum and (with_force) force, (3.81),
 * (3.87)/(3.82), (3.91). The grid arrays must be zero on entry (the binning zeroes them). */
typedef struct sm_p2g_io {
    size_t n;
    const double *x;              /* position (double: particles.h) */
    const sm_real *v, *B;         /* velocity, APIC B (APIC only) */
    const sm_real *tau, *vol0;    /* Kirchhoff stress, initial volume */
    const uint16_t *mat;
    const sm_material_rt *mats;   /* density: mass = density * vol0 */
    const sm_bins *bins;          /* perm, particle blocks, colours */
    sm_real *cache;               /* sm_transfer_cache data */
    int with_force;               /* 0: no stress term (implicit: the solve computes forces) */
    sm_grid_p2g grid;             /* out: mass, momentum, force */
    const sm_block_lists *lists;  /* the blocks to scatter, by colour; NULL: all (the bins' colour lists) */
    sm_grid_p2g side;             /* out: where a block's grid block c goes when bit c of its `side` is set
                                     (slot gslot[c] of these arrays; dist/overlap.c) */
} sm_p2g_io;

/* G2P reads the grid velocities and updates particles: v, B from v-tilde (3.109)-(3.113), x and
 * F^E-hat from v-bar (3.114)-(3.116); the safety net puts a particle that ends inside a user
 * collider back on its surface. */
typedef struct sm_g2p_io {
    size_t n;
    double *x;                    /* in/out: position (double: particles.h) */
    sm_real *v, *B, *F;           /* in/out (B: out, APIC only) */
    const sm_bins *bins;
    sm_real *cache;
    const sm_real *vn, *vbar, *vtilde; /* sm_grid_vel (vn: FLIP only) */
    const sm_collider *colliders; /* user colliders (not the walls), for the projection */
    int ncolliders;
    int particle_projection;      /* def.particle_projection */
    size_t owned;                 /* particles [0, owned) are this rank's: G2P skips the blocks of
                                     the others (ghosts, dist/dist.h); n on one rank */
} sm_g2p_io;

/* What G2P measured. */
typedef struct sm_g2p_stats {
    uint64_t clamped;   /* positions clamped to 2 cells inside the domain */
    uint64_t projected; /* particles put back on a collider's surface */
    double vmax2;       /* largest particle speed^2 */
    int bad;            /* a new particle value is not finite */
} sm_g2p_stats;

#ifdef SM_DIM
void SM_FN(sm_p2g)(const sm_p2g_io *io, const sm_step_ctx *c);
void SM_FN(sm_g2p)(const sm_g2p_io *io, const sm_step_ctx *c, sm_g2p_stats *st);
#endif

#endif
