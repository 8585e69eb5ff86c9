/* The background grid: sparse, in blocks of 4^d nodes. Only blocks near particles live.
 *
 * Node (i,j,k) sits at domain_min + (i,j,k) dx and belongs to block (i>>2, j>>2, k>>2). A block
 * is named by its key (the three block coordinates packed in 21 bits each) and, while it lives,
 * by its slot: the live blocks of a step are stored one after another in ascending key order,
 * 4^d nodes each, so node index = slot * 4^d + local, local = li 16 + lj 4 + lk (3D) or li 4 + lj
 * (2D). Memory and work follow the live blocks, not the domain: a large domain costs what its
 * particles cost. A hash table maps keys to slots (rebuilt each step, grown only when needed).
 *
 * Per node the grid stores a mass and two vectors of d values (three with FLIP), node * d + axis.
 * The vectors hold different quantities in different stages of the step; this table is the one
 * place that says which (the stages only see the named views below, sm_grid_p2g_arrays and
 * sm_grid_vel_arrays, never vec[]):
 *
 *   storage  P2G writes   grid update / implicit solve writes   G2P reads
 *   mass     mass         -                                     -
 *   vec[0]   momentum     v-tilde (v^n with FLIP)               v-tilde (v^n with FLIP)
 *   vec[1]   force        v-bar                                 v-bar
 *   vec[2]   -            v-tilde (FLIP only)                   v-tilde (FLIP only)
 *
 * i.e. v-bar (pre-friction velocity) takes the force's place and v-tilde (final velocity) the
 * momentum's: a node's momentum and force are read before its velocities are written. Only FLIP
 * needs v^n after the grid update (the blend (3.111)), and only FLIP pays for a third vector.
 * Memory per node is the budget (tests/test_memory.c), hence the reuse. */
#ifndef SM_GRID_H
#define SM_GRID_H

#include "core/common.h"

#define SM_BLOCK_BITS 2
#define SM_BLOCK (1 << SM_BLOCK_BITS)
#define SM_BLOCK_MASK (SM_BLOCK - 1)
#define SM_KEY_BITS 21
#define SM_KEY_MAX ((1 << SM_KEY_BITS) - 1) /* largest block coordinate */
#define SM_NO_SLOT UINT32_MAX

static inline uint64_t sm_block_key(int bi, int bj, int bk) {
    return ((uint64_t)(uint32_t)bi << (2 * SM_KEY_BITS)) | ((uint64_t)(uint32_t)bj << SM_KEY_BITS) | (uint64_t)(uint32_t)bk;
}

static inline void sm_block_coords(uint64_t key, int b[3]) {
    b[0] = (int)(key >> (2 * SM_KEY_BITS));
    b[1] = (int)((key >> SM_KEY_BITS) & SM_KEY_MAX);
    b[2] = (int)(key & SM_KEY_MAX);
}

/* Open-addressing hash table from block keys to 32-bit values; capacity a power of two, at
 * least twice the entries. */
typedef struct sm_block_hash {
    uint64_t *key; /* UINT64_MAX = empty */
    uint32_t *val;
    size_t cap;
} sm_block_hash;

/* Makes room for n entries (grows and clears when the capacity is too small). */
sm_status sm_block_hash_reserve(sm_block_hash *h, size_t n);
void sm_block_hash_clear(sm_block_hash *h);
void sm_block_hash_free(sm_block_hash *h);

/* Fibonacci hashing: the top log2(cap) bits of key * 2^64 / golden ratio. Every key bit reaches
 * the top of the product (low product bits see only low key bits, which are all zero in 2D), and
 * arithmetic progressions of keys -- rows of blocks -- spread evenly. cap >= 2 (a power of two). */
static inline size_t sm_block_hash_pos(const sm_block_hash *h, uint64_t key) {
    return (size_t)((key * 0x9E3779B97F4A7C15ULL) >> (64 - __builtin_ctzll((unsigned long long)h->cap)));
}
/* Value stored for key, or SM_NO_SLOT. */
static inline uint32_t sm_block_hash_find(const sm_block_hash *h, uint64_t key) {
    if (!h->cap) return SM_NO_SLOT;
    for (size_t i = sm_block_hash_pos(h, key);; i = (i + 1) & (h->cap - 1)) {
        if (h->key[i] == key) return h->val[i];
        if (h->key[i] == UINT64_MAX) return SM_NO_SLOT;
    }
}

/* Inserts key -> val unless key is present; returns the value stored for key. The table must
 * have room (sm_block_hash_reserve). */
static inline uint32_t sm_block_hash_put(sm_block_hash *h, uint64_t key, uint32_t val) {
    for (size_t i = sm_block_hash_pos(h, key);; i = (i + 1) & (h->cap - 1)) {
        if (h->key[i] == key) return h->val[i];
        if (h->key[i] == UINT64_MAX) {
            h->key[i] = key;
            h->val[i] = val;
            return val;
        }
    }
}

typedef struct sm_grid {
    int dim;
    int nodes[3];     /* nodes per axis of the domain (1 along z in 2D) */
    int blocks[3];    /* blocks per axis of the domain (1 along z in 2D) */
    int block_nodes;  /* 4^d */
    size_t nactive;   /* live blocks this step (slots 0 .. nactive-1) */
    size_t cap;       /* blocks allocated */
    uint64_t *key;    /* per slot, ascending */
    sm_real *mass;    /* kg per node */
    sm_real *vec[3];  /* node vectors: what each holds when is the table above; vec[2] only with FLIP */
    int flip;         /* FLIP transfer: v^n is kept for G2P (vec[2] allocated) */
    sm_block_hash hash; /* key -> slot of the live blocks */
} sm_grid;

/* What P2G accumulates into (zeroed by sm_grid_zero): kg, kg m/s, N. */
typedef struct sm_grid_p2g {
    sm_real *mass, *momentum, *force;
} sm_grid_p2g;

/* The grid velocities, m/s, from the grid update (or the implicit solve) on: v^n (FLIP only,
 * else NULL), v-bar (pre-friction: positions and F^E follow it, §3.6.5) and v-tilde (final:
 * particle velocities follow it). */
typedef struct sm_grid_vel {
    sm_real *vn, *vbar, *vtilde;
} sm_grid_vel;

static inline sm_grid_p2g sm_grid_p2g_arrays(const sm_grid *g) {
    sm_grid_p2g a = {g->mass, g->vec[0], g->vec[1]};
    return a;
}

static inline sm_grid_vel sm_grid_vel_arrays(const sm_grid *g) {
    sm_grid_vel a = {g->flip ? g->vec[0] : NULL, g->vec[1], g->flip ? g->vec[2] : g->vec[0]};
    return a;
}

/* An empty grid for a domain of nodes[] nodes; no block storage yet. */
void sm_grid_init(sm_grid *g, int dim, const int nodes[3], int flip);
void sm_grid_free(sm_grid *g);
/* Bytes held by the grid (allocated blocks and the hash table). */
size_t sm_grid_bytes(const sm_grid *g);
/* Makes room for nblocks live blocks (grows geometrically; never shrinks). */
sm_status sm_grid_reserve(sm_grid *g, size_t nblocks);
/* Zeroes what P2G accumulates into (mass, momentum, force) in the live blocks. */
void sm_grid_zero(sm_grid *g, int threads);
/* Makes the k blocks keys[] (ascending, none of them live) live too, in their places of the
 * ascending slot order: the live blocks keep what P2G accumulated in them (mass, momentum, force),
 * the new ones are zeroed; the hash follows. For a P2G that started before all particles were
 * binned (bin.h, sm_bin_more). */
sm_status sm_grid_add_blocks(sm_grid *g, const uint64_t *keys, size_t k);

/* Grid coordinates (i,j,k) of a node index. */
static inline void sm_grid_node_coords(const sm_grid *g, size_t node, int ijk[3]) {
    size_t slot = node / (size_t)g->block_nodes;
    unsigned local = (unsigned)(node % (size_t)g->block_nodes);
    int b[3];
    sm_block_coords(g->key[slot], b);
    if (g->dim == 2) {
        ijk[0] = (b[0] << SM_BLOCK_BITS) | (int)(local >> SM_BLOCK_BITS);
        ijk[1] = (b[1] << SM_BLOCK_BITS) | (int)(local & SM_BLOCK_MASK);
        ijk[2] = 0;
    } else {
        ijk[0] = (b[0] << SM_BLOCK_BITS) | (int)(local >> (2 * SM_BLOCK_BITS));
        ijk[1] = (b[1] << SM_BLOCK_BITS) | (int)((local >> SM_BLOCK_BITS) & SM_BLOCK_MASK);
        ijk[2] = (b[2] << SM_BLOCK_BITS) | (int)(local & SM_BLOCK_MASK);
    }
}

#endif
