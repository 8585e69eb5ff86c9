/* The binning's storage and the block ranges of the threads; the binning itself is bin_dim.c. */
#include <string.h>

#include "grid/bin.h"

void sm_bins_free(sm_bins *b) {
    free(b->perm);
    free(b->pb);
    free(b->pb_tmp);
    sm_block_hash_free(&b->pb_hash);
    free(b->counts);
    free(b->pairs);
    free(b->color_blocks);
    memset(b, 0, sizeof *b);
}

size_t sm_bins_bytes(const sm_bins *b) {
    return b->perm_cap * sizeof(uint32_t) + (b->pb_cap + b->pb_tmp_cap) * sizeof(sm_pblock) +
           b->pb_hash.cap * (sizeof(uint64_t) + sizeof(uint32_t)) + b->counts_cap * sizeof(uint32_t) +
           b->pairs_cap * sizeof(uint64_t) + b->color_cap * sizeof(uint32_t) + b->rebin_ws_bytes;
}

/* perm and the binning by movers' workspace are one allocation: the workspace grows with the
 * particle storage and never on its own (a step allocates nothing, tests/test_emit.c). */
sm_status sm_bins_reserve_perm(sm_bins *b, size_t cap) {
    if (cap <= b->perm_cap) return SM_OK;
    const size_t perm_bytes = (cap * sizeof(uint32_t) + 63) / 64 * 64, ws_bytes = (cap * SM_REBIN_WS_PER_PARTICLE + 63) / 64 * 64;
    uint32_t *pm = sm_realloc(b->perm, perm_bytes + ws_bytes); /* keeps perm's values */
    if (!pm) return SM_ERR_NOMEM;
    b->perm = pm;
    b->perm_cap = cap;
    b->rebin_ws = (char *)pm + perm_bytes;
    b->rebin_ws_bytes = ws_bytes;
    return SM_OK;
}
