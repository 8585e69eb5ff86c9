/* The implicit solve across ranks (dist.h): which live grid blocks this rank owns, and the
 * traffic of sm_imp_ranks (integrate/implicit_solver.h) -- node vectors refreshed on the blocks
 * owned elsewhere, exact sums added over the ranks.
 *
 * Ownership: grid block g belongs to the owner of Morton code g (dist.c's cuts, the same ranges
 * as particle blocks). Every particle that reaches g is on g's owner (owned, or a ghost:
 * exchange.c sends a copy to every rank holding a block the particle reaches complete), so every
 * sum over g's particles there is complete: the owner's values of g are a one-rank run's.
 * A rank may hold a block g that no particle reaches (the binner makes the 2^d grid blocks of
 * every particle block live) and that is not live on its owner: no gather reads it, and a
 * refresh writes zeros there.
 *
 * The plan, built each step after the binning (collective):
 *   1. for every live block owned elsewhere, its owner; the keys, grouped by owner, go to the
 *      owners (MPI_Alltoall of the counts, then one message per peer);
 *   2. each owner finds the asked keys' slots in its grid (SM_NO_SLOT: not live there, above);
 *   3. a refresh sends each peer the values of the blocks it asked for and writes what arrives
 *      into the blocks owned elsewhere (one message per peer and direction). */
#include <stdlib.h>
#include <string.h>

#include "dist/dist_internal.h"
#include "grid/grid.h"
#include "integrate/implicit_solver.h"
#include "world/world.h"

struct sm_dist_halo {
    sm_imp_ranks iface;
    size_t block_values;         /* sm_real per block of a node vector: 4^d d */
    unsigned char *owned;        /* per live block */
    uint32_t *need_slot, *give_slot; /* blocks this rank receives / sends, grouped by peer */
    uint64_t *need_key, *give_key;
    size_t need_slot_cap, need_key_cap, give_slot_cap, give_key_cap, owned_cap;
    size_t *need_at, *give_at;   /* per peer: first entry (size + 1 entries) */
    int *need_n, *give_n;        /* per peer: entries */
    sm_real *sendbuf, *recvbuf;
    size_t send_cap, recv_cap;   /* sm_real */
};

static int grow(void **p, size_t *cap, size_t need, size_t elem) {
    if (need <= *cap) return 1;
    void *q = sm_realloc(*p, (need ? need : 1) * elem);
    if (!q) return 0;
    *p = q;
    *cap = need;
    return 1;
}

static int all_ok(const sm_dist *d, int ok) {
    int all = 0;
    MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, d->comm);
    return all;
}

static sm_dist_halo *halo_create(int ranks) {
    sm_dist_halo *h = calloc(1, sizeof *h);
    if (!h) return NULL;
    h->need_at = calloc((size_t)ranks + 1, sizeof *h->need_at);
    h->give_at = calloc((size_t)ranks + 1, sizeof *h->give_at);
    h->need_n = calloc((size_t)ranks, sizeof *h->need_n);
    h->give_n = calloc((size_t)ranks, sizeof *h->give_n);
    if (!h->need_at || !h->give_at || !h->need_n || !h->give_n) {
        sm_dist_halo_free(h);
        return NULL;
    }
    return h;
}

void sm_dist_halo_free(sm_dist_halo *h) {
    if (!h) return;
    free(h->owned);
    free(h->need_slot);
    free(h->give_slot);
    free(h->need_key);
    free(h->give_key);
    free(h->need_at);
    free(h->give_at);
    free(h->need_n);
    free(h->give_n);
    free(h->sendbuf);
    free(h->recvbuf);
    free(h);
}

static int block_owner(const sm_dist *d, uint64_t key) {
    int b[3];
    sm_block_coords(key, b);
    return sm_dist_owner(d, sm_dist_morton(d->dim, b));
}

/* 1. Ownership of the live blocks and the ones to receive, grouped by owner (slot order within). */
static int list_needs(sm_dist *d, const sm_grid *g) {
    sm_dist_halo *h = d->halo;
    const size_t nb = g->nactive;
    if (!grow((void **)&h->owned, &h->owned_cap, nb, 1)) return 0;
    memset(h->need_n, 0, (size_t)d->size * sizeof *h->need_n);
    for (size_t t = 0; t < nb; t++) {
        const int o = block_owner(d, g->key[t]);
        h->owned[t] = o == d->rank;
        if (o != d->rank) h->need_n[o]++;
    }
    for (int r = 0; r < d->size; r++) h->need_at[r + 1] = h->need_at[r] + (size_t)h->need_n[r];
    const size_t total = h->need_at[d->size];
    if (!grow((void **)&h->need_slot, &h->need_slot_cap, total, sizeof *h->need_slot) ||
        !grow((void **)&h->need_key, &h->need_key_cap, total, sizeof *h->need_key))
        return 0;
    memset(h->need_n, 0, (size_t)d->size * sizeof *h->need_n);
    for (size_t t = 0; t < nb; t++) {
        if (h->owned[t]) continue;
        const int o = block_owner(d, g->key[t]);
        const size_t k = h->need_at[o] + (size_t)h->need_n[o]++;
        h->need_slot[k] = (uint32_t)t;
        h->need_key[k] = g->key[t];
    }
    return 1;
}

/* The requests for one message per peer and direction of these sizes (elements of `elem` bytes). */
static int reserve_requests(sm_dist *d, size_t elem) {
    const sm_dist_halo *h = d->halo;
    size_t n = 0;
    for (int r = 0; r < d->size; r++)
        n += sm_dist_request_count(d, (size_t)h->need_n[r] * elem) + sm_dist_request_count(d, (size_t)h->give_n[r] * elem);
    return sm_dist_reserve_requests(d, n);
}

/* 1-2. The keys to their owners; the asked keys' slots here (SM_NO_SLOT where not live). Returns
 * 0 out of memory. */
static int exchange_keys(sm_dist *d, const sm_grid *g) {
    sm_dist_halo *h = d->halo;
    MPI_Alltoall(h->need_n, 1, MPI_INT, h->give_n, 1, MPI_INT, d->comm);
    for (int r = 0; r < d->size; r++) h->give_at[r + 1] = h->give_at[r] + (size_t)h->give_n[r];
    const size_t total = h->give_at[d->size];
    int ok = grow((void **)&h->give_slot, &h->give_slot_cap, total, sizeof *h->give_slot) &&
             grow((void **)&h->give_key, &h->give_key_cap, total, sizeof *h->give_key) && reserve_requests(d, sizeof(uint64_t));
    if (!all_ok(d, ok)) return 0;
    size_t n = 0;
    for (int r = 0; r < d->size; r++)
        n += sm_dist_irecv(d, (unsigned char *)(h->give_key + h->give_at[r]), (size_t)h->give_n[r] * sizeof(uint64_t), r, 22, n);
    for (int r = 0; r < d->size; r++)
        n += sm_dist_isend(d, (const unsigned char *)(h->need_key + h->need_at[r]), (size_t)h->need_n[r] * sizeof(uint64_t), r,
                           22, n);
    sm_dist_wait(d, n);
    for (size_t k = 0; k < total; k++) h->give_slot[k] = sm_block_hash_find(&g->hash, h->give_key[k]);
    return 1;
}

static void halo_refresh(void *ctx, sm_real *v) {
    sm_dist *d = ctx;
    sm_dist_halo *h = d->halo;
    const size_t bw = h->block_values, bytes = bw * sizeof(sm_real);
    for (size_t k = 0; k < h->give_at[d->size]; k++) {
        if (h->give_slot[k] == SM_NO_SLOT) memset(h->sendbuf + k * bw, 0, bytes); /* not live here: reached by none */
        else memcpy(h->sendbuf + k * bw, v + (size_t)h->give_slot[k] * bw, bytes);
    }
    size_t n = 0;
    for (int r = 0; r < d->size; r++)
        n += sm_dist_irecv(d, (unsigned char *)(h->recvbuf + h->need_at[r] * bw), (size_t)h->need_n[r] * bytes, r, 23, n);
    for (int r = 0; r < d->size; r++) {
        if (!h->give_n[r]) continue;
        n += sm_dist_isend(d, (const unsigned char *)(h->sendbuf + h->give_at[r] * bw), (size_t)h->give_n[r] * bytes, r, 23, n);
        d->stats.halo_bytes_sent += (size_t)h->give_n[r] * bytes;
        d->stats.halo_messages_sent++;
    }
    sm_dist_wait(d, n);
    for (size_t k = 0; k < h->need_at[d->size]; k++) memcpy(v + h->need_slot[k] * bw, h->recvbuf + k * bw, bytes);
    d->stats.halo_refreshes++;
}

static void halo_sum(void *ctx, sm_xsum *acc) {
    const sm_dist *d = ctx;
    sm_xsum all;
    sm_xsum_normalize(acc); /* digits below 2^32: the ranks' sum cannot overflow them */
    MPI_Allreduce(acc->w, all.w, SM_XSUM_WORDS, MPI_INT64_T, MPI_SUM, d->comm);
    all.pending = d->size;
    *acc = all;
}

static int halo_max_int(void *ctx, int v) {
    const sm_dist *d = ctx;
    int r = v;
    MPI_Allreduce(&v, &r, 1, MPI_INT, MPI_MAX, d->comm);
    return r;
}

sm_status sm_dist_halo_plan(sm_world *w, const sm_imp_ranks **out) {
    sm_dist *d = w->dist;
    const sm_grid *g = &w->grid;
    *out = NULL;
    d->stats.halo_bytes_sent = d->stats.halo_messages_sent = d->stats.halo_refreshes = 0;
    if (!d->halo) d->halo = halo_create(d->size);
    int ok = d->halo && list_needs(d, g);
    if (!all_ok(d, ok)) return sm_world_fail(w, SM_ERR_NOMEM, "step %llu: out of memory for the implicit solve's halo",
                                             (unsigned long long)w->steps + 1);
    sm_dist_halo *h = d->halo;
    const int keys = exchange_keys(d, g);
    h->block_values = (size_t)g->block_nodes * (size_t)d->dim;
    ok = keys > 0 && grow((void **)&h->sendbuf, &h->send_cap, h->give_at[d->size] * h->block_values, sizeof(sm_real)) &&
         grow((void **)&h->recvbuf, &h->recv_cap, h->need_at[d->size] * h->block_values, sizeof(sm_real)) &&
         reserve_requests(d, h->block_values * sizeof(sm_real));
    if (!all_ok(d, ok)) return sm_world_fail(w, SM_ERR_NOMEM, "step %llu: out of memory for the implicit solve's halo",
                                             (unsigned long long)w->steps + 1);
    h->iface.ctx = d;
    h->iface.owned = h->owned;
    h->iface.refresh = halo_refresh;
    h->iface.sum = halo_sum;
    h->iface.max_int = halo_max_int;
    *out = &h->iface;
    return SM_OK;
}
