/* The stages of one explicit MPM step, written once and compiled for SM_DIM = 2 and SM_DIM = 3.
 *
 * Thesis Chapter 3 and Appendix B:
 *   kernels      (3.18)-(3.21): dyadic products of 1D B-splines. NB: the extracted text swaps the
 *                names; the spline with support 3 nodes (|x| < 3/2) is the quadratic one, the one
 *                with support 4 (|x| < 2) the cubic one.
 *   P2G          (3.81), (3.87): m_i = sum w m_p, (mv)_i = sum w m_p (v_p + C_p (x_i - x_p)),
 *                C_p = B_p D^-1, D = dx^2/4 (quadratic) or dx^2/3 (cubic) (3.84)-(3.86);
 *                PIC/FLIP use (3.82). Force (3.91): f_i = -sum V0 P F^T grad w = -sum V0 tau grad w.
 *   grid update  (3.92): v* = v^n + dt (f/m + g); then GRID_COLLISIONS and FRICTION (Algorithms 3, 7)
 *                give v-bar (pre-friction) and v-tilde (final).
 *   G2P          (3.109)-(3.113): v_p, B_p from v-tilde; FLIP blend (3.111);
 *                (3.114)-(3.116): x_p and F^E-hat from v-bar (pre-friction, §3.6.5).
 *   plasticity   Algorithm 2: SVD, PROJECT, hardening (3.78)-(3.80); then the Kirchhoff stress
 *                tau = U diag(2 mu ln s + lambda tr ln s) U^T for the next P2G (tau = P F^T).
 *
 * Sparse grid and race-free scatter (DESIGN §4): particles are binned by the 4^d grid block
 * holding their stencil's first node (a "particle block"); its particles write nodes
 * 4b .. 4b+6 per axis only, i.e. the 2^d grid blocks b + {0,1}^d, which are exactly the live
 * blocks (grid.h). Blocks of the same colour (block coordinates equal mod 2) never share a node.
 * P2G accumulates a particle block into a dense per-thread cache of 8^d nodes (the 2^d grid
 * blocks) with SM_LANES values per node, then adds the cache into the grid; colours run one
 * after another, blocks of a colour in parallel, particles of a block in order: every node sums
 * its contributions in the same order for any thread count, so results are bitwise identical.
 * G2P gathers the same 2^d grid blocks into the cache, then interpolates from it.
 *
 * The per-node work uses GCC/Clang vector extensions (one SM_LANES-wide vector per node) and
 * the separable structure of the weights: the contribution of particle p to node (s0,s1,s2) is
 *   w0 w1 w2 A + w1 w2 (w0 dp0 Cx + dw0 Vx) + w0 w2 (w1 dp1 Cy + dw1 Vy) + w0 w1 (w2 dp2 Cz + dw2 Vz)
 * with A = (m, m v, 0), C_e = (0, column e of m C, 0), V_e = (0, 0, column e of -V0 tau). */
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "material/implicit.h"
#include "material/material.h"
#include "material/plastic_batch.h"
#include "math/svd.h"
#include "transfer/kernel.h"
#include "world_internal.h"

#ifndef SM_DIM
#error "SM_DIM must be 2 or 3"
#endif
#define D SM_DIM
#define DD (D * D)
#if D == 2
#define SM_FN(name) name##_2d
#define NCOLORS 4
#define NCACHE (SM_CACHE_SIDE * SM_CACHE_SIDE)
#else
#define SM_FN(name) name##_3d
#define NCOLORS 8
#define NCACHE (SM_CACHE_SIDE * SM_CACHE_SIDE * SM_CACHE_SIDE)
#endif
#define BN (D == 2 ? 16 : 64) /* nodes per grid block */
#define NGB (1 << D)          /* grid blocks per particle block */

typedef sm_real vec __attribute__((vector_size(SM_LANES * sizeof(sm_real))));

/* Weights of one particle: per axis, S nodes starting at lb (relative to the particle block's
 * first node, 0..3). */
typedef struct weights {
    int lb[D];
    sm_real w[D][4];
    sm_real dw[D][4]; /* derivative w.r.t. position (already times 1/dx) */
    sm_real dp[D][4]; /* x_i - x_p per axis, m */
} weights;

static inline __attribute__((always_inline)) void kernel_weights(int S, const sm_real *xp, const sm_step_ctx *c,
                                                                 const int bc[3], weights *W) {
    for (int a = 0; a < D; a++) {
        sm_real X = (xp[a] - c->lo[a]) * c->inv_dx;
        int b = sm_kernel_1d(S, X, W->w[a], W->dw[a]);
        W->lb[a] = b - (bc[a] << SM_BLOCK_BITS);
        for (int k = 0; k < 4; k++) {
            W->dw[a][k] *= c->inv_dx;
            W->dp[a][k] = ((sm_real)(b + k) - X) * c->dx;
        }
    }
}

/* Weights of up to WCH consecutive particles of a block (idx i0 .. i0+cnt-1 of perm), computed
 * together in loops over the particles that the compiler vectorises (structure of arrays). The
 * same operations as kernel_weights, except that the stencil base is found by truncation: every
 * particle lies at least 2 cells inside the domain (sm_world_add_particles checks it, G2P clamps),
 * so X >= 2 and truncation equals floor. Lanes past cnt repeat particle i0 (ignored). */
#define WCH 16
typedef struct wchunk {
    int lb[D][WCH];
    sm_real w[D][4][WCH], dw[D][4][WCH], dp[D][4][WCH];
} wchunk;

static inline __attribute__((always_inline)) void chunk_weights(int S, const sm_real *restrict x, size_t n, int overread,
                                                                const uint32_t *restrict perm, uint32_t i0, int cnt,
                                                                const sm_step_ctx *c, const int bc[3],
                                                                wchunk *restrict wc) {
    /* Positions: read in place when the chunk's particles are consecutive in storage (the usual
     * case: a block's indices increase, so equal span and count mean consecutive) and WCH of them
     * exist from the first; else copied (lanes past cnt: the first particle). No gathers: they are
     * slow here. A partial chunk reads past its particles only with `overread` (P2G: nobody writes
     * positions then; G2P moves other blocks' particles concurrently). */
    const sm_real *xb;
    sm_real xl[WCH * D];
    const uint32_t q0 = perm[i0];
    if (perm[i0 + (uint32_t)cnt - 1] - q0 == (uint32_t)(cnt - 1) && (size_t)q0 + WCH <= n && (overread || cnt == WCH)) {
        xb = x + (size_t)q0 * D;
    } else {
        for (int j = 0; j < WCH; j++) {
            const uint32_t q = perm[i0 + (uint32_t)(j < cnt ? j : 0)];
            for (int a = 0; a < D; a++) xl[j * D + a] = x[(size_t)q * D + a];
        }
        xb = xl;
    }
    for (int a = 0; a < D; a++) {
        const sm_real lo = c->lo[a], inv = c->inv_dx, dx = c->dx;
        const int org = bc[a] << SM_BLOCK_BITS;
        for (int j = 0; j < WCH; j++) {
            const sm_real X = (xb[j * D + a] - lo) * inv;
            sm_real w4[4], d4[4];
            const int b = S == 3 ? (int)(X - SM_R(0.5)) : (int)X - 1; /* X >= 2: truncation = floor */
            sm_kernel_1d_at(S, X - (sm_real)b, w4, d4);
            wc->lb[a][j] = b - org;
            for (int k = 0; k < 4; k++) {
                wc->w[a][k][j] = w4[k];
                wc->dw[a][k][j] = d4[k] * inv;
                wc->dp[a][k][j] = ((sm_real)(b + k) - X) * dx;
            }
        }
    }
}

static inline __attribute__((always_inline)) void chunk_get(const wchunk *wc, int j, weights *W) {
    for (int a = 0; a < D; a++) {
        W->lb[a] = wc->lb[a][j];
        for (int k = 0; k < 4; k++) {
            W->w[a][k] = wc->w[a][k][j];
            W->dw[a][k] = wc->dw[a][k][j];
            W->dp[a][k] = wc->dp[a][k][j];
        }
    }
}

static inline int stencil_size(const sm_world *w) { return w->def.kernel == SM_KERNEL_CUBIC ? 4 : 3; }

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

/* First node (per axis) of a particle block. */
static inline void pblock_origin(const sm_pblock *pb, int bc[3]) {
    sm_block_coords(pb->key, bc);
    for (int a = 0; a < 3; a++) bc[a] = a < D ? bc[a] : 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Binning                                                                                      */

static inline uint64_t particle_key(const sm_step_ctx *c, const sm_real *xp, int S) {
    int bb[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) bb[a] = sm_kernel_base(S, (xp[a] - c->lo[a]) * c->inv_dx) >> SM_BLOCK_BITS;
    return sm_block_key(bb[0], bb[1], bb[2]);
}

static inline int key_color(uint64_t key) {
    int b[3];
    sm_block_coords(key, b);
    return (b[0] & 1) | ((b[1] & 1) << 1) | ((D == 3 ? (b[2] & 1) : 0) << 2);
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static sm_status grow(void **ptr, size_t *cap, size_t need, size_t elem) {
    if (need <= *cap) return SM_OK;
    size_t c = *cap ? *cap : 64;
    while (c < need) c += c / 2;
    void *q = sm_realloc(*ptr, c * elem);
    if (!q) return SM_ERR_NOMEM;
    *ptr = q;
    *cap = c;
    return SM_OK;
}

/* Moves particle storage into perm order (in place, following the permutation's cycles), so the
 * particles of a block are contiguous in memory; perm becomes the identity. */
static void reorder_particles(sm_world *w) {
    sm_particles *P = &w->p;
    const size_t n = P->n;
    uint32_t *perm = w->perm;
    const uint32_t MARK = 0x80000000u;
    for (size_t i = 0; i < n; i++) {
        if (perm[i] & MARK) continue;
        if (perm[i] == i) {
            perm[i] |= MARK;
            continue;
        }
        /* Position j receives the particle at perm[j]; save position i's particle first. */
        sm_real x[D], v[D], B[DD], F[DD], tau[SM_NTAU(D)], scal[3];
        uint16_t mat = P->mat[i];
        memcpy(x, P->x + i * D, sizeof x);
        memcpy(v, P->v + i * D, sizeof v);
        memcpy(B, P->B + i * DD, sizeof B);
        memcpy(F, P->F + i * DD, sizeof F);
        memcpy(tau, P->tau + i * SM_NTAU(D), sizeof tau);
        scal[0] = P->vol0[i];
        scal[1] = P->q[i];
        scal[2] = P->alpha[i];
        size_t j = i;
        for (;;) {
            size_t src = perm[j];
            perm[j] |= MARK;
            if (src == i) break;
            memcpy(P->x + j * D, P->x + src * D, sizeof x);
            memcpy(P->v + j * D, P->v + src * D, sizeof v);
            memcpy(P->B + j * DD, P->B + src * DD, sizeof B);
            memcpy(P->F + j * DD, P->F + src * DD, sizeof F);
            memcpy(P->tau + j * SM_NTAU(D), P->tau + src * SM_NTAU(D), sizeof tau);
            P->vol0[j] = P->vol0[src];
            P->q[j] = P->q[src];
            P->alpha[j] = P->alpha[src];
            P->mat[j] = P->mat[src];
            j = src;
        }
        memcpy(P->x + j * D, x, sizeof x);
        memcpy(P->v + j * D, v, sizeof v);
        memcpy(P->B + j * DD, B, sizeof B);
        memcpy(P->F + j * DD, F, sizeof F);
        memcpy(P->tau + j * SM_NTAU(D), tau, sizeof tau);
        P->vol0[j] = scal[0];
        P->q[j] = scal[1];
        P->alpha[j] = scal[2];
        P->mat[j] = mat;
    }
    for (size_t i = 0; i < n; i++) perm[i] = (uint32_t)i;
    w->reorders++;
}

static sm_status SM_FN(sort)(sm_world *w, const sm_step_ctx *c) {
    sm_grid *g = &w->grid;
    const size_t n = w->p.n;
    const int S = stencil_size(w);
    const sm_real *x = w->p.x;
    const int T = c->threads > 0 ? c->threads : 1;

    /* 1. Count each chunk's particles per block of the previous step (read-only hash lookups;
     * consecutive particles mostly share a block). Keys are recomputed, not stored. */
    sm_block_hash *ph = &w->pb_hash;
    size_t nb = w->npb;
    long misses = 0;
    for (int pass = 0; pass < 2; pass++) {
        if (grow((void **)&w->pb_scratch, &w->pb_scratch_cap, (size_t)(T + 1) * nb + 1, sizeof(uint32_t)) != SM_OK)
            return SM_ERR_NOMEM;
        uint32_t *cnt = w->pb_scratch;
        memset(cnt, 0, (size_t)T * nb * sizeof(uint32_t));
        misses = 0;
#pragma omp parallel for schedule(static, 1) reduction(+ : misses) num_threads(T)
        for (int t = 0; t < T; t++) {
            size_t p0 = n * (size_t)t / (size_t)T, p1 = n * (size_t)(t + 1) / (size_t)T;
            uint32_t *ct = cnt + (size_t)t * nb;
            uint64_t last = UINT64_MAX;
            uint32_t slot = SM_NO_SLOT;
            for (size_t p = p0; p < p1; p++) {
                uint64_t k = particle_key(c, x + p * D, S);
                if (k != last) {
                    last = k;
                    slot = sm_block_hash_find(ph, k);
                }
                if (slot == SM_NO_SLOT) misses++;
                else ct[slot]++;
            }
        }
        if (misses == 0) break;
        SM_ASSERT(pass == 0);
        /* 2. New blocks, in particle order (serial, deterministic); then count again. */
        uint64_t last = UINT64_MAX;
        for (size_t p = 0; p < n; p++) {
            uint64_t k = particle_key(c, x + p * D, S);
            if (k == last) continue;
            last = k;
            if (sm_block_hash_find(ph, k) != SM_NO_SLOT) continue;
            if (grow((void **)&w->pb, &w->pb_cap, nb + 1, sizeof *w->pb) != SM_OK) return SM_ERR_NOMEM;
            if (ph->cap < 2 * (nb + 1)) {
                if (sm_block_hash_reserve(ph, nb + 1) != SM_OK) return SM_ERR_NOMEM;
                for (size_t q = 0; q < nb; q++) sm_block_hash_put(ph, w->pb[q].key, (uint32_t)q);
            }
            sm_block_hash_put(ph, k, (uint32_t)nb);
            w->pb[nb++].key = k;
        }
    }
    /* 3. Stable counting sort by block, blocks in ascending key order. */
    if (grow((void **)&w->sort_keys, &w->sort_keys_cap, 2 * nb + 2, sizeof(uint64_t)) != SM_OK) return SM_ERR_NOMEM;
    uint32_t *cnt = w->pb_scratch, *rank = w->pb_scratch + (size_t)T * nb;
    uint64_t *pairs = w->sort_keys;
    size_t nne = 0;
    for (size_t b = 0; b < nb; b++) {
        uint32_t total = 0;
        for (int t = 0; t < T; t++) total += cnt[(size_t)t * nb + b];
        if (total) {
            pairs[2 * nne] = w->pb[b].key;
            pairs[2 * nne + 1] = b;
            nne++;
        }
        rank[b] = SM_NO_SLOT;
    }
    qsort(pairs, nne, 2 * sizeof(uint64_t), cmp_u64); /* (key, index) pairs, by key */
    /* Per-thread cursors: cnt becomes the first position of thread t's particles of block b. */
    uint32_t pos = 0;
    for (size_t r = 0; r < nne; r++) {
        size_t b = (size_t)pairs[2 * r + 1];
        rank[b] = (uint32_t)r;
        for (int t = 0; t < T; t++) {
            uint32_t k = cnt[(size_t)t * nb + b];
            cnt[(size_t)t * nb + b] = pos;
            pos += k;
        }
    }
#pragma omp parallel for schedule(static, 1) num_threads(T)
    for (int t = 0; t < T; t++) {
        size_t p0 = n * (size_t)t / (size_t)T, p1 = n * (size_t)(t + 1) / (size_t)T;
        uint32_t *ct = cnt + (size_t)t * nb;
        uint64_t last = UINT64_MAX;
        uint32_t slot = 0;
        for (size_t p = p0; p < p1; p++) {
            uint64_t k = particle_key(c, x + p * D, S);
            if (k != last) {
                last = k;
                slot = sm_block_hash_find(ph, k);
            }
            w->perm[ct[slot]++] = (uint32_t)p;
        }
    }
    /* The new block list (ascending key) and its hash. cnt[T-1 row] now holds block ends. */
    {
        uint32_t start = 0;
        for (size_t r = 0; r < nne; r++) {
            size_t b = (size_t)pairs[2 * r + 1];
            uint32_t end = cnt[(size_t)(T - 1) * nb + b];
            pairs[2 * r + 1] = ((uint64_t)start << 32) | end;
            start = end;
        }
        for (size_t r = 0; r < nne; r++) {
            w->pb[r].key = pairs[2 * r];
            w->pb[r].start = (uint32_t)(pairs[2 * r + 1] >> 32);
            w->pb[r].end = (uint32_t)pairs[2 * r + 1];
        }
        w->npb = nne;
        sm_block_hash_clear(ph);
        for (size_t r = 0; r < nne; r++) sm_block_hash_put(ph, w->pb[r].key, (uint32_t)r);
    }
    /* 4. Live grid blocks: the 2^d neighbours (+0/+1 per axis) of every particle block, in
     * ascending key order. */
    sm_block_hash *gh = &g->hash;
    if (sm_block_hash_reserve(gh, nne * NGB) != SM_OK) return SM_ERR_NOMEM;
    sm_block_hash_clear(gh);
    size_t ng = 0;
    for (size_t r = 0; r < nne; r++) {
        int bc[3];
        sm_block_coords(w->pb[r].key, bc);
        for (int cb = 0; cb < NGB; cb++) {
            int o[3] = {0, 0, 0};
            for (int a = 0; a < D; a++) o[a] = bc[a] + ((cb >> (D - 1 - a)) & 1);
            if (o[0] >= g->blocks[0] || o[1] >= g->blocks[1] || o[2] >= g->blocks[2]) continue;
            sm_block_hash_put(gh, sm_block_key(o[0], o[1], o[2]), 0);
        }
    }
    for (size_t i = 0; i < gh->cap; i++) ng += gh->key[i] != UINT64_MAX;
    if (sm_grid_reserve(g, ng) != SM_OK) return SM_ERR_NOMEM;
    {
        size_t k = 0;
        for (size_t i = 0; i < gh->cap; i++)
            if (gh->key[i] != UINT64_MAX) g->key[k++] = gh->key[i];
        qsort(g->key, ng, sizeof(uint64_t), cmp_u64);
        sm_block_hash_clear(gh);
        for (size_t s = 0; s < ng; s++) sm_block_hash_put(gh, g->key[s], (uint32_t)s);
        g->nactive = ng;
    }
    for (size_t r = 0; r < nne; r++) {
        int bc[3];
        sm_block_coords(w->pb[r].key, bc);
        for (int cb = 0; cb < NGB; cb++) {
            int o[3] = {0, 0, 0};
            for (int a = 0; a < D; a++) o[a] = bc[a] + ((cb >> (D - 1 - a)) & 1);
            w->pb[r].gslot[cb] = sm_block_hash_find(gh, sm_block_key(o[0], o[1], o[2]));
        }
        for (int cb = NGB; cb < 8; cb++) w->pb[r].gslot[cb] = SM_NO_SLOT;
    }
    sm_grid_zero(g, T);
    /* 5. Colour lists. */
    if (grow((void **)&w->color_blocks, &w->color_cap, nne, sizeof(uint32_t)) != SM_OK) return SM_ERR_NOMEM;
    memset(w->color_count, 0, sizeof w->color_count);
    for (size_t r = 0; r < nne; r++) w->color_count[key_color(w->pb[r].key)]++;
    w->color_offset[0] = 0;
    for (int col = 0; col < 8; col++) w->color_offset[col + 1] = w->color_offset[col] + w->color_count[col];
    uint32_t cursor[8];
    for (int col = 0; col < 8; col++) cursor[col] = w->color_offset[col];
    for (size_t r = 0; r < nne; r++) w->color_blocks[cursor[key_color(w->pb[r].key)]++] = (uint32_t)r;
    /* 6. Per-thread transfer caches. */
    size_t cache_need = (size_t)T * NCACHE * SM_LANES;
    if (w->cache_cap < cache_need) {
        free(w->cache);
        w->cache = sm_aligned_alloc(64, cache_need * sizeof(sm_real));
        if (!w->cache) {
            w->cache_cap = 0;
            return SM_ERR_NOMEM;
        }
        w->cache_cap = cache_need;
    }
    /* 7. Reorder the storage when the particles of a block are no longer mostly contiguous
     * (fewer than 16 in a row on average): contiguous runs make every later pass stream. */
    size_t breaks = 0;
    for (size_t i = 1; i < n; i++) breaks += w->perm[i] != w->perm[i - 1] + 1;
    if (breaks * 16 > n) reorder_particles(w);
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* P2G                                                                                          */

static inline __attribute__((always_inline)) void p2g_block(sm_world *w, const sm_step_ctx *c, int S,
                                                           int with_force, uint32_t b, vec *restrict cache) {
    sm_grid *g = &w->grid;
    const sm_particles *P = &w->p;
    const sm_pblock *pb = &w->pb[b];
    const int apic = (w->def.transfer == SM_TRANSFER_APIC);
    const sm_real dinv = (S == 3 ? SM_R(4.0) : SM_R(3.0)) * c->inv_dx * c->inv_dx;
    int bc[3];
    pblock_origin(pb, bc);
    memset(cache, 0, NCACHE * sizeof(vec));
    wchunk wc;
    for (uint32_t idx = pb->start; idx < pb->end; idx++) {
        const size_t p = w->perm[idx];
        const int j = (int)((idx - pb->start) % WCH);
        if (j == 0) chunk_weights(S, P->x, P->n, 1, w->perm, idx, (int)(pb->end - idx), c, bc, &wc);
        weights W;
        chunk_get(&wc, j, &W);
        const sm_real mp = sm_particle_mass(w->mats, P, p);
        const sm_real *vp = P->v + p * D;
        sm_real mC[DD], Vt[DD];
        const sm_real vf = with_force ? -P->vol0[p] : 0;
        const sm_real *tp = P->tau + p * SM_NTAU(D);
        for (int k = 0; k < DD; k++) mC[k] = apic ? mp * P->B[p * DD + k] * dinv : 0;
#if D == 2
        Vt[0] = vf * tp[0];
        Vt[3] = vf * tp[1];
        Vt[1] = Vt[2] = vf * tp[2];
#else
        Vt[0] = vf * tp[0];
        Vt[4] = vf * tp[1];
        Vt[8] = vf * tp[2];
        Vt[1] = Vt[3] = vf * tp[3];
        Vt[2] = Vt[6] = vf * tp[4];
        Vt[5] = Vt[7] = vf * tp[5];
#endif
        vec A = {0}, Ce[D], Ve[D];
        A[0] = mp;
        for (int a = 0; a < D; a++) A[1 + a] = mp * vp[a];
        for (int e = 0; e < D; e++) {
            Ce[e] = (vec){0};
            Ve[e] = (vec){0};
            for (int a = 0; a < D; a++) {
                Ce[e][1 + a] = mC[a * D + e];
                Ve[e][1 + D + a] = Vt[a * D + e];
            }
        }
        /* Per-axis parts: axis 0 carries A; axes 1.. carry only their C and V terms. */
        vec Px[4], Ry[4];
        for (int s = 0; s < S; s++) {
            Px[s] = W.w[0][s] * A + (W.w[0][s] * W.dp[0][s]) * Ce[0] + W.dw[0][s] * Ve[0];
            Ry[s] = (W.w[1][s] * W.dp[1][s]) * Ce[1] + W.dw[1][s] * Ve[1];
        }
#if D == 2
        for (int s0 = 0; s0 < S; s0++) {
            vec *row = cache + (W.lb[0] + s0) * SM_CACHE_SIDE + W.lb[1];
            for (int s1 = 0; s1 < S; s1++) row[s1] += W.w[1][s1] * Px[s0] + W.w[0][s0] * Ry[s1];
        }
#else
        vec Rz[4], Y[4][4];
        sm_real W12[4][4];
        for (int s = 0; s < S; s++) Rz[s] = (W.w[2][s] * W.dp[2][s]) * Ce[2] + W.dw[2][s] * Ve[2];
        for (int s1 = 0; s1 < S; s1++)
            for (int s2 = 0; s2 < S; s2++) {
                W12[s1][s2] = W.w[1][s1] * W.w[2][s2];
                Y[s1][s2] = W.w[2][s2] * Ry[s1] + W.w[1][s1] * Rz[s2];
            }
        for (int s0 = 0; s0 < S; s0++) {
            const sm_real w0 = W.w[0][s0];
            for (int s1 = 0; s1 < S; s1++) {
                vec *row = cache + ((W.lb[0] + s0) * SM_CACHE_SIDE + W.lb[1] + s1) * SM_CACHE_SIDE + W.lb[2];
                for (int s2 = 0; s2 < S; s2++) row[s2] += W12[s1][s2] * Px[s0] + w0 * Y[s1][s2];
            }
        }
#endif
    }
    /* Add the cache into the 2^d grid blocks. */
    for (int cb = 0; cb < NGB; cb++) {
        const uint32_t slot = pb->gslot[cb];
        if (slot == SM_NO_SLOT) continue;
        for (int l = 0; l < BN; l++) {
            const vec q = cache[cache_index(cb, l)];
            const size_t ni = (size_t)slot * BN + (size_t)l;
            g->m[ni] += q[0];
            for (int a = 0; a < D; a++) {
                g->v[ni * D + a] += q[1 + a];
                g->f[ni * D + a] += q[1 + D + a];
            }
        }
    }
}

/* Blocks first..last-1 of `list` (NULL: block indices first..last-1) in T contiguous ranges of
 * about equal particle counts; range t is [*lo, *hi). P2G, G2P and plasticity all split the
 * particles this way (blocks and storage are both in key order), so a thread works on the same
 * particles in every stage: with dynamic scheduling, the cross-core traffic halved the 2-thread
 * speed whenever the two cores did not share a cache. */
static void block_range(const sm_world *w, const uint32_t *list, long first, long last, int T, int t, long *lo,
                        long *hi) {
    size_t total = 0;
    for (long i = first; i < last; i++) {
        const sm_pblock *pb = &w->pb[list ? list[i] : (uint32_t)i];
        total += pb->end - pb->start;
    }
    /* s_k = first block i with (particles in first..i-1) >= total k / T; s_T = last. */
    const size_t want0 = total * (size_t)t / (size_t)T, want1 = total * (size_t)(t + 1) / (size_t)T;
    size_t cum = 0;
    long i = first;
    while (i < last && cum < want0) {
        const sm_pblock *pb = &w->pb[list ? list[i] : (uint32_t)i];
        cum += pb->end - pb->start;
        i++;
    }
    *lo = i;
    if (t == T - 1) {
        *hi = last;
        return;
    }
    while (i < last && cum < want1) {
        const sm_pblock *pb = &w->pb[list ? list[i] : (uint32_t)i];
        cum += pb->end - pb->start;
        i++;
    }
    *hi = i;
}

static void SM_FN(p2g)(sm_world *w, const sm_step_ctx *c, int with_force) {
    const int S = stencil_size(w);
    vec *caches = (vec *)w->cache;
#pragma omp parallel num_threads(c->threads)
    {
#ifdef _OPENMP
        const int t = omp_get_thread_num(), T = omp_get_num_threads();
#else
        const int t = 0, T = 1;
#endif
        vec *cache = caches + (size_t)t * NCACHE;
        for (int col = 0; col < NCOLORS; col++) {
            long lo, hi;
            block_range(w, w->color_blocks, (long)w->color_offset[col], (long)w->color_offset[col + 1], T, t, &lo,
                        &hi);
            if (S == 3)
                for (long k = lo; k < hi; k++) p2g_block(w, c, 3, with_force, w->color_blocks[k], cache);
            else
                for (long k = lo; k < hi; k++) p2g_block(w, c, 4, with_force, w->color_blocks[k], cache);
#pragma omp barrier
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Grid update, collisions, friction                                                            */

/* Centre of grid block `slot` (m) and its half-diagonal. */
static inline double block_center(const sm_grid *g, const sm_step_ctx *c, size_t slot, double ctr[3]) {
    int bc[3];
    sm_block_coords(g->key[slot], bc);
    ctr[0] = ctr[1] = ctr[2] = 0;
    for (int a = 0; a < D; a++) ctr[a] = (double)c->lo[a] + ((double)(bc[a] << SM_BLOCK_BITS) + 1.5) * (double)c->dx;
    return 1.5 * (double)c->dx * sqrt((double)D);
}

/* 1 if no collider can act on any node of a block with centre ctr and half-diagonal R whose
 * nodes move at most vmax (m/s) in dt: every collider's signed distance, at both poses, exceeds R
 * plus the step's travel plus the contact tolerance. Signed distances are 1-Lipschitz
 * (tests/test_collide.c checks it), so the bound at the centre covers every node. */
static inline int block_free(const sm_collider *cols, int ncol, const double ctr[3], double R, double reach) {
    for (int b = 0; b < ncol; b++) {
        if (!(sm_collider_phi(&cols[b], D, 0, ctr, NULL) > R + reach)) return 0;
        if (!(sm_collider_phi(&cols[b], D, 1, ctr, NULL) > R + reach)) return 0;
    }
    return 1;
}

static void SM_FN(grid_update)(sm_world *w, const sm_step_ctx *c) {
    sm_grid *g = &w->grid;
    const long nb = (long)g->nactive;
    const size_t bn = (size_t)g->block_nodes;
    const double dt = c->dt;
    const sm_collider *cols = w->colliders;
    const int ncol = w->ncolliders + w->nwalls;
    const int static_sticks = w->def.static_friction_sticks;
    const sm_real dtr = (sm_real)dt;
#pragma omp parallel for schedule(static) num_threads(c->threads)
    for (long t = 0; t < nb; t++) {
        size_t b = (size_t)t;
        /* v^n = (mv)/m, v* = v^n + dt (f/m + g) -> f (v-bar) and vt; the largest |v*|. */
        double vmax2 = 0;
        for (size_t ni = b * bn; ni < (b + 1) * bn; ni++) {
            sm_real m = g->m[ni];
            sm_real inv_m = m > 0 ? SM_R(1.0) / m : 0;
            sm_real s2 = 0;
            for (int a = 0; a < D; a++) {
                sm_real vn = g->v[ni * D + a] * inv_m;
                sm_real vs = m > 0 ? vn + dtr * (g->f[ni * D + a] * inv_m + c->gravity[a]) : 0;
                g->v[ni * D + a] = vn;
                g->f[ni * D + a] = vs;
                g->vt[ni * D + a] = vs;
                s2 += vs * vs;
            }
            if ((double)s2 > vmax2) vmax2 = (double)s2;
        }
        double ctr[3];
        const double R = block_center(g, c, b, ctr);
        const double reach = dt * sqrt(vmax2) + 1e-6 * (1.0 + fabs(ctr[0]) + fabs(ctr[1]) + fabs(ctr[2]) + R);
        if (block_free(cols, ncol, ctr, R, reach)) continue;
        for (size_t ni = b * bn; ni < (b + 1) * bn; ni++) {
            if (!(g->m[ni] > 0)) continue;
            double vstar[3] = {0, 0, 0}, v[3] = {0, 0, 0}, xi[3] = {0, 0, 0};
            int ijk[3];
            sm_grid_node_coords(g, ni, ijk);
            for (int a = 0; a < D; a++) {
                vstar[a] = (double)g->f[ni * D + a];
                v[a] = vstar[a];
                xi[a] = (double)c->lo[a] + (double)ijk[a] * (double)c->dx;
            }
            /* GRID_COLLISIONS (user colliders, then the domain walls), then FRICTION. */
            sm_node_contact rec;
            sm_collide_node(cols, ncol, D, xi, dt, v, &rec);
            for (int a = 0; a < D; a++) g->f[ni * D + a] = (sm_real)v[a]; /* v-bar */
            if (rec.count > 0) {
                double dv[3] = {v[0] - vstar[0], v[1] - vstar[1], v[2] - vstar[2]};
                int stuck = sm_friction_node(cols, D, xi, &rec, dv, v);
                if (stuck && static_sticks)
                    for (int a = 0; a < D; a++) g->f[ni * D + a] = (sm_real)v[a];
            }
            for (int a = 0; a < D; a++) g->vt[ni * D + a] = (sm_real)v[a];
        }
    }
}

static long SM_FN(grid_check)(const sm_world *w) {
    const sm_grid *g = &w->grid;
    const size_t nn = g->nactive * (size_t)g->block_nodes;
    for (size_t ni = 0; ni < nn; ni++)
        for (int a = 0; a < D; a++)
            if (!isfinite(g->vt[ni * D + a]) || !isfinite(g->f[ni * D + a])) return (long)ni;
    return -1;
}

/* ------------------------------------------------------------------------------------------ */
/* G2P                                                                                          */

/* Gathers the 2^d grid blocks of particle block pb into the cache: lanes 0..d-1 hold v-tilde
 * (FLIP: v-tilde - r v^n, so that r v_p + sum w (v-tilde - r v^n) is the FLIP blend (3.111)),
 * lanes d..2d-1 hold v-bar. */
static void SM_FN(g2p_gather)(const sm_world *w, const sm_pblock *pb, vec *restrict cache) {
    const sm_grid *g = &w->grid;
    const int flip = (w->def.transfer == SM_TRANSFER_FLIP);
    const sm_real r = (sm_real)w->def.flip_ratio;
    for (int cb = 0; cb < NGB; cb++) {
        const uint32_t slot = pb->gslot[cb];
        for (int l = 0; l < BN; l++) {
            vec *q = &cache[cache_index(cb, l)];
            vec val = {0};
            if (slot != SM_NO_SLOT) {
                const size_t ni = (size_t)slot * BN + (size_t)l;
                for (int a = 0; a < D; a++) {
                    val[a] = flip ? g->vt[ni * D + a] - r * g->v[ni * D + a] : g->vt[ni * D + a];
                    val[D + a] = g->f[ni * D + a];
                }
            }
            *q = val;
        }
    }
}

/* Per-block G2P results: positions' bounding box, largest speed, non-finite flag, clamps. */
typedef struct g2p_acc {
    sm_real lo[D], hi[D];
    sm_real vmax2;
    sm_real nan;        /* 0 * every new value, summed: NaN iff one of them is not finite */
    size_t clamped;
} g2p_acc;

static inline __attribute__((always_inline)) void g2p_one(sm_world *w, const sm_step_ctx *c, int S, size_t p,
                                                         const weights *restrict Wp, const vec *restrict cache,
                                                         g2p_acc *acc) {
    sm_particles *P = &w->p;
    const int transfer = w->def.transfer;
    const sm_real dt = (sm_real)c->dt;
    const weights W = *Wp;
    /* K_e[s] = (w dp, ..., dw, ...): lanes 0..d-1 weight v-tilde by w dp (B), lanes d..2d-1 weight
     * v-bar by dw (velocity gradient). */
    vec K[D][4];
    for (int e = 0; e < D; e++)
        for (int s = 0; s < S; s++) {
            vec k = {0};
            for (int a = 0; a < D; a++) {
                k[a] = W.w[e][s] * W.dp[e][s];
                k[D + a] = W.dw[e][s];
            }
            K[e][s] = k;
        }
    vec Sum = {0}, E[D];
    for (int e = 0; e < D; e++) E[e] = (vec){0};
#if D == 2
    for (int s0 = 0; s0 < S; s0++) {
        const vec *row = cache + (W.lb[0] + s0) * SM_CACHE_SIDE + W.lb[1];
        vec t = {0}, ty = {0};
        for (int s1 = 0; s1 < S; s1++) {
            const vec N = row[s1];
            t += W.w[1][s1] * N;
            ty += K[1][s1] * N;
        }
        Sum += W.w[0][s0] * t;
        E[0] += K[0][s0] * t;
        E[1] += W.w[0][s0] * ty;
    }
#else
    vec KY[4][4], KZ[4][4];
    sm_real W12[4][4];
    for (int s1 = 0; s1 < S; s1++)
        for (int s2 = 0; s2 < S; s2++) {
            W12[s1][s2] = W.w[1][s1] * W.w[2][s2];
            KY[s1][s2] = W.w[2][s2] * K[1][s1];
            KZ[s1][s2] = W.w[1][s1] * K[2][s2];
        }
    for (int s0 = 0; s0 < S; s0++) {
        vec t = {0}, ty = {0}, tz = {0};
        for (int s1 = 0; s1 < S; s1++) {
            const vec *row = cache + ((W.lb[0] + s0) * SM_CACHE_SIDE + W.lb[1] + s1) * SM_CACHE_SIDE + W.lb[2];
            for (int s2 = 0; s2 < S; s2++) {
                const vec N = row[s2];
                t += W12[s1][s2] * N;
                ty += KY[s1][s2] * N;
                tz += KZ[s1][s2] * N;
            }
        }
        Sum += W.w[0][s0] * t;
        E[0] += K[0][s0] * t;
        E[1] += W.w[0][s0] * ty;
        E[2] += W.w[0][s0] * tz;
    }
#endif
    sm_real s2 = 0, z = 0;
    for (int a = 0; a < D; a++) {
        sm_real va = transfer == SM_TRANSFER_FLIP ? (sm_real)w->def.flip_ratio * P->v[p * D + a] + Sum[a] : Sum[a];
        P->v[p * D + a] = va;
        s2 += va * va;
        z += 0 * va;
    }
    acc->vmax2 = s2 > acc->vmax2 ? s2 : acc->vmax2;
    if (transfer == SM_TRANSFER_APIC)
        for (int a = 0; a < D; a++)
            for (int e = 0; e < D; e++) P->B[p * DD + a * D + e] = E[e][a];
    /* F^E-hat = (I + dt T) F^E (3.114), T = sum v-bar grad w^T. */
    sm_real Fo[DD], *F = P->F + p * DD;
    memcpy(Fo, F, sizeof Fo);
    for (int a = 0; a < D; a++)
        for (int e = 0; e < D; e++) {
            sm_real s = Fo[a * D + e];
            for (int k = 0; k < D; k++) s += dt * E[k][D + a] * Fo[k * D + e];
            F[a * D + e] = s;
            z += 0 * s;
        }
    /* x = x + dt sum w v-bar (3.116); the safety clamp keeps every stencil inside the grid. */
    for (int a = 0; a < D; a++) {
        sm_real xa = P->x[p * D + a] + dt * Sum[D + a];
        sm_real lo = c->lo[a] + SM_R(2.0) * c->dx;
        sm_real hi = c->lo[a] + (sm_real)(w->cells[a] - 2) * c->dx;
        if (xa < lo) {
            xa = lo;
            acc->clamped++;
        } else if (xa > hi) {
            xa = hi;
            acc->clamped++;
        }
        z += 0 * xa;
        P->x[p * D + a] = xa;
        acc->lo[a] = xa < acc->lo[a] ? xa : acc->lo[a];
        acc->hi[a] = xa > acc->hi[a] ? xa : acc->hi[a];
    }
    acc->nan += z;
}

/* Safety net: a particle that ends a step inside a collider is put back on its surface along
 * the gradient (positions only). The grid-level constraints keep this rare and small; it is
 * counted in sm_diagnostics.projected_particles. Only colliders that may reach the block's
 * bounding box (1-Lipschitz signed distance at its centre) are evaluated per particle. */
static size_t SM_FN(project_block)(sm_world *w, const sm_pblock *pb, const g2p_acc *acc) {
    sm_particles *P = &w->p;
    double ctr[3] = {0, 0, 0}, R2 = 0;
    for (int a = 0; a < D; a++) {
        ctr[a] = 0.5 * ((double)acc->lo[a] + (double)acc->hi[a]);
        double h = 0.5 * ((double)acc->hi[a] - (double)acc->lo[a]);
        R2 += h * h;
    }
    const double R = sqrt(R2) + 1e-6 * (1.0 + fabs(ctr[0]) + fabs(ctr[1]) + fabs(ctr[2]));
    size_t projected = 0;
    for (int b = 0; b < w->ncolliders; b++) {
        if (sm_collider_phi(&w->colliders[b], D, 1, ctr, NULL) > R) continue;
        for (uint32_t idx = pb->start; idx < pb->end; idx++) {
            const size_t p = w->perm[idx];
            double xp[3] = {0, 0, 0}, gr[3];
            for (int a = 0; a < D; a++) xp[a] = (double)P->x[p * D + a];
            double phi = sm_collider_phi(&w->colliders[b], D, 1, xp, gr);
            if (phi < 0) {
                for (int a = 0; a < D; a++) P->x[p * D + a] = (sm_real)(xp[a] - phi * gr[a]);
                projected++;
            }
        }
    }
    return projected;
}

static void SM_FN(g2p)(sm_world *w, const sm_step_ctx *c) {
    const int S = stencil_size(w);
    const long nb = (long)w->npb;
    vec *caches = (vec *)w->cache;
    unsigned long long clamped = 0, projected = 0, bad = 0;
    double vmax2 = 0;
#pragma omp parallel num_threads(c->threads) reduction(+ : clamped, projected, bad) reduction(max : vmax2)
    {
#ifdef _OPENMP
        const int t = omp_get_thread_num(), T = omp_get_num_threads();
#else
        const int t = 0, T = 1;
#endif
        vec *cache = caches + (size_t)t * NCACHE;
        long blo, bhi;
        block_range(w, NULL, 0, nb, T, t, &blo, &bhi);
        for (long b = blo; b < bhi; b++) {
            const sm_pblock *pb = &w->pb[b];
            int bc[3];
            pblock_origin(pb, bc);
            SM_FN(g2p_gather)(w, pb, cache);
            g2p_acc acc;
            for (int a = 0; a < D; a++) {
                acc.lo[a] = (sm_real)INFINITY;
                acc.hi[a] = -(sm_real)INFINITY;
            }
            acc.vmax2 = acc.nan = 0;
            acc.clamped = 0;
            wchunk wc;
            for (uint32_t idx = pb->start; idx < pb->end; idx++) {
                const int j = (int)((idx - pb->start) % WCH);
                weights W;
                if (S == 3) {
                    if (j == 0) chunk_weights(3, w->p.x, w->p.n, 0, w->perm, idx, (int)(pb->end - idx), c, bc, &wc);
                    chunk_get(&wc, j, &W);
                    g2p_one(w, c, 3, w->perm[idx], &W, cache, &acc);
                } else {
                    if (j == 0) chunk_weights(4, w->p.x, w->p.n, 0, w->perm, idx, (int)(pb->end - idx), c, bc, &wc);
                    chunk_get(&wc, j, &W);
                    g2p_one(w, c, 4, w->perm[idx], &W, cache, &acc);
                }
            }
            clamped += acc.clamped;
            if (acc.nan != 0 || acc.nan != acc.nan) bad++;
            else if (w->def.particle_projection && w->ncolliders > 0) projected += SM_FN(project_block)(w, pb, &acc);
            if ((double)acc.vmax2 > vmax2) vmax2 = (double)acc.vmax2;
        }
    }
    w->clamped += clamped;
    w->projected += projected;
    w->step_vmax2 = vmax2;
    w->step_bad = bad > 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Plasticity, hardening, stress                                                                */

static inline void svd_d(const sm_real *F, sm_real *U, sm_real *s, sm_real *V) {
#if D == 2
    sm_svd2(F, U, s, V);
#else
    sm_svd3(F, U, s, V);
#endif
}

/* Algorithm 2 in batches of SM_PLASTIC_LANES consecutive particles (material/plastic_batch.h):
 * every particle goes through the same lane-wise operations whatever its batch, so the result
 * does not depend on the thread count. */
static void SM_FN(plasticity)(sm_world *w, const sm_step_ctx *c, size_t first) {
    sm_particles *P = &w->p;
    const size_t n = P->n;
    const sm_material_rt *mats = w->mats;
    const int nt = c ? c->threads : 1;
    enum { L = SM_PLASTIC_LANES };
    const long nbatch = (long)((n - first + L - 1) / L);
    int bad = 0;
#pragma omp parallel num_threads(nt) reduction(| : bad)
    {
        sm_plastic_lanes b;
        int lane_mat[L]; /* material whose parameters lane l holds (-1: padding) */
        for (int l = 0; l < L; l++) lane_mat[l] = -2;
        sm_real z = 0; /* 0 * every output: NaN iff one is not finite */
#pragma omp for schedule(static)
        for (long t = 0; t < nbatch; t++) {
            const size_t p0 = first + (size_t)t * L;
            const int cnt = (int)(n - p0 < (size_t)L ? n - p0 : (size_t)L);
            for (int l = 0; l < L; l++) {
                const size_t p = p0 + (size_t)l;
                const int mi = l < cnt ? (int)P->mat[p] : -1;
                if (mi != lane_mat[l]) { /* the lanes keep their parameters between batches */
                    lane_mat[l] = mi;
                    if (mi >= 0) {
                        const sm_material_rt *m = &mats[mi];
                        b.mu[l] = m->mu;
                        b.lambda[l] = m->lambda;
                        b.h0[l] = (sm_real)m->h0;
                        b.h1[l] = (sm_real)m->h1;
                        b.h2[l] = (sm_real)m->h2;
                        b.h3[l] = (sm_real)m->h3;
                        b.plastic[l] = m->plastic;
                        b.hardening[l] = m->hardening;
                        b.fit[l] = (int32_t)m->def.cone_fit;
                    } else { /* padding: an undeformed elastic particle */
                        b.mu[l] = 1;
                        b.lambda[l] = 0;
                        b.h0[l] = b.h1[l] = b.h2[l] = b.h3[l] = 0;
                        b.plastic[l] = b.hardening[l] = b.fit[l] = 0;
                    }
                }
                if (mi >= 0) {
                    for (int k = 0; k < DD; k++) b.F[k][l] = P->F[p * DD + k];
                    b.alpha[l] = P->alpha[p];
                    b.q[l] = P->q[p];
                } else {
                    for (int k = 0; k < DD; k++) b.F[k][l] = (k % (D + 1) == 0) ? 1 : 0;
                    b.alpha[l] = b.q[l] = 0;
                }
            }
#if D == 2
            sm_plastic_lanes2(&b);
            static const int ta[3] = {0, 3, 1};
#else
            sm_plastic_lanes3(&b);
            static const int ta[6] = {0, 4, 8, 1, 2, 5};
#endif
            for (int l = 0; l < cnt; l++) {
                const size_t p = p0 + (size_t)l;
                for (int k = 0; k < DD; k++) {
                    P->F[p * DD + k] = b.F[k][l];
                    z += 0 * b.F[k][l];
                }
                P->alpha[p] = b.alpha[l];
                P->q[p] = b.q[l];
                for (int k = 0; k < SM_NTAU(D); k++) {
                    P->tau[p * SM_NTAU(D) + k] = b.tau[ta[k]][l];
                    z += 0 * b.tau[ta[k]][l];
                }
            }
        }
        bad |= (z != 0 || z != z);
    }
    if (bad) w->step_bad = 1;
}

static double SM_FN(elastic_energy)(const sm_world *w) {
    const sm_particles *P = &w->p;
    double e = 0;
    for (size_t p = 0; p < P->n; p++) {
        const sm_material_rt *m = &w->mats[P->mat[p]];
        sm_real U[DD], V[DD], s[D];
        svd_d(P->F + p * DD, U, s, V);
        e += (double)P->vol0[p] * (double)sm_hencky_psi(D, s, m->mu, m->lambda);
    }
    return e;
}

static void SM_FN(grid_totals)(const sm_world *w, int which, double *mass, double mom[3], double ang[3]) {
    const sm_grid *g = &w->grid;
    const size_t bn = (size_t)g->block_nodes;
    const sm_real *vel = which ? g->vt : g->v;
    *mass = 0;
    for (int a = 0; a < 3; a++) mom[a] = ang[a] = 0;
    for (size_t t = 0; t < g->nactive; t++) {
        size_t b = t;
        for (size_t ni = b * bn; ni < (b + 1) * bn; ni++) {
            double m = (double)g->m[ni];
            if (!(m > 0)) continue;
            int ijk[3];
            sm_grid_node_coords(g, ni, ijk);
            double x[3] = {0, 0, 0}, mv[3] = {0, 0, 0};
            for (int a = 0; a < D; a++) {
                x[a] = w->def.domain_min[a] + ijk[a] * w->def.dx;
                mv[a] = m * (double)vel[ni * D + a];
            }
            *mass += m;
            for (int a = 0; a < 3; a++) mom[a] += mv[a];
            ang[0] += x[1] * mv[2] - x[2] * mv[1];
            ang[1] += x[2] * mv[0] - x[0] * mv[2];
            ang[2] += x[0] * mv[1] - x[1] * mv[0];
        }
    }
}


/* ------------------------------------------------------------------------------------------ */
/* Implicit integration (thesis §3.6.2.2, Algorithms 5, 6, 8)                                   */
/*
 * Unknowns: grid velocities z on the nodes of the active blocks ("compact" vectors, nodes with
 * zero mass held at zero). With F_p(z) = (I + dt sum_i z_i grad w_ip^T) F_p^n and the per-particle
 * force matrix G_p(z) = V0 Y(F_p(z)) F_p^nT (Y: first Piola stress of the Drucker–Prager projected
 * F, material/implicit.h), the residual of Algorithm 5 is
 *     y_i(z) = z_i - v_i^n - dt g + (dt / m_i) sum_p G_p(z) grad w_ip,
 * evaluated at collided velocities and pruned (sticky rows zeroed, contact normals removed).
 * Newton: solve J dz = -y by GMRES (mass-weighted inner product, at most gmres_max_iterations),
 * with J dz = P(dz' + (dt^2/m) sum_p apply_p(sum_i dz'_i grad w_ip^T) grad w_ip), dz' = P dz
 * (Algorithm 6 TIMES_DIFF, P the contact projection); z += s dz with a backtracking line search on
 * |y|; z <- GRID_COLLISIONS(z). Converged when sqrt(sum m |y|^2 / sum m) < newton_tolerance dt.
 * Then v-bar = z, v* = v^n + dt g - (dt/m) sum G(v-bar) grad w, dv = GRID_COLLISIONS(v*) - v*,
 * v-tilde = FRICTION(v-bar, dv) (Algorithm 5, lines 3-5).
 * Sums over nodes are per active block, then added in block order: bitwise the same for any
 * thread count. Scatters use the same colour schedule as P2G. */

#define IMP_BN ((size_t)(D == 2 ? 16 : 64))

static sm_status SM_FN(imp_reserve)(sm_world *w, size_t nodes, size_t np, int K) {
    sm_implicit_ws *ws = &w->imp;
    sm_grid *g = &w->grid;
    if (ws->partial_cap < g->nactive) {
        double *pa = sm_realloc(ws->partial, g->nactive * sizeof *pa);
        if (!pa) return SM_ERR_NOMEM;
        ws->partial = pa;
        ws->partial_cap = g->nactive;
    }
    if (ws->ncap < nodes || ws->kcap < K + 1) {
        size_t cap = nodes + nodes / 4 + 64;
        int kc = K + 1;
        sm_real **vecs[7] = {&ws->mass, &ws->vn, &ws->z, &ws->y, &ws->dz, &ws->tmp, &ws->force};
        for (int k = 0; k < 7; k++) {
            sm_real *q = sm_realloc(*vecs[k], cap * (k == 0 ? 1 : D) * sizeof(sm_real));
            if (!q) return SM_ERR_NOMEM;
            *vecs[k] = q;
        }
        sm_real *kr = sm_realloc(ws->krylov, (size_t)kc * cap * D * sizeof(sm_real));
        sm_node_contact *rc = sm_realloc(ws->rec, cap * sizeof *rc);
        if (kr) ws->krylov = kr;
        if (rc) ws->rec = rc;
        if (!kr || !rc) return SM_ERR_NOMEM;
        ws->ncap = cap;
        ws->kcap = kc;
    }
    if (ws->pcap < np) {
        size_t cap = np + np / 4 + 64;
        sm_implicit_particle *pp = sm_realloc(ws->pp, cap * sizeof *pp);
        sm_real *G = sm_realloc(ws->G, cap * DD * sizeof(sm_real));
        if (pp) ws->pp = pp;
        if (G) ws->G = G;
        if (!pp || !G) return SM_ERR_NOMEM;
        ws->pcap = cap;
    }
    return SM_OK;
}

/* Mass-weighted dot product over the compact nodes, deterministic. */
static double SM_FN(imp_dot)(const sm_world *w, const sm_real *a, const sm_real *b, int threads) {
    const sm_implicit_ws *ws = &w->imp;
    const long nb = (long)w->grid.nactive;
#pragma omp parallel for schedule(static) num_threads(threads)
    for (long t = 0; t < nb; t++) {
        double s = 0;
        for (size_t l = (size_t)t * IMP_BN; l < (size_t)(t + 1) * IMP_BN; l++) {
            double m = (double)ws->mass[l];
            if (!(m > 0)) continue;
            for (int k = 0; k < D; k++) s += m * (double)a[l * D + k] * (double)b[l * D + k];
        }
        ws->partial[t] = s;
    }
    double s = 0;
    for (long t = 0; t < nb; t++) s += ws->partial[t];
    return s;
}

/* Particles' T = sum_i z_i grad w^T from a grid vector (particle p of block pb). */
static inline __attribute__((always_inline)) void SM_FN(imp_gather_T)(const sm_world *w, const sm_step_ctx *c, int S,
                                                                      size_t p, const sm_pblock *pb, const sm_real *z,
                                                                      sm_real *T) {
    weights W;
    int bc[3];
    pblock_origin(pb, bc);
    kernel_weights(S, w->p.x + p * D, c, bc, &W);
    for (int k = 0; k < DD; k++) T[k] = 0;
    STENCIL_BEGIN(S, W, pb)
    (void)wgt;
    for (int a = 0; a < D; a++)
        for (int e = 0; e < D; e++) T[a * D + e] += z[ni * D + a] * gw[e];
    STENCIL_END
}

/* out_i = sum_p M_p grad w_ip, with M_p from `mats` (n x DD), scattered in the colour schedule. */
static void SM_FN(imp_scatter)(sm_world *w, const sm_step_ctx *c, const sm_real *mats, sm_real *out, size_t nodes) {
    const int S = stencil_size(w);
    memset(out, 0, nodes * D * sizeof(sm_real));
    for (int col = 0; col < NCOLORS; col++) {
        const long first = (long)w->color_offset[col], last = (long)w->color_offset[col + 1];
#pragma omp parallel for schedule(dynamic, 1) num_threads(c->threads)
        for (long t = first; t < last; t++) {
            const sm_pblock *pb = &w->pb[w->color_blocks[t]];
            int bc[3];
            pblock_origin(pb, bc);
            for (uint32_t idx = pb->start; idx < pb->end; idx++) {
                const size_t p = w->perm[idx];
                weights W;
                kernel_weights(S, w->p.x + p * D, c, bc, &W);
                const sm_real *M = mats + p * DD;
                STENCIL_BEGIN(S, W, pb)
                (void)wgt;
                for (int a = 0; a < D; a++) {
                    sm_real acc = 0;
                    for (int e = 0; e < D; e++) acc += M[a * D + e] * gw[e];
                    out[ni * D + a] += acc;
                }
                STENCIL_END
            }
        }
    }
}

static inline sm_implicit_material SM_FN(imp_material)(const sm_world *w, size_t p) {
    const sm_material_rt *m = &w->mats[w->p.mat[p]];
    sm_implicit_material im;
    im.mu = m->mu;
    im.lambda = m->lambda;
    im.alpha = w->p.alpha[p];
    im.plastic = m->plastic;
    return im;
}

/* Per particle at velocities z: G_p (and the Algorithm 8 precompute if `pre`); then
 * ws->force = sum_p G_p grad w (compact). */
static void SM_FN(imp_forces)(sm_world *w, const sm_step_ctx *c, const sm_real *z, int pre, size_t nodes) {
    sm_implicit_ws *ws = &w->imp;
    const int S = stencil_size(w);
    const long nb = (long)w->npb;
    const sm_real dt = (sm_real)c->dt;
#pragma omp parallel for schedule(dynamic, 1) num_threads(c->threads)
    for (long b = 0; b < nb; b++)
    for (uint32_t i = w->pb[b].start; i < w->pb[b].end; i++) {
        size_t p = w->perm[i];
        sm_real T[DD];
        if (S == 3) SM_FN(imp_gather_T)(w, c, 3, p, &w->pb[b], z, T);
        else SM_FN(imp_gather_T)(w, c, 4, p, &w->pb[b], z, T);
        sm_implicit_material im = SM_FN(imp_material)(w, p);
        if (pre) sm_implicit_precompute(D, w->p.F + p * DD, dt, T, w->p.vol0[p], &im, &ws->pp[p], ws->G + p * DD);
        else sm_implicit_force_matrix(D, w->p.F + p * DD, dt, T, w->p.vol0[p], &im, ws->G + p * DD);
    }
    SM_FN(imp_scatter)(w, c, ws->G, ws->force, nodes);
}

/* Node position of compact node l. */
static inline void SM_FN(imp_node_x)(const sm_world *w, const sm_step_ctx *c, size_t l, double xi[3]) {
    int ijk[3];
    sm_grid_node_coords(&w->grid, l, ijk);
    xi[0] = xi[1] = xi[2] = 0;
    for (int a = 0; a < D; a++) xi[a] = (double)c->lo[a] + (double)ijk[a] * (double)c->dx;
}

/* GRID_COLLISIONS on a compact vector (in place), recording contacts. */
static void SM_FN(imp_collide)(sm_world *w, const sm_step_ctx *c, sm_real *z, size_t nodes) {
    sm_implicit_ws *ws = &w->imp;
    const int ncol = w->ncolliders + w->nwalls;
    const long nl = (long)nodes;
#pragma omp parallel for schedule(static) num_threads(c->threads)
    for (long l = 0; l < nl; l++) {
        sm_node_contact *rec = &ws->rec[l];
        rec->sticky = -1;
        rec->count = 0;
        if (!(ws->mass[l] > 0)) continue;
        double xi[3], v[3] = {0, 0, 0};
        SM_FN(imp_node_x)(w, c, (size_t)l, xi);
        for (int a = 0; a < D; a++) v[a] = (double)z[l * D + a];
        sm_collide_node(w->colliders, ncol, D, xi, c->dt, v, rec);
        for (int a = 0; a < D; a++) z[l * D + a] = (sm_real)v[a];
    }
}

/* The contact projection P (sticky rows to zero, normals removed). prune = 1: PRUNE_COLLISIONS
 * (a separating contact whose residual points away, y . n < 0, is forgotten first). */
static void SM_FN(imp_project)(sm_world *w, const sm_step_ctx *c, sm_real *y, size_t nodes, int prune) {
    sm_implicit_ws *ws = &w->imp;
    const long nl = (long)nodes;
#pragma omp parallel for schedule(static) num_threads(c->threads)
    for (long l = 0; l < nl; l++) {
        sm_node_contact *rec = &ws->rec[l];
        sm_real *v = y + l * D;
        if (!(ws->mass[l] > 0) || rec->sticky >= 0) {
            for (int a = 0; a < D; a++) v[a] = 0;
            continue;
        }
        for (int k = 0; k < rec->count; k++) {
            const double *nrm = rec->n[k];
            double vn = 0;
            for (int a = 0; a < D; a++) vn += (double)v[a] * nrm[a];
            if (prune && (w->colliders[rec->body[k]].def.mode == SM_COLLIDE_SEPARATE || rec->stick[k]) && vn < 0) {
                for (int j = k; j + 1 < rec->count; j++) {
                    rec->stick[j] = rec->stick[j + 1];
                    rec->body[j] = rec->body[j + 1];
                    memcpy(rec->n[j], rec->n[j + 1], sizeof rec->n[j]);
                }
                rec->count--;
                k--;
                continue;
            }
            for (int a = 0; a < D; a++) v[a] = (sm_real)((double)v[a] - vn * nrm[a]);
        }
    }
}

/* y = z - v^n - dt g + (dt/m) force, for nodes with mass. */
static void SM_FN(imp_residual)(sm_world *w, const sm_step_ctx *c, const sm_real *z, sm_real *y, size_t nodes) {
    const sm_implicit_ws *ws = &w->imp;
    const sm_real dt = (sm_real)c->dt;
    for (size_t l = 0; l < nodes; l++) {
        sm_real m = ws->mass[l];
        for (int a = 0; a < D; a++)
            y[l * D + a] = m > 0 ? z[l * D + a] - ws->vn[l * D + a] - dt * c->gravity[a] + dt / m * ws->force[l * D + a] : 0;
    }
}

/* out = v^n + FORCE_INCREMENT_VEL(z) = v^n + dt g - (dt/m) sum_p G_p(z) grad w (nodes with mass). */
static void SM_FN(imp_force_increment)(sm_world *w, const sm_step_ctx *c, const sm_real *z, sm_real *out, size_t nodes) {
    const sm_implicit_ws *ws = &w->imp;
    const sm_real dt = (sm_real)c->dt;
    SM_FN(imp_forces)(w, c, z, 0, nodes);
    for (size_t l = 0; l < nodes; l++)
        for (int a = 0; a < D; a++)
            out[l * D + a] = ws->mass[l] > 0 ? ws->vn[l * D + a] + dt * c->gravity[a] - dt / ws->mass[l] * ws->force[l * D + a] : 0;
}

/* NONLINEAR_FUNCTION at z (already collided): y = pruned residual; returns sum m |y|^2. */
static double SM_FN(imp_residual_norm2)(sm_world *w, const sm_step_ctx *c, const sm_real *z, sm_real *y, size_t nodes) {
    SM_FN(imp_forces)(w, c, z, 0, nodes);
    SM_FN(imp_residual)(w, c, z, y, nodes);
    SM_FN(imp_project)(w, c, y, nodes, 1);
    return SM_FN(imp_dot)(w, y, y, c->threads);
}

/* TIMES_DIFF (Algorithm 6): out = P(x' + (dt^2/m) sum_p apply_p(T1_p) grad w), x' = P x. */
static void SM_FN(imp_times_diff)(sm_world *w, const sm_step_ctx *c, const sm_real *x, sm_real *out, size_t nodes) {
    sm_implicit_ws *ws = &w->imp;
    const int S = stencil_size(w);
    const long nb = (long)w->npb;
    sm_real *xp = ws->tmp;
    memcpy(xp, x, nodes * D * sizeof(sm_real));
    SM_FN(imp_project)(w, c, xp, nodes, 0);
#pragma omp parallel for schedule(dynamic, 1) num_threads(c->threads)
    for (long b = 0; b < nb; b++)
    for (uint32_t i = w->pb[b].start; i < w->pb[b].end; i++) {
        size_t p = w->perm[i];
        sm_real T1[DD];
        if (S == 3) SM_FN(imp_gather_T)(w, c, 3, p, &w->pb[b], xp, T1);
        else SM_FN(imp_gather_T)(w, c, 4, p, &w->pb[b], xp, T1);
        sm_implicit_apply(D, &ws->pp[p], T1, ws->G + p * DD);
    }
    SM_FN(imp_scatter)(w, c, ws->G, out, nodes);
    const sm_real dt2 = (sm_real)(c->dt * c->dt);
    for (size_t l = 0; l < nodes; l++) {
        sm_real m = ws->mass[l];
        for (int a = 0; a < D; a++) out[l * D + a] = m > 0 ? xp[l * D + a] + dt2 / m * out[l * D + a] : 0;
    }
    SM_FN(imp_project)(w, c, out, nodes, 0);
}

/* GMRES on J x = b, x0 = 0, mass-weighted inner product; returns iterations. */
static int SM_FN(imp_gmres)(sm_world *w, const sm_step_ctx *c, const sm_real *b, sm_real *x, size_t nodes, int K,
                            double rtol) {
    sm_implicit_ws *ws = &w->imp;
    const size_t N = nodes * D;
    sm_real *V = ws->krylov;
    double H[201][200], cs[200], sn[200], gvec[201];
    memset(x, 0, N * sizeof(sm_real));
    double beta = sqrt(SM_FN(imp_dot)(w, b, b, c->threads));
    if (!(beta > 0)) return 0;
    for (size_t k = 0; k < N; k++) V[k] = (sm_real)((double)b[k] / beta);
    memset(gvec, 0, sizeof gvec);
    gvec[0] = beta;
    int j = 0;
    for (; j < K; j++) {
        sm_real *vj = V + (size_t)j * N, *wv = V + (size_t)(j + 1) * N;
        /* The Hessian product overwrites ws->G; the caller recomputes G when it needs it. */
        SM_FN(imp_times_diff)(w, c, vj, wv, nodes);
        for (int i = 0; i <= j; i++) { /* modified Gram-Schmidt */
            const sm_real *vi = V + (size_t)i * N;
            double h = SM_FN(imp_dot)(w, wv, vi, c->threads);
            H[i][j] = h;
            for (size_t k = 0; k < N; k++) wv[k] = (sm_real)((double)wv[k] - h * (double)vi[k]);
        }
        double hn = sqrt(SM_FN(imp_dot)(w, wv, wv, c->threads));
        H[j + 1][j] = hn;
        for (int i = 0; i < j; i++) { /* apply earlier Givens rotations */
            double t = cs[i] * H[i][j] + sn[i] * H[i + 1][j];
            H[i + 1][j] = -sn[i] * H[i][j] + cs[i] * H[i + 1][j];
            H[i][j] = t;
        }
        double r = hypot(H[j][j], H[j + 1][j]);
        cs[j] = r > 0 ? H[j][j] / r : 1;
        sn[j] = r > 0 ? H[j + 1][j] / r : 0;
        H[j][j] = r;
        H[j + 1][j] = 0;
        gvec[j + 1] = -sn[j] * gvec[j];
        gvec[j] = cs[j] * gvec[j];
        if (hn > 0)
            for (size_t k = 0; k < N; k++) wv[k] = (sm_real)((double)wv[k] / hn);
        if (fabs(gvec[j + 1]) <= rtol * beta || !(hn > 0)) {
            j++;
            break;
        }
    }
    double yv[200];
    for (int i = j - 1; i >= 0; i--) { /* back substitution */
        double s = gvec[i];
        for (int k = i + 1; k < j; k++) s -= H[i][k] * yv[k];
        yv[i] = H[i][i] != 0 ? s / H[i][i] : 0;
    }
    for (int i = 0; i < j; i++) {
        const sm_real *vi = V + (size_t)i * N;
        for (size_t k = 0; k < N; k++) x[k] += (sm_real)(yv[i] * (double)vi[k]);
    }
    return j;
}

static sm_status SM_FN(implicit_grid)(sm_world *w, const sm_step_ctx *c) {
    sm_grid *g = &w->grid;
    sm_implicit_ws *ws = &w->imp;
    const size_t nodes = g->nactive * IMP_BN;
    const int K = w->def.gmres_max_iterations;
    if (SM_FN(imp_reserve)(w, nodes, w->p.n, K) != SM_OK)
        return sm_world_fail(w, SM_ERR_NOMEM, "implicit integrator: out of memory for %zu grid nodes", nodes);
    /* Compact mass and v^n (P2G left momentum in g->v). */
    double msum = 0;
    for (size_t l = 0; l < nodes; l++) {
        size_t ni = l;
        sm_real m = g->m[ni];
        ws->mass[l] = m > 0 ? m : 0;
        msum += (double)ws->mass[l];
        for (int a = 0; a < D; a++) {
            sm_real vn = m > 0 ? g->v[ni * D + a] / m : 0;
            g->v[ni * D + a] = vn;
            ws->vn[l * D + a] = vn;
        }
    }
    const sm_real dt = (sm_real)c->dt;
    /* Initial guess. COUPLED_SOLVE starts from the explicit predictor v^n + FORCE_INCREMENT_VEL(v^n);
     * at time steps well above the explicit limit that predictor is itself unstable (its residual
     * measured 1e8 m/s^2 on an elastic block at 10x the limit, and Newton never recovered), so we
     * start from whichever of it and v^n + dt g has the smaller residual. */
    SM_FN(imp_force_increment)(w, c, ws->vn, ws->z, nodes);
    SM_FN(imp_collide)(w, c, ws->z, nodes);
    double r_explicit = SM_FN(imp_residual_norm2)(w, c, ws->z, ws->y, nodes);
    for (size_t l = 0; l < nodes; l++)
        for (int a = 0; a < D; a++) ws->dz[l * D + a] = ws->mass[l] > 0 ? ws->vn[l * D + a] + dt * c->gravity[a] : 0;
    SM_FN(imp_collide)(w, c, ws->dz, nodes);
    if (SM_FN(imp_residual_norm2)(w, c, ws->dz, ws->y, nodes) < r_explicit) memcpy(ws->z, ws->dz, nodes * D * sizeof(sm_real));
    SM_FN(imp_collide)(w, c, ws->z, nodes);
    const double tol = w->def.newton_tolerance * c->dt;
    int it = 0;
    double a_norm = INFINITY;
    for (;; it++) {
        /* NONLINEAR_FUNCTION at z (already collided), with the Algorithm 8 precompute. */
        SM_FN(imp_forces)(w, c, ws->z, 1, nodes);
        SM_FN(imp_residual)(w, c, ws->z, ws->y, nodes);
        SM_FN(imp_project)(w, c, ws->y, nodes, 1);
        a_norm = sqrt(SM_FN(imp_dot)(w, ws->y, ws->y, c->threads) / (msum > 0 ? msum : 1));
        if (it < (int)(sizeof w->newton_hist / sizeof w->newton_hist[0])) w->newton_hist[it] = a_norm / c->dt;
        if ((it > 0 && a_norm < tol) || it >= w->def.newton_max_iterations) break;
        /* Solve J dz = -y. */
        for (size_t k = 0; k < nodes * D; k++) ws->y[k] = -ws->y[k];
        int gi = SM_FN(imp_gmres)(w, c, ws->y, ws->dz, nodes, K, w->def.gmres_tolerance);
        w->gmres_total += (uint64_t)gi;
        /* Backtracking line search on the residual norm (z is kept in ws->krylov's first vector). */
        sm_real *z0 = ws->krylov;
        memcpy(z0, ws->z, nodes * D * sizeof(sm_real));
        double step = 1;
        for (int ls = 0; ls < 6; ls++) {
            for (size_t k = 0; k < nodes * D; k++) ws->z[k] = z0[k] + (sm_real)step * ws->dz[k];
            SM_FN(imp_collide)(w, c, ws->z, nodes);
            if (ls == 5) break;
            double an = sqrt(SM_FN(imp_residual_norm2)(w, c, ws->z, ws->tmp, nodes) / (msum > 0 ? msum : 1));
            if (an < a_norm || an < tol) break;
            step *= 0.5;
        }
    }
    w->newton_total += (uint64_t)it;
    w->newton_last = it;
    w->newton_last_residual = a_norm / c->dt;
    if (!(a_norm < tol)) w->newton_unconverged++;
    if (!isfinite(a_norm))
        return sm_world_fail(w, SM_ERR_NUMERICAL, "step %llu (t = %.6g s, dt = %.3g s): the implicit solve diverged (residual %g)",
                             (unsigned long long)w->steps + 1, w->time, c->dt, a_norm);
    /* v-bar = z; v* = v^n + FORCE_INCREMENT_VEL(v-bar); dv = GRID_COLLISIONS(v*) - v*;
     * v-tilde = FRICTION(v-bar, dv). */
    sm_real *vstar = ws->tmp;
    SM_FN(imp_force_increment)(w, c, ws->z, vstar, nodes);
    memcpy(ws->dz, vstar, nodes * D * sizeof(sm_real));
    SM_FN(imp_collide)(w, c, ws->dz, nodes); /* records of this call drive FRICTION */
    const int static_sticks = w->def.static_friction_sticks;
    const long nl = (long)nodes;
#pragma omp parallel for schedule(static) num_threads(c->threads)
    for (long l = 0; l < nl; l++) {
        size_t ni = (size_t)l;
        double v[3] = {0, 0, 0}, dv[3] = {0, 0, 0}, xi[3];
        for (int a = 0; a < D; a++) {
            v[a] = (double)ws->z[l * D + a];
            dv[a] = (double)ws->dz[l * D + a] - (double)vstar[l * D + a];
            g->f[ni * D + a] = ws->z[l * D + a];
        }
        if (ws->mass[l] > 0 && ws->rec[l].count > 0) {
            SM_FN(imp_node_x)(w, c, (size_t)l, xi);
            int stuck = sm_friction_node(w->colliders, D, xi, &ws->rec[l], dv, v);
            if (stuck && static_sticks)
                for (int a = 0; a < D; a++) g->f[ni * D + a] = (sm_real)v[a];
        }
        for (int a = 0; a < D; a++) g->vt[ni * D + a] = (sm_real)v[a];
    }
    return SM_OK;
}


/* Test hook: at random grid velocities z (scale vs), compares TIMES_DIFF(dz) with the central
 * difference (y(z + h dz) - y(z - h dz)) / 2h of the unprojected residual y (no colliders may touch
 * the nodes). Returns the relative error |J dz - fd| / |fd| (mass-weighted norms). */
static double SM_FN(implicit_jvp_check)(sm_world *w, const sm_step_ctx *c, uint64_t seed, double vs, double h) {
    sm_grid *g = &w->grid;
    sm_implicit_ws *ws = &w->imp;
    const size_t nodes = g->nactive * IMP_BN;
    if (SM_FN(imp_reserve)(w, nodes, w->p.n, 2) != SM_OK) return INFINITY;
    uint64_t st = seed;
    for (size_t l = 0; l < nodes; l++) {
        size_t ni = l;
        ws->mass[l] = g->m[ni] > 0 ? g->m[ni] : 0;
        for (int a = 0; a < D; a++) {
            st = st * 6364136223846793005ULL + 1442695040888963407ULL;
            double r1 = (double)(st >> 11) / 9007199254740992.0 - 0.5;
            st = st * 6364136223846793005ULL + 1442695040888963407ULL;
            double r2 = (double)(st >> 11) / 9007199254740992.0 - 0.5;
            ws->vn[l * D + a] = 0;
            ws->z[l * D + a] = ws->mass[l] > 0 ? (sm_real)(vs * r1) : 0;
            ws->dz[l * D + a] = ws->mass[l] > 0 ? (sm_real)(vs * r2) : 0;
        }
        ws->rec[l].sticky = -1;
        ws->rec[l].count = 0;
    }
    sm_real *zp = ws->krylov, *yp = ws->krylov + nodes * D, *ym = ws->krylov + 2 * nodes * D;
    for (int sgn = 0; sgn < 2; sgn++) {
        for (size_t k = 0; k < nodes * D; k++) zp[k] = ws->z[k] + (sm_real)((sgn ? -h : h)) * ws->dz[k];
        SM_FN(imp_forces)(w, c, zp, 0, nodes);
        SM_FN(imp_residual)(w, c, zp, sgn ? ym : yp, nodes);
    }
    for (size_t k = 0; k < nodes * D; k++) yp[k] = (sm_real)(((double)yp[k] - (double)ym[k]) / (2 * h));
    SM_FN(imp_forces)(w, c, ws->z, 1, nodes);
    SM_FN(imp_times_diff)(w, c, ws->dz, ym, nodes);
    double num = 0;
    for (size_t k = 0; k < nodes * D; k++) ws->y[k] = ym[k] - yp[k];
    num = SM_FN(imp_dot)(w, ws->y, ws->y, c->threads);
    double den = SM_FN(imp_dot)(w, yp, yp, c->threads);
    return sqrt(num / den);
}

const sm_dim_ops SM_FN(sm_dim_ops) = {
    .dim = D,
    .sort = SM_FN(sort),
    .p2g = SM_FN(p2g),
    .grid_update = SM_FN(grid_update),
    .implicit_grid = SM_FN(implicit_grid),
    .implicit_jvp_check = SM_FN(implicit_jvp_check),
    .grid_check = SM_FN(grid_check),
    .g2p = SM_FN(g2p),
    .plasticity = SM_FN(plasticity),
    .elastic_energy = SM_FN(elastic_energy),
    .grid_totals = SM_FN(grid_totals),
};
