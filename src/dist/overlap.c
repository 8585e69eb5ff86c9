/* The exchange overlapped with interior work (dist.h), for an explicit step. In the order the
 * step calls it (integrate/step.c, exchange_bin_p2g):
 *
 *   sm_dist_exchange_begin   route the particles, post the messages (exchange.c); the storage
 *                            holds the particles this rank kept
 *   bin them                 the step's binning with P->n = kept (grid/bin_dim.c)
 *   sm_dist_inner_blocks     mark the inner blocks E; the step scatters them (P2G) colour by
 *                            colour, sm_dist_progress between colours
 *   sm_dist_exchange_finish  wait for the messages, append the arrivals and the ghosts
 *   sm_bin_more              bin those as a second batch (grid/bin.h)
 *   sm_dist_outer_blocks     check, then the other blocks, which the step scatters
 *
 * Why every node still sums as on one rank. P2G adds a block's contribution (its particles in
 * ascending id: a function of the block's particles alone) to the nodes of grid blocks
 * b + {0,1}^d; a node gets one block of each colour, in colour order. Scattering E first and the
 * other blocks after keeps that order at every node if
 *   (a) no arrival joins a block of E (its particles are all here before the messages), and
 *   (b) every block of lower colour that shares a grid block with a block b of E (the blocks
 *       b + e, e in {-1,0,1}^d) is in E too, or holds no particle once the arrivals are in:
 *       then at every node E's contributions are the first ones of its colour order.
 * A block is a candidate when every block within two of it (b + {-2..2}^d, in the domain) is
 * this rank's. Without a re-cut this step (exchange.c turns the overlap off after one), an
 * arrival is a particle that started the last step in another rank's block: to reach a
 * candidate or a neighbour of one, whose neighbours are all this rank's, it would have crossed a
 * whole block (4 cells) in one step, which the CFL bound forbids. Ghosts lie in other ranks'
 * blocks, never within two blocks of a candidate. E is then, colour after colour, the candidates
 * whose lower-colour neighbours are in E or empty after the kept particles' binning. Once the
 * arrivals are binned, (a) and (b) are checked: an arrival within one block of a block of E (a
 * particle faster than a block per step, or test mode 2) makes this rank zero its grid and
 * scatter every block (sm_dist_stats.overlap_redone). Candidates are found by Morton codes: the
 * code grows with each block coordinate, so a box's codes lie between its corners' codes, and a
 * box whose corners are within this rank's range is this rank's (else each block is looked up). */
#include <string.h>

#include "dist/dist_internal.h"
#include "grid/grid.h"
#include "world/world.h"

/* This rank's range of Morton codes: [lo, hi) (the cuts ascend: dist.c). */
static void my_codes(const sm_dist *d, uint64_t *lo, uint64_t *hi) {
    *lo = d->cuts[d->rank];
    *hi = d->rank + 1 < d->size ? d->cuts[d->rank + 1] : UINT64_MAX;
    if (*hi < *lo) *hi = *lo; /* never (dist.c sorts the histogram it cuts), but then no candidates */
}

/* 1 if every block of b + {-2..2}^d inside the domain's blocks nb[] is this rank's. */
static int candidate(const sm_dist *d, const int b[3], const int nb[3]) {
    uint64_t lo, hi;
    my_codes(d, &lo, &hi);
    int b0[3] = {0, 0, 0}, b1[3] = {0, 0, 0};
    for (int a = 0; a < d->dim; a++) {
        b0[a] = b[a] - 2 > 0 ? b[a] - 2 : 0;
        b1[a] = b[a] + 2 < nb[a] - 1 ? b[a] + 2 : nb[a] - 1;
    }
    if (sm_dist_morton(d->dim, b0) >= lo && sm_dist_morton(d->dim, b1) < hi) return 1;
    int o[3] = {0, 0, 0};
    for (o[2] = b0[2]; o[2] <= b1[2]; o[2]++)
        for (o[1] = b0[1]; o[1] <= b1[1]; o[1]++)
            for (o[0] = b0[0]; o[0] <= b1[0]; o[0]++) {
                const uint64_t m = sm_dist_morton(d->dim, o);
                if (m < lo || m >= hi) return 0;
            }
    return 1;
}

static int colour_of(int dim, const int b[3]) {
    return (b[0] & 1) | ((b[1] & 1) << 1) | ((dim == 3 ? (b[2] & 1) : 0) << 2);
}

/* Calls visit(r) for each non-empty particle block b + e, e in {-1,0,1}^d, inside the domain
 * (including b itself), until visit returns 1; returns 1 if one did. */
typedef int (*visit_fn)(const sm_bins *bins, uint32_t r, int colour, int limit);
static int any_neighbour(const sm_bins *bins, int dim, const int b[3], const int nb[3], visit_fn visit, int limit) {
    const int m = dim == 3 ? 27 : 9;
    for (int k = 0; k < m; k++) {
        const int o[3] = {b[0] + k % 3 - 1, b[1] + (k / 3) % 3 - 1, dim == 3 ? b[2] + k / 9 - 1 : 0};
        if (o[0] < 0 || o[1] < 0 || o[2] < 0 || o[0] >= nb[0] || o[1] >= nb[1] || o[2] >= nb[2]) continue;
        const uint32_t r = sm_block_hash_find(&bins->pb_hash, sm_block_key(o[0], o[1], o[2]));
        if (r != SM_NO_SLOT && visit(bins, r, colour_of(dim, o), limit)) return 1;
    }
    return 0;
}

/* A lower-colour neighbour that is not inner (breaks condition (b) for a block of colour limit). */
static int lower_not_inner(const sm_bins *bins, uint32_t r, int colour, int limit) {
    return colour < limit && !bins->pb[r].early;
}

/* An inner block (an arrival next to it breaks condition (a) or (b)). */
static int inner(const sm_bins *bins, uint32_t r, int colour, int limit) {
    (void)colour;
    (void)limit;
    return bins->pb[r].early != 0;
}

static int reserve_lists(sm_dist *d, size_t n) {
    if (n <= d->lists_cap) return 1;
    uint32_t *q = sm_realloc(d->lists, n * sizeof *q);
    if (!q) return 0;
    d->lists = q;
    d->lists_cap = n;
    return 1;
}

const sm_block_lists *sm_dist_inner_blocks(sm_world *w) {
    sm_dist *d = w->dist;
    sm_bins *bins = &w->bins;
    for (size_t r = 0; r < bins->npb; r++) bins->pb[r].early = 0;
    if (!reserve_lists(d, bins->npb + 1)) return NULL; /* no overlap: slower, not wrong */
    const int ncol = 1 << d->dim;
    uint32_t k = 0;
    size_t early = 0;
    for (int col = 0; col < 8; col++) {
        d->inner.offset[col] = k;
        for (uint32_t i = col < ncol ? bins->color_offset[col] : 0; col < ncol && i < bins->color_offset[col + 1]; i++) {
            const uint32_t r = bins->color_blocks[i];
            int b[3];
            sm_block_coords(bins->pb[r].key, b);
            if (!candidate(d, b, w->grid.blocks) ||
                any_neighbour(bins, d->dim, b, w->grid.blocks, lower_not_inner, col))
                continue;
            bins->pb[r].early = 1;
            d->lists[k++] = r;
            early += bins->pb[r].end - bins->pb[r].start;
        }
    }
    d->inner.offset[8] = k;
    d->inner.blocks = d->lists;
    d->stats.early_particles = early;
    return k ? &d->inner : NULL;
}

/* 1 if an arrival (particles [kept, owned)) lies within one block of an inner block. */
static int arrival_next_to_inner(const sm_world *w, size_t kept) {
    const sm_dist *d = w->dist;
    for (size_t p = kept; p < d->owned; p++) {
        int b[3];
        sm_dist_particle_block(d, w->p.x + p * (size_t)d->dim, b);
        if (any_neighbour(&w->bins, d->dim, b, w->grid.blocks, inner, 0)) return 1;
    }
    return 0;
}

const sm_block_lists *sm_dist_outer_blocks(sm_world *w, size_t kept) {
    sm_dist *d = w->dist;
    sm_bins *bins = &w->bins;
    if (d->stats.early_particles == 0) return NULL;
    if (d->overlap == 2 || arrival_next_to_inner(w, kept) || !reserve_lists(d, bins->npb + 1)) {
        sm_grid_zero(&w->grid, w->threads > 0 ? w->threads : 1);
        for (size_t r = 0; r < bins->npb; r++) bins->pb[r].early = 0;
        d->stats.early_particles = 0;
        d->stats.overlap_redone++;
        return NULL;
    }
    const int ncol = 1 << d->dim;
    uint32_t k = 0;
    for (int col = 0; col < 8; col++) {
        d->outer.offset[col] = k;
        for (uint32_t i = col < ncol ? bins->color_offset[col] : 0; col < ncol && i < bins->color_offset[col + 1]; i++)
            if (!bins->pb[bins->color_blocks[i]].early) d->lists[k++] = bins->color_blocks[i];
    }
    d->outer.offset[8] = k;
    d->outer.blocks = d->lists;
    return &d->outer;
}

void sm_dist_set_overlap(sm_world *w, int mode) {
    if (w->dist) w->dist->overlap = mode;
}

sm_status sm_world_set_dist_overlap(sm_world *w, int on) {
    if (!w->dist) return sm_world_fail(w, SM_ERR_INVALID, "sm_world_set_dist_overlap: the world is not distributed");
    if (on != 0 && on != 1) return sm_world_fail(w, SM_ERR_INVALID, "sm_world_set_dist_overlap: on must be 0 or 1, got %d", on);
    w->dist->overlap = on;
    return SM_OK;
}
