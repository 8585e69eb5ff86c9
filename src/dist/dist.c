/* The distributed world (dist.h, sandmpm_mpi.h): the decomposition of the particle blocks into
 * Morton ranges, its re-cut, the reductions the step needs, the public calls.
 *
 * Morton order: block coordinates (bi, bj, bk) of 21 bits each interleaved bit by bit
 * (bk, bj, bi from the lowest bit up), so that a contiguous range of codes is a compact set of
 * blocks and a rank's halo is a surface. The cuts: with the blocks' particle counts c_i in Morton
 * order and N = sum c_i, rank r's range starts at the first block i whose preceding count
 * sum_{j<i} c_j reaches floor(N r / P). */
#include <stdlib.h>
#include <string.h>

#include "dist/dist_internal.h"
#include "grid/grid.h"
#include "transfer/kernel.h"
#include "world/world.h"

static uint64_t spread3(uint64_t x) {
    x &= 0x1fffffULL;
    x = (x | x << 32) & 0x1f00000000ffffULL;
    x = (x | x << 16) & 0x1f0000ff0000ffULL;
    x = (x | x << 8) & 0x100f00f00f00f00fULL;
    x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
    return x;
}

static uint64_t spread2(uint64_t x) {
    x &= 0x1fffffULL;
    x = (x | x << 16) & 0x0000ffff0000ffffULL;
    x = (x | x << 8) & 0x00ff00ff00ff00ffULL;
    x = (x | x << 4) & 0x0f0f0f0f0f0f0f0fULL;
    x = (x | x << 2) & 0x3333333333333333ULL;
    x = (x | x << 1) & 0x5555555555555555ULL;
    return x;
}

uint64_t sm_dist_morton(int dim, const int b[3]) {
    if (dim == 2) return spread2((uint64_t)b[0]) << 1 | spread2((uint64_t)b[1]);
    return spread3((uint64_t)b[0]) << 2 | spread3((uint64_t)b[1]) << 1 | spread3((uint64_t)b[2]);
}

void sm_dist_particle_block(const sm_dist *d, const double *x, int b[3]) {
    b[0] = b[1] = b[2] = 0;
    for (int a = 0; a < d->dim; a++) b[a] = sm_kernel_base(d->stencil, (x[a] - d->lo[a]) * d->inv_dx) >> SM_BLOCK_BITS;
}

int sm_dist_owner(const sm_dist *d, uint64_t m) {
    int lo = 0, hi = d->size - 1; /* the largest r with cuts[r] <= m; cuts[0] = 0 */
    while (lo < hi) {
        const int mid = (lo + hi + 1) / 2;
        if (d->cuts[mid] <= m) lo = mid;
        else hi = mid - 1;
    }
    return lo;
}

int sm_dist_buf_reserve(sm_dist_buf *buf, size_t need) {
    if (need <= buf->cap) return 1;
    size_t cap = buf->cap ? buf->cap : 4096;
    while (cap < need) cap += cap / 2;
    unsigned char *q = sm_realloc(buf->data, cap);
    if (!q) return 0;
    buf->data = q;
    buf->cap = cap;
    return 1;
}

int sm_dist_cmp_u64(const void *a, const void *b) {
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* (Morton code, particles) pairs of the blocks of particles [0, n), ascending code, into
 * d->hist; returns the number of pairs, or -1 when out of memory. */
static long block_histogram(sm_dist *d, const sm_particles *P, size_t n) {
    if (d->hist_cap < 2 * n + 2) {
        uint64_t *q = sm_realloc(d->hist, (2 * n + 2) * sizeof *q);
        if (!q) return -1;
        d->hist = q;
        d->hist_cap = 2 * n + 2;
    }
    uint64_t *codes = d->hist + n; /* the upper half, read ahead of the pairs written below */
    for (size_t i = 0; i < n; i++) {
        int b[3];
        sm_dist_particle_block(d, P->x + i * (size_t)d->dim, b);
        codes[i] = sm_dist_morton(d->dim, b);
    }
    qsort(codes, n, sizeof *codes, sm_dist_cmp_u64);
    long np = 0;
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && codes[j] == codes[i]) j++;
        const uint64_t code = codes[i], count = j - i;
        d->hist[2 * np] = code; /* 2 np <= i: never past what was read */
        d->hist[2 * np + 1] = count;
        np++;
        i = j;
    }
    return np;
}

/* (code, count) pairs sorted by code, equal codes merged (counts added); returns the pairs left. */
static size_t merge_histogram(uint64_t *pairs, size_t np) {
    qsort(pairs, np, 2 * sizeof *pairs, sm_dist_cmp_u64); /* compares the codes */
    size_t k = 0;
    for (size_t i = 0; i < np; i++) {
        if (k > 0 && pairs[2 * (k - 1)] == pairs[2 * i]) {
            pairs[2 * (k - 1) + 1] += pairs[2 * i + 1];
            continue;
        }
        pairs[2 * k] = pairs[2 * i];
        pairs[2 * k + 1] = pairs[2 * i + 1];
        k++;
    }
    return k;
}

void sm_dist_cuts_from_histogram(sm_dist *d, const uint64_t *pairs, size_t np) {
    uint64_t total = 0;
    for (size_t i = 0; i < np; i++) total += pairs[2 * i + 1];
    d->cuts[0] = 0;
    size_t i = 0;
    uint64_t before = 0;
    for (int r = 1; r < d->size; r++) {
        const uint64_t target = total * (uint64_t)r / (uint64_t)d->size;
        while (i < np && before < target) before += pairs[2 * i++ + 1];
        d->cuts[r] = i < np ? pairs[2 * i] : UINT64_MAX;
    }
}

sm_status sm_dist_recut(sm_world *w) {
    sm_dist *d = w->dist;
    const long np = block_histogram(d, &w->p, d->owned);
    int mine = np < 0 ? -1 : (int)np, bad = 0;
    MPI_Allreduce(&(int){mine < 0}, &bad, 1, MPI_INT, MPI_MAX, d->comm);
    if (bad) return sm_world_fail(w, SM_ERR_NOMEM, "distributed run: out of memory for the block histogram");
    int *counts = d->counts, *displs = d->counts + d->size;
    const int pairs2 = 2 * mine;
    MPI_Allgather(&pairs2, 1, MPI_INT, counts, 1, MPI_INT, d->comm);
    long total = 0;
    for (int r = 0; r < d->size; r++) {
        displs[r] = (int)total;
        total += counts[r];
    }
    uint64_t *all = malloc((size_t)(total ? total : 1) * sizeof *all);
    if (!all) return sm_world_fail(w, SM_ERR_NOMEM, "distributed run: out of memory for the block histogram");
    MPI_Allgatherv(d->hist, pairs2, MPI_UINT64_T, all, counts, displs, MPI_UINT64_T, d->comm);
    /* The ranks' particles have moved since the last exchange: some lie outside their rank's
     * range, and a block may be on two ranks. Sorted by code and merged, the histogram is the
     * same whatever rank held what (the cuts were not monotone before, which sm_dist_owner's
     * search does not expect: a rank's blocks were then not one Morton range). */
    sm_dist_cuts_from_histogram(d, all, merge_histogram(all, (size_t)total / 2));
    free(all);
    d->stats.rebalances++;
    return SM_OK;
}

/* ---- Reductions and queries ---------------------------------------------------------------- */

size_t sm_dist_owned(const sm_world *w) { return w->dist->owned; }

double sm_dist_max(const sm_world *w, double v) {
    double r = v;
    MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_MAX, w->dist->comm);
    return r;
}

int sm_dist_max_int(const sm_world *w, int v) {
    int r = v;
    MPI_Allreduce(&v, &r, 1, MPI_INT, MPI_MAX, w->dist->comm);
    return r;
}

void sm_dist_sum_n(const sm_world *w, double *v, int n) {
    const sm_dist *d = w->dist;
    double *all = malloc((size_t)d->size * 32 * sizeof *all);
    double mine[32] = {0};
    memcpy(mine, v, (size_t)n * sizeof *v);
    if (!all) { /* no room for the rank-ordered sum: a plain reduction (its order is MPI's) */
        MPI_Allreduce(mine, v, n, MPI_DOUBLE, MPI_SUM, d->comm);
        return;
    }
    MPI_Allgather(mine, 32, MPI_DOUBLE, all, 32, MPI_DOUBLE, d->comm);
    for (int k = 0; k < n; k++) {
        double s = 0;
        for (int r = 0; r < d->size; r++) s += all[32 * r + k];
        v[k] = s;
    }
    free(all);
}

void sm_dist_max_n(const sm_world *w, double *v, int n) {
    double mine[64];
    for (int k = 0; k < n; k += 64) {
        const int m = n - k < 64 ? n - k : 64;
        memcpy(mine, v + k, (size_t)m * sizeof *v);
        MPI_Allreduce(mine, v + k, m, MPI_DOUBLE, MPI_MAX, w->dist->comm);
    }
}

int sm_dist_block_complete(const sm_world *w, uint64_t key) {
    const sm_dist *d = w->dist;
    int g[3];
    sm_block_coords(key, g);
    for (int c = 0; c < (1 << d->dim); c++) {
        int b[3] = {g[0], g[1], g[2]};
        for (int a = 0; a < d->dim; a++) b[a] -= (c >> a) & 1;
        if (b[0] < 0 || b[1] < 0 || b[2] < 0) continue;
        if (sm_dist_owner(d, sm_dist_morton(d->dim, b)) == d->rank) return 1;
    }
    return 0;
}

void sm_dist_adopt(sm_world *w, size_t first) {
    sm_dist *d = w->dist;
    sm_particles *P = &w->p;
    size_t j = first;
    for (size_t i = first; i < P->n; i++) {
        int b[3];
        sm_dist_particle_block(d, P->x + i * (size_t)d->dim, b);
        if (sm_dist_owner(d, sm_dist_morton(d->dim, b)) != d->rank) continue;
        if (j != i) sm_particles_move(P, d->dim, j, i);
        j++;
    }
    P->n = j;
    d->owned = j;
}

/* Every rank's particles gathered into *P on rank 0 (collective; P empty elsewhere), in pieces
 * (message.c: a rank's share can pass INT_MAX bytes); 0 when out of memory on some rank (every
 * rank returns the same). */
static int gather_particles(const sm_world *w, sm_particles *P) {
    sm_dist *d = w->dist;
    const size_t ps = sm_particles_packed_size(d->dim), n = d->owned;
    memset(P, 0, sizeof *P);
    uint64_t mine_bytes = (uint64_t)n * ps, *bytes = malloc((size_t)d->size * sizeof *bytes);
    unsigned char *mine = malloc(n ? n * ps : 1);
    int ok = mine && bytes, all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
    if (all_ok) {
        for (size_t i = 0; i < n; i++) sm_particles_pack(&w->p, d->dim, i, mine + i * ps);
        MPI_Gather(&mine_bytes, 1, MPI_UINT64_T, bytes, 1, MPI_UINT64_T, 0, d->comm);
        size_t total = 0, nreq = 0;
        if (d->rank == 0)
            for (int r = 0; r < d->size; r++) total += (size_t)bytes[r], nreq += sm_dist_request_count(d, (size_t)bytes[r]);
        else nreq = sm_dist_request_count(d, n * ps);
        unsigned char *all = d->rank == 0 ? malloc(total ? total : 1) : NULL;
        ok = (d->rank != 0 || all) && sm_dist_reserve_requests(d, nreq);
        MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
        if (all_ok && d->rank == 0) {
            size_t at = bytes[0], k = 0;
            memcpy(all, mine, n * ps);
            for (int r = 1; r < d->size; r++) k += sm_dist_irecv(d, all + at, (size_t)bytes[r], r, 20, k), at += (size_t)bytes[r];
            sm_dist_wait(d, k);
        } else if (all_ok) sm_dist_wait(d, sm_dist_isend(d, mine, n * ps, 0, 20, 0));
        if (all_ok && d->rank == 0 && (ok = sm_particles_reserve(P, d->dim, total / ps) == SM_OK)) {
            for (size_t i = 0; i < total / ps; i++) sm_particles_unpack(P, d->dim, i, all + i * ps);
            P->n = total / ps;
        }
        free(all);
        if (all_ok) MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
    }
    free(mine);
    free(bytes);
    return all_ok;
}

/* Every rank's particles gathered on rank 0, hashed in id order there, the hash sent to all. */
uint64_t sm_dist_id_hash(const sm_world *w) {
    sm_particles P;
    uint64_t h = 0;
    if (gather_particles(w, &P) && w->dist->rank == 0) h = sm_particles_hash_by_id(&P, w->dim);
    sm_particles_free(&P);
    MPI_Bcast(&h, 1, MPI_UINT64_T, 0, w->dist->comm);
    return h;
}

/* A checkpoint of the whole run, written by rank 0 (checkpoint.c's format, one rank's world): every
 * particle in id order, the counters summed and the last step's largest speed taken over the
 * ranks, so that it resumes on any number of ranks (or none) as the run would have gone on. */
sm_status sm_dist_save(const sm_world *w, sm_write_fn write, void *user) {
    const sm_dist *d = w->dist;
    uint64_t counts[2] = {w->clamped, w->projected}, sums[2];
    MPI_Allreduce(counts, sums, 2, MPI_UINT64_T, MPI_SUM, d->comm);
    const double vmax2 = sm_dist_max(w, w->step_vmax2);
    sm_particles P;
    sm_status st = SM_OK;
    if (!gather_particles(w, &P)) st = SM_ERR_NOMEM;
    else if (d->rank == 0) {
        uint32_t *order = malloc((P.n ? P.n : 1) * sizeof *order);
        uint64_t *pairs = malloc((P.n ? P.n : 1) * sizeof *pairs);
        if (!order || !pairs) st = SM_ERR_NOMEM;
        else {
            for (size_t i = 0; i < P.n; i++) pairs[i] = ((uint64_t)P.id[i] << 32) | i;
            qsort(pairs, P.n, sizeof *pairs, sm_dist_cmp_u64);
            for (size_t i = 0; i < P.n; i++) order[i] = (uint32_t)pairs[i];
            sm_particles_permute(&P, w->dim, order);
            sm_world one = *w; /* a shallow copy: the save only reads it */
            one.p = P;
            one.dist = NULL;
            one.clamped = sums[0];
            one.projected = sums[1];
            one.step_vmax2 = vmax2;
            st = sm_world_save(&one, write, user);
        }
        free(order);
        free(pairs);
    }
    sm_particles_free(&P);
    int code = (int)st;
    MPI_Bcast(&code, 1, MPI_INT, 0, d->comm);
    return (sm_status)code;
}

/* ---- Creation and the public calls ---------------------------------------------------------- */

void sm_dist_free(sm_dist *d) {
    if (!d) return;
    for (int r = 0; r < d->size; r++) {
        if (d->own_out) free(d->own_out[r].data);
        if (d->ghost_out) free(d->ghost_out[r].data);
    }
    free(d->own_out);
    free(d->ghost_out);
    free(d->in.data);
    free(d->counts);
    free(d->req);
    free(d->cuts);
    free(d->hist);
    free(d->scratch);
    free(d->lists);
    free(d->side);
    free(d->side_key);
    sm_dist_halo_free(d->halo);
    MPI_Comm_free(&d->comm);
    free(d);
}

sm_dist *sm_dist_create(const sm_world *w, MPI_Comm comm) {
    sm_dist *d = calloc(1, sizeof *d);
    if (!d) return NULL;
    MPI_Comm_dup(comm, &d->comm);
    MPI_Comm_rank(d->comm, &d->rank);
    MPI_Comm_size(d->comm, &d->size);
    d->dim = w->dim;
    d->stencil = w->def.kernel == SM_KERNEL_CUBIC ? 4 : 3;
    for (int a = 0; a < 3; a++) d->lo[a] = w->def.domain_min[a];
    d->inv_dx = w->inv_dx;
    const size_t P = (size_t)d->size;
    d->cuts = calloc(P, sizeof *d->cuts);
    d->own_out = calloc(P, sizeof *d->own_out);
    d->ghost_out = calloc(P, sizeof *d->ghost_out);
    d->counts = calloc(4 * P, sizeof *d->counts);
    d->req = calloc(2 * P, sizeof *d->req);
    d->req_cap = 2 * P;
    d->piece = SM_DIST_PIECE;
    d->overlap = 1;
    if (!d->cuts || !d->own_out || !d->ghost_out || !d->counts || !d->req) {
        sm_dist_free(d);
        return NULL;
    }
    d->stats.rank = d->rank;
    d->stats.ranks = d->size;
    return d;
}

void sm_dist_attach(sm_world *w, sm_dist *d) {
    w->dist = d;
    w->bins.keep_storage = 1;
    w->dirty = 1;
}

sm_status sm_world_distribute(sm_world *w, MPI_Comm comm) {
    if (w->dist) return sm_world_fail(w, SM_ERR_INVALID, "sm_world_distribute: the world is distributed already");
    uint64_t h[2] = {sm_world_state_hash(w), (uint64_t)w->p.n}, lo[2], hi[2];
    MPI_Allreduce(h, lo, 2, MPI_UINT64_T, MPI_MIN, comm);
    MPI_Allreduce(h, hi, 2, MPI_UINT64_T, MPI_MAX, comm);
    if (lo[0] != hi[0] || lo[1] != hi[1])
        return sm_world_fail(w, SM_ERR_INVALID,
                             "sm_world_distribute: the ranks' worlds differ (%llu to %llu particles, different states): "
                             "every rank must build the same world",
                             (unsigned long long)lo[1], (unsigned long long)hi[1]);
    sm_dist *d = sm_dist_create(w, comm);
    if (!d) return sm_world_fail(w, SM_ERR_NOMEM, "sm_world_distribute: out of memory");
    /* Every rank holds every particle: the same histogram everywhere, no communication. */
    d->owned = w->p.n;
    const long np = block_histogram(d, &w->p, w->p.n);
    if (np < 0) {
        sm_dist_free(d);
        return sm_world_fail(w, SM_ERR_NOMEM, "sm_world_distribute: out of memory");
    }
    sm_dist_cuts_from_histogram(d, d->hist, (size_t)np);
    sm_dist_attach(w, d);
    sm_dist_adopt(w, 0);
    return SM_OK;
}

int sm_world_dist_stats(const sm_world *w, sm_dist_stats *out) {
    memset(out, 0, sizeof *out);
    if (!w->dist) return 0;
    *out = w->dist->stats;
    out->particles = w->dist->owned;
    return 1;
}
