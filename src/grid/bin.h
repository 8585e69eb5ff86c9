/* Binning particles by grid block (thesis §3.1 step 2, DESIGN §4): the order every transfer
 * loop runs in.
 *
 * A particle belongs to the "particle block" holding its stencil's first node. Its stencil
 * touches nodes 4 b .. 4 b + 6 per axis only, i.e. the 2^d grid blocks b + {0,1}^d, which are
 * exactly the live grid blocks (grid.h). Particle blocks of the same colour (block coordinates
 * equal mod 2) never share a node, so P2G scatters one colour at a time, blocks of a colour in
 * parallel, particles of a block in ascending id: every node sums its contributions in the same
 * order for any thread count, any storage order and (with MPI) any number of ranks (bitwise
 * identical results). */
#ifndef SM_GRID_BIN_H
#define SM_GRID_BIN_H

#include "core/step_ctx.h"
#include "grid/grid.h"
#include "particles/particles.h"

/* A particle block: the particles whose stencil starts in grid block `key`, and the slots of the
 * live grid blocks b + {0,1}^d they touch: gslot[c] with c = (ci << 2 | cj << 1 | ck) in 3D,
 * (ci << 1 | cj) in 2D (SM_NO_SLOT outside the domain). */
typedef struct sm_pblock {
    uint64_t key;
    uint32_t start, end;    /* positions in perm */
    uint32_t ascending;     /* 1: perm[start..end) increases (storage order is id order here) */
    uint32_t gslot[8];
    uint32_t more;          /* sm_bin_more only: the block's particles of the second batch, then its cursor;
                               while the binning by movers runs: the particles that left the block */
    uint32_t early;         /* 1: scattered by P2G before the second batch (dist/overlap.c); 0 after a full
                               binning, and for the blocks a second batch adds; while the binning by movers
                               runs: the particles that arrive */
    uint32_t side;          /* bit c: gslot[c] is a slot of the P2G's side arrays, not of the grid
                               (sm_p2g_io.side; dist/overlap.c sets and clears it); while the binning by
                               movers runs: the block's new start in perm */
} sm_pblock;

/* Particle blocks grouped by colour: blocks[offset[c] .. offset[c + 1]) are indices into sm_bins.pb of
 * colour c. P2G scatters a list's colours in order (transfer.h, sm_p2g_io.lists). */
typedef struct sm_block_lists {
    const uint32_t *blocks;
    uint32_t offset[9];
} sm_block_lists;

/* What a full binning was computed from: the next step may keep it only if these are unchanged. */
typedef struct sm_bins_basis {
    int valid, stencil;
    size_t n, nactive;
    double pos_lo[3], pos_inv_dx;
} sm_bins_basis;

/* A particle that left its block (the binning by movers, rebin_dim.c). */
typedef struct sm_bin_mover {
    uint64_t key;   /* the block it reached */
    uint32_t id, p; /* its id and its index in the storage */
} sm_bin_mover;

/* Bytes of the binning by movers' workspace per particle: room for the movers' records (16 bytes
 * each) when a sixteenth of the particles moved, the most it takes on (tests/test_memory.c holds
 * the whole world to 166 bytes per particle in 3D float). */
#define SM_REBIN_WS_PER_PARTICLE 1

/* The binning of one step, grown as needed, never shrunk. */
typedef struct sm_bins {
    uint32_t *perm;         /* particle indices grouped by particle block, ascending id within a block (capacity: the
                               particles', sm_bins_reserve_perm) */
    size_t perm_cap;
    sm_pblock *pb;          /* this step's non-empty particle blocks, ascending key */
    size_t npb, pb_cap;
    sm_pblock *pb_tmp;      /* sm_bin_more: the blocks it adds, sorted */
    size_t pb_tmp_cap;
    sm_block_hash pb_hash;  /* key -> index in pb (of the last binning: the next one's guess) */
    uint32_t *counts;       /* per-thread particle counts, then cursors, per block */
    size_t counts_cap;
    uint64_t *pairs;        /* (key, index) pairs of the non-empty blocks, sorted by key */
    size_t pairs_cap;
    uint32_t *color_blocks; /* particle blocks grouped by colour */
    size_t color_cap;
    uint32_t color_count[8], color_offset[9];
    void *rebin_ws;         /* the binning by movers' workspace (rebin_dim.c): SM_REBIN_WS_PER_PARTICLE bytes per
                               particle of perm's capacity, in perm's allocation (after it) */
    size_t rebin_ws_bytes;
    uint64_t reorders;      /* times the particle storage was reordered by block */
    uint64_t reuses;        /* binnings that kept the last one (every particle still in its block) */
    uint64_t rebins;        /* binnings made by moving the particles that left their blocks (rebin_dim.c) */
    sm_bins_basis basis;    /* what the last full binning was made of (valid 0: none yet) */
    int keep_storage;       /* never reorder the storage (a distributed world's storage holds its
                               particles, then ghosts: dist/exchange.c reorders its particles) */
} sm_bins;

void sm_bins_free(sm_bins *b);
/* Bytes held. */
size_t sm_bins_bytes(const sm_bins *b);
/* Room in perm for cap particles (the particle storage's capacity). */
sm_status sm_bins_reserve_perm(sm_bins *b, size_t cap);

#ifdef SM_DIM
/* Bins the particles by block: fills perm, the particle blocks, their colour lists, the live grid
 * blocks (zeroed for P2G: sm_grid_zero) and every block's grid slots; reorders the particle
 * storage (every field) by block when a block's particles are no longer mostly contiguous. */
sm_status SM_FN(sm_bin_particles)(sm_bins *b, sm_particles *P, sm_grid *g, const sm_step_ctx *c);
/* A second batch (a distributed step's arrivals, dist/overlap.c): b and g hold the binning of
 * particles [0, first) that sm_bin_particles made with P->n = first; particles [first, P->n) are
 * added, and b and g become what sm_bin_particles of all P->n particles would make of them (the
 * same blocks, slots, colours and, per block, particles in ascending id), except that the P2G
 * arrays of the grid blocks already live keep their values (the blocks new to the grid are
 * zeroed) and the storage is not reordered. The early marks stay with their blocks. perm must
 * have room for P->n (sm_bins_reserve_perm). */
sm_status SM_FN(sm_bin_more)(sm_bins *b, sm_particles *P, sm_grid *g, const sm_step_ctx *c, size_t first);
#endif

#endif
