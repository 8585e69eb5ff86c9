/* The particle passes of the implicit operators (implicit_solver.h), compiled for SM_DIM = 2 and 3.
 *
 * Thesis Algorithms 5, 6, 8 and Appendix A.5. Every operator of implicit_ops_dim.c that reaches
 * the particles is one pass: per particle p a d x d matrix M_p from
 *   T_p = sum_i z_i grad w_ip^T                       (the gather: dt T_p F^n is F_p(z) - F^n)
 * and then
 *   out_i = sum_p M_p grad w_ip                       (the scatter, as (3.91))
 * with M_p = G_p(z) = V0 Y(F_p(z)) F^nT (the force), the same with Algorithm 8's precompute at z
 * (a Newton iterate), or apply_p(T_p) (TIMES_DIFF's Hessian product).
 *
 * One pass does both, in P2G's colour schedule: per particle block, z on its 2^d grid blocks is
 * gathered into the thread's dense cache (4 lanes per node, 0..d-1 used), each particle's T_p is read from it
 * with the separable weights of chunk_weights, M_p grad w_ip is accumulated into a second
 * cache, which is then added into out. Per node the sum runs over the particle blocks in colour
 * order, a block's particles in perm order: the same for any thread count, and across ranks
 * for any rank count (a block that reaches no grid block this rank owns is skipped). */
#include "core/dim.h"

#include <string.h>

#include "core/team.h"
#include "integrate/implicit_solver.h"
#include "transfer/stencil_dim.h"

/* A node's d values in one vector of 4 lanes (lanes past d hold 0): half of the transfers' 8,
 * which the d values of a node vector do not need; so the pass's two caches (its input and its
 * sums) together fill the thread's transfer cache, SM_CACHE_SIDE^d x SM_LANES values. */
#define NLANES 4
typedef sm_real nvec __attribute__((vector_size(NLANES * sizeof(sm_real))));
_Static_assert(2 * NLANES <= SM_LANES, "the two node caches fit in a thread's transfer cache");

/* Whether particle block pb reaches a grid block this rank owns: across ranks, a ghost block
 * that only reaches other ranks' blocks adds nothing the solve reads, and is skipped. */
static inline int pblock_needed(const sm_implicit_sys *s, const sm_pblock *pb) {
    if (!s->ranks) return 1;
    for (int c = 0; c < (1 << D); c++)
        if (pb->gslot[c] != SM_NO_SLOT && s->ranks->owned[pb->gslot[c]]) return 1;
    return 0;
}

/* z on the nodes of pb's 2^d grid blocks that its particles reach (CACHE_REACH_BEGIN) into the
 * cache, lanes 0..d-1 (0 where a block is missing). */
static void gather_block(int S, const sm_pblock *pb, const sm_real *z, nvec *restrict cache) {
    for (int cb = 0; cb < NGB; cb++) {
        const uint32_t slot = pb->gslot[cb];
        CACHE_REACH_BEGIN(S, cb, l)
        nvec val = {0};
        if (slot != SM_NO_SLOT)
            for (int a = 0; a < D; a++) val[a] = z[((size_t)slot * BN + (size_t)l) * D + a];
        cache[cache_index(cb, l)] = val;
        CACHE_REACH_END
    }
}

/* Zeroes the cache's nodes that pb's particles reach. */
static void clear_block(int S, nvec *restrict cache) {
    for (int cb = 0; cb < NGB; cb++) {
        CACHE_REACH_BEGIN(S, cb, l)
        cache[cache_index(cb, l)] = (nvec){0};
        CACHE_REACH_END
    }
}

/* T = sum_i z_i grad w_ip^T of particle j of the chunk, from the cache: E[e] holds column e. */
static inline __attribute__((always_inline)) void cache_T(int S, const wchunk *restrict wc, int j,
                                                         const nvec *restrict cache, sm_real T[DD]) {
    nvec E[D];
    for (int e = 0; e < D; e++) E[e] = (nvec){0};
#if D == 2
    for (int s0 = 0; s0 < S; s0++) {
        const nvec *row = cache + (WC_LB(0) + s0) * SM_CACHE_SIDE + WC_LB(1);
        const sm_real w0 = WC_W(0, s0), d0 = WC_DW(0, s0);
        for (int s1 = 0; s1 < S; s1++) {
            const nvec q = row[s1];
            E[0] += (d0 * WC_W(1, s1)) * q;
            E[1] += (w0 * WC_DW(1, s1)) * q;
        }
    }
#else
    for (int s0 = 0; s0 < S; s0++)
        for (int s1 = 0; s1 < S; s1++) {
            const nvec *row = cache + ((WC_LB(0) + s0) * SM_CACHE_SIDE + WC_LB(1) + s1) * SM_CACHE_SIDE + WC_LB(2);
            const sm_real g0 = WC_DW(0, s0) * WC_W(1, s1), g1 = WC_W(0, s0) * WC_DW(1, s1),
                          g2 = WC_W(0, s0) * WC_W(1, s1);
            for (int s2 = 0; s2 < S; s2++) {
                const nvec q = row[s2];
                E[0] += (g0 * WC_W(2, s2)) * q;
                E[1] += (g1 * WC_W(2, s2)) * q;
                E[2] += (g2 * WC_DW(2, s2)) * q;
            }
        }
#endif
    for (int a = 0; a < D; a++)
        for (int e = 0; e < D; e++) T[a * D + e] = E[e][a];
}

/* M grad w_ip into the cache's S^d nodes of particle j (lanes 0..d-1). With Mc_e the column e
 * of M: sum_e (grad w)_e Mc_e, grad w = (w0' w1 w2, w0 w1' w2, w0 w1 w2') in separable parts. */
static inline __attribute__((always_inline)) void cache_scatter(int S, const wchunk *restrict wc, int j,
                                                               const sm_real M[DD], nvec *restrict cache) {
    nvec Mc[D];
    for (int e = 0; e < D; e++) {
        Mc[e] = (nvec){0};
        for (int a = 0; a < D; a++) Mc[e][a] = M[a * D + e];
    }
#if D == 2
    for (int s0 = 0; s0 < S; s0++) {
        nvec *row = cache + (WC_LB(0) + s0) * SM_CACHE_SIDE + WC_LB(1);
        const nvec P0 = WC_DW(0, s0) * Mc[0], Q0 = WC_W(0, s0) * Mc[1];
        for (int s1 = 0; s1 < S; s1++) row[s1] += WC_W(1, s1) * P0 + WC_DW(1, s1) * Q0;
    }
#else
    nvec Px[4], Y[4][4];
    sm_real W12[4][4];
    for (int s1 = 0; s1 < S; s1++)
        for (int s2 = 0; s2 < S; s2++) {
            W12[s1][s2] = WC_W(1, s1) * WC_W(2, s2);
            Y[s1][s2] = (WC_DW(1, s1) * WC_W(2, s2)) * Mc[1] + (WC_W(1, s1) * WC_DW(2, s2)) * Mc[2];
        }
    for (int s0 = 0; s0 < S; s0++) Px[s0] = WC_DW(0, s0) * Mc[0];
    for (int s0 = 0; s0 < S; s0++) {
        const sm_real w0 = WC_W(0, s0);
        for (int s1 = 0; s1 < S; s1++) {
            nvec *row = cache + ((WC_LB(0) + s0) * SM_CACHE_SIDE + WC_LB(1) + s1) * SM_CACHE_SIDE + WC_LB(2);
            for (int s2 = 0; s2 < S; s2++) row[s2] += W12[s1][s2] * Px[s0] + w0 * Y[s1][s2];
        }
    }
#endif
}

/* The cache's reachable nodes (lanes 0..d-1) added into out on the 2^d grid blocks of pb (the
 * others hold +0, which changes no sum). */
static void flush_block(int S, const sm_pblock *pb, const nvec *restrict cache, sm_real *out) {
    for (int cb = 0; cb < NGB; cb++) {
        const uint32_t slot = pb->gslot[cb];
        if (slot == SM_NO_SLOT) continue;
        CACHE_REACH_BEGIN(S, cb, l)
        const nvec q = cache[cache_index(cb, l)];
        sm_real *o = out + ((size_t)slot * BN + (size_t)l) * D;
        for (int a = 0; a < D; a++) o[a] += q[a];
        CACHE_REACH_END
    }
}

static inline sm_implicit_material particle_material(const sm_implicit_sys *s, size_t p) {
    const sm_material_rt *m = &s->mats[s->mat[p]];
    sm_implicit_material im;
    im.mu = m->law.mu;
    im.lambda = m->law.lambda;
    im.alpha = s->alpha[p];
    im.plastic = m->law.plastic;
    return im;
}

/* M_p of the pass from T_p (see the top of the file). */
static inline void particle_matrix(const sm_implicit_sys *s, sm_imp_pass kind, size_t p, const sm_real T[DD],
                                   sm_real M[DD]) {
    if (kind == SM_IMP_PASS_HESSIAN) {
        sm_implicit_apply(D, &s->ws->pp[p], T, M);
        return;
    }
    const sm_real dt = (sm_real)s->c->dt;
    const sm_implicit_material im = particle_material(s, p);
    if (kind == SM_IMP_PASS_PRECOMPUTE)
        sm_implicit_precompute(D, s->F + p * DD, dt, T, s->vol0[p], &im, &s->ws->pp[p], M);
    else
        sm_implicit_force_matrix(D, s->F + p * DD, dt, T, s->vol0[p], &im, M);
}

/* The pass over particle block pb (stencil S a constant where inlined: the loops unroll). */
static inline __attribute__((always_inline)) void pass_block(const sm_implicit_sys *s, int S, sm_imp_pass kind,
                                                            const sm_pblock *pb, const sm_real *in, sm_real *out,
                                                            nvec *restrict cin, nvec *restrict cout) {
    const sm_bins *bins = s->bins;
    int bc[3];
    pblock_origin(pb, bc);
    gather_block(S, pb, in, cin);
    clear_block(S, cout);
    wchunk wc;
    for (uint32_t idx = pb->start; idx < pb->end; idx++) {
        const size_t p = bins->perm[idx];
        const int j = (int)((idx - pb->start) % WCH);
        if (j == 0)
            chunk_weights(S, s->x, s->n, 1, (int)pb->ascending, bins->perm, idx, (int)(pb->end - idx), s->c, bc, &wc);
        sm_real T[DD], M[DD];
        cache_T(S, &wc, j, cin, T);
        particle_matrix(s, kind, p, T, M);
        cache_scatter(S, &wc, j, M, cout);
    }
    flush_block(S, pb, cout, out);
}

/* Work on one particle block of a colour sweep, on thread th. */
typedef void (*block_fn)(const sm_implicit_sys *s, const sm_pblock *pb, int th, void *arg);

/* fn for every particle block this rank needs, colour by colour (no two threads reach a node at
 * once; the same order per node for any thread count), the blocks of a colour claimed by the
 * threads from the two ends of its list (core/team.h, sm_team_claim): which thread does a block
 * changes no bit. */
typedef struct sweep_job {
    const sm_implicit_sys *s;
    block_fn fn;
    void *arg;
    sm_team_claims colour[NCOLORS];
} sweep_job;

static void sweep_share(void *arg, int th, int nt) {
    sweep_job *job = arg;
    const sm_implicit_sys *s = job->s;
    const sm_bins *bins = s->bins;
    for (int col = 0; col < NCOLORS; col++) {
        if (bins->color_offset[col] == bins->color_offset[col + 1]) continue; /* the same on every thread */
        const uint32_t *blocks = bins->color_blocks + bins->color_offset[col];
        sm_team_claimer claimer;
        sm_team_claimer_init(&claimer, &job->colour[col], th, nt);
        long lo, hi;
        while (sm_team_claim(&claimer, 1, &lo, &hi))
            for (long t = lo; t < hi; t++) {
                const sm_pblock *pb = &bins->pb[blocks[t]];
                if (pblock_needed(s, pb)) job->fn(s, pb, th, job->arg);
            }
        sm_team_barrier();
    }
}

static void sweep_by_colour(const sm_implicit_sys *s, block_fn fn, void *arg) {
    sweep_job job = {.s = s, .fn = fn, .arg = arg};
    const uint32_t *off = s->bins->color_offset;
    for (int col = 0; col < NCOLORS; col++) sm_team_claims_init(&job.colour[col], (long)(off[col + 1] - off[col]));
    sm_team_run(s->c->threads, sweep_share, &job);
}

typedef struct {
    sm_imp_pass kind;
    const sm_real *in;
    sm_real *out;
} pass_arg;

static void pass_block_fn(const sm_implicit_sys *s, const sm_pblock *pb, int th, void *arg) {
    const pass_arg *a = arg;
    nvec *cin = (nvec *)(s->cache + (size_t)th * NCACHE * SM_LANES), *cout = cin + NCACHE;
    if (s->c->stencil == 3) pass_block(s, 3, a->kind, pb, a->in, a->out, cin, cout);
    else pass_block(s, 4, a->kind, pb, a->in, a->out, cin, cout);
}

void SM_FN(sm_imp_particle_pass)(const sm_implicit_sys *s, sm_imp_pass kind, const sm_real *in, sm_real *out) {
    memset(out, 0, s->nodes * D * sizeof(sm_real));
    pass_arg a = {kind, in, out};
    sweep_by_colour(s, pass_block_fn, &a);
}

typedef struct {
    sm_imp_particle_scatter fn;
    const void *arg;
    sm_real *out;
} scatter_arg;

static void scatter_block_fn(const sm_implicit_sys *s, const sm_pblock *pb, int th, void *arg) {
    (void)th;
    const scatter_arg *a = arg;
    int bc[3];
    pblock_origin(pb, bc);
    for (uint32_t idx = pb->start; idx < pb->end; idx++) a->fn(s, a->arg, s->bins->perm[idx], pb, bc, a->out);
}

void SM_FN(sm_imp_scatter_by_colour)(const sm_implicit_sys *s, sm_imp_particle_scatter fn, const void *arg,
                                     sm_real *out) {
    scatter_arg a = {fn, arg, out};
    sweep_by_colour(s, scatter_block_fn, &a);
}
