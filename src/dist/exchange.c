/* The exchange of a distributed step (dist.h): migration, re-balancing and ghosts, before the
 * binning; and the end of the step, which drops the ghosts.
 *
 *   1. imbalance: the ranks' particle counts; a re-cut when max > SM_DIST_IMBALANCE x mean (at
 *      most every SM_DIST_RECUT_STEPS steps);
 *   2. route: for each particle, the owner o of its block and the ranks G (less o) that need it
 *      as a ghost. It goes to o (stays if o is this rank), and a copy to every rank of G (this
 *      rank's own copy becomes a local ghost); the kept particles are compacted in place.
 *      A rank needs the particles that reach a grid block it holds complete (dist.h's
 *      sm_dist_block_complete: one of the block's contributors g - {0,1}^d is its own), no
 *      others: a particle of block b whose stencil stays in grid block b along axis a (for the
 *      quadratic kernel half of a block's particles, those with base node 4 b_a + 0 or + 1)
 *      touches grid blocks b + delta, delta_a = 0, whose contributors along a are b_a - 1 and
 *      b_a, not b_a + 1; one that crosses into b_a + 1 reaches the contributors b_a - 1 .. b_a + 1.
 *      So the ranks of G are the owners of the blocks b + o, o_a in {-1, 0} (+1 where the stencil
 *      crosses), one list per crossing pattern of a block: a planar cut sends one side's whole
 *      layer and half of the other's (the 3^d neighbourhood sent both whole);
 *   3. send: counts to every rank (MPI_Alltoall), then one message per peer holding its
 *      migrating particles (sm_particles_pack, every field), then its ghosts: in an explicit
 *      step only the fields P2G reads (sm_particles_pack_p2g; 106 of 150 bytes in 3D float: F^E,
 *      q and alpha stay with the owner, whose G2P and plasticity alone read them), in an
 *      implicit one every field (the solve evaluates the ghosts' stress at F^E(v));
 *   4. receive, in rank order: migrating particles appended to [0, owned), then the ghosts.
 * sm_dist_exchange_begin does 1-3 and leaves the messages in flight; sm_dist_exchange_finish
 * waits for them and does 4. Between the two, an explicit step bins the particles this rank kept
 * and scatters its inner blocks (overlap.c), calling sm_dist_progress now and then. Storage
 * order does not matter to the results (a block's particles are summed in id order). */
#include <limits.h>
#include <string.h>

#include "dist/dist_internal.h"
#include "grid/grid.h"
#include "transfer/kernel.h"
#include "world/world.h"

/* Particle i packed at the end of buf: every field, or a ghost's p2g fields (p2g_only). */
static int append(sm_dist_buf *buf, const sm_particles *P, int dim, size_t i, size_t bytes, int p2g_only) {
    if (!sm_dist_buf_reserve(buf, buf->len + bytes)) return 0;
    if (p2g_only) sm_particles_pack_p2g(P, dim, i, buf->data + buf->len);
    else sm_particles_pack(P, dim, i, buf->data + buf->len);
    buf->len += bytes;
    return 1;
}

/* The owners of the blocks b + o other than `skip`, distinct, into dst, where o_a runs over
 * {-1, 0}, and over {-1, 0, 1} for the axes in the bit mask `cross`; returns their number. */
static int ghost_owners(const sm_dist *d, const int b[3], int cross, int skip, int *dst) {
    int n = 0;
    const int m = d->dim == 3 ? 27 : 9;
    for (int k = 0; k < m; k++) {
        const int off[3] = {k % 3 - 1, (k / 3) % 3 - 1, d->dim == 3 ? k / 9 - 1 : 0};
        int o[3], skip_k = 0;
        for (int a = 0; a < 3; a++) {
            o[a] = b[a] + off[a];
            skip_k |= off[a] == 1 && !((cross >> a) & 1);
        }
        if (skip_k) continue;
        if (o[0] < 0 || o[1] < 0 || o[2] < 0 || o[0] > SM_KEY_MAX || o[1] > SM_KEY_MAX || o[2] > SM_KEY_MAX) continue;
        const int r = sm_dist_owner(d, sm_dist_morton(d->dim, o));
        if (r == skip) continue;
        int seen = 0;
        for (int j = 0; j < n; j++) seen |= dst[j] == r;
        if (!seen) dst[n++] = r;
    }
    return n;
}

/* The block of the particle at x and the axes along which its stencil crosses into the next
 * grid block (bit a of the result). */
static int particle_block_cross(const sm_dist *d, const double *x, int b[3]) {
    int cross = 0;
    b[0] = b[1] = b[2] = 0;
    for (int a = 0; a < d->dim; a++) {
        const int base = sm_kernel_base(d->stencil, (x[a] - d->lo[a]) * d->inv_dx);
        b[a] = base >> SM_BLOCK_BITS;
        cross |= ((base & SM_BLOCK_MASK) + d->stencil - 1 > SM_BLOCK_MASK) << a;
    }
    return cross;
}

/* 1. Re-cut when the largest rank holds too many particles. */
static sm_status balance(sm_world *w) {
    sm_dist *d = w->dist;
    const double mine = (double)d->owned;
    double mx = 0, sum = 0;
    MPI_Allreduce(&mine, &mx, 1, MPI_DOUBLE, MPI_MAX, d->comm);
    MPI_Allreduce(&mine, &sum, 1, MPI_DOUBLE, MPI_SUM, d->comm);
    const double mean = sum / d->size;
    d->stats.max_particles = (size_t)mx;
    d->stats.mean_particles = mean;
    if (++d->since_recut < SM_DIST_RECUT_STEPS || !(mx > SM_DIST_IMBALANCE * mean && mx > 1)) return SM_OK;
    d->since_recut = 0;
    return sm_dist_recut(w);
}

/* 2. Routes every particle; returns 0 when out of memory. The ghost lists of the last block
 * seen, one per crossing pattern, are found when first needed (ng[c] < 0: not yet). */
static int route(sm_dist *d, sm_particles *P, size_t ps, size_t gs) {
    for (int r = 0; r < d->size; r++) d->own_out[r].len = d->ghost_out[r].len = 0;
    int last[3] = {-1, -1, -1}, owner = d->rank, ok = 1;
    int ng[8], ghosts[8][27];
    size_t kept = 0;
    for (size_t i = 0; i < P->n; i++) {
        int b[3];
        const int cross = particle_block_cross(d, P->x + i * (size_t)d->dim, b);
        if (b[0] != last[0] || b[1] != last[1] || b[2] != last[2]) {
            memcpy(last, b, sizeof last);
            owner = sm_dist_owner(d, sm_dist_morton(d->dim, b));
            for (int c = 0; c < 8; c++) ng[c] = -1;
        }
        if (ng[cross] < 0) ng[cross] = ghost_owners(d, b, cross, owner, ghosts[cross]);
        for (int j = 0; j < ng[cross]; j++) ok &= append(&d->ghost_out[ghosts[cross][j]], P, d->dim, i, gs, gs < ps);
        if (owner != d->rank) {
            ok &= append(&d->own_out[owner], P, d->dim, i, ps, 0);
            d->stats.migrated_sent++;
            continue;
        }
        if (kept != i) sm_particles_move(P, d->dim, kept, i);
        kept++;
    }
    P->n = kept;
    return ok;
}

/* 3. Posts the sends of the buffers and the receives into d->in (rank after rank: migrating, then
 * ghosts); d->pending requests are in flight. */
static int send_receive(sm_dist *d, size_t ps, size_t gs) {
    const int P = d->size;
    int *sent = d->counts, *recv = d->counts + 2 * P;
    for (int r = 0; r < P; r++) {
        sent[2 * r] = r == d->rank ? 0 : (int)(d->own_out[r].len / ps);
        sent[2 * r + 1] = r == d->rank ? 0 : (int)(d->ghost_out[r].len / gs);
    }
    MPI_Alltoall(sent, 2, MPI_INT, recv, 2, MPI_INT, d->comm);
    size_t total = 0;
    for (int r = 0; r < P; r++) total += (size_t)recv[2 * r] * ps + (size_t)recv[2 * r + 1] * gs;
    /* Migrating then ghosts in one message per peer: the ghosts appended to the migrating buffer. */
    int ok = sm_dist_buf_reserve(&d->in, total + 1), all_ok = 0;
    size_t nreq = 0;
    for (int r = 0; r < P; r++) {
        if (r == d->rank) continue;
        sm_dist_buf *o = &d->own_out[r];
        ok = ok && sm_dist_buf_reserve(o, o->len + d->ghost_out[r].len);
        nreq += sm_dist_request_count(d, (size_t)recv[2 * r] * ps + (size_t)recv[2 * r + 1] * gs) +
                sm_dist_request_count(d, o->len + d->ghost_out[r].len);
    }
    ok = ok && sm_dist_reserve_requests(d, nreq);
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
    if (!all_ok) return 0;
    nreq = 0;
    size_t at = 0;
    for (int r = 0; r < P; r++) {
        const size_t bytes = (size_t)recv[2 * r] * ps + (size_t)recv[2 * r + 1] * gs;
        nreq += sm_dist_irecv(d, d->in.data + at, bytes, r, 19, nreq);
        at += bytes;
    }
    d->in.len = at;
    d->stats.bytes_sent = d->stats.messages_sent = 0;
    for (int r = 0; r < P; r++) {
        if (r == d->rank || !(sent[2 * r] + sent[2 * r + 1])) continue;
        sm_dist_buf *o = &d->own_out[r];
        memcpy(o->data + o->len, d->ghost_out[r].data, d->ghost_out[r].len);
        o->len += d->ghost_out[r].len;
        nreq += sm_dist_isend(d, o->data, o->len, r, 19, nreq);
        d->stats.bytes_sent += o->len;
        d->stats.messages_sent++;
        d->stats.ghosts_sent += (size_t)sent[2 * r + 1];
    }
    d->pending = nreq;
    return 1;
}

static void unpack_run(sm_particles *P, int dim, const unsigned char *src, size_t count, size_t bytes, int p2g_only) {
    for (size_t i = 0; i < count; i++) {
        if (p2g_only) sm_particles_unpack_p2g(P, dim, P->n + i, src + i * bytes);
        else sm_particles_unpack(P, dim, P->n + i, src + i * bytes);
    }
    P->n += count;
}

/* 4. This rank's particles, the arrivals, then the ghosts (its own copies first). */
static sm_status place(sm_world *w, size_t ps, size_t gs) {
    sm_dist *d = w->dist;
    sm_particles *P = &w->p;
    const int *recv = d->counts + 2 * d->size;
    size_t arrive = 0, ghosts = d->ghost_out[d->rank].len / gs;
    for (int r = 0; r < d->size; r++) {
        arrive += (size_t)recv[2 * r];
        ghosts += (size_t)recv[2 * r + 1];
    }
    if (sm_particles_reserve(P, d->dim, P->n + arrive + ghosts) != SM_OK ||
        sm_bins_reserve_perm(&w->bins, P->cap) != SM_OK)
        return SM_ERR_NOMEM;
    size_t at = 0;
    for (int r = 0; r < d->size; r++) {
        unpack_run(P, d->dim, d->in.data + at, (size_t)recv[2 * r], ps, 0);
        at += (size_t)recv[2 * r] * ps + (size_t)recv[2 * r + 1] * gs;
    }
    d->owned = P->n;
    unpack_run(P, d->dim, d->ghost_out[d->rank].data, d->ghost_out[d->rank].len / gs, gs, gs < ps);
    at = 0;
    for (int r = 0; r < d->size; r++) {
        at += (size_t)recv[2 * r] * ps;
        unpack_run(P, d->dim, d->in.data + at, (size_t)recv[2 * r + 1], gs, gs < ps);
        at += (size_t)recv[2 * r + 1] * gs;
    }
    return SM_OK;
}

/* The packed sizes of a migrating particle and of a ghost: an explicit step's ghosts carry what
 * P2G reads; the implicit solve's read F^E and alpha too. */
static void packed_sizes(const sm_world *w, size_t *ps, size_t *gs) {
    *ps = sm_particles_packed_size(w->dim);
    *gs = w->def.integrator == SM_INTEGRATOR_IMPLICIT ? *ps : sm_particles_p2g_size(w->dim);
}

static sm_status out_of_memory(sm_world *w) {
    return sm_world_fail(w, SM_ERR_NOMEM, "step %llu: out of memory for the particles exchanged between ranks",
                         (unsigned long long)w->steps + 1);
}

sm_status sm_dist_exchange_begin(sm_world *w, int *overlap) {
    sm_dist *d = w->dist;
    size_t ps, gs;
    packed_sizes(w, &ps, &gs);
    d->stats.ghosts_sent = d->stats.migrated_sent = 0;
    d->stats.early_particles = 0;
    const uint64_t recuts = d->stats.rebalances;
    if (balance(w) != SM_OK) return SM_ERR_NOMEM;
    int ok = route(d, &w->p, ps, gs), all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
    if (!all_ok || !send_receive(d, ps, gs)) return out_of_memory(w);
    /* A re-cut moves blocks between ranks wholesale: this step's arrivals may land anywhere. One
     * rank has no messages to wait for (test mode 2 overlaps there too). */
    *overlap = (d->overlap == 2 || (d->overlap && d->size > 1)) && d->stats.rebalances == recuts &&
               w->def.integrator != SM_INTEGRATOR_IMPLICIT;
    return SM_OK;
}

void sm_dist_progress(sm_world *w) {
    sm_dist *d = w->dist;
    int done = 0;
    for (size_t at = 0; at < d->pending;) { /* MPI_Testall's count is int */
        const int k = (int)(d->pending - at < (size_t)INT_MAX ? d->pending - at : (size_t)INT_MAX);
        MPI_Testall(k, d->req + at, &done, MPI_STATUSES_IGNORE);
        at += (size_t)k;
    }
}

sm_status sm_dist_exchange_finish(sm_world *w) {
    sm_dist *d = w->dist;
    size_t ps, gs;
    packed_sizes(w, &ps, &gs);
    const double t0 = MPI_Wtime();
    sm_dist_wait(d, d->pending);
    d->pending = 0;
    d->stats.exchange_wait_s = MPI_Wtime() - t0;
    return place(w, ps, gs) == SM_OK ? SM_OK : out_of_memory(w);
}

/* The owned particles in block order (perm of the binning, ghosts left out); reordered when a
 * block's particles are scattered (as the binner does for one rank). */
void sm_dist_end_step(sm_world *w) {
    sm_dist *d = w->dist;
    sm_particles *P = &w->p;
    const size_t n = P->n, own = d->owned;
    P->n = own;
    if (own == 0 || n > w->bins.perm_cap) return;
    if (d->scratch_cap < own) {
        uint32_t *q = sm_realloc(d->scratch, own * sizeof *q);
        if (!q) return; /* no reorder: slower, not wrong */
        d->scratch = q;
        d->scratch_cap = own;
    }
    size_t k = 0, breaks = 0;
    for (size_t i = 0; i < n; i++) {
        const uint32_t p = w->bins.perm[i];
        if (p >= own) continue;
        breaks += k > 0 && p != d->scratch[k - 1] + 1;
        d->scratch[k++] = p;
    }
    if (k == own && breaks * 16 > own) {
        sm_particles_permute(P, d->dim, d->scratch);
        w->bins.reorders++;
    }
}
