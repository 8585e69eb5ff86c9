/* G2P (transfer.h), compiled for SM_DIM = 2 and 3.
 *
 * Thesis §3.6.1, §3.6.5:
 *   v_p = sum_i w_ip v-tilde_i                                (3.109)  (PIC, APIC)
 *   v_p = r v_p + sum_i w_ip (v-tilde_i - r v^n_i)             (3.111)  (FLIP, ratio r)
 *   B_p = sum_i w_ip v-tilde_i (x_i - x_p)^T                   (3.112), (3.113)  (APIC)
 *   F^E-hat_p = (I + dt sum_i v-bar_i grad w_ip^T) F^E_p       (3.114)
 *   x_p = x_p + dt sum_i w_ip v-bar_i                          (3.116)
 * Positions and F^E follow the pre-friction v-bar, velocities the final v-tilde (§3.6.5).
 * A position is clamped 2 cells inside the domain (every stencil stays on the grid) and, as a
 * safety net, put back on the surface of a user collider it ended inside.
 *
 * Per particle block: gather the 2^d grid blocks into the thread's cache (lanes 0..d-1:
 * v-tilde, or v-tilde - r v^n for FLIP; lanes d..2d-1: v-bar), then interpolate each particle
 * from it with the separable weights; in 2D two particles at a time (g2p_sums_pair: their 4
 * lanes side by side in one vector, the same operations per lane, so the same bits). The threads
 * claim blocks from the two ends of the list (core/team.h, sm_team_claim): about the particles
 * each had in P2G; every block's results are its own, so which thread does it changes no bit. */
#include "core/dim.h"

#include <string.h>

#include "core/team.h"
#include "transfer/stencil_dim.h"

/* Gathers the nodes of particle block pb's 2^d grid blocks that its particles can reach
 * (CACHE_REACH_BEGIN) into the cache (see the top of the file). */
static void g2p_gather(const sm_g2p_io *io, const sm_step_ctx *c, const sm_pblock *pb, vec *restrict cache) {
    const int flip = (c->transfer == SM_TRANSFER_FLIP), S = c->stencil;
    const sm_real r = c->flip_ratio;
    for (int cb = 0; cb < NGB; cb++) {
        const uint32_t slot = pb->gslot[cb];
        CACHE_REACH_BEGIN(S, cb, l)
        vec *q = &cache[cache_index(cb, l)];
        vec val = {0};
        if (slot != SM_NO_SLOT) {
            const size_t ni = (size_t)slot * BN + (size_t)l;
            for (int a = 0; a < D; a++) {
                val[a] = flip ? io->vtilde[ni * D + a] - r * io->vn[ni * D + a] : io->vtilde[ni * D + a];
                val[D + a] = io->vbar[ni * D + a];
            }
        }
        *q = val;
        CACHE_REACH_END
    }
}

/* Per-block G2P results: positions' bounding box, largest speed, non-finite flag, clamps. */
typedef struct g2p_acc {
    double lo[D], hi[D];
    sm_real vmax2;
    sm_real nan;        /* 0 * every new value, summed: NaN iff one of them is not finite */
    size_t clamped;
} g2p_acc;

/* The interpolated sums of one particle from the cache: Sum = sum w N (lanes 0..d-1: v-tilde
 * part, d..2d-1: v-bar) and E[e] = sum K_e N, where K_e = (w dp_e, ..., dw_e, ...): lanes 0..d-1
 * give B's column e, lanes d..2d-1 the velocity gradient's column e. */
static inline __attribute__((always_inline)) void g2p_sums(int S, const wchunk *restrict wc, int j,
                                                          const vec *restrict cache, vec *Sum_out, vec E[D]) {
    vec K[D][4];
    /* Built by lane stores in 2D, by bit selects of broadcasts in 3D: each measured the faster
     * there (Intel Xeon, float: 2D G2P 1.45e7 against 1.28e7 particles/s; 3D 1.4e7 against 1.15e7) */
#if D == 2
    for (int e = 0; e < D; e++)
        for (int s = 0; s < S; s++) {
            vec k = {0};
            for (int a = 0; a < D; a++) {
                k[a] = WC_W(e, s) * WC_DP(e, s);
                k[D + a] = WC_DW(e, s);
            }
            K[e][s] = k;
        }
#else
    for (int e = 0; e < D; e++)
        for (int s = 0; s < S; s++) K[e][s] = vec_pair(WC_W(e, s) * WC_DP(e, s), WC_DW(e, s));
#endif
    vec Sum = {0};
    for (int e = 0; e < D; e++) E[e] = (vec){0};
#if D == 2
    for (int s0 = 0; s0 < S; s0++) {
        const vec *row = cache + (WC_LB(0) + s0) * SM_CACHE_SIDE + WC_LB(1);
        vec t = {0}, ty = {0};
        for (int s1 = 0; s1 < S; s1++) {
            const vec N = row[s1];
            t += WC_W(1, s1) * N;
            ty += K[1][s1] * N;
        }
        Sum += WC_W(0, s0) * t;
        E[0] += K[0][s0] * t;
        E[1] += WC_W(0, s0) * ty;
    }
#else
    /* Separable: per row (s0, s1) of nodes, a = sum_s2 w2 N and c = sum_s2 K2 N; then per plane s0
     * t = sum_s1 w1 a, ty = sum_s1 K1 a, tz = sum_s1 w1 c. Three products per node, as when every
     * node was weighted by w1 w2, K1 w2 and w1 K2 formed in advance, but without forming those
     * 18 vectors and 9 products per particle (they did not fit the registers): 3D float G2P 1.6e7
     * -> 1.82e7 particles/s on one thread, 3.2e7 -> 3.64e7 on two at 1e6 (docs/benchmarks.md,
     * "... 3D G2P by rows ..."). It changed the rounding of the 3D sums (beb7114). */
    for (int s0 = 0; s0 < S; s0++) {
        vec t = {0}, ty = {0}, tz = {0};
        for (int s1 = 0; s1 < S; s1++) {
            const vec *row = cache + ((WC_LB(0) + s0) * SM_CACHE_SIDE + WC_LB(1) + s1) * SM_CACHE_SIDE + WC_LB(2);
            vec a = {0}, cz = {0};
            for (int s2 = 0; s2 < S; s2++) {
                const vec N = row[s2];
                a += WC_W(2, s2) * N;
                cz += K[2][s2] * N;
            }
            t += WC_W(1, s1) * a;
            ty += K[1][s1] * a;
            tz += WC_W(1, s1) * cz;
        }
        Sum += WC_W(0, s0) * t;
        E[0] += K[0][s0] * t;
        E[1] += WC_W(0, s0) * ty;
        E[2] += WC_W(0, s0) * tz;
    }
#endif
    *Sum_out = Sum;
}

#if D == 2
/* Two particles at once (2D): lanes 0..3 of a cached node hold all that G2P reads (v-tilde part,
 * v-bar), so one vector holds particle j's node in lanes 0..3 and particle j + 1's in lanes 4..7,
 * and each operation of g2p_sums is done for both. Every lane goes through the same operations in
 * the same order as in g2p_sums, so the sums are the same bits. 2D float G2P, 200k particles on
 * one thread: 3.57-3.60e7 -> 3.89-3.96e7 particles/s (docs/benchmarks.md, "2D G2P, two particles
 * at a time"). The same in 3D with 16-lane (AVX-512) vectors, and pairs in P2G, did not pay. */
static inline __attribute__((always_inline)) vec pair_lo_hi(vec a, vec b) {
    return __builtin_shufflevector(a, b, 0, 1, 2, 3, 8, 9, 10, 11);
}

/* (a, a, a, a, b, b, b, b) */
static inline __attribute__((always_inline)) vec pair_bcast(sm_real a, sm_real b) {
    const vec va = {a, a, a, a, a, a, a, a}, vb = {b, b, b, b, b, b, b, b};
    return pair_lo_hi(va, vb);
}

/* Particle j + 1's lanes 4..7 moved to lanes 0..3 (the others 0). */
static inline __attribute__((always_inline)) vec pair_hi(vec p) {
    const vec z = {0};
    return __builtin_shufflevector(p, z, 4, 5, 6, 7, 8, 8, 8, 8);
}

/* Particle j's lanes 0..3 (the others 0). */
static inline __attribute__((always_inline)) vec pair_lo(vec p) {
    const vec z = {0};
    return __builtin_shufflevector(p, z, 0, 1, 2, 3, 8, 8, 8, 8);
}

/* g2p_sums for particles j and j + 1 of the chunk. */
static inline __attribute__((always_inline)) void g2p_sums_pair(int S, const wchunk *restrict wc, int j,
                                                               const vec *restrict cache, vec Sum_out[2],
                                                               vec E_out[2][D]) {
    const int j1 = j + 1;
    vec K[D][4], W1[4];
    for (int e = 0; e < D; e++)
        for (int s = 0; s < S; s++) {
            vec k = {0};
            for (int a = 0; a < D; a++) {
                k[a] = wc->w[e][s][j] * wc->dp[e][s][j];
                k[D + a] = wc->dw[e][s][j];
                k[4 + a] = wc->w[e][s][j1] * wc->dp[e][s][j1];
                k[4 + D + a] = wc->dw[e][s][j1];
            }
            K[e][s] = k;
        }
    for (int s = 0; s < S; s++) W1[s] = pair_bcast(wc->w[1][s][j], wc->w[1][s][j1]);
    vec Sum = {0}, E0 = {0}, E1 = {0};
    for (int s0 = 0; s0 < S; s0++) {
        const vec *rowa = cache + (wc->lb[0][j] + s0) * SM_CACHE_SIDE + wc->lb[1][j];
        const vec *rowb = cache + (wc->lb[0][j1] + s0) * SM_CACHE_SIDE + wc->lb[1][j1];
        vec t = {0}, ty = {0};
        for (int s1 = 0; s1 < S; s1++) {
            const vec N = pair_lo_hi(rowa[s1], rowb[s1]);
            t += W1[s1] * N;
            ty += K[1][s1] * N;
        }
        const vec W0 = pair_bcast(wc->w[0][s0][j], wc->w[0][s0][j1]);
        Sum += W0 * t;
        E0 += K[0][s0] * t;
        E1 += W0 * ty;
    }
    Sum_out[0] = pair_lo(Sum), Sum_out[1] = pair_hi(Sum);
    E_out[0][0] = pair_lo(E0), E_out[1][0] = pair_hi(E0);
    E_out[0][1] = pair_lo(E1), E_out[1][1] = pair_hi(E1);
}
#endif

/* The step's constants G2P's update reads per particle, copied once per block into locals: read
 * through c, they were loaded again after every store (sm_real and double stores may alias them). */
typedef struct g2p_consts {
    sm_real dt, flip_ratio;
    int transfer;
    double lo[D], hi[D]; /* the safety clamp's bounds, m */
} g2p_consts;

static inline g2p_consts g2p_consts_of(const sm_step_ctx *c) {
    g2p_consts k;
    k.dt = (sm_real)c->dt;
    k.flip_ratio = c->flip_ratio;
    k.transfer = c->transfer;
    for (int a = 0; a < D; a++) {
        k.lo[a] = c->pos_lo[a] + 2.0 * c->pos_dx;
        k.hi[a] = c->pos_lo[a] + (double)(c->cells[a] - 2) * c->pos_dx;
    }
    return k;
}

#if D == 3
/* A row of a 3 x 3 matrix in a vector (lane 3: 0). */
typedef sm_real row4 __attribute__((vector_size(4 * sizeof(sm_real))));
#endif

/* F^E-hat = (I + dt T) F^E (3.114), T = sum v-bar grad w^T (lanes d..2d-1 of E[k] hold column k
 * of T); returns 0 * every new entry, summed (NaN iff one is not finite). */
static inline __attribute__((always_inline)) sm_real g2p_update_F(sm_real *restrict F, sm_real dt, const vec E[D]) {
#if D == 3
    /* By rows: row a of F-hat = ((row a + dt T_a0 row 0) + dt T_a1 row 1) + dt T_a2 row 2, each
     * entry summed in the order of the scalar loop over k it replaces: the same bits. 3D G2P on
     * one thread, 200k particles: 1.52-1.53e7 -> 1.61-1.63e7 particles/s (with g2p_consts); on
     * two threads no change shows. In 2D the scalar loop measured faster (2.6e7 against 2.1e7). */
    row4 r[D], nz = {0};
    /* Rows built and stored lane by lane, not through memcpy: gcc put those through the stack,
     * where a vector load of a row after its scalar stores cannot be forwarded (perf: 6.4% of
     * G2P's samples on that load; gone after). 3D G2P on one thread, 200k particles, 8 pairs: a
     * change within the noise (1.39-1.75e7 against 1.45-1.75e7 particles/s). */
    for (int k = 0; k < D; k++) r[k] = (row4){F[k * D], F[k * D + 1], F[k * D + 2], 0};
    for (int a = 0; a < D; a++) {
        row4 s = r[a];
        for (int k = 0; k < D; k++) s += (dt * E[k][D + a]) * r[k];
        for (int e = 0; e < D; e++) F[a * D + e] = s[e];
        nz += 0 * s;
    }
    return (nz[0] + nz[1]) + (nz[2] + nz[3]);
#else
    sm_real Fo[DD], z = 0;
    memcpy(Fo, F, sizeof Fo);
    for (int a = 0; a < D; a++)
        for (int e = 0; e < D; e++) {
            sm_real s = Fo[a * D + e];
            for (int k = 0; k < D; k++) s += dt * E[k][D + a] * Fo[k * D + e];
            F[a * D + e] = s;
            z += 0 * s;
        }
    return z;
#endif
}

/* Particle p's new v, B, F^E-hat and x from its sums. */
static inline __attribute__((always_inline)) void g2p_update(const sm_g2p_io *io, const g2p_consts *k, size_t p,
                                                            vec Sum, const vec E[D], g2p_acc *acc) {
    const sm_real dt = k->dt;
    sm_real s2 = 0, z = 0;
    for (int a = 0; a < D; a++) {
        sm_real va = k->transfer == SM_TRANSFER_FLIP ? k->flip_ratio * io->v[p * D + a] + Sum[a] : Sum[a];
        io->v[p * D + a] = va;
        s2 += va * va;
        z += 0 * va;
    }
    acc->vmax2 = s2 > acc->vmax2 ? s2 : acc->vmax2;
    if (k->transfer == SM_TRANSFER_APIC)
        for (int a = 0; a < D; a++)
            for (int e = 0; e < D; e++) io->B[p * DD + a * D + e] = E[e][a];
    z += g2p_update_F(io->F + p * DD, dt, E);
    /* x = x + dt sum w v-bar (3.116), in double (particles.h); the safety clamp keeps every
     * stencil inside the grid. */
    for (int a = 0; a < D; a++) {
        double xa = io->x[p * D + a] + (double)(dt * Sum[D + a]);
        if (xa < k->lo[a]) {
            xa = k->lo[a];
            acc->clamped++;
        } else if (xa > k->hi[a]) {
            xa = k->hi[a];
            acc->clamped++;
        }
        z += 0 * (sm_real)xa;
        io->x[p * D + a] = xa;
        acc->lo[a] = xa < acc->lo[a] ? xa : acc->lo[a];
        acc->hi[a] = xa > acc->hi[a] ? xa : acc->hi[a];
    }
    acc->nan += z;
}

/* Safety net: a particle that ends a step inside a collider is put back on its surface along
 * the gradient (positions only). The grid-level constraints keep this rare and small; it is
 * counted in sm_diagnostics.projected_particles. Only colliders that may reach into the block's
 * bounding box (sm_collider_phi_box: exact for a half-space, the Lipschitz bound otherwise) are
 * evaluated per particle: a block resting on the ground is not. */
static size_t project_block(const sm_g2p_io *io, const sm_pblock *pb, const g2p_acc *acc) {
    double ctr[3] = {0, 0, 0}, half[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) ctr[a] = 0.5 * (acc->lo[a] + acc->hi[a]);
    const double slack = 1e-6 * (1.0 + fabs(ctr[0]) + fabs(ctr[1]) + fabs(ctr[2])); /* rounding of ctr, half */
    for (int a = 0; a < D; a++) half[a] = 0.5 * (acc->hi[a] - acc->lo[a]) + slack;
    size_t projected = 0;
    for (int b = 0; b < io->ncolliders; b++) {
        if (sm_collider_phi_box(&io->colliders[b], D, 1, ctr, half) > 0) continue;
        for (uint32_t idx = pb->start; idx < pb->end; idx++) {
            const size_t p = io->bins->perm[idx];
            double xp[3] = {0, 0, 0}, gr[3];
            for (int a = 0; a < D; a++) xp[a] = io->x[p * D + a];
            double phi = sm_collider_phi(&io->colliders[b], D, 1, xp, gr);
            if (phi < 0) {
                for (int a = 0; a < D; a++) io->x[p * D + a] = xp[a] - phi * gr[a];
                projected++;
            }
        }
    }
    return projected;
}

/* The particles of block pb, S nodes per axis. */
static inline __attribute__((always_inline)) void g2p_block(const sm_g2p_io *io, const sm_step_ctx *c, int S,
                                                           const sm_pblock *pb, const vec *restrict cache,
                                                           g2p_acc *acc) {
    const uint32_t *perm = io->bins->perm;
    int bc[3];
    pblock_origin(pb, bc);
    wchunk wc;
    const g2p_consts k = g2p_consts_of(c);
    for (uint32_t idx = pb->start; idx < pb->end; idx++) {
        const int j = (int)((idx - pb->start) % WCH);
        if (j == 0) chunk_weights(S, io->x, io->n, 0, (int)pb->ascending, perm, idx, (int)(pb->end - idx), c, bc, &wc);
#if D == 2
        if (idx + 1 < pb->end) { /* j is even here: WCH is, and pairs start at even j */
            vec Sum2[2], E2[2][D];
            g2p_sums_pair(S, &wc, j, cache, Sum2, E2);
            g2p_update(io, &k, perm[idx], Sum2[0], E2[0], acc);
            g2p_update(io, &k, perm[idx + 1], Sum2[1], E2[1], acc);
            idx++;
            continue;
        }
#endif
        vec Sum, E[D];
        g2p_sums(S, &wc, j, cache, &Sum, E);
        g2p_update(io, &k, perm[idx], Sum, E, acc);
    }
}

typedef struct g2p_job {
    const sm_g2p_io *io;
    const sm_step_ctx *c;
    sm_team_claims blocks; /* the particle blocks (core/team.h: the threads meet where the work does) */
    atomic_ullong clamped, projected, bad;
    _Atomic double vmax2;
} g2p_job;

/* What a thread's blocks measured. */
typedef struct g2p_tally {
    unsigned long long clamped, projected, bad;
    double vmax2;
} g2p_tally;

/* Particle block pb: its particles' G2P, then the safety projection. */
static void g2p_pblock(const sm_g2p_io *io, const sm_step_ctx *c, const sm_pblock *pb, vec *restrict cache,
                       g2p_tally *tally) {
    g2p_gather(io, c, pb, cache);
    g2p_acc acc;
    for (int a = 0; a < D; a++) {
        acc.lo[a] = INFINITY;
        acc.hi[a] = -INFINITY;
    }
    acc.vmax2 = acc.nan = 0;
    acc.clamped = 0;
    if (c->stencil == 3) g2p_block(io, c, 3, pb, cache, &acc);
    else g2p_block(io, c, 4, pb, cache, &acc);
    tally->clamped += acc.clamped;
    if (acc.nan != 0 || acc.nan != acc.nan) tally->bad++;
    else if (io->particle_projection && io->ncolliders > 0) tally->projected += project_block(io, pb, &acc);
    if ((double)acc.vmax2 > tally->vmax2) tally->vmax2 = (double)acc.vmax2;
}

/* Thread t's particle blocks: claimed from its end of the list (sm_team_claim). */
static void g2p_share(void *arg, int t, int T) {
    g2p_job *job = arg;
    const sm_g2p_io *io = job->io;
    const sm_bins *bins = io->bins;
    vec *cache = (vec *)io->cache + (size_t)t * NCACHE;
    g2p_tally tally = {0, 0, 0, 0};
    sm_team_claimer claimer;
    sm_team_claimer_init(&claimer, &job->blocks, t, T);
    long lo, hi;
    while (sm_team_claim(&claimer, 1, &lo, &hi))
        for (long b = lo; b < hi; b++) {
            const sm_pblock *pb = &bins->pb[b];
            if (bins->perm[pb->start] < io->owned) g2p_pblock(io, job->c, pb, cache, &tally); /* else a ghost block */
        }
    atomic_fetch_add_explicit(&job->clamped, tally.clamped, memory_order_relaxed);
    atomic_fetch_add_explicit(&job->projected, tally.projected, memory_order_relaxed);
    atomic_fetch_add_explicit(&job->bad, tally.bad, memory_order_relaxed);
    sm_team_max(&job->vmax2, tally.vmax2);
}

void SM_FN(sm_g2p)(const sm_g2p_io *io, const sm_step_ctx *c, sm_g2p_stats *st) {
    g2p_job job = {.io = io, .c = c};
    sm_team_claims_init(&job.blocks, (long)io->bins->npb);
    sm_team_run(c->threads, g2p_share, &job);
    st->clamped = atomic_load(&job.clamped);
    st->projected = atomic_load(&job.projected);
    st->vmax2 = atomic_load(&job.vmax2);
    st->bad = atomic_load(&job.bad) > 0;
}
