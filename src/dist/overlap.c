/* The exchange overlapped with interior work (dist.h), for an explicit step. In the order the
 * step calls it (integrate/step.c, exchange):
 *
 *   sm_dist_exchange_begin   route the particles, post the messages (exchange.c); the storage
 *                            holds the particles this rank kept
 *   bin them                 the step's binning with P->n = kept (grid/bin_dim.c)
 *   sm_dist_inner_blocks     choose the inner blocks E; the step scatters them (P2G) colour by
 *                            colour, sm_dist_progress between colours
 *   sm_dist_exchange_finish  wait for the messages, append the arrivals and the ghosts
 *   sm_bin_more              bin those as a second batch (grid/bin.h)
 *   sm_dist_outer_blocks     check, then for each colour: sm_dist_replay, and the step scatters
 *                            the other blocks of that colour
 *
 * Why every node still sums as on one rank. P2G adds a block's contribution (its particles in
 * ascending id: a function of the block's particles alone) to the nodes of grid blocks
 * b + {0,1}^d; a grid block G gets one contribution from each of its contributors G - {0,1}^d,
 * one of each colour, in colour order. Scattering E first, in colour order, gives a grid block
 * whose every contributor with particles is in E its one-rank sums. A grid block that E touches
 * and that has a contributor with particles outside E ("mixed") must instead get its
 * contributions in colour order interleaved with the others': E's blocks write their part of it
 * to a side slot of its own (0 + x is x, so a side slot holds exactly that block's contribution),
 * and in the late pass, colour by colour, the side slots of that colour are added to the grid
 * (sm_dist_replay) next to the scatter of the other blocks of that colour (a grid block has one
 * contributor per colour: the two never write the same node). So every node sums in colour order.
 *
 * E must hold every particle of its blocks before the messages come, and a block outside E next
 * to a block of E must not gain particles (the mixed test above used the kept particles):
 * a block is a candidate for E when every block within two of it (b + {-2..2}^d, in the domain)
 * is this rank's. Without a re-cut this step (exchange.c turns the overlap off after one), an
 * arrival is a particle that started the last step in another rank's block: to reach a candidate
 * or a neighbour of one, whose neighbours are all this rank's, it would have crossed a whole block
 * (4 cells) in one step, which the CFL bound forbids. Ghosts lie in other ranks' blocks, never
 * within two blocks of a candidate. Once the arrivals are binned this is checked: an arrival
 * within one block of a block of E (a particle faster than a block per step, or test mode 2) makes
 * this rank zero its grid and scatter every block (sm_dist_stats.overlap_redone). Candidates are
 * found by Morton codes: the code grows with each block coordinate, so a box's codes lie between
 * its corners' codes, and a box whose corners are within this rank's range is this rank's (else
 * each block is looked up). */
#include <string.h>

#include "core/team.h"
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

static int in_domain(const int o[3], const int nb[3]) {
    return o[0] >= 0 && o[1] >= 0 && o[2] >= 0 && o[0] < nb[0] && o[1] < nb[1] && o[2] < nb[2];
}

/* The particle block at o (in the domain), or NULL when it holds no particle. */
static const sm_pblock *block_at(const sm_bins *bins, const int o[3]) {
    const uint32_t r = sm_block_hash_find(&bins->pb_hash, sm_block_key(o[0], o[1], o[2]));
    return r == SM_NO_SLOT ? NULL : &bins->pb[r];
}

/* Of the blocks b + e, e in {-1,0,1}^d, in the domain: 1 if one with particles is not in E
 * (want_early 0), or is in E (want_early 1). */
static int neighbour_with(const sm_bins *bins, int dim, const int b[3], const int nb[3], int want_early) {
    const int m = dim == 3 ? 27 : 9;
    for (int k = 0; k < m; k++) {
        const int o[3] = {b[0] + k % 3 - 1, b[1] + (k / 3) % 3 - 1, dim == 3 ? b[2] + k / 9 - 1 : 0};
        if (!in_domain(o, nb)) continue;
        const sm_pblock *pb = block_at(bins, o);
        if (pb && (pb->early != 0) == want_early) return 1;
    }
    return 0;
}

/* 1 if grid block g has a contributor (g - {0,1}^d) with particles outside E. */
static int mixed(const sm_bins *bins, int dim, const int g[3], const int nb[3]) {
    for (int c = 0; c < (1 << dim); c++) {
        int o[3] = {g[0], g[1], g[2]};
        for (int a = 0; a < dim; a++) o[a] -= (c >> a) & 1;
        if (!in_domain(o, nb)) continue;
        const sm_pblock *pb = block_at(bins, o);
        if (pb && !pb->early) return 1;
    }
    return 0;
}

static int reserve_lists(sm_dist *d, size_t n) {
    if (n <= d->lists_cap) return 1;
    uint32_t *q = sm_realloc(d->lists, n * sizeof *q);
    if (!q) return 0;
    d->lists = q;
    d->lists_cap = n;
    return 1;
}

/* Room for n side slots of block_nodes nodes each (1 + 2 d values per node), zeroed: masses,
 * then momenta, then forces (side_arrays), for d->nside = n slots. */
static int reserve_side(sm_dist *d, size_t n, size_t block_nodes) {
    const size_t per = block_nodes * (size_t)(1 + 2 * d->dim);
    if (n > d->side_cap) {
        sm_real *s = sm_realloc(d->side, n * per * sizeof *s);
        if (!s) return 0;
        d->side = s;
        uint64_t *k = sm_realloc(d->side_key, n * sizeof *k);
        if (!k) return 0;
        d->side_key = k;
        d->side_cap = n;
    }
    if (n) memset(d->side, 0, n * per * sizeof *d->side);
    return 1;
}

/* The side arrays of d's nside slots, for sm_p2g_io.side. */
static sm_grid_p2g side_arrays(const sm_dist *d, size_t block_nodes) {
    const size_t n = d->nside * block_nodes;
    const sm_grid_p2g s = {d->side, d->side + n, d->side + n * (size_t)(1 + d->dim)};
    return s;
}

/* The mixed grid blocks of E's blocks (the first nearly of d->lists) sent to side slots of their
 * own; returns 0 when out of memory. The slots are counted first, then assigned. */
static int divert_mixed(sm_world *w, size_t nearly) {
    sm_dist *d = w->dist;
    sm_bins *bins = &w->bins;
    const int dim = d->dim, ngb = 1 << dim;
    const size_t bn = (size_t)w->grid.block_nodes;
    for (int pass = 0; pass < 2; pass++) {
        size_t k = 0;
        for (size_t i = 0; i < nearly; i++) {
            sm_pblock *pb = &bins->pb[d->lists[i]];
            int b[3];
            sm_block_coords(pb->key, b);
            if (!neighbour_with(bins, dim, b, w->grid.blocks, 0)) continue; /* all inside E: nothing mixed */
            for (int cb = 0; cb < ngb; cb++) {
                if (pb->gslot[cb] == SM_NO_SLOT) continue;
                int g[3] = {b[0], b[1], b[2]};
                for (int a = 0; a < dim; a++) g[a] += (cb >> (dim - 1 - a)) & 1;
                if (!mixed(bins, dim, g, w->grid.blocks)) continue;
                if (pass == 1) {
                    d->side_key[k] = sm_block_key(g[0], g[1], g[2]) << 3 | (uint64_t)colour_of(dim, b);
                    pb->gslot[cb] = (uint32_t)k;
                    pb->side |= 1u << cb;
                }
                k++;
            }
        }
        if (pass == 0 && !reserve_side(d, k, bn)) return 0;
        d->nside = k; /* side_arrays's layout */
    }
    return 1;
}

const sm_block_lists *sm_dist_inner_blocks(sm_world *w, sm_grid_p2g *side) {
    sm_dist *d = w->dist;
    sm_bins *bins = &w->bins;
    for (size_t r = 0; r < bins->npb; r++) bins->pb[r].early = bins->pb[r].side = 0;
    d->nside = 0;
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
            if (!candidate(d, b, w->grid.blocks)) continue;
            bins->pb[r].early = 1;
            d->lists[k++] = r;
            early += bins->pb[r].end - bins->pb[r].start;
        }
    }
    d->inner.offset[8] = k;
    d->inner.blocks = d->lists;
    if (k == 0 || !divert_mixed(w, k)) {
        for (size_t r = 0; r < bins->npb; r++) bins->pb[r].early = bins->pb[r].side = 0;
        return NULL;
    }
    d->stats.early_particles = early;
    *side = side_arrays(d, (size_t)w->grid.block_nodes);
    return &d->inner;
}

/* 1 if an arrival (particles [kept, owned)) lies within one block of a block of E. */
static int arrival_next_to_inner(const sm_world *w, size_t kept) {
    const sm_dist *d = w->dist;
    for (size_t p = kept; p < d->owned; p++) {
        int b[3];
        sm_dist_particle_block(d, w->p.x + p * (size_t)d->dim, b);
        if (neighbour_with(&w->bins, d->dim, b, w->grid.blocks, 1)) return 1;
    }
    return 0;
}

const sm_block_lists *sm_dist_outer_blocks(sm_world *w, size_t kept) {
    sm_dist *d = w->dist;
    sm_bins *bins = &w->bins;
    if (d->stats.early_particles == 0) return NULL;
    for (size_t r = 0; r < bins->npb; r++) bins->pb[r].side = 0; /* sm_bin_more linked every slot to the grid */
    if (d->overlap == 2 || arrival_next_to_inner(w, kept) || !reserve_lists(d, bins->npb + 1)) {
        sm_grid_zero(&w->grid, w->threads > 0 ? w->threads : 1);
        for (size_t r = 0; r < bins->npb; r++) bins->pb[r].early = 0;
        d->nside = 0;
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

typedef struct replay_job {
    const sm_dist *d;
    const sm_grid *grid_of;
    sm_grid_p2g side, grid;
    size_t bn, dim;
    int colour;
} replay_job;

/* Side blocks [lo, hi) of the colour added into their grid blocks. */
static void replay_range(void *arg, long lo, long hi) {
    const replay_job *job = arg;
    const sm_dist *d = job->d;
    const size_t bn = job->bn, dim = job->dim;
    for (long s = lo; s < hi; s++) {
        if ((int)(d->side_key[s] & 7) != job->colour) continue;
        const uint32_t slot = sm_block_hash_find(&job->grid_of->hash, d->side_key[s] >> 3); /* live: an E block touches it */
        for (size_t l = 0; l < bn; l++) {
            const size_t gi = (size_t)slot * bn + l, si = (size_t)s * bn + l;
            job->grid.mass[gi] += job->side.mass[si];
            for (size_t a = 0; a < dim; a++) {
                job->grid.momentum[gi * dim + a] += job->side.momentum[si * dim + a];
                job->grid.force[gi * dim + a] += job->side.force[si * dim + a];
            }
        }
    }
}

void sm_dist_replay(sm_world *w, int colour) {
    const sm_dist *d = w->dist;
    if (!d || d->nside == 0) return;
    const size_t bn = (size_t)w->grid.block_nodes;
    replay_job job = {d, &w->grid, side_arrays(d, bn), sm_grid_p2g_arrays(&w->grid), bn, (size_t)d->dim, colour};
    sm_team_for(w->threads > 0 ? w->threads : 1, (long)d->nside, replay_range, &job);
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
