/* P2G (transfer.h), compiled for SM_DIM = 2 and 3.
 *
 * Thesis §3.3, §3.6.1:
 *   m_i = sum_p w_ip m_p                                                        (3.81)
 *   (mv)_i = sum_p w_ip m_p (v_p + C_p (x_i - x_p)),  C_p = B_p D^-1 (APIC)      (3.87)
 *            D = dx^2/4 (quadratic), dx^2/3 (cubic)                             (3.84)-(3.86)
 *   PIC / FLIP: C_p = 0                                                         (3.82)
 *   f_i = -sum_p V0_p P_p F_p^T grad w_ip = -sum_p V0_p tau_p grad w_ip          (3.91)
 * with tau the Kirchhoff stress the previous step's plasticity stored.
 *
 * Race-free and deterministic (bin.h): colours one after another, the blocks of a colour claimed
 * by the threads from the two ends of its list (core/team.h), the particles of a block in order,
 * each block accumulated into the thread's dense cache and then added into the grid.
 * A list of blocks (sm_p2g_io.lists) scatters only those, and a block may send some of its grid
 * blocks' sums to side arrays: a distributed step scatters its inner blocks while the exchange's
 * messages travel, then the others (dist/overlap.c says why every node still sums in colour
 * order).
 *
 * The contribution of particle p to cached node (s0, s1, s2) uses the separable weights:
 *   w0 w1 w2 A + w1 w2 (w0 dp0 Cx + dw0 Vx) + w0 w2 (w1 dp1 Cy + dw1 Vy) + w0 w1 (w2 dp2 Cz + dw2 Vz)
 * with lanes A = (m, m v, 0), C_e = (0, column e of m C, 0), V_e = (0, 0, column e of -V0 tau). */
#include "core/dim.h"

#include "core/team.h"
#include "transfer/stencil_dim.h"

/* Particle p's lane vectors A, C_e, V_e (see the top of the file). */
static inline __attribute__((always_inline)) void p2g_terms(const sm_p2g_io *io, size_t p, int apic, sm_real dinv,
                                                           vec *A, vec Ce[D], vec Ve[D]) {
    const sm_real mp = sm_particle_mass_of(io->mats, io->mat, io->vol0, p);
    const sm_real *vp = io->v + p * D;
    sm_real mC[DD], Vt[DD];
    const sm_real vf = io->with_force ? -io->vol0[p] : 0;
    const sm_real *tp = io->tau + p * SM_NSYM(D);
    for (int k = 0; k < DD; k++) mC[k] = apic ? mp * io->B[p * DD + k] * dinv : 0;
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
    *A = (vec){0};
    (*A)[0] = mp;
    for (int a = 0; a < D; a++) (*A)[1 + a] = mp * vp[a];
    for (int e = 0; e < D; e++) {
        Ce[e] = (vec){0};
        Ve[e] = (vec){0};
        for (int a = 0; a < D; a++) {
            Ce[e][1 + a] = mC[a * D + e];
            Ve[e][1 + D + a] = Vt[a * D + e];
        }
    }
}

/* Adds one particle's contributions to its S^d cached nodes. */
static inline __attribute__((always_inline)) void p2g_splat(int S, const wchunk *restrict wc, int j, vec A,
                                                           const vec Ce[D], const vec Ve[D], vec *restrict cache) {
    /* Per-axis parts: axis 0 carries A; axes 1.. carry only their C and V terms. */
    vec Px[4], Ry[4];
    for (int s = 0; s < S; s++) {
        Px[s] = WC_W(0, s) * A + (WC_W(0, s) * WC_DP(0, s)) * Ce[0] + WC_DW(0, s) * Ve[0];
        Ry[s] = (WC_W(1, s) * WC_DP(1, s)) * Ce[1] + WC_DW(1, s) * Ve[1];
    }
#if D == 2
    for (int s0 = 0; s0 < S; s0++) {
        vec *row = cache + (WC_LB(0) + s0) * SM_CACHE_SIDE + WC_LB(1);
        for (int s1 = 0; s1 < S; s1++) row[s1] += WC_W(1, s1) * Px[s0] + WC_W(0, s0) * Ry[s1];
    }
#else
    vec Rz[4], Y[4][4];
    sm_real W12[4][4];
    for (int s = 0; s < S; s++) Rz[s] = (WC_W(2, s) * WC_DP(2, s)) * Ce[2] + WC_DW(2, s) * Ve[2];
    for (int s1 = 0; s1 < S; s1++)
        for (int s2 = 0; s2 < S; s2++) {
            W12[s1][s2] = WC_W(1, s1) * WC_W(2, s2);
            Y[s1][s2] = WC_W(2, s2) * Ry[s1] + WC_W(1, s1) * Rz[s2];
        }
    for (int s0 = 0; s0 < S; s0++) {
        const sm_real w0 = WC_W(0, s0);
        for (int s1 = 0; s1 < S; s1++) {
            vec *row = cache + ((WC_LB(0) + s0) * SM_CACHE_SIDE + WC_LB(1) + s1) * SM_CACHE_SIDE + WC_LB(2);
            for (int s2 = 0; s2 < S; s2++) row[s2] += W12[s1][s2] * Px[s0] + w0 * Y[s1][s2];
        }
    }
#endif
}

/* Zeroes the cache's nodes that the block's particles can reach (CACHE_REACH_BEGIN). */
static inline __attribute__((always_inline)) void p2g_clear(int S, vec *restrict cache) {
    for (int cb = 0; cb < NGB; cb++) {
        CACHE_REACH_BEGIN(S, cb, l)
        cache[cache_index(cb, l)] = (vec){0};
        CACHE_REACH_END
    }
}

/* Adds the cache's reachable nodes into the particle block's 2^d grid blocks (or, where its `side`
 * bit says so, into the side arrays): lane 0 mass, lanes 1..d momentum, lanes d+1..2d force. */
static inline __attribute__((always_inline)) void p2g_flush(int S, const sm_pblock *pb, const vec *restrict cache,
                                                           const sm_grid_p2g *grid, const sm_grid_p2g *side) {
    for (int cb = 0; cb < NGB; cb++) {
        const uint32_t slot = pb->gslot[cb];
        if (slot == SM_NO_SLOT) continue;
        const sm_grid_p2g *g = (pb->side >> cb) & 1 ? side : grid;
        CACHE_REACH_BEGIN(S, cb, l)
        const vec q = cache[cache_index(cb, l)];
        const size_t ni = (size_t)slot * BN + (size_t)l;
        g->mass[ni] += q[0];
        for (int a = 0; a < D; a++) {
            g->momentum[ni * D + a] += q[1 + a];
            g->force[ni * D + a] += q[1 + D + a];
        }
        CACHE_REACH_END
    }
}

static inline __attribute__((always_inline)) void p2g_block(const sm_p2g_io *io, const sm_step_ctx *c, int S,
                                                           uint32_t b, vec *restrict cache) {
    const sm_bins *bins = io->bins;
    const sm_pblock *pb = &bins->pb[b];
    const int apic = (c->transfer == SM_TRANSFER_APIC);
    const sm_real dinv = (S == 3 ? SM_R(4.0) : SM_R(3.0)) * c->inv_dx * c->inv_dx;
    int bc[3];
    pblock_origin(pb, bc);
    p2g_clear(S, cache);
    wchunk wc;
    for (uint32_t idx = pb->start; idx < pb->end; idx++) {
        const size_t p = bins->perm[idx];
        const int j = (int)((idx - pb->start) % WCH);
        if (j == 0) chunk_weights(S, io->x, io->n, 1, (int)pb->ascending, bins->perm, idx, (int)(pb->end - idx), c, bc, &wc);
        vec A, Ce[D], Ve[D];
        p2g_terms(io, p, apic, dinv, &A, Ce, Ve);
        p2g_splat(S, &wc, j, A, Ce, Ve, cache);
    }
    p2g_flush(S, pb, cache, &io->grid, &io->side);
}

typedef struct p2g_job {
    const sm_p2g_io *io;
    const sm_step_ctx *c;
    const uint32_t *list, *offset; /* the blocks by colour */
    sm_team_claims colour[NCOLORS]; /* each colour's blocks (core/team.h: the threads meet where the work does) */
} p2g_job;

/* Thread t's blocks of each colour, the colours one after another. Within a colour no two blocks
 * reach a node, so which thread does a block changes no bit: the threads claim them from the two
 * ends of the colour's list (sm_team_claim). */
static void p2g_share(void *arg, int t, int T) {
    p2g_job *job = arg;
    const sm_p2g_io *io = job->io;
    const uint32_t *list = job->list, *offset = job->offset;
    vec *cache = (vec *)io->cache + (size_t)t * NCACHE;
    int last = -1; /* the last colour with blocks: the run's end is its barrier */
    for (int col = 0; col < NCOLORS; col++)
        if (offset[col] != offset[col + 1]) last = col;
    for (int col = 0; col <= last; col++) {
        if (offset[col] == offset[col + 1]) continue; /* the same on every thread: no barrier needed */
        sm_team_claimer claimer;
        sm_team_claimer_init(&claimer, &job->colour[col], t, T);
        long lo, hi;
        while (sm_team_claim(&claimer, 1, &lo, &hi)) {
            const uint32_t *blocks = list + offset[col];
            if (job->c->stencil == 3)
                for (long k = lo; k < hi; k++) p2g_block(io, job->c, 3, blocks[k], cache);
            else
                for (long k = lo; k < hi; k++) p2g_block(io, job->c, 4, blocks[k], cache);
        }
        if (col < last) sm_team_barrier();
    }
}

void SM_FN(sm_p2g)(const sm_p2g_io *io, const sm_step_ctx *c) {
    p2g_job job = {.io = io, .c = c};
    job.list = io->lists ? io->lists->blocks : io->bins->color_blocks;
    job.offset = io->lists ? io->lists->offset : io->bins->color_offset;
    for (int col = 0; col < NCOLORS; col++) sm_team_claims_init(&job.colour[col], (long)(job.offset[col + 1] - job.offset[col]));
    sm_team_run(c->threads, p2g_share, &job);
}
