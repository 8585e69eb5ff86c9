/* Binning particles by grid block (see bin.h), compiled for SM_DIM = 2 and 3.
 *
 * A stable counting sort by particle block, in the steps below. Block keys are recomputed from
 * positions where needed, never stored per particle (memory per particle is the budget). The
 * previous step's blocks are the first guess: particles move less than a cell per step (CFL), so
 * new blocks are rare and are found in a serial pass in particle order (deterministic).
 *   1. count_known_blocks: each thread counts its contiguous share of the particles per known
 *      block (read-only hash lookups; consecutive particles mostly share a block);
 *   2. add_new_blocks: blocks not known yet, in particle order; then step 1 again;
 *   3. sort_blocks + scatter_particles + publish_blocks: the non-empty blocks in ascending key
 *      order, per-thread cursors, perm (stable), the new block list and its hash;
 *      order_by_id: within a block the particles in ascending id, so that the order P2G sums a
 *      block's particles in is a function of the particles alone, not of the storage order
 *      (which reorders, resumed checkpoints and, with MPI, migration between ranks change);
 *   4. live_grid_blocks: the 2^d grid blocks of every particle block, in ascending key order
 *      (merged from the particle blocks' order), zeroed for P2G; each particle block's slots;
 *   5. colour_lists: particle blocks grouped by colour for the race-free scatter;
 *   6. reorder_if_scattered: move the particle storage into block order when a block's
 *      particles are no longer mostly contiguous (every later pass then streams).
 * Before all of these, when the last binning was made for the same particle count, kernel, domain
 * and grid: the binning by movers (rebin_dim.c), which makes steps 1-3's result from the last
 * binning by moving only the particles that left their blocks. When none did (a pile at rest, a
 * slow scene), steps 4-6 would give the last binning again, and only the grid is zeroed.
 *
 * A second batch (sm_bin_more, for a distributed step whose P2G starts before the arrivals):
 * the new particles counted per block (new blocks appended, then sorted and merged in), each
 * block's stretch of perm moved up to make room (from the last block down, so nothing is
 * overwritten), the new particles scattered after the old ones and the blocks that gained some
 * put in id order; the new grid blocks merged into the live ones (grid.c, sm_grid_add_blocks:
 * the values of the others kept), then slots (link_grid_slots) and colours as in 5. */
#include "core/dim.h"

#include <string.h>

#include "core/team.h"
#include "grid/bin_dim.h"

static inline int key_color(uint64_t key) {
    int b[3];
    sm_block_coords(key, b);
    return (b[0] & 1) | ((b[1] & 1) << 1) | ((D == 3 ? (b[2] & 1) : 0) << 2);
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Thread t's share of the n particles: [p0, p1). */
static inline void thread_share(size_t n, int T, int t, size_t *p0, size_t *p1) {
    *p0 = n * (size_t)t / (size_t)T;
    *p1 = n * (size_t)(t + 1) / (size_t)T;
}

/* The work of the binning's parallel passes over thread shares t = 0 .. T-1 (each share is an
 * item of sm_team_for: a team of fewer threads still does every share). */
typedef struct count_job {
    sm_bins *b;
    const double *x;
    size_t n;
    const sm_step_ctx *c;
    int T;
    atomic_long misses;
} count_job;

static void count_shares(void *arg, long lo, long hi) {
    count_job *job = arg;
    const sm_bins *b = job->b;
    const size_t nb = b->npb;
    const sm_step_ctx *c = job->c;
    long misses = 0;
    for (int t = (int)lo; t < (int)hi; t++) {
        size_t p0, p1;
        thread_share(job->n, job->T, t, &p0, &p1);
        uint32_t *ct = b->counts + (size_t)t * nb;
        uint64_t last = UINT64_MAX;
        uint32_t slot = SM_NO_SLOT;
        for (size_t p = p0; p < p1; p++) {
            uint64_t k = sm_bin_particle_key(c, job->x + p * D, c->stencil);
            if (k != last) {
                last = k;
                slot = sm_block_hash_find(&b->pb_hash, k);
            }
            if (slot == SM_NO_SLOT) misses++;
            else ct[slot]++;
        }
    }
    atomic_fetch_add_explicit(&job->misses, misses, memory_order_relaxed);
}

/* 1. counts[t * npb + block] = thread t's particles in each known block; returns the particles
 * whose block is not known. */
static sm_status count_known_blocks(sm_bins *b, const double *x, size_t n, const sm_step_ctx *c, int T,
                                    long *misses_out) {
    const size_t nb = b->npb;
    if (sm_bin_grow((void **)&b->counts, &b->counts_cap, (size_t)T * nb + 1, sizeof(uint32_t)) != SM_OK) return SM_ERR_NOMEM;
    uint32_t *cnt = b->counts;
    memset(cnt, 0, (size_t)T * nb * sizeof(uint32_t));
    count_job job = {b, x, n, c, T, 0};
    sm_team_for(T, T, count_shares, &job);
    *misses_out = (long)atomic_load(&job.misses);
    return SM_OK;
}

/* 2. Appends the blocks not known yet, in particle order (serial: deterministic). */
static sm_status add_new_blocks(sm_bins *b, const double *x, size_t n, const sm_step_ctx *c) {
    sm_block_hash *ph = &b->pb_hash;
    size_t nb = b->npb;
    uint64_t last = UINT64_MAX;
    for (size_t p = 0; p < n; p++) {
        uint64_t k = sm_bin_particle_key(c, x + p * D, c->stencil);
        if (k == last) continue;
        last = k;
        if (sm_block_hash_find(ph, k) != SM_NO_SLOT) continue;
        if (sm_bin_grow((void **)&b->pb, &b->pb_cap, nb + 1, sizeof *b->pb) != SM_OK) return SM_ERR_NOMEM;
        if (ph->cap < 2 * (nb + 1)) {
            if (sm_block_hash_reserve(ph, nb + 1) != SM_OK) return SM_ERR_NOMEM;
            for (size_t q = 0; q < nb; q++) sm_block_hash_put(ph, b->pb[q].key, (uint32_t)q);
        }
        sm_block_hash_put(ph, k, (uint32_t)nb);
        b->pb[nb++].key = k;
    }
    b->npb = nb;
    return SM_OK;
}

/* 3a. The non-empty blocks as (key, index) pairs in ascending key order; counts become each
 * thread's first position in perm per block (thread t's particles of a block follow those of
 * threads < t: stable). Returns the number of non-empty blocks. */
static size_t sort_blocks(sm_bins *b, int T) {
    const size_t nb = b->npb;
    uint32_t *cnt = b->counts;
    uint64_t *pairs = b->pairs;
    size_t nne = 0;
    for (size_t k = 0; k < nb; k++) {
        uint32_t total = 0;
        for (int t = 0; t < T; t++) total += cnt[(size_t)t * nb + k];
        if (total) {
            pairs[2 * nne] = b->pb[k].key;
            pairs[2 * nne + 1] = k;
            nne++;
        }
    }
    qsort(pairs, nne, 2 * sizeof(uint64_t), cmp_u64); /* (key, index) pairs, by key */
    uint32_t pos = 0;
    for (size_t r = 0; r < nne; r++) {
        size_t k = (size_t)pairs[2 * r + 1];
        for (int t = 0; t < T; t++) {
            uint32_t m = cnt[(size_t)t * nb + k];
            cnt[(size_t)t * nb + k] = pos;
            pos += m;
        }
    }
    return nne;
}

/* 3b. perm: every particle at its thread's cursor of its block. */
static void scatter_shares(void *arg, long lo, long hi) {
    const count_job *job = arg;
    sm_bins *b = job->b;
    const size_t nb = b->npb;
    const sm_step_ctx *c = job->c;
    for (int t = (int)lo; t < (int)hi; t++) {
        size_t p0, p1;
        thread_share(job->n, job->T, t, &p0, &p1);
        uint32_t *ct = b->counts + (size_t)t * nb;
        uint64_t last = UINT64_MAX;
        uint32_t slot = 0;
        for (size_t p = p0; p < p1; p++) {
            uint64_t k = sm_bin_particle_key(c, job->x + p * D, c->stencil);
            if (k != last) {
                last = k;
                slot = sm_block_hash_find(&b->pb_hash, k);
            }
            b->perm[ct[slot]++] = (uint32_t)p;
        }
    }
}

static void scatter_particles(sm_bins *b, const double *x, size_t n, const sm_step_ctx *c, int T) {
    count_job job = {b, x, n, c, T, 0};
    sm_team_for(T, T, scatter_shares, &job);
}

/* 3c. The new block list (ascending key, with its range in perm) and its hash. After the
 * scatter, the last thread's cursors are the blocks' ends. */
static void publish_blocks(sm_bins *b, size_t nne, int T) {
    const size_t nb = b->npb;
    uint64_t *pairs = b->pairs;
    uint32_t start = 0;
    for (size_t r = 0; r < nne; r++) {
        size_t k = (size_t)pairs[2 * r + 1];
        uint32_t end = b->counts[(size_t)(T - 1) * nb + k];
        pairs[2 * r + 1] = ((uint64_t)start << 32) | end;
        start = end;
    }
    for (size_t r = 0; r < nne; r++) {
        b->pb[r].key = pairs[2 * r];
        b->pb[r].start = (uint32_t)(pairs[2 * r + 1] >> 32);
        b->pb[r].end = (uint32_t)pairs[2 * r + 1];
        b->pb[r].more = b->pb[r].early = b->pb[r].side = 0;
    }
    b->npb = nne;
    sm_block_hash_clear(&b->pb_hash);
    for (size_t r = 0; r < nne; r++) sm_block_hash_put(&b->pb_hash, b->pb[r].key, (uint32_t)r);
}

/* 3d. Each block's stretch of perm in ascending particle id. Storage order is mostly block order
 * already, so a block's particles are a few runs sorted by id (the previous block order): an
 * insertion sort costs about one comparison per particle. A block the sort did not change keeps
 * the scatter's increasing indices (`ascending`: the transfers' cheap test for a run). */
/* perm[s..e) in ascending id (an insertion sort); returns 1 if it moved anything. */
static uint32_t sort_by_id(uint32_t *perm, const uint32_t *id, uint32_t s, uint32_t e) {
    uint32_t moved = 0;
    for (uint32_t i = s + 1; i < e; i++) {
        const uint32_t p = perm[i], key = id[p];
        uint32_t j = i;
        while (j > s && id[perm[j - 1]] > key) {
            perm[j] = perm[j - 1];
            j--;
        }
        perm[j] = p;
        moved |= j != i;
    }
    return moved;
}

typedef struct id_job {
    sm_bins *b;
    const uint32_t *id;
} id_job;

static void order_blocks_by_id(void *arg, long lo, long hi) {
    const id_job *job = arg;
    sm_bins *b = job->b;
    for (long r = lo; r < hi; r++) {
        const uint32_t moved = sort_by_id(b->perm, job->id, b->pb[r].start, b->pb[r].end);
        b->pb[r].ascending = !moved; /* the scatter's order increases; any move breaks it */
    }
}

static void order_by_id(sm_bins *b, const uint32_t *id, int T) {
    id_job job = {b, id};
    sm_team_for(T, (long)b->npb, order_blocks_by_id, &job);
}

/* Key of grid block cb (0 .. 2^d - 1) of particle block bc; 0 in *inside if outside the domain. */
static inline uint64_t neighbour_key(const sm_grid *g, const int bc[3], int cb, int *inside) {
    int o[3] = {0, 0, 0};
    for (int a = 0; a < D; a++) o[a] = bc[a] + ((cb >> (D - 1 - a)) & 1);
    *inside = o[0] < g->blocks[0] && o[1] < g->blocks[1] && o[2] < g->blocks[2];
    return sm_block_key(o[0], o[1], o[2]);
}

/* The key of grid block cb of the first particle block from *r on whose block cb is inside the
 * domain (*r moves to it), or UINT64_MAX when none is left. */
static uint64_t next_inside(const sm_bins *b, const sm_grid *g, int cb, size_t *r) {
    for (; *r < b->npb; (*r)++) {
        int bc[3], inside;
        sm_block_coords(b->pb[*r].key, bc);
        const uint64_t key = neighbour_key(g, bc, cb, &inside);
        if (inside) return key;
    }
    return UINT64_MAX;
}

/* The live grid blocks' keys in ascending order, each once, into out, and every particle block's
 * slots (SM_NO_SLOT outside the domain and past 2^d); with out NULL only counted. Returns how
 * many. They merge the 2^d lists "grid block cb of every particle block", each ascending as the
 * particle blocks are (an offset of 0 or 1 per coordinate adds the same to every key, without a
 * carry out of a coordinate's bits). */
static size_t merge_live_keys(sm_bins *b, const sm_grid *g, uint64_t *out) {
    size_t cur[NGB], k = 0;
    uint64_t head[NGB], last = UINT64_MAX;
    if (out)
        for (size_t r = 0; r < b->npb; r++)
            for (int cb = 0; cb < 8; cb++) b->pb[r].gslot[cb] = SM_NO_SLOT;
    for (int cb = 0; cb < NGB; cb++) {
        cur[cb] = 0;
        head[cb] = next_inside(b, g, cb, &cur[cb]);
    }
    for (;;) {
        int lo = 0;
        for (int cb = 1; cb < NGB; cb++)
            if (head[cb] < head[lo]) lo = cb;
        if (head[lo] == UINT64_MAX) return k;
        if (head[lo] != last) {
            if (out) out[k] = head[lo];
            k++;
            last = head[lo];
        }
        if (out) b->pb[cur[lo]].gslot[lo] = (uint32_t)(k - 1);
        cur[lo]++;
        head[lo] = next_inside(b, g, lo, &cur[lo]);
    }
}

/* 4. The live grid blocks: the 2^d neighbours (+0/+1 per axis) of every particle block, in
 * ascending key order (slot order), the grid's hash of them and every particle block's slots.
 * (Merged from the particle blocks' order: 2D, 1e6 particles on 2 threads, the binning
 * 1.9-2.1e8 -> 2.8-3.0e8 particles/s against a hash of them sorted by qsort and looked up again
 * per particle block; docs/benchmarks.md.) */
static sm_status live_grid_blocks(sm_bins *b, sm_grid *g) {
    const size_t ng = merge_live_keys(b, g, NULL);
    if (sm_grid_reserve(g, ng) != SM_OK) return SM_ERR_NOMEM;
    merge_live_keys(b, g, g->key);
    sm_block_hash *gh = &g->hash;
    sm_block_hash_clear(gh);
    for (size_t s = 0; s < ng; s++) sm_block_hash_put(gh, g->key[s], (uint32_t)s);
    g->nactive = ng;
    return SM_OK;
}

/* Every particle block's grid slots (SM_NO_SLOT outside the domain and past 2^d), looked up (the
 * second batch's; a binning's come with its live grid blocks). */
static void link_grid_slots(sm_bins *b, const sm_grid *g) {
    for (size_t r = 0; r < b->npb; r++) {
        int bc[3], inside;
        sm_block_coords(b->pb[r].key, bc);
        for (int cb = 0; cb < NGB; cb++) b->pb[r].gslot[cb] = sm_block_hash_find(&g->hash, neighbour_key(g, bc, cb, &inside));
        for (int cb = NGB; cb < 8; cb++) b->pb[r].gslot[cb] = SM_NO_SLOT;
    }
}

/* 5. The particle blocks grouped by colour (ascending key within a colour). */
static sm_status colour_lists(sm_bins *b) {
    const size_t nne = b->npb;
    if (sm_bin_grow((void **)&b->color_blocks, &b->color_cap, nne, sizeof(uint32_t)) != SM_OK) return SM_ERR_NOMEM;
    memset(b->color_count, 0, sizeof b->color_count);
    for (size_t r = 0; r < nne; r++) b->color_count[key_color(b->pb[r].key)]++;
    b->color_offset[0] = 0;
    for (int col = 0; col < 8; col++) b->color_offset[col + 1] = b->color_offset[col] + b->color_count[col];
    uint32_t cursor[8];
    for (int col = 0; col < 8; col++) cursor[col] = b->color_offset[col];
    for (size_t r = 0; r < nne; r++) b->color_blocks[cursor[key_color(b->pb[r].key)]++] = (uint32_t)r;
    return SM_OK;
}

/* 6. Reorders the storage when the particles of a block are no longer mostly contiguous (fewer
 * than 16 in a row on average); perm becomes the identity. On two threads or more, two threads
 * move half of the fields each (particles/permute.c; the binning by movers' workspace is free by
 * now and holds their bitmaps). */
static void reorder_if_scattered(sm_bins *b, sm_particles *P, int T) {
    const size_t n = P->n;
    if (b->keep_storage) return;
    size_t breaks = 0;
    for (size_t i = 1; i < n; i++) breaks += b->perm[i] != b->perm[i - 1] + 1;
    if (breaks * 16 > n) {
        if (T < 2 || !sm_particles_permute_pair(P, D, b->perm, b->rebin_ws, b->rebin_ws_bytes)) sm_particles_permute(P, D, b->perm);
        b->reorders++;
    }
}

static sm_bins_basis basis_of(const sm_particles *P, const sm_grid *g, const sm_step_ctx *c) {
    sm_bins_basis s;
    s.valid = 1;
    s.stencil = c->stencil;
    s.n = P->n;
    s.nactive = g->nactive;
    for (int a = 0; a < 3; a++) s.pos_lo[a] = c->pos_lo[a];
    s.pos_inv_dx = c->pos_inv_dx;
    return s;
}

static int same_basis(const sm_bins_basis *a, const sm_bins_basis *o) {
    int same = a->stencil == o->stencil && a->n == o->n && a->nactive == o->nactive && a->pos_inv_dx == o->pos_inv_dx;
    for (int k = 0; k < 3; k++) same &= a->pos_lo[k] == o->pos_lo[k];
    return same;
}

/* ---- A second batch -------------------------------------------------------------------- */

/* Counts particles [first, n) into their blocks' `more`, appending the blocks not known yet
 * (serial, in particle order). */
static sm_status count_more(sm_bins *b, const sm_particles *P, size_t first, const sm_step_ctx *c) {
    sm_block_hash *ph = &b->pb_hash;
    for (size_t r = 0; r < b->npb; r++) b->pb[r].more = 0;
    uint64_t last = UINT64_MAX;
    uint32_t slot = SM_NO_SLOT;
    for (size_t p = first; p < P->n; p++) {
        const uint64_t k = sm_bin_particle_key(c, P->x + p * D, c->stencil);
        if (k != last) {
            last = k;
            slot = sm_block_hash_find(ph, k);
        }
        if (slot == SM_NO_SLOT) {
            const size_t nb = b->npb;
            if (sm_bin_grow((void **)&b->pb, &b->pb_cap, nb + 1, sizeof *b->pb) != SM_OK) return SM_ERR_NOMEM;
            if (ph->cap < 2 * (nb + 1)) {
                if (sm_block_hash_reserve(ph, nb + 1) != SM_OK) return SM_ERR_NOMEM;
                for (size_t q = 0; q < nb; q++) sm_block_hash_put(ph, b->pb[q].key, (uint32_t)q);
            }
            memset(&b->pb[nb], 0, sizeof b->pb[nb]);
            b->pb[nb].key = k;
            slot = sm_block_hash_put(ph, k, (uint32_t)nb);
            b->npb = nb + 1;
        }
        b->pb[slot].more++;
    }
    return SM_OK;
}

static int cmp_pblock(const void *a, const void *b) {
    const uint64_t x = ((const sm_pblock *)a)->key, y = ((const sm_pblock *)b)->key;
    return (x > y) - (x < y);
}

/* The blocks in key order again (the first `old` are; the ones count_more appended are sorted
 * and merged in from the back), each block's old particles moved to the front of its new stretch
 * of perm, `more` its cursor for the new ones. New positions never fall below old ones, so going
 * from the last block down overwrites nothing not yet moved. The blocks that gain particles go
 * to b->counts (index, bit 31 set for a block new to the binning); returns how many. */
static size_t make_room(sm_bins *b, size_t old) {
    const size_t nnew = b->npb - old;
    memcpy(b->pb_tmp, b->pb + old, nnew * sizeof *b->pb);
    qsort(b->pb_tmp, nnew, sizeof *b->pb_tmp, cmp_pblock);
    uint32_t end = 0;
    for (size_t r = 0; r < b->npb; r++) end += b->pb[r].end - b->pb[r].start + b->pb[r].more;
    size_t i = old, j = nnew, touched = 0;
    for (size_t k = b->npb; k-- > 0;) {
        const int take_new = j > 0 && (i == 0 || b->pb_tmp[j - 1].key > b->pb[i - 1].key);
        sm_pblock pb = take_new ? b->pb_tmp[--j] : b->pb[--i];
        const uint32_t len = pb.end - pb.start, start = end - len - pb.more;
        memmove(b->perm + start, b->perm + pb.start, len * sizeof *b->perm);
        if (pb.more) b->counts[touched++] = (uint32_t)k | (take_new ? 1u << 31 : 0);
        pb.more = start + len;
        pb.start = start;
        pb.end = end;
        b->pb[k] = pb;
        end = start;
    }
    sm_block_hash_clear(&b->pb_hash);
    for (size_t r = 0; r < b->npb; r++) sm_block_hash_put(&b->pb_hash, b->pb[r].key, (uint32_t)r);
    return touched;
}

/* Touched blocks [lo, hi) (their indices in counts) in ascending id. */
static void order_touched_by_id(void *arg, long lo, long hi) {
    const id_job *job = arg;
    sm_bins *b = job->b;
    for (long t = lo; t < hi; t++) {
        sm_pblock *pb = &b->pb[b->counts[t] & ~(1u << 31)];
        const uint32_t s = pb->start, e = pb->end;
        sort_by_id(b->perm, job->id, s, e);
        uint32_t increasing = 1; /* (the old particles may have been moved by the first binning's sort) */
        for (uint32_t i = s + 1; i < e; i++) increasing &= b->perm[i] > b->perm[i - 1];
        pb->ascending = increasing;
    }
}

/* Particles [first, n) at their blocks' cursors; then each block that gained some in ascending id
 * (an insertion sort: its old particles are in order already), `ascending` as order_by_id leaves
 * it. */
static void scatter_more(sm_bins *b, const sm_particles *P, size_t first, const sm_step_ctx *c, size_t touched,
                         int T) {
    uint64_t last = UINT64_MAX;
    uint32_t slot = 0;
    for (size_t p = first; p < P->n; p++) {
        const uint64_t k = sm_bin_particle_key(c, P->x + p * D, c->stencil);
        if (k != last) {
            last = k;
            slot = sm_block_hash_find(&b->pb_hash, k);
        }
        b->perm[b->pb[slot].more++] = (uint32_t)p;
    }
    id_job job = {b, P->id};
    sm_team_for(T, (long)touched, order_touched_by_id, &job);
}

/* The grid blocks that the blocks new to the binning touch and that are not live yet: merged into
 * the live ones. */
static sm_status grow_grid(sm_bins *b, sm_grid *g, size_t touched) {
    if (sm_bin_grow((void **)&b->pairs, &b->pairs_cap, (size_t)NGB * touched + 2, sizeof(uint64_t)) != SM_OK) return SM_ERR_NOMEM;
    size_t k = 0;
    for (size_t t = 0; t < touched; t++) {
        if (!(b->counts[t] >> 31)) continue;
        int bc[3], inside;
        sm_block_coords(b->pb[b->counts[t] & ~(1u << 31)].key, bc);
        for (int cb = 0; cb < NGB; cb++) {
            const uint64_t key = neighbour_key(g, bc, cb, &inside);
            if (inside && sm_block_hash_find(&g->hash, key) == SM_NO_SLOT) b->pairs[k++] = key;
        }
    }
    qsort(b->pairs, k, sizeof(uint64_t), cmp_u64);
    size_t u = 0;
    for (size_t i = 0; i < k; i++)
        if (u == 0 || b->pairs[i] != b->pairs[u - 1]) b->pairs[u++] = b->pairs[i];
    return sm_grid_add_blocks(g, b->pairs, u);
}

sm_status SM_FN(sm_bin_more)(sm_bins *b, sm_particles *P, sm_grid *g, const sm_step_ctx *c, size_t first) {
    const int T = c->threads > 0 ? c->threads : 1;
    const size_t old = b->npb;
    if (count_more(b, P, first, c) != SM_OK ||
        sm_bin_grow((void **)&b->pb_tmp, &b->pb_tmp_cap, b->npb - old + 1, sizeof *b->pb_tmp) != SM_OK ||
        sm_bin_grow((void **)&b->counts, &b->counts_cap, b->npb + 1, sizeof(uint32_t)) != SM_OK)
        return SM_ERR_NOMEM;
    const size_t touched = make_room(b, old);
    scatter_more(b, P, first, c, touched, T);
    if (grow_grid(b, g, touched) != SM_OK) return SM_ERR_NOMEM;
    link_grid_slots(b, g);
    if (colour_lists(b) != SM_OK) return SM_ERR_NOMEM;
    b->basis = basis_of(P, g, c);
    return SM_OK;
}

/* ---- The binning ------------------------------------------------------------------------ */

/* 4.-6. after the particle blocks (of the full binning or the binning by movers). */
static sm_status bin_finish(sm_bins *b, sm_particles *P, sm_grid *g, const sm_step_ctx *c, int T) {
    if (live_grid_blocks(b, g) != SM_OK) return SM_ERR_NOMEM;
    sm_grid_zero(g, T);
    if (colour_lists(b) != SM_OK) return SM_ERR_NOMEM;
    reorder_if_scattered(b, P, T);
    b->basis = basis_of(P, g, c);
    return SM_OK;
}

sm_status SM_FN(sm_bin_particles)(sm_bins *b, sm_particles *P, sm_grid *g, const sm_step_ctx *c) {
    const size_t n = P->n;
    const int T = c->threads > 0 ? c->threads : 1;
    long misses = 0;
    const sm_bins_basis now = basis_of(P, g, c);
    sm_rebin_outcome rebin = SM_REBIN_FULL;
    if (b->basis.valid && same_basis(&now, &b->basis) && SM_FN(sm_rebin)(b, P, c, T, &rebin) != SM_OK) return SM_ERR_NOMEM;
    if (rebin == SM_REBIN_HELD) {
        sm_grid_zero(g, T);
        reorder_if_scattered(b, P, T);
        b->reuses++;
        return SM_OK;
    }
    b->basis.valid = 0;
    if (rebin == SM_REBIN_MOVED) return bin_finish(b, P, g, c, T);
    if (count_known_blocks(b, P->x, n, c, T, &misses) != SM_OK) return SM_ERR_NOMEM;
    if (misses > 0) {
        if (add_new_blocks(b, P->x, n, c) != SM_OK) return SM_ERR_NOMEM;
        if (count_known_blocks(b, P->x, n, c, T, &misses) != SM_OK) return SM_ERR_NOMEM;
        SM_ASSERT(misses == 0);
    }
    if (sm_bin_grow((void **)&b->pairs, &b->pairs_cap, 2 * b->npb + 2, sizeof(uint64_t)) != SM_OK) return SM_ERR_NOMEM;
    const size_t nne = sort_blocks(b, T);
    scatter_particles(b, P->x, n, c, T);
    publish_blocks(b, nne, T);
    order_by_id(b, P->id, T);
    return bin_finish(b, P, g, c, T);
}
