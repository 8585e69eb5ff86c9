/* The contact gate (grid_collide.h, def.contact_gap), compiled for SM_DIM = 2 and 3.
 *
 * For node i and separating collider b:
 *   gate_i has bit(b)  <=>  some particle p with i in its stencil has
 *                           min(phi_b^n(x_p), phi_b^{n+1}(x_p + dt v_p)) <= gap.
 * The stencil is the kernel's (3.18)-(3.21): S = 3 (quadratic) or 4 (cubic) nodes per axis from
 * the base node (kernel.h), the same nodes P2G gives mass to, whatever their weight.
 *
 * A particle block b (grid/bin.h) holds the particles whose base node lies in grid block b: per
 * axis X in [4 b + 1/2, 4 b + 9/2) (quadratic) or [4 b + 1, 4 b + 5) (cubic) in cells, a box of
 * half-width 2 dx, and X + dt v in that box grown by dx. A block whose boxes lie farther than the
 * gap from collider b (sm_collider_phi_box, a lower bound) has no particle to open bit(b), and
 * none of its particles is looked at. */
#include "core/dim.h"

#include <math.h>
#include <string.h>

#include "collide/grid_collide.h"
#include "transfer/kernel.h"

/* Bits of the separating colliders whose gap the boxes of particle block `pb` may reach. */
static unsigned block_reach(const sm_contact_gate_io *io, const sm_step_ctx *c, const sm_pblock *pb) {
    int bc[3];
    sm_block_coords(pb->key, bc);
    const double dx = c->pos_dx, off = c->stencil == 3 ? 2.5 : 3.0;
    double ctr[3] = {0, 0, 0}, h0[3] = {0, 0, 0}, h1[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) {
        ctr[a] = c->pos_lo[a] + ((double)(bc[a] << SM_BLOCK_BITS) + off) * dx;
        h0[a] = 2.0 * dx;
        h1[a] = 3.0 * dx;
    }
    unsigned bits = 0;
    for (int b = 0; b < io->colliders.count; b++) {
        const sm_collider *cb = &io->colliders.cols[b];
        if (cb->def.mode != SM_COLLIDE_SEPARATE || (bits & sm_gate_bit(b))) continue;
        if (sm_collider_phi_box(cb, D, 0, ctr, h0) <= io->gap || sm_collider_phi_box(cb, D, 1, ctr, h1) <= io->gap)
            bits |= sm_gate_bit(b);
    }
    return bits;
}

/* Bits (among `reach`) of the colliders within the gap of particle q, now or as it moves. */
static unsigned particle_bits(const sm_contact_gate_io *io, const sm_step_ctx *c, size_t q, unsigned reach) {
    double x0[3] = {0, 0, 0}, x1[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) {
        x0[a] = io->x[q * D + a];
        x1[a] = x0[a] + c->dt * (double)io->v[q * D + a];
    }
    unsigned bits = 0;
    for (int b = 0; b < io->colliders.count; b++) {
        const unsigned bit = sm_gate_bit(b);
        if (!(reach & bit) || (bits & bit) || io->colliders.cols[b].def.mode != SM_COLLIDE_SEPARATE) continue;
        const sm_collider *cb = &io->colliders.cols[b];
        if (sm_collider_phi(cb, D, 0, x0, NULL) <= io->gap || sm_collider_phi(cb, D, 1, x1, NULL) <= io->gap)
            bits |= bit;
    }
    return bits;
}

/* Opens `bits` at node ni (an OR another thread may be doing too). */
static inline void open_node(uint8_t *gate, size_t ni, unsigned bits) {
    const unsigned have = __atomic_load_n(&gate[ni], __ATOMIC_RELAXED);
    if ((have & bits) != bits) __atomic_fetch_or(&gate[ni], (uint8_t)bits, __ATOMIC_RELAXED);
}

/* Opens `bits` at every node of particle q's stencil (q in particle block pb). */
static void open_stencil(const sm_contact_gate_io *io, const sm_step_ctx *c, const sm_pblock *pb, size_t q,
                         unsigned bits) {
    const int S = c->stencil;
    int bc[3], lb[3] = {0, 0, 0};
    sm_block_coords(pb->key, bc);
    for (int a = 0; a < D; a++)
        lb[a] = sm_kernel_base(S, (io->x[q * D + a] - c->pos_lo[a]) * c->pos_inv_dx) - (bc[a] << SM_BLOCK_BITS);
    const int S2 = D == 3 ? S : 1;
    for (int s0 = 0; s0 < S; s0++)
        for (int s1 = 0; s1 < S; s1++)
            for (int s2 = 0; s2 < S2; s2++) {
                const int s[3] = {s0, s1, s2};
                unsigned cb = 0, local = 0;
                for (int a = 0; a < D; a++) {
                    const int node = lb[a] + s[a];
                    cb = (cb << 1) | (unsigned)(node >> SM_BLOCK_BITS);
                    local = (local << SM_BLOCK_BITS) | (unsigned)(node & SM_BLOCK_MASK);
                }
                if (pb->gslot[cb] != SM_NO_SLOT) open_node(io->gate, (size_t)pb->gslot[cb] * BN + local, bits);
            }
}

void SM_FN(sm_contact_gate)(const sm_contact_gate_io *io, const sm_step_ctx *c) {
    const sm_bins *bins = io->bins;
    const long nb = (long)io->grid->nactive, npb = (long)bins->npb;
    (void)nb;
#pragma omp parallel num_threads(c->threads)
    {
#pragma omp for schedule(static)
        for (long s = 0; s < nb; s++) memset(io->gate + (size_t)s * BN, 0, BN);
#pragma omp for schedule(dynamic, 16)
        for (long k = 0; k < npb; k++) {
            const sm_pblock *pb = &bins->pb[k];
            const unsigned reach = block_reach(io, c, pb);
            if (!reach) continue;
            for (uint32_t i = pb->start; i < pb->end; i++) {
                const size_t q = bins->perm[i];
                const unsigned bits = particle_bits(io, c, q, reach);
                if (bits) open_stencil(io, c, pb, q, bits);
            }
        }
    }
}
