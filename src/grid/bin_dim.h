/* What the binning's two files share (bin_dim.c: the full binning and the second batch;
 * rebin_dim.c: the binning by movers). Dimension-generic: included after core/dim.h. */
#ifndef SM_GRID_BIN_DIM_H
#define SM_GRID_BIN_DIM_H

#include "core/step_ctx.h"
#include "grid/bin.h"
#include "transfer/kernel.h"

/* Key of the particle block of a particle at xp: the grid block of its stencil's first node. */
static inline uint64_t sm_bin_particle_key(const sm_step_ctx *c, const double *xp, int S) {
    int bb[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) bb[a] = sm_kernel_base(S, (xp[a] - c->pos_lo[a]) * c->pos_inv_dx) >> SM_BLOCK_BITS;
    return sm_block_key(bb[0], bb[1], bb[2]);
}

/* Grows *ptr (of *cap elements of elem bytes) to at least need elements, by half each time. */
static inline sm_status sm_bin_grow(void **ptr, size_t *cap, size_t need, size_t elem) {
    if (need <= *cap) return SM_OK;
    size_t c = *cap ? *cap : 64;
    while (c < need) c += c / 2;
    void *q = sm_realloc(*ptr, c * elem);
    if (!q) return SM_ERR_NOMEM;
    *ptr = q;
    *cap = c;
    return SM_OK;
}

/* What sm_rebin made of the last binning. */
typedef enum sm_rebin_outcome {
    SM_REBIN_FULL,  /* not possible: the full binning must run (b's blocks keep their keys) */
    SM_REBIN_HELD,  /* no particle left its block: the last binning holds as it is */
    SM_REBIN_MOVED  /* the particles that left their blocks are in the blocks they reached */
} sm_rebin_outcome;

/* The binning by movers (rebin_dim.c). The caller has checked that b's last binning was made for
 * the same particle count, kernel, domain and grid (bin_dim.c, same_basis). Makes b's perm and
 * blocks (key, start, end, ascending; more, early and side 0) and the blocks' hash what the full
 * binning's steps 1-3 make of P now; the grid, the slots, the colours and the storage's reorder
 * are the caller's. *outcome says what it did. */
sm_status SM_FN(sm_rebin)(sm_bins *b, const sm_particles *P, const sm_step_ctx *c, int T, sm_rebin_outcome *outcome);

#endif
