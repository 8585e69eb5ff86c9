/* Sparse block grid storage; see grid.h. */
#include <string.h>

#include "core/team.h"
#include "grid/grid.h"

sm_status sm_block_hash_reserve(sm_block_hash *h, size_t n) {
    if (h->cap >= 2 * n && h->cap >= 16) return SM_OK;
    size_t cap = 16;
    while (cap < 2 * n) cap *= 2;
    cap *= 2; /* headroom: growth stays rare */
    uint64_t *k = sm_realloc(h->key, cap * sizeof *k);
    if (!k) return SM_ERR_NOMEM;
    h->key = k;
    uint32_t *v = sm_realloc(h->val, cap * sizeof *v);
    if (!v) return SM_ERR_NOMEM;
    h->val = v;
    h->cap = cap;
    sm_block_hash_clear(h);
    return SM_OK;
}

void sm_block_hash_clear(sm_block_hash *h) {
    if (h->cap) memset(h->key, 0xff, h->cap * sizeof *h->key);
}

void sm_block_hash_free(sm_block_hash *h) {
    free(h->key);
    free(h->val);
    memset(h, 0, sizeof *h);
}

void sm_grid_init(sm_grid *g, int dim, const int nodes[3], int flip) {
    memset(g, 0, sizeof *g);
    g->dim = dim;
    g->flip = flip;
    for (int a = 0; a < 3; a++) {
        g->nodes[a] = (a < dim) ? nodes[a] : 1;
        g->blocks[a] = (a < dim) ? (nodes[a] + SM_BLOCK - 1) / SM_BLOCK : 1;
    }
    g->block_nodes = (dim == 2) ? SM_BLOCK * SM_BLOCK : SM_BLOCK * SM_BLOCK * SM_BLOCK;
}

void sm_grid_free(sm_grid *g) {
    free(g->key);
    free(g->mass);
    for (int i = 0; i < 3; i++) free(g->vec[i]);
    sm_block_hash_free(&g->hash);
    memset(g, 0, sizeof *g);
}

size_t sm_grid_bytes(const sm_grid *g) {
    size_t nn = g->cap * (size_t)g->block_nodes;
    return nn * sizeof(sm_real) * (1 + (g->flip ? 3 : 2) * (size_t)g->dim) + g->cap * sizeof(uint64_t) +
           g->hash.cap * (sizeof(uint64_t) + sizeof(uint32_t));
}

sm_status sm_grid_reserve(sm_grid *g, size_t nblocks) {
    if (sm_block_hash_reserve(&g->hash, nblocks) != SM_OK) return SM_ERR_NOMEM;
    if (nblocks <= g->cap) return SM_OK;
    size_t cap = g->cap ? g->cap : 64;
    while (cap < nblocks) cap += cap / 2;
    const size_t nn = cap * (size_t)g->block_nodes, d = (size_t)g->dim;
    uint64_t *k = sm_realloc(g->key, cap * sizeof *k);
    if (!k) return SM_ERR_NOMEM;
    g->key = k;
    /* Node arrays: contents are not kept (the grid is zeroed after every reserve). 64-byte
     * aligned so that a block's nodes start a cache line: threads writing neighbouring blocks
     * then never share a line. */
    sm_real **arr[4] = {&g->mass, &g->vec[0], &g->vec[1], &g->vec[2]};
    for (int i = 0; i < (g->flip ? 4 : 3); i++) {
        sm_real *q = sm_aligned_alloc(64, nn * (i == 0 ? 1 : d) * sizeof(sm_real));
        if (!q) return SM_ERR_NOMEM;
        free(*arr[i]);
        *arr[i] = q;
    }
    g->cap = cap;
    return SM_OK;
}

typedef struct zero_job {
    sm_grid_p2g a;
    size_t bn, d;
} zero_job;

static void zero_blocks(void *arg, long lo, long hi) {
    const zero_job *z = arg;
    const size_t b0 = (size_t)lo, nb = (size_t)(hi - lo), bn = z->bn, d = z->d;
    memset(z->a.mass + b0 * bn, 0, nb * bn * sizeof(sm_real));
    memset(z->a.momentum + b0 * bn * d, 0, nb * bn * d * sizeof(sm_real));
    memset(z->a.force + b0 * bn * d, 0, nb * bn * d * sizeof(sm_real));
}

void sm_grid_zero(sm_grid *g, int threads) {
    zero_job z = {sm_grid_p2g_arrays(g), (size_t)g->block_nodes, (size_t)g->dim};
    sm_team_for(threads, (long)g->nactive, zero_blocks, &z);
}

/* The P2G arrays of g (mass, momentum, force) and their values per node. */
static void p2g_arrays(const sm_grid *g, sm_real *arr[3], size_t per[3]) {
    const sm_grid_p2g a = sm_grid_p2g_arrays(g);
    arr[0] = a.mass;
    arr[1] = a.momentum;
    arr[2] = a.force;
    per[0] = 1;
    per[1] = per[2] = (size_t)g->dim;
}

/* Merges from the back: old slot i of (okey, src) and new key j end in slot s of (g->key, dst),
 * largest key first, so that dst may be src (new slots are never below old ones). */
static void merge_blocks(sm_grid *g, const uint64_t *okey, sm_real *const src[3], sm_real *const dst[3],
                         const size_t per[3], size_t na, const uint64_t *keys, size_t k) {
    const size_t bn = (size_t)g->block_nodes;
    size_t i = na, j = k, s = na + k;
    while (s > 0) {
        s--;
        const int take_new = j > 0 && (i == 0 || keys[j - 1] > okey[i - 1]);
        for (int q = 0; q < 3; q++) {
            const size_t len = bn * per[q];
            if (take_new) memset(dst[q] + s * len, 0, len * sizeof(sm_real));
            else if (dst[q] != src[q] || s != i - 1) memmove(dst[q] + s * len, src[q] + (i - 1) * len, len * sizeof(sm_real));
        }
        g->key[s] = take_new ? keys[--j] : okey[--i];
    }
}

sm_status sm_grid_add_blocks(sm_grid *g, const uint64_t *keys, size_t k) {
    if (k == 0) return SM_OK;
    const size_t na = g->nactive, total = na + k;
    sm_real *src[3];
    size_t per[3];
    p2g_arrays(g, src, per);
    if (total <= g->cap) {
        merge_blocks(g, g->key, src, src, per, na, keys, k);
    } else { /* into new storage (grid.h: the node arrays hold only the live blocks' values) */
        sm_grid big = *g;
        memset(&big.hash, 0, sizeof big.hash);
        big.key = NULL;
        big.mass = big.vec[0] = big.vec[1] = big.vec[2] = NULL;
        big.cap = 0;
        if (sm_grid_reserve(&big, total) != SM_OK) {
            sm_grid_free(&big);
            return SM_ERR_NOMEM;
        }
        sm_real *dst[3];
        p2g_arrays(&big, dst, per);
        uint64_t *okey = g->key;
        g->key = big.key;
        merge_blocks(g, okey, src, dst, per, na, keys, k);
        free(okey);
        free(g->mass);
        for (int q = 0; q < 3; q++) free(g->vec[q]);
        g->mass = big.mass;
        for (int q = 0; q < 3; q++) g->vec[q] = big.vec[q];
        g->cap = big.cap;
        sm_block_hash_free(&big.hash);
    }
    g->nactive = total;
    if (sm_block_hash_reserve(&g->hash, total) != SM_OK) return SM_ERR_NOMEM;
    sm_block_hash_clear(&g->hash);
    for (size_t s = 0; s < total; s++) sm_block_hash_put(&g->hash, g->key[s], (uint32_t)s);
    return SM_OK;
}
