/* Block-major grid storage; see grid.h. */
#include <string.h>

#include "grid/grid.h"

sm_status sm_grid_init(sm_grid *g, int dim, const int nodes[3]) {
    memset(g, 0, sizeof *g);
    g->dim = dim;
    g->nblocks = 1;
    for (int a = 0; a < 3; a++) {
        g->nodes[a] = (a < dim) ? nodes[a] : 1;
        g->blocks[a] = (a < dim) ? (nodes[a] + SM_BLOCK - 1) / SM_BLOCK : 1;
        g->nblocks *= (size_t)g->blocks[a];
    }
    g->block_nodes = (dim == 2) ? SM_BLOCK * SM_BLOCK : SM_BLOCK * SM_BLOCK * SM_BLOCK;
    size_t nn = g->nblocks * (size_t)g->block_nodes;
    g->m = calloc(nn, sizeof(sm_real));
    g->v = calloc(nn * (size_t)dim, sizeof(sm_real));
    g->f = calloc(nn * (size_t)dim, sizeof(sm_real));
    g->vt = calloc(nn * (size_t)dim, sizeof(sm_real));
    g->active = calloc(g->nblocks, 1);
    g->active_list = malloc(g->nblocks * sizeof(uint32_t));
    if (!g->m || !g->v || !g->f || !g->vt || !g->active || !g->active_list) {
        sm_grid_free(g);
        return SM_ERR_NOMEM;
    }
    return SM_OK;
}

void sm_grid_free(sm_grid *g) {
    free(g->m);
    free(g->v);
    free(g->f);
    free(g->vt);
    free(g->active);
    free(g->active_list);
    memset(g, 0, sizeof *g);
}

size_t sm_grid_bytes(const sm_grid *g) {
    size_t nn = g->nblocks * (size_t)g->block_nodes;
    return nn * sizeof(sm_real) * (1 + 3 * (size_t)g->dim) + g->nblocks * (1 + sizeof(uint32_t));
}

void sm_grid_clear_active(sm_grid *g) {
    memset(g->active, 0, g->nblocks);
    g->nactive = 0;
}

void sm_grid_prepare_active(sm_grid *g, int threads) {
    size_t n = 0;
    for (size_t b = 0; b < g->nblocks; b++)
        if (g->active[b]) g->active_list[n++] = (uint32_t)b;
    g->nactive = n;
    const size_t bn = (size_t)g->block_nodes, d = (size_t)g->dim;
    long nb = (long)n;
    (void)threads;
#pragma omp parallel for schedule(static) num_threads(threads)
    for (long t = 0; t < nb; t++) {
        size_t b = g->active_list[t];
        memset(g->m + b * bn, 0, bn * sizeof(sm_real));
        memset(g->v + b * bn * d, 0, bn * d * sizeof(sm_real));
        memset(g->f + b * bn * d, 0, bn * d * sizeof(sm_real));
    }
}
