/* The transfer caches' storage (transfer.h). */
#include "transfer/transfer.h"

static size_t cache_values(int dim, int threads) {
    const size_t side = dim == 2 ? SM_CACHE_SIDE * SM_CACHE_SIDE : SM_CACHE_SIDE * SM_CACHE_SIDE * SM_CACHE_SIDE;
    return (size_t)threads * side * SM_LANES;
}

size_t sm_transfer_cache_bytes_for(int dim, int threads) { return cache_values(dim, threads) * sizeof(sm_real); }

sm_status sm_transfer_cache_reserve(sm_transfer_cache *c, int dim, int threads) {
    const size_t need = cache_values(dim, threads);
    if (c->cap >= need) return SM_OK;
    free(c->data);
    c->data = sm_aligned_alloc(64, need * sizeof(sm_real));
    if (!c->data) {
        c->cap = 0;
        return SM_ERR_NOMEM;
    }
    c->cap = need;
    return SM_OK;
}

void sm_transfer_cache_free(sm_transfer_cache *c) {
    free(c->data);
    c->data = NULL;
    c->cap = 0;
}
