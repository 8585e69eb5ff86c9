/* Id slices (sandmpm_mpi.h): every particle of a distributed run in id order, cut into one
 * contiguous piece per rank, so that the ranks write one file together (a frame, a checkpoint)
 * without any rank holding the whole run.
 *
 * The cut: ids lie in [0, next_id). They are counted in B buckets of W = ceil(next_id / B) ids
 * (B = 256 per rank, at most 2^20), the counts summed over the ranks, and rank r's slice starts at
 * the first bucket whose preceding count reaches floor(N r / P) (N particles, P ranks), as the
 * block cuts do (dist.c). Each particle goes, with every field, to the rank of its id's bucket
 * (one message per pair of ranks, in pieces: message.c); each rank sorts what it received by id.
 * Rank r's particles are then those at positions first_r .. first_r + n_r - 1 of the whole run in
 * id order, first_r = sum of n_q for q < r.
 *
 * The slice's world is a copy of the run's state at the moment of the cut (clock, statistics,
 * collider poses, emitter counters, materials) with the slice's particles and no decomposition;
 * the counters are summed and the last step's largest speed taken over the ranks, as
 * sm_world_save of a distributed world does, so its checkpoint stream (sm_id_slice_save) is the
 * same bytes. */
#include <stdlib.h>
#include <string.h>

#include "dist/dist_internal.h"
#include "world/world.h"

#define SLICE_TAG 22

struct sm_id_slice {
    sm_world w;      /* the run's state with the slice's particles (its own copies below) */
    uint64_t first;  /* position of the slice's first particle in the whole run's id order */
    uint64_t total;  /* particles of the whole run */
    MPI_Comm comm;   /* the run's (not owned) */
    int rank;
};

/* The copy of w's state that the slice keeps (arrays a later step changes are copied; grid, bins
 * and caches are left out: nothing reads them from a slice). */
static int copy_state(sm_id_slice *s, const sm_world *w) {
    sm_world *c = &s->w;
    *c = *w;
    memset(&c->p, 0, sizeof c->p);
    memset(&c->grid, 0, sizeof c->grid);
    memset(&c->bins, 0, sizeof c->bins);
    c->bins.reorders = w->bins.reorders;
    memset(&c->cache, 0, sizeof c->cache);
    memset(&c->imp, 0, sizeof c->imp);
    c->dist = NULL;
    c->emit_buf = NULL;
    c->emit_cap = 0;
    c->keep = NULL;
    c->interrupt = NULL;
    const int ncol = w->ncolliders + w->nwalls;
    c->mats = malloc((size_t)(w->nmats ? w->nmats : 1) * sizeof *c->mats);
    c->colliders = malloc((size_t)(ncol ? ncol : 1) * sizeof *c->colliders);
    c->emitters = malloc((size_t)(w->nemitters ? w->nemitters : 1) * sizeof *c->emitters);
    c->mats_cap = w->nmats;
    c->colliders_cap = ncol;
    c->emitters_cap = w->nemitters;
    if (!c->mats || !c->colliders || !c->emitters) return 0;
    if (w->nmats) memcpy(c->mats, w->mats, (size_t)w->nmats * sizeof *c->mats); /* w's arrays: NULL when empty */
    if (ncol) memcpy(c->colliders, w->colliders, (size_t)ncol * sizeof *c->colliders);
    if (w->nemitters) memcpy(c->emitters, w->emitters, (size_t)w->nemitters * sizeof *c->emitters);
    return 1;
}

void sm_id_slice_destroy(sm_id_slice *s) {
    if (!s) return;
    sm_particles_free(&s->w.p);
    free(s->w.mats);
    free(s->w.colliders);
    free(s->w.emitters);
    free(s);
}

/* P's particles in ascending id; 0 when out of memory. */
static int sort_by_id(sm_particles *P, int dim) {
    uint64_t *pairs = malloc((P->n ? P->n : 1) * sizeof *pairs);
    uint32_t *order = malloc((P->n ? P->n : 1) * sizeof *order);
    const int ok = pairs && order;
    if (ok) {
        for (size_t i = 0; i < P->n; i++) pairs[i] = (uint64_t)P->id[i] << 32 | i;
        qsort(pairs, P->n, sizeof *pairs, sm_dist_cmp_u64);
        for (size_t i = 0; i < P->n; i++) order[i] = (uint32_t)pairs[i];
        sm_particles_permute(P, dim, order);
    }
    free(pairs);
    free(order);
    return ok;
}

/* The particles of [0, n) of src appended to dst (every field). */
static int copy_particles(sm_particles *dst, const sm_particles *src, int dim, size_t n) {
    const size_t ps = sm_particles_packed_size(dim);
    unsigned char *buf = malloc(ps);
    const int ok = buf && sm_particles_reserve(dst, dim, dst->n + n) == SM_OK;
    for (size_t i = 0; ok && i < n; i++) {
        sm_particles_pack(src, dim, i, buf);
        sm_particles_unpack(dst, dim, dst->n++, buf);
    }
    free(buf);
    return ok;
}

/* The buckets' first ids of each rank's slice: bucket_of(id) = id / width, rank r takes buckets
 * [start[r], start[r + 1]). */
typedef struct slice_cut {
    uint64_t width, buckets;
    uint64_t *start; /* size + 1 entries */
} slice_cut;

static int rank_of(const slice_cut *c, int size, uint64_t id) {
    const uint64_t b = id / c->width;
    int lo = 0, hi = size - 1; /* the largest r with start[r] <= b */
    while (lo < hi) {
        const int mid = (lo + hi + 1) / 2;
        if (c->start[mid] <= b) lo = mid;
        else hi = mid - 1;
    }
    return lo;
}

/* The cut from every rank's id counts (collective); 0 when out of memory on some rank. */
static int make_cut(const sm_world *w, const sm_dist *d, slice_cut *c, uint64_t *total) {
    uint64_t next = w->next_id, all_next = 0;
    MPI_Allreduce(&next, &all_next, 1, MPI_UINT64_T, MPI_MAX, d->comm);
    uint64_t b = 256 * (uint64_t)d->size;
    if (b > (1u << 20)) b = 1u << 20;
    if (b > all_next) b = all_next ? all_next : 1;
    c->buckets = b;
    c->width = all_next ? (all_next + b - 1) / b : 1;
    uint64_t *mine = calloc(b, sizeof *mine), *sum = malloc(b * sizeof *sum);
    c->start = malloc(((size_t)d->size + 1) * sizeof *c->start);
    int ok = mine && sum && c->start, all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
    if (all_ok) {
        for (size_t i = 0; i < d->owned; i++) mine[w->p.id[i] / c->width]++;
        MPI_Allreduce(mine, sum, (int)b, MPI_UINT64_T, MPI_SUM, d->comm);
        uint64_t n = 0;
        for (uint64_t k = 0; k < b; k++) n += sum[k];
        *total = n;
        uint64_t before = 0, k = 0;
        c->start[0] = 0;
        for (int r = 1; r <= d->size; r++) {
            const uint64_t target = n * (uint64_t)r / (uint64_t)d->size;
            while (k < b && before < target) before += sum[k++];
            c->start[r] = r == d->size ? b : k;
        }
    }
    free(mine);
    free(sum);
    return all_ok;
}

/* Sends every owned particle to the rank of its id and receives this rank's into P (collective);
 * 0 when out of memory on some rank. */
static int redistribute(const sm_world *w, sm_dist *d, const slice_cut *c, sm_particles *P) {
    const size_t ps = sm_particles_packed_size(d->dim), size = (size_t)d->size;
    uint64_t *cnt = calloc(4 * size, sizeof *cnt), *sent = cnt + size, *recv = cnt + 2 * size, *at = cnt + 3 * size;
    int *dest = malloc((d->owned ? d->owned : 1) * sizeof *dest);
    int ok = cnt && dest, all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
    unsigned char *out = NULL, *in = NULL;
    if (all_ok) {
        for (size_t i = 0; i < d->owned; i++) cnt[dest[i] = rank_of(c, d->size, w->p.id[i])]++;
        MPI_Alltoall(cnt, 1, MPI_UINT64_T, recv, 1, MPI_UINT64_T, d->comm);
        uint64_t nin = 0, nreq = 0;
        for (size_t r = 0; r < size; r++) {
            sent[r] = r ? sent[r - 1] + cnt[r - 1] : 0; /* where rank r's particles start in out */
            at[r] = nin;
            nin += recv[r];
            if ((int)r != d->rank) nreq += sm_dist_request_count(d, cnt[r] * ps) + sm_dist_request_count(d, recv[r] * ps);
        }
        out = malloc(d->owned ? d->owned * ps : 1);
        in = malloc(nin ? nin * ps : 1);
        ok = out && in && sm_dist_reserve_requests(d, nreq) && sm_particles_reserve(P, d->dim, nin) == SM_OK;
        MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
        if (all_ok) {
            uint64_t *fill = cnt; /* the counts become fill positions */
            for (size_t r = 0; r < size; r++) fill[r] = sent[r];
            for (size_t i = 0; i < d->owned; i++) sm_particles_pack(&w->p, d->dim, i, out + fill[dest[i]]++ * ps);
            size_t k = 0;
            for (size_t r = 0; r < size; r++) {
                const uint64_t n_out = fill[r] - sent[r];
                if ((int)r == d->rank) memcpy(in + at[r] * ps, out + sent[r] * ps, n_out * ps);
                else {
                    k += sm_dist_irecv(d, in + at[r] * ps, recv[r] * ps, (int)r, SLICE_TAG, k);
                    k += sm_dist_isend(d, out + sent[r] * ps, n_out * ps, (int)r, SLICE_TAG, k);
                }
            }
            sm_dist_wait(d, k);
            for (uint64_t i = 0; i < nin; i++) sm_particles_unpack(P, d->dim, i, in + i * ps);
            P->n = nin;
        }
    }
    free(cnt);
    free(dest);
    free(out);
    free(in);
    return all_ok;
}

/* The slice of a distributed world (collective). */
static sm_status slice_ranks(const sm_world *w, sm_id_slice *s) {
    sm_dist *d = w->dist;
    slice_cut c = {0, 0, NULL};
    uint64_t total = 0, n = 0;
    int ok = make_cut(w, d, &c, &total) && redistribute(w, d, &c, &s->w.p);
    ok = ok && sort_by_id(&s->w.p, w->dim);
    int all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, d->comm);
    free(c.start);
    if (!all_ok) return SM_ERR_NOMEM;
    n = s->w.p.n;
    MPI_Exscan(&n, &s->first, 1, MPI_UINT64_T, MPI_SUM, d->comm);
    if (d->rank == 0) s->first = 0; /* Exscan leaves rank 0's undefined */
    s->total = total;
    uint64_t counts[2] = {w->clamped, w->projected}, sums[2];
    MPI_Allreduce(counts, sums, 2, MPI_UINT64_T, MPI_SUM, d->comm);
    s->w.clamped = sums[0];
    s->w.projected = sums[1];
    s->w.step_vmax2 = sm_dist_max(w, w->step_vmax2);
    s->comm = d->comm;
    s->rank = d->rank;
    return SM_OK;
}

sm_status sm_world_id_slice(const sm_world *w, sm_id_slice **out) {
    *out = NULL;
    sm_id_slice *s = calloc(1, sizeof *s);
    int ok = s && copy_state(s, w), all_ok = ok;
    if (w->dist) MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, w->dist->comm);
    sm_status st = all_ok ? SM_OK : SM_ERR_NOMEM;
    if (st == SM_OK && w->dist) st = slice_ranks(w, s);
    else if (st == SM_OK) { /* one process: the whole world in id order */
        s->comm = MPI_COMM_SELF;
        s->total = w->p.n;
        if (!copy_particles(&s->w.p, &w->p, w->dim, w->p.n) || !sort_by_id(&s->w.p, w->dim)) st = SM_ERR_NOMEM;
    }
    if (st != SM_OK) sm_id_slice_destroy(s);
    else *out = s;
    return st;
}

const sm_world *sm_id_slice_world(const sm_id_slice *s) { return &s->w; }
uint64_t sm_id_slice_first(const sm_id_slice *s) { return s->first; }
uint64_t sm_id_slice_total(const sm_id_slice *s) { return s->total; }
MPI_Comm sm_id_slice_comm(const sm_id_slice *s) { return s->comm; }

sm_status sm_id_slice_save(const sm_id_slice *s, sm_pwrite_fn write, void *user, uint64_t *bytes) {
    return sm_world_save_part(&s->w, s->first, s->total, s->rank == 0, write, user, bytes);
}
