/* The background grid: nodes grouped in blocks of 4^d, stored block by block.
 *
 * Only blocks touched by particles are "active": cleared, updated and visited each step. The
 * block-major layout is what a sparse grid needs (blocks can later live in a page table or a hash
 * without changing the stages), and the block is the unit of the race-free P2G schedule: particle
 * blocks of one of the 2^d colours never write the same node (DESIGN §4).
 *
 * Node (i,j,k) sits at domain_min + (i,j,k) dx. Per node: mass, v (momentum during P2G, then
 * v^n), f (force during P2G, then v-bar), vt (v-tilde, the final velocity). Vectors are stored
 * per node (node*d + axis). */
#ifndef SM_GRID_H
#define SM_GRID_H

#include "core/common.h"

#define SM_BLOCK_BITS 2
#define SM_BLOCK (1 << SM_BLOCK_BITS)
#define SM_BLOCK_MASK (SM_BLOCK - 1)

typedef struct sm_grid {
    int dim;
    int nodes[3];     /* nodes per axis (1 along z in 2D) */
    int blocks[3];    /* blocks per axis (1 along z in 2D) */
    size_t nblocks;
    int block_nodes;  /* 4^d */
    sm_real *m, *v, *f, *vt;
    uint8_t *active;  /* per block */
    uint32_t *active_list;
    size_t nactive;
} sm_grid;

sm_status sm_grid_init(sm_grid *g, int dim, const int nodes[3]);
void sm_grid_free(sm_grid *g);
/* Bytes held by the grid arrays. */
size_t sm_grid_bytes(const sm_grid *g);

static inline size_t sm_grid_block_id(const sm_grid *g, int bi, int bj, int bk) {
    return ((size_t)bi * (size_t)g->blocks[1] + (size_t)bj) * (size_t)g->blocks[2] + (size_t)bk;
}

/* Index of node (i,j,k) in the block-major arrays. */
static inline size_t sm_grid_node(const sm_grid *g, int i, int j, int k) {
    size_t b = sm_grid_block_id(g, i >> SM_BLOCK_BITS, j >> SM_BLOCK_BITS, k >> SM_BLOCK_BITS);
    unsigned local = (unsigned)(((i & SM_BLOCK_MASK) << (2 * SM_BLOCK_BITS)) |
                                ((j & SM_BLOCK_MASK) << SM_BLOCK_BITS) | (k & SM_BLOCK_MASK));
    if (g->dim == 2) local = (unsigned)(((i & SM_BLOCK_MASK) << SM_BLOCK_BITS) | (j & SM_BLOCK_MASK));
    return b * (size_t)g->block_nodes + local;
}

/* Grid coordinates (i,j,k) of a node index. */
static inline void sm_grid_node_coords(const sm_grid *g, size_t node, int ijk[3]) {
    size_t b = node / (size_t)g->block_nodes;
    unsigned local = (unsigned)(node % (size_t)g->block_nodes);
    int bk = (int)(b % (size_t)g->blocks[2]);
    size_t r = b / (size_t)g->blocks[2];
    int bj = (int)(r % (size_t)g->blocks[1]);
    int bi = (int)(r / (size_t)g->blocks[1]);
    if (g->dim == 2) {
        ijk[0] = (bi << SM_BLOCK_BITS) | (int)(local >> SM_BLOCK_BITS);
        ijk[1] = (bj << SM_BLOCK_BITS) | (int)(local & SM_BLOCK_MASK);
        ijk[2] = 0;
    } else {
        ijk[0] = (bi << SM_BLOCK_BITS) | (int)(local >> (2 * SM_BLOCK_BITS));
        ijk[1] = (bj << SM_BLOCK_BITS) | (int)((local >> SM_BLOCK_BITS) & SM_BLOCK_MASK);
        ijk[2] = (bk << SM_BLOCK_BITS) | (int)(local & SM_BLOCK_MASK);
    }
}

/* Clears the active flags (call before marking a new step's blocks). */
void sm_grid_clear_active(sm_grid *g);
/* Builds active_list (ascending block id) from the flags and zeroes those blocks' nodes. */
void sm_grid_prepare_active(sm_grid *g, int threads);

#endif
