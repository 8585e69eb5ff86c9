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
           b->pairs_cap * sizeof(uint64_t) + b->color_cap * sizeof(uint32_t);
}

sm_status sm_bins_reserve_perm(sm_bins *b, size_t cap) {
    if (cap <= b->perm_cap) return SM_OK;
    uint32_t *pm = sm_realloc(b->perm, cap * sizeof(uint32_t));
    if (!pm) return SM_ERR_NOMEM;
    b->perm = pm;
    b->perm_cap = cap;
    return SM_OK;
}

static inline size_t block_particles(const sm_bins *b, const uint32_t *list, long i) {
    const sm_pblock *pb = &b->pb[list ? list[i] : (uint32_t)i];
    return pb->end - pb->start;
}

void sm_bins_range(const sm_bins *b, const uint32_t *list, long first, long last, int T, int t, long *lo, long *hi) {
    size_t total = 0;
    for (long i = first; i < last; i++) total += block_particles(b, list, i);
    /* s_k = first block i with (particles in first..i-1) >= total k / T; s_T = last. */
    const size_t want0 = total * (size_t)t / (size_t)T, want1 = total * (size_t)(t + 1) / (size_t)T;
    size_t cum = 0;
    long i = first;
    while (i < last && cum < want0) cum += block_particles(b, list, i++);
    *lo = i;
    if (t == T - 1) {
        *hi = last;
        return;
    }
    while (i < last && cum < want1) cum += block_particles(b, list, i++);
    *hi = i;
}
