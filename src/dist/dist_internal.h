/* The distributed world's state, shared by dist.c (decomposition, reductions, the public calls)
 * and exchange.c (migration and ghosts). */
#ifndef SM_DIST_INTERNAL_H
#define SM_DIST_INTERNAL_H

#include <mpi.h>

#include "dist/dist.h"
#include "grid/bin.h"
#include "sandmpm/sandmpm_mpi.h"

typedef struct sm_dist_halo sm_dist_halo; /* halo.c: the implicit solve's grid traffic */

/* A growing byte buffer: packed particles (particles.h's sm_particles_pack) for one rank. */
typedef struct sm_dist_buf {
    unsigned char *data;
    size_t len, cap; /* bytes used, bytes allocated */
} sm_dist_buf;

struct sm_dist {
    MPI_Comm comm;
    int rank, size;
    int dim, stencil;         /* the world's dimension and kernel support (3 or 4 nodes) */
    double lo[3], inv_dx;     /* the domain's lower corner and 1/dx, as the binner uses them */
    uint64_t *cuts;           /* size entries: rank r owns Morton codes [cuts[r], cuts[r + 1]) */
    size_t owned;             /* this rank's particles: [0, owned) of the storage */
    sm_dist_buf *own_out;     /* per rank: particles migrating to it */
    sm_dist_buf *ghost_out;   /* per rank: ghost copies for it (this rank's own ghosts too) */
    sm_dist_buf in;           /* received particles, rank after rank */
    int *counts;              /* 2 per rank sent (migrating, ghosts), then 2 per rank received */
    MPI_Request *req;         /* req_cap requests: one per piece of a message (message.c) */
    size_t req_cap;
    size_t piece;             /* the largest piece of a message, bytes (SM_DIST_PIECE) */
    uint64_t *hist;           /* (Morton code, particles) pairs of the blocks, for a re-cut */
    size_t hist_cap;
    uint32_t *scratch;        /* the owned particles' order for a reorder */
    size_t scratch_cap;
    int since_recut;          /* steps since the last cut */
    size_t pending;           /* the exchange's requests in flight (sm_dist_exchange_begin .. _finish) */
    int overlap;              /* 1 (default): an explicit step scatters its inner blocks while the exchange's
                                 messages travel (overlap.c); 2: also redo them every step (a test of the
                                 fallback); 0: the exchange first */
    uint32_t *lists;          /* overlap.c: the block lists of sm_dist_inner_blocks / sm_dist_outer_blocks */
    size_t lists_cap;
    sm_block_lists inner, outer;
    sm_real *side;            /* overlap.c: side arrays, per slot a grid block's mass, momentum and force */
    uint64_t *side_key;       /* per side slot: the grid block's key << 3 | the contributing block's colour */
    size_t nside, side_cap;
    sm_dist_halo *halo;       /* NULL until an implicit step */
    sm_dist_stats stats;
};

/* Messages of any size (message.c): sm_dist_isend / sm_dist_irecv post `bytes` in pieces of at
 * most d->piece bytes from request d->req + at on and return how many they posted
 * (sm_dist_request_count(d, bytes), which sm_dist_reserve_requests must have room for);
 * sm_dist_wait waits for the first n. */
int sm_dist_reserve_requests(sm_dist *d, size_t n);
size_t sm_dist_request_count(const sm_dist *d, size_t bytes);
size_t sm_dist_isend(sm_dist *d, const unsigned char *buf, size_t bytes, int peer, int tag, size_t at);
size_t sm_dist_irecv(sm_dist *d, unsigned char *buf, size_t bytes, int peer, int tag, size_t at);
void sm_dist_wait(sm_dist *d, size_t n);

/* Morton code of block coordinates (21 bits each; z ignored in 2D). */
uint64_t sm_dist_morton(int dim, const int b[3]);
/* The block coordinates of the particle at x (the binner's particle block). */
void sm_dist_particle_block(const sm_dist *d, const double *x, int b[3]);
/* The rank owning Morton code m. */
int sm_dist_owner(const sm_dist *d, uint64_t m);
/* Grows buf to hold `need` bytes; 0 when out of memory. */
int sm_dist_buf_reserve(sm_dist_buf *buf, size_t need);
void sm_dist_halo_free(sm_dist_halo *h);
/* rank r's range from the (Morton code, particles) pairs of every block, ascending code. */
void sm_dist_cuts_from_histogram(sm_dist *d, const uint64_t *pairs, size_t np);
/* A decomposition for w over comm (duplicated), its cuts all 0; NULL when out of memory. */
sm_dist *sm_dist_create(const struct sm_world *w, MPI_Comm comm);
/* d becomes w's decomposition (the binning keeps its storage; the next step checks every particle). */
void sm_dist_attach(struct sm_world *w, sm_dist *d);
/* qsort's comparison of uint64_t values, ascending. */
int sm_dist_cmp_u64(const void *a, const void *b);
/* Re-cuts the blocks by the particles every rank holds in [0, owned) (collective). */
sm_status sm_dist_recut(struct sm_world *w);

#endif
