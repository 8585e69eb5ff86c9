/* The contact gate (grid_collide.h, def.contact_gap), compiled for SM_DIM = 2 and 3.
 *
 * For node i and separating collider b:
 *   gate_i has bit(b)  <=>  some particle p with i in its stencil has phi_b^{n+1}(x_p + dt v_p) <= gap,
 * the particle's distance from the collider at the end of the step as it moves now. The stencil is
 * the kernel's (3.18)-(3.21): S = 3 (quadratic) or 4 (cubic) nodes per axis from the base node
 * (kernel.h), the same nodes P2G gives mass to, whatever their weight.
 *
 * A particle block b (grid/bin.h) holds the particles whose base node lies in grid block b: per
 * axis X in [4 b + 1/2, 4 b + 9/2) (quadratic) or [4 b + 1, 4 b + 5) (cubic) in cells, a box of
 * half-width 2 dx, and X + dt v in that box grown by dx. A block whose box lies farther than the
 * gap from collider b (sm_collider_phi_box, a lower bound) has no particle to open bit(b), and none
 * of its particles is looked at. A collider of one half-space has a linear phi: per particle it is
 * a dot product with the coefficients taken once per step (to rounding the same value). */
#include "core/dim.h"

#include <string.h>

#include "collide/grid_collide.h"
#include "core/team.h"
#include "transfer/stencil_dim.h"

/* The separating colliders of a step: whether each is a single half-space, and then phi(x) =
 * phi0 + grad . (x - origin) at pose 1. Colliders from GATE_CAP on are evaluated in full. */
enum { GATE_CAP = 32 };
typedef struct gate_cols {
    double origin[3];
    int linear[GATE_CAP];
    double phi0[GATE_CAP], grad[GATE_CAP][3];
} gate_cols;

static void gate_cols_init(const sm_contact_gate_io *io, const sm_step_ctx *c, gate_cols *g) {
    for (int a = 0; a < 3; a++) g->origin[a] = a < D ? c->pos_lo[a] : 0;
    for (int b = 0; b < io->colliders.count && b < GATE_CAP; b++) {
        const sm_collider *cb = &io->colliders.cols[b];
        g->linear[b] = cb->def.shape_count == 1 && cb->def.shapes[0].kind == SM_SHAPE_HALFSPACE && !cb->animated;
        g->phi0[b] = sm_collider_phi(cb, D, 1, g->origin, g->grad[b]);
    }
}

/* phi of collider b at pose 1 of x. */
static inline double gate_phi(const sm_contact_gate_io *io, const gate_cols *g, int b, const double x[3]) {
    if (b < GATE_CAP && g->linear[b]) {
        double s = g->phi0[b];
        for (int a = 0; a < D; a++) s += g->grad[b][a] * (x[a] - g->origin[a]);
        return s;
    }
    return sm_collider_phi(&io->colliders.cols[b], D, 1, x, NULL);
}

/* Bits of the separating colliders whose gap the box of particle block `pb` may reach. */
static unsigned block_reach(const sm_contact_gate_io *io, const sm_step_ctx *c, const sm_pblock *pb) {
    int bc[3];
    sm_block_coords(pb->key, bc);
    const double dx = c->pos_dx, off = c->stencil == 3 ? 2.5 : 3.0;
    double ctr[3] = {0, 0, 0}, half[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) {
        ctr[a] = c->pos_lo[a] + ((double)(bc[a] << SM_BLOCK_BITS) + off) * dx;
        half[a] = 3.0 * dx;
    }
    unsigned bits = 0;
    for (int b = 0; b < io->colliders.count; b++) {
        const sm_collider *cb = &io->colliders.cols[b];
        if (cb->def.mode != SM_COLLIDE_SEPARATE || (bits & sm_gate_bit(b))) continue;
        if (sm_collider_phi_box(cb, D, 1, ctr, half) <= io->gap) bits |= sm_gate_bit(b);
    }
    return bits;
}

/* Bits (among `reach`) of the colliders within the gap of particle q at the end of the step. */
static unsigned particle_bits(const sm_contact_gate_io *io, const sm_step_ctx *c, const gate_cols *g, size_t q,
                              unsigned reach) {
    double x1[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) x1[a] = io->x[q * D + a] + c->dt * (double)io->v[q * D + a];
    unsigned bits = 0;
    for (int b = 0; b < io->colliders.count; b++) {
        const unsigned bit = sm_gate_bit(b);
        if (!(reach & bit) || (bits & bit) || io->colliders.cols[b].def.mode != SM_COLLIDE_SEPARATE) continue;
        if (gate_phi(io, g, b, x1) <= io->gap) bits |= bit;
    }
    return bits;
}

/* Opens `bits` at node ni (an OR another thread may be doing too). */
static inline void open_node(uint8_t *gate, size_t ni, unsigned bits) {
    const unsigned have = __atomic_load_n(&gate[ni], __ATOMIC_RELAXED);
    if ((have & bits) != bits) __atomic_fetch_or(&gate[ni], (uint8_t)bits, __ATOMIC_RELAXED);
}

/* Opens `bits` at every node of particle q's stencil (q in particle block pb): the nodes P2G gives
 * its mass to (stencil_node). */
static void open_stencil(const sm_contact_gate_io *io, const sm_step_ctx *c, const sm_pblock *pb, size_t q,
                         unsigned bits) {
    const int S = c->stencil;
    int bc[3];
    pblock_origin(pb, bc);
    weights W; /* only the stencil's first node per axis is used */
    for (int a = 0; a < D; a++)
        W.lb[a] = sm_kernel_base(S, (io->x[q * D + a] - c->pos_lo[a]) * c->pos_inv_dx) - (bc[a] << SM_BLOCK_BITS);
    const int S2 = D == 3 ? S : 1;
    for (int s0 = 0; s0 < S; s0++)
        for (int s1 = 0; s1 < S; s1++)
            for (int s2 = 0; s2 < S2; s2++) {
                const int s[3] = {s0, s1, s2};
                open_node(io->gate, stencil_node(pb, &W, s), bits);
            }
}

typedef struct gate_job {
    const sm_contact_gate_io *io;
    const sm_step_ctx *c;
    gate_cols g;
    atomic_long next; /* the next particle block not taken (chunks of 16: blocks differ in cost) */
} gate_job;

static void gate_share(void *arg, int t, int T) {
    gate_job *job = arg;
    const sm_contact_gate_io *io = job->io;
    const sm_step_ctx *c = job->c;
    const sm_bins *bins = io->bins;
    const long npb = (long)bins->npb;
    long lo, hi;
    sm_team_split((long)io->grid->nactive, T, t, &lo, &hi);
    memset(io->gate + (size_t)lo * BN, 0, (size_t)(hi - lo) * BN);
    sm_team_barrier();
    for (;;) {
        const long k0 = atomic_fetch_add_explicit(&job->next, 16, memory_order_relaxed);
        if (k0 >= npb) break;
        for (long k = k0; k < k0 + 16 && k < npb; k++) {
            const sm_pblock *pb = &bins->pb[k];
            const unsigned reach = block_reach(io, c, pb);
            if (!reach) continue;
            for (uint32_t i = pb->start; i < pb->end; i++) {
                const size_t q = bins->perm[i];
                const unsigned bits = particle_bits(io, c, &job->g, q, reach);
                if (bits) open_stencil(io, c, pb, q, bits);
            }
        }
    }
}

void SM_FN(sm_contact_gate)(const sm_contact_gate_io *io, const sm_step_ctx *c) {
    gate_job job = {.io = io, .c = c};
    gate_cols_init(io, c, &job.g);
    atomic_init(&job.next, 0);
    sm_team_run(c->threads, gate_share, &job);
}
