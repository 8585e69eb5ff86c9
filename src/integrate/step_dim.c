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
 * Race-free scatter (DESIGN §4): particles are binned by the 4^d grid block holding their stencil's
 * first node; a block's particles write nodes [4b, 4b+6] per axis only, so blocks of the same colour
 * (block coordinates equal mod 2) never share a node. Colours run one after another, blocks of a
 * colour in parallel, particles of a block in index order: every node sums its contributions in
 * the same order for any thread count, so results are bitwise identical. */
#include <string.h>

#include "material/material.h"
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
#else
#define SM_FN(name) name##_3d
#define NCOLORS 8
#endif

/* Weights of one particle: per axis, S nodes starting at base. */
typedef struct weights {
    int base[D];
    sm_real w[D][4];
    sm_real dw[D][4]; /* derivative w.r.t. position (already times 1/dx) */
    sm_real dp[D][4]; /* x_i - x_p per axis, m */
    size_t off[D][4]; /* per-axis part of the node index: index = off[0][s0] + off[1][s1] (+ off[2][s2]) */
} weights;

/* The block-major node index separates into a sum of per-axis terms (see grid.h):
 * ((bi B1 + bj) B2 + bk) N + local, local = li 16 + lj 4 + lk (3D) or li 4 + lj (2D). */
static inline __attribute__((always_inline)) void kernel_weights(int S, const sm_real *xp, const sm_step_ctx *c,
                                                                 const sm_grid *g, weights *W) {
#if D == 2
    const size_t stride[2] = {(size_t)g->blocks[1] * 16, 16};
    const unsigned lmul[2] = {4, 1};
#else
    const size_t stride[3] = {(size_t)g->blocks[1] * (size_t)g->blocks[2] * 64, (size_t)g->blocks[2] * 64, 64};
    const unsigned lmul[3] = {16, 4, 1};
#endif
    for (int a = 0; a < D; a++) {
        sm_real X = (xp[a] - c->lo[a]) * c->inv_dx;
        int b = sm_kernel_1d(S, X, W->w[a], W->dw[a]);
        W->base[a] = b;
        for (int k = 0; k < 4; k++) {
            int node = b + k;
            W->dw[a][k] *= c->inv_dx;
            W->dp[a][k] = ((sm_real)node - X) * c->dx;
            W->off[a][k] = (size_t)(node >> SM_BLOCK_BITS) * stride[a] + (size_t)(node & SM_BLOCK_MASK) * lmul[a];
        }
    }
}

static inline int stencil_size(const sm_world *w) { return w->def.kernel == SM_KERNEL_CUBIC ? 4 : 3; }

/* Iterate over the stencil: defines node index `ni`, weight `wgt`, gradient `gw[D]` and offset
 * `dpos[D]` = x_i - x_p (m). */
#if D == 2
#define STENCIL_BEGIN(S, W, g, c)                                                              \
    for (int s0 = 0; s0 < (S); s0++)                                                           \
        for (int s1 = 0; s1 < (S); s1++) {                                                     \
            size_t ni = (W).off[0][s0] + (W).off[1][s1];                                       \
            sm_real wgt = (W).w[0][s0] * (W).w[1][s1];                                         \
            sm_real gw[2] = {(W).dw[0][s0] * (W).w[1][s1], (W).w[0][s0] * (W).dw[1][s1]};      \
            sm_real dpos[2] = {(W).dp[0][s0], (W).dp[1][s1]};
#define STENCIL_END }
#else
#define STENCIL_BEGIN(S, W, g, c)                                                              \
    for (int s0 = 0; s0 < (S); s0++)                                                           \
        for (int s1 = 0; s1 < (S); s1++)                                                       \
            for (int s2 = 0; s2 < (S); s2++) {                                                 \
                size_t ni = (W).off[0][s0] + (W).off[1][s1] + (W).off[2][s2];                  \
                sm_real wyz = (W).w[1][s1] * (W).w[2][s2];                                     \
                sm_real wgt = (W).w[0][s0] * wyz;                                              \
                sm_real gw[3] = {(W).dw[0][s0] * wyz, (W).w[0][s0] * (W).dw[1][s1] * (W).w[2][s2], \
                                 (W).w[0][s0] * (W).w[1][s1] * (W).dw[2][s2]};                 \
                sm_real dpos[3] = {(W).dp[0][s0], (W).dp[1][s1], (W).dp[2][s2]};
#define STENCIL_END }
#endif

/* ------------------------------------------------------------------------------------------ */
/* Binning                                                                                      */

static inline uint32_t particle_block(const sm_world *w, const sm_step_ctx *c, const sm_real *xp, int S) {
    int bb[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) bb[a] = sm_kernel_base(S, (xp[a] - c->lo[a]) * c->inv_dx) >> SM_BLOCK_BITS;
    return (uint32_t)sm_grid_block_id(&w->grid, bb[0], bb[1], bb[2]);
}

static void SM_FN(sort)(sm_world *w, const sm_step_ctx *c) {
    sm_grid *g = &w->grid;
    const size_t n = w->p.n;
    const int S = stencil_size(w);
    const long nl = (long)n;
    const sm_real *x = w->p.x;
    uint32_t *keys = w->keys;
#pragma omp parallel for schedule(static) num_threads(c->threads)
    for (long p = 0; p < nl; p++) keys[p] = particle_block(w, c, x + (size_t)p * D, S);

    /* Stable counting sort by block id. */
    uint32_t *start = w->block_start;
    memset(start, 0, (g->nblocks + 1) * sizeof(uint32_t));
    for (size_t p = 0; p < n; p++) start[keys[p] + 1]++;
    for (size_t b = 0; b < g->nblocks; b++) start[b + 1] += start[b];
    /* Fill using a running cursor per block; reuse color_blocks as scratch is not possible (size),
     * so walk with a temporary copy held in the perm's tail: instead do two passes over blocks. */
    for (size_t p = 0; p < n; p++) {
        uint32_t k = keys[p];
        w->perm[start[k]++] = (uint32_t)p;
    }
    /* start[k] now points at the end of block k; shift back to block starts. */
    for (size_t b = g->nblocks; b > 0; b--) start[b] = start[b - 1];
    start[0] = 0;

    /* Colour lists of non-empty particle blocks, and the active grid blocks around them. */
    sm_grid_clear_active(g);
    memset(w->color_count, 0, sizeof w->color_count);
    for (size_t b = 0; b < g->nblocks; b++) {
        if (start[b + 1] == start[b]) continue;
        int bk = (int)(b % (size_t)g->blocks[2]);
        size_t r = b / (size_t)g->blocks[2];
        int bj = (int)(r % (size_t)g->blocks[1]);
        int bi = (int)(r / (size_t)g->blocks[1]);
        int color = (bi & 1) | ((bj & 1) << 1) | ((D == 3 ? (bk & 1) : 0) << 2);
        w->color_count[color]++;
        for (int di = 0; di < 2; di++)
            for (int dj = 0; dj < 2; dj++)
                for (int dk = 0; dk < (D == 3 ? 2 : 1); dk++) {
                    int ii = bi + di, jj = bj + dj, kk = bk + dk;
                    if (ii < g->blocks[0] && jj < g->blocks[1] && kk < g->blocks[2])
                        g->active[sm_grid_block_id(g, ii, jj, kk)] = 1;
                }
    }
    w->color_offset[0] = 0;
    for (int col = 0; col < 8; col++) w->color_offset[col + 1] = w->color_offset[col] + w->color_count[col];
    uint32_t cursor[8];
    for (int col = 0; col < 8; col++) cursor[col] = w->color_offset[col];
    for (size_t b = 0; b < g->nblocks; b++) {
        if (start[b + 1] == start[b]) continue;
        int bk = (int)(b % (size_t)g->blocks[2]);
        size_t r = b / (size_t)g->blocks[2];
        int bj = (int)(r % (size_t)g->blocks[1]);
        int bi = (int)(r / (size_t)g->blocks[1]);
        int color = (bi & 1) | ((bj & 1) << 1) | ((D == 3 ? (bk & 1) : 0) << 2);
        w->color_blocks[cursor[color]++] = (uint32_t)b;
    }
    sm_grid_prepare_active(g, c->threads);
}

/* ------------------------------------------------------------------------------------------ */
/* P2G                                                                                          */

static inline __attribute__((always_inline)) void p2g_block(sm_world *w, const sm_step_ctx *c, int S,
                                                           int with_force, uint32_t b) {
    sm_grid *g = &w->grid;
    const sm_particles *P = &w->p;
    const int apic = (w->def.transfer == SM_TRANSFER_APIC);
    const sm_real dinv = (S == 3 ? SM_R(4.0) : SM_R(3.0)) * c->inv_dx * c->inv_dx;
    for (uint32_t idx = w->block_start[b]; idx < w->block_start[b + 1]; idx++) {
        const size_t p = w->perm[idx];
        weights W;
        kernel_weights(S, P->x + p * D, c, g, &W);
        const sm_real mp = P->mass[p];
        sm_real mv[D], mC[DD], Vt[DD];
        for (int a = 0; a < D; a++) mv[a] = mp * P->v[p * D + a];
        for (int k = 0; k < DD; k++) {
            mC[k] = apic ? mp * P->B[p * DD + k] * dinv : 0;
            Vt[k] = with_force ? -P->vol0[p] * P->tau[p * DD + k] : 0;
        }
        STENCIL_BEGIN(S, W, g, c)
        g->m[ni] += wgt * mp;
        for (int a = 0; a < D; a++) {
            sm_real aff = 0, fa = 0;
            for (int e = 0; e < D; e++) {
                aff += mC[a * D + e] * dpos[e];
                fa += Vt[a * D + e] * gw[e];
            }
            g->v[ni * D + a] += wgt * (mv[a] + aff);
            g->f[ni * D + a] += fa;
        }
        STENCIL_END
    }
}

static void SM_FN(p2g)(sm_world *w, const sm_step_ctx *c, int with_force) {
    const int S = stencil_size(w);
    for (int col = 0; col < NCOLORS; col++) {
        const long first = (long)w->color_offset[col], last = (long)w->color_offset[col + 1];
        if (S == 3) {
#pragma omp parallel for schedule(dynamic, 1) num_threads(c->threads)
            for (long t = first; t < last; t++) p2g_block(w, c, 3, with_force, w->color_blocks[t]);
        } else {
#pragma omp parallel for schedule(dynamic, 1) num_threads(c->threads)
            for (long t = first; t < last; t++) p2g_block(w, c, 4, with_force, w->color_blocks[t]);
        }
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Grid update, collisions, friction                                                            */

static void SM_FN(grid_update)(sm_world *w, const sm_step_ctx *c) {
    sm_grid *g = &w->grid;
    const long nb = (long)g->nactive;
    const size_t bn = (size_t)g->block_nodes;
    const double dt = c->dt;
    const sm_collider *cols = w->colliders;
    const int ncol = w->ncolliders + w->nwalls;
    const int static_sticks = w->def.static_friction_sticks;
#pragma omp parallel for schedule(static) num_threads(c->threads)
    for (long t = 0; t < nb; t++) {
        size_t b = g->active_list[t];
        for (size_t ni = b * bn; ni < (b + 1) * bn; ni++) {
            sm_real m = g->m[ni];
            if (!(m > 0)) {
                for (int a = 0; a < D; a++) g->v[ni * D + a] = g->f[ni * D + a] = g->vt[ni * D + a] = 0;
                continue;
            }
            sm_real inv_m = SM_R(1.0) / m;
            double vstar[3] = {0, 0, 0}, v[3] = {0, 0, 0}, xi[3] = {0, 0, 0};
            int ijk[3];
            sm_grid_node_coords(g, ni, ijk);
            for (int a = 0; a < D; a++) {
                sm_real vn = g->v[ni * D + a] * inv_m;
                g->v[ni * D + a] = vn;
                vstar[a] = (double)(vn + (sm_real)dt * (g->f[ni * D + a] * inv_m + c->gravity[a]));
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
    const size_t bn = (size_t)g->block_nodes;
    for (size_t t = 0; t < g->nactive; t++) {
        size_t b = g->active_list[t];
        for (size_t ni = b * bn; ni < (b + 1) * bn; ni++)
            for (int a = 0; a < D; a++)
                if (!isfinite(g->vt[ni * D + a]) || !isfinite(g->f[ni * D + a])) return (long)ni;
    }
    return -1;
}

/* ------------------------------------------------------------------------------------------ */
/* G2P                                                                                          */

static inline __attribute__((always_inline)) size_t g2p_one(sm_world *w, const sm_step_ctx *c, int S,
                                                           size_t p) {
    const sm_grid *g = &w->grid;
    sm_particles *P = &w->p;
    const int transfer = w->def.transfer;
    const sm_real dt = (sm_real)c->dt;
    weights W;
    kernel_weights(S, P->x + p * D, c, g, &W);
    sm_real vpic[D] = {0}, vflip[D] = {0}, vbar[D] = {0}, Bn[DD] = {0}, T[DD] = {0};
    STENCIL_BEGIN(S, W, g, c)
    for (int a = 0; a < D; a++) {
        sm_real vt = g->vt[ni * D + a], vb = g->f[ni * D + a];
        vpic[a] += wgt * vt;
        vbar[a] += wgt * vb;
        if (transfer == SM_TRANSFER_FLIP) vflip[a] += wgt * (vt - g->v[ni * D + a]);
        for (int e = 0; e < D; e++) {
            Bn[a * D + e] += wgt * vt * dpos[e];
            T[a * D + e] += vb * gw[e];
        }
    }
    STENCIL_END
    if (transfer == SM_TRANSFER_FLIP) {
        sm_real r = (sm_real)w->def.flip_ratio;
        for (int a = 0; a < D; a++) P->v[p * D + a] = r * (P->v[p * D + a] + vflip[a]) + (1 - r) * vpic[a];
    } else {
        for (int a = 0; a < D; a++) P->v[p * D + a] = vpic[a];
    }
    if (transfer == SM_TRANSFER_APIC)
        for (int k = 0; k < DD; k++) P->B[p * DD + k] = Bn[k];
    /* F^E-hat = (I + dt T) F^E (3.114). */
    sm_real Fo[DD], *F = P->F + p * DD;
    memcpy(Fo, F, sizeof Fo);
    for (int a = 0; a < D; a++)
        for (int e = 0; e < D; e++) {
            sm_real s = Fo[a * D + e];
            for (int k = 0; k < D; k++) s += dt * T[a * D + k] * Fo[k * D + e];
            F[a * D + e] = s;
        }
    /* x = x + dt sum w v-bar (3.116); the safety clamp keeps every stencil inside the grid. */
    size_t clamped = 0;
    for (int a = 0; a < D; a++) {
        sm_real xa = P->x[p * D + a] + dt * vbar[a];
        sm_real lo = c->lo[a] + SM_R(2.0) * c->dx;
        sm_real hi = c->lo[a] + (sm_real)(w->cells[a] - 2) * c->dx;
        if (xa < lo) {
            xa = lo;
            clamped = 1;
        } else if (xa > hi) {
            xa = hi;
            clamped = 1;
        }
        P->x[p * D + a] = xa;
    }
    /* Safety net: a particle that ends a step inside a collider is put back on its surface along
     * the gradient (positions only). The grid-level constraints above keep this rare and small;
     * it is counted in sm_diagnostics.projected_particles. */
    if (w->def.particle_projection) {
        for (int b = 0; b < w->ncolliders; b++) {
            double xp[3] = {0, 0, 0}, gr[3];
            for (int a = 0; a < D; a++) xp[a] = (double)P->x[p * D + a];
            double phi = sm_collider_phi(&w->colliders[b], D, 1, xp, gr);
            if (phi < 0) {
                for (int a = 0; a < D; a++) P->x[p * D + a] = (sm_real)(xp[a] - phi * gr[a]);
                clamped |= 2;
            }
        }
    }
    return clamped;
}

static void SM_FN(g2p)(sm_world *w, const sm_step_ctx *c) {
    const int S = stencil_size(w);
    const long n = (long)w->p.n;
    unsigned long long clamped = 0, projected = 0;
    if (S == 3) {
#pragma omp parallel for schedule(static) reduction(+ : clamped, projected) num_threads(c->threads)
        for (long i = 0; i < n; i++) {
            size_t r = g2p_one(w, c, 3, w->perm[i]);
            clamped += r & 1;
            projected += r >> 1;
        }
    } else {
#pragma omp parallel for schedule(static) reduction(+ : clamped, projected) num_threads(c->threads)
        for (long i = 0; i < n; i++) {
            size_t r = g2p_one(w, c, 4, w->perm[i]);
            clamped += r & 1;
            projected += r >> 1;
        }
    }
    w->clamped += clamped;
    w->projected += projected;
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

static void SM_FN(plasticity)(sm_world *w, const sm_step_ctx *c, size_t first) {
    sm_particles *P = &w->p;
    const long n = (long)P->n;
    const sm_material_rt *mats = w->mats;
    (void)c;
    int nt = c ? c->threads : 1;
#pragma omp parallel for schedule(static) num_threads(nt)
    for (long i = (long)first; i < n; i++) {
        size_t p = (size_t)i;
        const sm_material_rt *m = &mats[P->mat[p]];
        sm_real *F = P->F + p * DD;
        sm_real U[DD], V[DD], s[D], tau[D];
        svd_d(F, U, s, V);
        if (m->plastic) {
            sm_real dq = 0;
            int kase = sm_dp_project(D, s, P->alpha[p], m->mu, m->lambda, s, &dq);
            if (kase != 1) {
                for (int a = 0; a < D; a++)
                    for (int e = 0; e < D; e++) {
                        sm_real acc = 0;
                        for (int k = 0; k < D; k++) acc += U[a * D + k] * s[k] * V[e * D + k];
                        F[a * D + e] = acc;
                    }
                if (m->hardening && dq > 0) {
                    P->q[p] += dq;
                    double phi = sm_hardening_phi((double)P->q[p], m->h0, m->h1, m->h2, m->h3);
                    P->alpha[p] = (sm_real)sm_dp_alpha(phi);
                }
            }
        }
        sm_hencky_tau(D, s, m->mu, m->lambda, tau);
        sm_real *T = P->tau + p * DD;
        for (int a = 0; a < D; a++)
            for (int e = 0; e < D; e++) {
                sm_real acc = 0;
                for (int k = 0; k < D; k++) acc += U[a * D + k] * tau[k] * U[e * D + k];
                T[a * D + e] = acc;
            }
    }
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
        size_t b = g->active_list[t];
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

const sm_dim_ops SM_FN(sm_dim_ops) = {
    .dim = D,
    .sort = SM_FN(sort),
    .p2g = SM_FN(p2g),
    .grid_update = SM_FN(grid_update),
    .grid_check = SM_FN(grid_check),
    .g2p = SM_FN(g2p),
    .plasticity = SM_FN(plasticity),
    .elastic_energy = SM_FN(elastic_energy),
    .grid_totals = SM_FN(grid_totals),
};
