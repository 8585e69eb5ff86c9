/* Stencil helpers shared by P2G, G2P and the implicit operators (included by *_dim.c files
 * only: D is a constant). The weights are the dyadic products of the 1D B-splines of kernel.h,
 * (3.18)-(3.21); a particle of particle block b (grid/bin.h) touches the nodes 4 b + lb + s,
 * s = 0 .. S-1 per axis, which lie in the 2^d grid blocks b + {0,1}^d.
 *
 * The hot loops use GCC/Clang vector extensions: one SM_LANES-wide vector `vec` per cached node. */
#ifndef SM_TRANSFER_STENCIL_DIM_H
#define SM_TRANSFER_STENCIL_DIM_H

#include "core/dim.h"
#include "transfer/kernel.h"
#include "transfer/transfer.h"

#if D == 2
#define NCACHE (SM_CACHE_SIDE * SM_CACHE_SIDE)
#else
#define NCACHE (SM_CACHE_SIDE * SM_CACHE_SIDE * SM_CACHE_SIDE)
#endif

typedef sm_real vec __attribute__((vector_size(SM_LANES * sizeof(sm_real))));
#if SM_DOUBLE
typedef int64_t ivec __attribute__((vector_size(SM_LANES * sizeof(sm_real)))); /* vec's bits */
#else
typedef int32_t ivec __attribute__((vector_size(SM_LANES * sizeof(sm_real))));
#endif

/* The vector (a, .., a, b, .., b, 0, ..): a in lanes 0..d-1, b in lanes d..2d-1, exactly (bit
 * selects of two broadcasts, not arithmetic, which would turn -0 into +0). */
static inline __attribute__((always_inline)) vec vec_pair(sm_real a, sm_real b) {
    vec va = {0}, vb = {0};
    ivec lo = {0}, hi = {0};
    for (int l = 0; l < SM_LANES; l++) {
        va[l] = a;
        vb[l] = b;
        lo[l] = l < D ? -1 : 0;
        hi[l] = l >= D && l < 2 * D ? -1 : 0;
    }
    return (vec)(((ivec)va & lo) | ((ivec)vb & hi));
}

/* Weights of one particle: per axis, S nodes starting at lb (relative to the particle block's
 * first node, 0..3). */
typedef struct weights {
    int lb[D];
    sm_real w[D][4];
    sm_real dw[D][4]; /* derivative w.r.t. position (already times 1/dx) */
    sm_real dp[D][4]; /* x_i - x_p per axis, m */
} weights;

static inline __attribute__((always_inline)) void kernel_weights(int S, const double *xp, const sm_step_ctx *c,
                                                                 const int bc[3], weights *W) {
    for (int a = 0; a < D; a++) {
        const double X = (xp[a] - c->pos_lo[a]) * c->pos_inv_dx;
        int b = sm_kernel_1d_pos(S, X, W->w[a], W->dw[a]);
        W->lb[a] = b - (bc[a] << SM_BLOCK_BITS);
        for (int k = 0; k < 4; k++) {
            W->dw[a][k] *= c->inv_dx;
            W->dp[a][k] = (sm_real)(((double)(b + k) - X) * c->pos_dx);
        }
    }
}

/* Weights of up to WCH consecutive particles of a block (idx i0 .. i0+cnt-1 of perm), computed
 * together in loops over the particles that the compiler vectorises (structure of arrays). The
 * same operations as kernel_weights, except that the stencil base is found by truncation: every
 * particle lies at least 2 cells inside the domain (sm_world_add_particles checks it, G2P clamps),
 * so X >= 2 and truncation equals floor. Lanes past cnt repeat particle i0 (ignored). X, the base
 * and the offsets are formed in double from the double positions, then rounded to sm_real. */
#define WCH 16
typedef struct wchunk {
    int lb[D][WCH];
    sm_real w[D][4][WCH], dw[D][4][WCH], dp[D][4][WCH];
} wchunk;

static inline __attribute__((always_inline)) void chunk_weights(int S, const double *restrict x, size_t n, int overread,
                                                                int ascending, const uint32_t *restrict perm,
                                                                uint32_t i0, int cnt,
                                                                const sm_step_ctx *c, const int bc[3],
                                                                wchunk *restrict wc) {
    /* Positions: read in place when the chunk's particles are consecutive in storage (the usual
     * case: storage is mostly in block order, and a block's particles in ascending id) and WCH of
     * them exist from the first; else copied (lanes past cnt: the first particle). No gathers:
     * they are slow here. A partial chunk reads past its particles only with `overread` (P2G:
     * nobody writes positions then; G2P moves other blocks' particles concurrently). In a block
     * whose perm increases (`ascending`, bin_dim.c), equal span and count mean consecutive;
     * elsewhere every index is compared. */
    const double *xb;
    double xl[WCH * D];
    const uint32_t q0 = perm[i0];
    int run = perm[i0 + (uint32_t)cnt - 1] - q0 == (uint32_t)(cnt - 1) && (size_t)q0 + WCH <= n && (overread || cnt == WCH);
    if (run && !ascending) {
        uint32_t off = 0; /* a full chunk: a fixed count, which the compiler vectorises */
        if (cnt == WCH)
            for (int j = 0; j < WCH; j++) off |= perm[i0 + (uint32_t)j] ^ (q0 + (uint32_t)j);
        else
            for (int j = 1; j < cnt; j++) off |= perm[i0 + (uint32_t)j] ^ (q0 + (uint32_t)j);
        run = off == 0;
    }
    if (run) {
        xb = x + (size_t)q0 * D;
    } else {
        for (int j = 0; j < WCH; j++) {
            const uint32_t q = perm[i0 + (uint32_t)(j < cnt ? j : 0)];
            for (int a = 0; a < D; a++) xl[j * D + a] = x[(size_t)q * D + a];
        }
        xb = xl;
    }
    for (int a = 0; a < D; a++) {
        const double lo = c->pos_lo[a], inv = c->pos_inv_dx, dx = c->pos_dx;
        const sm_real inv_r = c->inv_dx;
        const int org = bc[a] << SM_BLOCK_BITS;
        for (int j = 0; j < WCH; j++) {
            const double X = (xb[j * D + a] - lo) * inv;
            sm_real w4[4], d4[4];
            const int b = S == 3 ? (int)(X - 0.5) : (int)X - 1; /* X >= 2: truncation = floor */
            sm_kernel_1d_at(S, (sm_real)(X - (double)b), w4, d4);
            wc->lb[a][j] = b - org;
            for (int k = 0; k < 4; k++) {
                wc->w[a][k][j] = w4[k];
                wc->dw[a][k][j] = d4[k] * inv_r;
                wc->dp[a][k][j] = (sm_real)(((double)(b + k) - X) * dx);
            }
        }
    }
}

/* Particle j's weights, read where chunk_weights stored them (`wc` and `j` in scope), not copied
 * into a `weights` first: that struct, written value by value, was read back by vector loads,
 * which store forwarding cannot serve (perf: 10% of G2P's samples on the load after it). With
 * g2p_dim.c's K from broadcasts, 3D float G2P went from 1.12e7-1.29e7 to 1.38e7-1.45e7 particles/s
 * on an Intel Xeon; either change alone measured within the noise. */
#define WC_W(a, k) (wc->w[a][k][j])
#define WC_DW(a, k) (wc->dw[a][k][j])
#define WC_DP(a, k) (wc->dp[a][k][j])
#define WC_LB(a) (wc->lb[a][j])

/* Grid node index of stencil node s (per axis) of a particle of block pb. */
static inline size_t stencil_node(const sm_pblock *pb, const weights *W, const int *s) {
    unsigned cb = 0, local = 0;
    for (int a = 0; a < D; a++) {
        int node = W->lb[a] + s[a];
        cb = (cb << 1) | (unsigned)(node >> SM_BLOCK_BITS);
        local = (local << SM_BLOCK_BITS) | (unsigned)(node & SM_BLOCK_MASK);
    }
    return (size_t)pb->gslot[cb] * BN + local;
}

/* Generic stencil loop (implicit integrator): node index `ni`, weight `wgt`, gradient `gw[D]`. */
#if D == 2
#define STENCIL_BEGIN(S, W, pb)                                                                \
    for (int s0 = 0; s0 < (S); s0++)                                                           \
        for (int s1 = 0; s1 < (S); s1++) {                                                     \
            const int ss_[2] = {s0, s1};                                                       \
            size_t ni = stencil_node((pb), &(W), ss_);                                         \
            sm_real wgt = (W).w[0][s0] * (W).w[1][s1];                                         \
            sm_real gw[2] = {(W).dw[0][s0] * (W).w[1][s1], (W).w[0][s0] * (W).dw[1][s1]};
#define STENCIL_END }
#else
#define STENCIL_BEGIN(S, W, pb)                                                                \
    for (int s0 = 0; s0 < (S); s0++)                                                           \
        for (int s1 = 0; s1 < (S); s1++)                                                       \
            for (int s2 = 0; s2 < (S); s2++) {                                                 \
                const int ss_[3] = {s0, s1, s2};                                               \
                size_t ni = stencil_node((pb), &(W), ss_);                                     \
                sm_real wyz = (W).w[1][s1] * (W).w[2][s2];                                     \
                sm_real wgt = (W).w[0][s0] * wyz;                                              \
                sm_real gw[3] = {(W).dw[0][s0] * wyz, (W).w[0][s0] * (W).dw[1][s1] * (W).w[2][s2], \
                                 (W).w[0][s0] * (W).w[1][s1] * (W).dw[2][s2]};
#define STENCIL_END }
#endif

/* Cache entry of node l (block-local index, grid.h) of the particle block's grid block cb. */
static inline int cache_index(int cb, int l) {
    const int ci = (cb >> (D - 1)) & 1, cj = (cb >> (D - 2)) & 1;
#if D == 2
    return (4 * ci + (l >> 2)) * SM_CACHE_SIDE + 4 * cj + (l & 3);
#else
    const int ck = cb & 1;
    return ((4 * ci + (l >> 4)) * SM_CACHE_SIDE + 4 * cj + ((l >> 2) & 3)) * SM_CACHE_SIDE + 4 * ck + (l & 3);
#endif
}

/* The block-local nodes l of grid block cb (cache_index) that a particle of the particle block can
 * reach with a stencil of S nodes per axis: a particle's first node lies 0..3 nodes into the
 * block (it is binned by it), so its nodes reach S + 2 nodes in: local coordinates 0..3 along an
 * axis where cb is the particle block's own grid block, 0..S-2 where it is the next one. Only
 * these need gathering (G2P), zeroing and adding into the grid (P2G): 6^d of the cache's 8^d
 * nodes with the quadratic kernel. The others hold +0, whose addition changes no grid value. */
#define CACHE_REACH_BEGIN(S, cb, l)                                                  \
    {                                                                                \
        int n_[3] = {1, 1, 1};                                                       \
        for (int a_ = 0; a_ < D; a_++) n_[a_] = (((cb) >> (D - 1 - a_)) & 1) ? (S) - 1 : 4; \
        for (int i_ = 0; i_ < n_[0]; i_++)                                           \
            for (int j_ = 0; j_ < n_[1]; j_++)                                       \
                for (int k_ = 0; k_ < n_[2]; k_++) {                                 \
                    const int l = D == 2 ? i_ * 4 + j_ : (i_ * 4 + j_) * 4 + k_;
#define CACHE_REACH_END \
    }                   \
    }

/* First node (per axis) of a particle block. */
static inline void pblock_origin(const sm_pblock *pb, int bc[3]) {
    sm_block_coords(pb->key, bc);
    for (int a = 0; a < 3; a++) bc[a] = a < D ? bc[a] : 0;
}


#endif
