/* The binning by movers (bin_dim.h, sm_rebin), compiled for SM_DIM = 2 and 3.
 *
 * From one step to the next most particles stay in their particle block: they move less than a
 * cell per step and a block is 4 cells wide. So this step's binning is the last one with the
 * particles that left a block (the movers) taken out of it and put into the blocks they reached:
 *   1. scan_blocks (parallel, per block): each particle's key from its position; in each block's
 *      stretch of perm the stayers close up to the front in their order and the movers go behind
 *      them (pb.more: how many). The stayers must be in ascending (id, index): the order the full
 *      binning gives (its counting sort scatters by index, then an insertion sort orders by id,
 *      stable). If they are not (the storage changed beneath the binning), the full binning runs.
 *   2. collect_movers: the movers with the keys of the blocks they reached, into the workspace
 *      (bin.h: in perm's allocation, room for a sixteenth of the particles), sorted by (key, id,
 *      index);
 *   3. add_fresh_blocks: the keys the movers reach that are not blocks yet, merged into the list
 *      (ascending key) as empty blocks; plan_blocks: each block's arrivals (pb.early) and new
 *      start in perm (pb.side): the new stretches follow each other in key order;
 *   4. move_stayers: every block's stayers to their new place in perm: the blocks that move down in
 *      ascending order, then those that move up in descending order. A block's stayers never land
 *      on the stayers of a block that has not moved yet (the new place of a block starts after the
 *      new places of the blocks before it, and a block that moves up starts after its old place);
 *   5. finish_blocks: each block's arrivals merged in by (id, index), from the back; its new
 *      range; `ascending` (whether the stretch's indices increase, as the full binning's id sort
 *      leaves it) where it changed; more, early and side back to 0;
 *   6. the blocks every particle left dropped, the hash made again where blocks came or went.
 * Every block's stretch then holds the particles whose key it is, in (id, index) order, and the
 * blocks are the non-empty ones in ascending key: the full binning's perm and blocks, entry for
 * entry (tests/test_rebin.c compares them). With no movers only the scan runs. When more than a
 * sixteenth of the particles moved (or more of one block than a thread's share of the workspace
 * holds: an eighth of all, on two threads), the full binning runs instead: its counting sort is
 * then cheaper than sorting the movers, and the workspace has no more room. Nothing here allocates but the
 * growth of the block list and its hash, as the full binning's. */
#include "core/dim.h"

#include <string.h>

#include "core/team.h"
#include "grid/bin_dim.h"

/* 1 if particle p comes before q in a block: ascending id, then ascending index. */
static inline int before(const uint32_t *id, uint32_t p, uint32_t q) {
    return id[p] < id[q] || (id[p] == id[q] && p < q);
}

/* 1. Block pb: its stayers to the front of its stretch, its movers (via scratch) behind them,
 * pb->more = how many moved, pb->ascending = whether the stayers' indices increase. Returns 0 if
 * the stayers are not in (id, index) order or more than scratch_len moved. */
static int scan_block(sm_pblock *pb, uint32_t *perm, const sm_particles *P, const sm_step_ctx *c,
                      uint32_t *scratch, uint32_t scratch_len) {
    const uint32_t s = pb->start, e = pb->end, *id = P->id;
    const uint64_t key = pb->key;
    /* last: the previous stayer (index, id); the flags are integers, not branches: kept in
     * memory as bytes, `increasing` cost a failed store-to-load forward per particle */
    uint32_t w = s, moved = 0, have = 0, last = 0, last_id = 0, disorder = 0, drops = 0;
    for (uint32_t j = s; j < e; j++) {
        const uint32_t p = perm[j];
        if (sm_bin_particle_key(c, P->x + (size_t)p * D, c->stencil) != key) {
            if (moved == scratch_len) return 0;
            scratch[moved++] = p;
            continue;
        }
        const uint32_t idp = id[p];
        disorder |= have & ((idp < last_id) | ((idp == last_id) & (p < last)));
        drops += have & (p < last);
        last = p, last_id = idp, have = 1;
        perm[w++] = p;
    }
    if (disorder) return 0;
    memcpy(perm + w, scratch, moved * sizeof *perm);
    pb->more = moved;
    pb->ascending = drops == 0;
    return 1;
}

typedef struct scan_job {
    sm_bins *b;
    const sm_particles *P;
    const sm_step_ctx *c;
    uint32_t scratch_len; /* entries of scratch per thread */
    atomic_int usable;
    atomic_long movers;
} scan_job;

static void scan_share(void *arg, int t, int T) {
    scan_job *job = arg;
    sm_bins *b = job->b;
    uint32_t *scratch = (uint32_t *)b->rebin_ws + (size_t)t * job->scratch_len;
    long lo, hi, movers = 0;
    sm_team_split((long)b->npb, T, t, &lo, &hi);
    for (long r = lo; r < hi; r++) {
        if (!scan_block(&b->pb[r], b->perm, job->P, job->c, scratch, job->scratch_len)) {
            atomic_store_explicit(&job->usable, 0, memory_order_relaxed);
            return;
        }
        movers += b->pb[r].more;
    }
    atomic_fetch_add_explicit(&job->movers, movers, memory_order_relaxed);
}

/* 1. *usable = 0 if a block's stayers were out of order (or more of its particles moved than a
 * thread's share of the workspace holds); *movers = the particles that left. */
static void scan_blocks(sm_bins *b, const sm_particles *P, const sm_step_ctx *c, int T, int *usable,
                        size_t *movers) {
    const size_t share = b->rebin_ws_bytes / sizeof(uint32_t) / (size_t)T;
    scan_job job = {b, P, c, (uint32_t)(share < UINT32_MAX ? share : UINT32_MAX), 1, 0};
    sm_team_run(T, scan_share, &job);
    *usable = atomic_load(&job.usable);
    *movers = (size_t)atomic_load(&job.movers);
}

static int cmp_mover(const void *x, const void *y) {
    const sm_bin_mover *a = x, *b = y;
    if (a->key != b->key) return a->key < b->key ? -1 : 1;
    if (a->id != b->id) return a->id < b->id ? -1 : 1;
    return (a->p > b->p) - (a->p < b->p);
}

/* 2. The movers (at the back of their old blocks' stretches) with their new keys, sorted; returns
 * how many distinct keys they reach that are not blocks yet. */
static size_t collect_movers(const sm_bins *b, sm_bin_mover *mv, const sm_particles *P, const sm_step_ctx *c,
                             size_t nmovers) {
    size_t m = 0;
    for (size_t r = 0; r < b->npb; r++)
        for (uint32_t j = b->pb[r].end - b->pb[r].more; j < b->pb[r].end; j++) {
            const uint32_t p = b->perm[j];
            mv[m++] = (sm_bin_mover){sm_bin_particle_key(c, P->x + (size_t)p * D, c->stencil), P->id[p], p};
        }
    SM_ASSERT(m == nmovers);
    qsort(mv, nmovers, sizeof *mv, cmp_mover);
    size_t fresh = 0;
    for (size_t j = 0; j < nmovers; j++)
        if ((j == 0 || mv[j].key != mv[j - 1].key) && sm_block_hash_find(&b->pb_hash, mv[j].key) == SM_NO_SLOT) fresh++;
    return fresh;
}

/* 3. The blocks the movers reach that are not blocks yet (fresh of them), merged into the list from
 * the back (nothing is overwritten before it moved, as in bin_dim.c's make_room), with an empty
 * old stretch. */
static void add_fresh_blocks(sm_bins *b, const sm_bin_mover *mv, size_t nmovers, size_t fresh) {
    size_t i = b->npb, k = b->npb + fresh;
    for (size_t j = nmovers; j-- > 0 && k > i;) {
        if (j > 0 && mv[j].key == mv[j - 1].key) continue; /* a key once: at the first of its movers */
        while (i > 0 && b->pb[i - 1].key > mv[j].key) b->pb[--k] = b->pb[--i];
        if (i > 0 && b->pb[i - 1].key == mv[j].key) continue; /* a block already */
        sm_pblock *pb = &b->pb[--k];
        memset(pb, 0, sizeof *pb);
        pb->key = mv[j].key;
    }
    b->npb += fresh;
}

/* 3. Each block's arrivals (early) and new start in perm (side): its stayers, then its arrivals. */
static void plan_blocks(sm_bins *b, const sm_bin_mover *mv, size_t nmovers) {
    size_t j = 0;
    uint32_t pos = 0;
    for (size_t r = 0; r < b->npb; r++) {
        sm_pblock *pb = &b->pb[r];
        const size_t a0 = j;
        while (j < nmovers && mv[j].key == pb->key) j++;
        pb->early = (uint32_t)(j - a0);
        pb->side = pos;
        pos += pb->end - pb->start - pb->more + pb->early;
    }
    SM_ASSERT(j == nmovers);
}

/* 4. Every block's stayers to the front of its new stretch (see the top of the file). */
static void move_stayers(sm_bins *b) {
    for (size_t r = 0; r < b->npb; r++) {
        const sm_pblock *pb = &b->pb[r];
        if (pb->side < pb->start) memmove(b->perm + pb->side, b->perm + pb->start, (pb->end - pb->start - pb->more) * sizeof *b->perm);
    }
    for (size_t r = b->npb; r-- > 0;) {
        const sm_pblock *pb = &b->pb[r];
        if (pb->side > pb->start) memmove(b->perm + pb->side, b->perm + pb->start, (pb->end - pb->start - pb->more) * sizeof *b->perm);
    }
}

/* 5. Block pb's arrivals mv[0 .. pb->early) merged into its new stretch from the back; the block
 * takes its new range, `ascending` (computed again if it changed) and more = early = side = 0. */
static void merge_arrivals(sm_pblock *pb, uint32_t *perm, const sm_bin_mover *mv, const uint32_t *id) {
    const uint32_t stay = pb->end - pb->start - pb->more, start = pb->side, end = start + stay + pb->early;
    const int touched = pb->more > 0 || pb->early > 0;
    long i = (long)start + (long)stay - 1, a = (long)pb->early - 1, out = (long)end - 1;
    while (a >= 0) {
        const uint32_t q = mv[a].p;
        if (i >= (long)start && before(id, q, perm[i])) perm[out--] = perm[i--];
        else perm[out--] = q, a--;
    }
    if (touched) {
        uint32_t increasing = 1;
        for (uint32_t j = start + 1; j < end; j++) increasing &= perm[j] > perm[j - 1];
        pb->ascending = increasing;
    }
    pb->start = start;
    pb->end = end;
    pb->more = pb->early = pb->side = 0;
}

/* 5. and 6. Every block's arrivals; the blocks every particle left dropped; the hash made again
 * where blocks came or went. */
static void finish_blocks(sm_bins *b, const sm_bin_mover *mv, const uint32_t *id, size_t fresh) {
    size_t a = 0, k = 0;
    for (size_t r = 0; r < b->npb; r++) {
        sm_pblock pb = b->pb[r];
        const uint32_t arrivals = pb.early;
        merge_arrivals(&pb, b->perm, mv + a, id);
        a += arrivals;
        if (pb.end > pb.start) b->pb[k++] = pb;
    }
    const int changed = fresh > 0 || k < b->npb;
    b->npb = k;
    if (!changed) return; /* every block kept its index */
    sm_block_hash_clear(&b->pb_hash);
    for (size_t r = 0; r < k; r++) sm_block_hash_put(&b->pb_hash, b->pb[r].key, (uint32_t)r);
}

sm_status SM_FN(sm_rebin)(sm_bins *b, const sm_particles *P, const sm_step_ctx *c, int T, sm_rebin_outcome *outcome) {
    *outcome = SM_REBIN_FULL;
    if (b->npb == 0 || b->pb[0].start != 0 || b->pb[b->npb - 1].end != P->n) return SM_OK;
    int usable = 0;
    size_t nmovers = 0;
    scan_blocks(b, P, c, T, &usable, &nmovers);
    if (!usable || nmovers > P->n / 16 || nmovers * sizeof(sm_bin_mover) > b->rebin_ws_bytes) return SM_OK;
    if (nmovers == 0) {
        *outcome = SM_REBIN_HELD;
        return SM_OK;
    }
    sm_bin_mover *mv = b->rebin_ws;
    const size_t fresh = collect_movers(b, mv, P, c, nmovers);
    if (fresh > 0) {
        if (sm_bin_grow((void **)&b->pb, &b->pb_cap, b->npb + fresh, sizeof *b->pb) != SM_OK ||
            sm_block_hash_reserve(&b->pb_hash, b->npb + fresh) != SM_OK)
            return SM_ERR_NOMEM;
        add_fresh_blocks(b, mv, nmovers, fresh);
    }
    plan_blocks(b, mv, nmovers);
    move_stayers(b);
    finish_blocks(b, mv, P->id, fresh);
    b->rebins++;
    *outcome = SM_REBIN_MOVED;
    return SM_OK;
}
