/* Seeding a distributed world without any rank holding every particle (sandmpm_mpi.h:
 * sm_dist_seeding). Two builds of the same world on every rank:
 *
 *   census: every particle added is counted in its particle block (the binner's block,
 *           dist.c's sm_dist_particle_block) and none is stored; ids advance as they would;
 *   share:  the cuts come from the census's counts exactly as sm_world_distribute computes them
 *           from a whole world (Morton order, floor(N r / P) particles before rank r's first
 *           block), and only the particles of this rank's blocks are stored, in the order they
 *           were added, with the ids they would have had.
 *
 * So after sm_world_distribute_share each rank holds what sm_world_distribute of the whole world
 * would have left it: the same particles, in the same order, with the same cuts (the run's bits do
 * not change). A rank's memory is its share plus the census's (Morton code, count) pairs: 16
 * bytes per block of sand (a block is 4^d cells), and a buffer of SM_SEED_PENDING codes. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/hash.h"
#include "dist/dist_internal.h"
#include "world/world.h"

#define SM_SEED_PENDING ((size_t)1 << 18)

enum { PHASE_NONE, PHASE_CENSUS, PHASE_SHARE };

struct sm_dist_seeding {
    MPI_Comm comm;
    int phase, failed;  /* failed: out of memory in the census */
    int have_geometry;  /* geo's dim, stencil, lo, inv_dx set by the first world */
    sm_dist geo;        /* the binner's geometry and, in the share phase, the cuts (rank, size) */
    uint64_t *pending;  /* block codes not yet merged into pairs */
    size_t npending;
    uint64_t *pairs;    /* (Morton code, particles) of the blocks counted so far, ascending code */
    size_t npairs;
    uint64_t counted;   /* particles counted by the census */
    uint64_t kept;      /* particles kept by the share */
};

/* The pending codes merged into the pairs (sorted, counts added where a block is in both). */
static int merge_pending(sm_dist_seeding *s) {
    if (s->npending == 0) return 1;
    qsort(s->pending, s->npending, sizeof *s->pending, sm_dist_cmp_u64);
    uint64_t *out = malloc((2 * (s->npairs + s->npending)) * sizeof *out);
    if (!out) return 0;
    size_t n = 0, i = 0, j = 0;
    while (i < s->npairs || j < s->npending) {
        uint64_t code, count = 0;
        if (j == s->npending || (i < s->npairs && s->pairs[2 * i] <= s->pending[j])) {
            code = s->pairs[2 * i];
            count = s->pairs[2 * i++ + 1];
        } else code = s->pending[j];
        while (j < s->npending && s->pending[j] == code) j++, count++;
        out[2 * n] = code;
        out[2 * n++ + 1] = count;
    }
    free(s->pairs);
    s->pairs = out;
    s->npairs = n;
    s->npending = 0;
    return 1;
}

static uint64_t code_of(const sm_dist_seeding *s, const double x[3]) {
    int b[3];
    sm_dist_particle_block(&s->geo, x, b);
    return sm_dist_morton(s->geo.dim, b);
}

static int census_keep(void *user, const double x[3]) {
    sm_dist_seeding *s = user;
    if (s->failed) return 0;
    if (s->npending == SM_SEED_PENDING && !merge_pending(s)) s->failed = 1;
    else s->pending[s->npending++] = code_of(s, x);
    s->counted++;
    return 0;
}

static int share_keep(void *user, const double x[3]) {
    sm_dist_seeding *s = user;
    const int mine = sm_dist_owner(&s->geo, code_of(s, x)) == s->geo.rank;
    s->kept += (uint64_t)mine;
    return mine;
}

sm_status sm_dist_seeding_create(MPI_Comm comm, sm_dist_seeding **out) {
    *out = NULL;
    sm_dist_seeding *s = calloc(1, sizeof *s);
    if (!s) return SM_ERR_NOMEM;
    s->comm = comm;
    MPI_Comm_rank(comm, &s->geo.rank);
    MPI_Comm_size(comm, &s->geo.size);
    s->pending = malloc(SM_SEED_PENDING * sizeof *s->pending);
    s->geo.cuts = calloc((size_t)s->geo.size, sizeof *s->geo.cuts);
    if (!s->pending || !s->geo.cuts) {
        sm_dist_seeding_destroy(s);
        return SM_ERR_NOMEM;
    }
    *out = s;
    return SM_OK;
}

void sm_dist_seeding_destroy(sm_dist_seeding *s) {
    if (!s) return;
    free(s->pending);
    free(s->pairs);
    free(s->geo.cuts);
    free(s);
}

static void take_geometry(sm_dist_seeding *s, const sm_world *w) {
    s->geo.dim = w->dim;
    s->geo.stencil = w->def.kernel == SM_KERNEL_CUBIC ? 4 : 3;
    for (int a = 0; a < 3; a++) s->geo.lo[a] = w->def.domain_min[a];
    s->geo.inv_dx = w->inv_dx;
    s->have_geometry = 1;
}

/* w may join s: no particle added yet, no other seeding, the geometry of the first world. */
static sm_status attach(sm_world *w, sm_dist_seeding *s, const char *call) {
    if (w->dist) return sm_world_fail(w, SM_ERR_INVALID, "%s: the world is distributed already", call);
    if (w->next_id != 0 || w->p.n != 0 || w->keep)
        return sm_world_fail(w, SM_ERR_INVALID, "%s: the world must have no particles yet (and no other seeding)", call);
    const int stencil = w->def.kernel == SM_KERNEL_CUBIC ? 4 : 3;
    if (!s->have_geometry) take_geometry(s, w);
    int same = s->geo.dim == w->dim && s->geo.stencil == stencil && s->geo.inv_dx == w->inv_dx;
    for (int a = 0; a < 3; a++) same = same && s->geo.lo[a] == w->def.domain_min[a];
    if (!same)
        return sm_world_fail(w, SM_ERR_INVALID,
                             "%s: the world's grid (dimension, dx, domain corner, kernel) differs from the census's", call);
    return SM_OK;
}

sm_status sm_world_seed_census(sm_world *w, sm_dist_seeding *s) {
    if (s->phase != PHASE_NONE)
        return sm_world_fail(w, SM_ERR_INVALID, "sm_world_seed_census: this seeding has taken its census already");
    sm_status st = attach(w, s, "sm_world_seed_census");
    if (st != SM_OK) return st;
    s->phase = PHASE_CENSUS;
    w->keep = census_keep;
    w->keep_user = s;
    return SM_OK;
}

/* The census's counts the same on every rank (every rank counted every particle): the cuts.
 * Collective; the status is the same on every rank, its message in err. */
static sm_status cut_counts(sm_dist_seeding *s, char *err, size_t errlen) {
    int bad = !merge_pending(s) || s->failed, any_bad = 0;
    MPI_Allreduce(&bad, &any_bad, 1, MPI_INT, MPI_MAX, s->comm);
    if (any_bad) {
        snprintf(err, errlen, "out of memory for the census");
        return SM_ERR_NOMEM;
    }
    /* the ranks' censuses agree: the same count and pairs */
    uint64_t mine[2] = {s->counted, sm_hash64(s->pairs, 2 * s->npairs * sizeof *s->pairs, 0)}, lo[2], hi[2];
    MPI_Allreduce(mine, lo, 2, MPI_UINT64_T, MPI_MIN, s->comm);
    MPI_Allreduce(mine, hi, 2, MPI_UINT64_T, MPI_MAX, s->comm);
    if (lo[0] != hi[0] || lo[1] != hi[1]) {
        snprintf(err, errlen, "the ranks' censuses differ (%llu to %llu particles): every rank must build the same world",
                 (unsigned long long)lo[0], (unsigned long long)hi[0]);
        return SM_ERR_INVALID;
    }
    sm_dist_cuts_from_histogram(&s->geo, s->pairs, s->npairs);
    return SM_OK;
}

static sm_status cut(sm_world *w, sm_dist_seeding *s) {
    char msg[256];
    const sm_status st = cut_counts(s, msg, sizeof msg);
    return st == SM_OK ? st : sm_world_fail(w, st, "sm_world_seed_share: %s", msg);
}

sm_status sm_world_seed_share(sm_world *w, sm_dist_seeding *s) {
    if (s->phase == PHASE_NONE)
        return sm_world_fail(w, SM_ERR_INVALID, "sm_world_seed_share: no census yet (sm_world_seed_census first)");
    if (s->phase == PHASE_SHARE)
        return sm_world_fail(w, SM_ERR_INVALID, "sm_world_seed_share: this seeding has its share's world already");
    sm_status st = attach(w, s, "sm_world_seed_share");
    if (st == SM_OK) st = cut(w, s); /* collective */
    if (st != SM_OK) return st;
    s->phase = PHASE_SHARE;
    w->keep = share_keep;
    w->keep_user = s;
    return SM_OK;
}

/* w, holding this rank's share, made its part of the run with s's cuts (collective). */
static sm_status adopt_cuts(sm_world *w, sm_dist_seeding *s, const char *call) {
    sm_dist *d = sm_dist_create(w, s->comm);
    int ok = d != NULL, all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, s->comm);
    if (!all_ok) {
        sm_dist_free(d);
        return sm_world_fail(w, SM_ERR_NOMEM, "%s: out of memory", call);
    }
    memcpy(d->cuts, s->geo.cuts, (size_t)d->size * sizeof *d->cuts);
    d->owned = w->p.n;
    w->keep = NULL; /* particles added from now on (emitters): on every rank, each keeps its blocks' */
    w->keep_user = NULL;
    sm_dist_attach(w, d);
    return SM_OK;
}

sm_status sm_world_distribute_share(sm_world *w, sm_dist_seeding *s) {
    const int ours = s->phase == PHASE_SHARE && w->keep == share_keep && w->keep_user == s;
    uint64_t mine[3] = {(uint64_t)!ours, (uint64_t)w->p.n, w->next_id}, sum[3], lo, hi;
    MPI_Allreduce(mine, sum, 3, MPI_UINT64_T, MPI_SUM, s->comm);
    MPI_Allreduce(&w->next_id, &lo, 1, MPI_UINT64_T, MPI_MIN, s->comm);
    MPI_Allreduce(&w->next_id, &hi, 1, MPI_UINT64_T, MPI_MAX, s->comm);
    if (sum[0])
        return sm_world_fail(w, SM_ERR_INVALID,
                             "sm_world_distribute_share: a rank's world was not seeded with this seeding's share "
                             "(sm_world_seed_share on the world before its particles)");
    if (lo != hi || hi != s->counted || sum[1] != s->counted)
        return sm_world_fail(w, SM_ERR_INVALID,
                             "sm_world_distribute_share: the ranks kept %llu of %llu particles (census: %llu): every rank "
                             "must build the census's world again",
                             (unsigned long long)sum[1], (unsigned long long)hi, (unsigned long long)s->counted);
    return adopt_cuts(w, s, "sm_world_distribute_share");
}

/* ---- Restoring a checkpoint by shares (sm_world_restore_share) ------------------------------- */

static void restore_census(void *user, const double x[3]) { (void)census_keep(user, x); }

static sm_status restore_cut(void *user, sm_status st, char *err, size_t errlen) {
    sm_dist_seeding *s = user;
    int bad = st != SM_OK, any_bad = 0;
    MPI_Allreduce(&bad, &any_bad, 1, MPI_INT, MPI_MAX, s->comm);
    if (any_bad) {
        if (err && errlen) snprintf(err, errlen, "checkpoint: another rank could not read it");
        return st != SM_OK ? st : SM_ERR_IO;
    }
    return cut_counts(s, err, errlen);
}

/* The worst status over the ranks: a rank that succeeded reports the others' failure. */
static sm_status agree(sm_world *w, MPI_Comm comm, sm_status st) {
    int mine = (int)st, worst = 0; /* the largest status code: the same on every rank */
    MPI_Allreduce(&mine, &worst, 1, MPI_INT, MPI_MAX, comm);
    if (worst != SM_OK && st == SM_OK) return sm_world_fail(w, (sm_status)worst, "checkpoint: another rank could not restore it");
    return st;
}

sm_status sm_world_restore_share(sm_world *w, MPI_Comm comm, sm_pread_fn read, void *user, uint64_t len) {
    if (w->dist) return sm_world_fail(w, SM_ERR_INVALID, "sm_world_restore_share: the world is distributed already");
    sm_dist_seeding *s = NULL;
    sm_status st = agree(w, comm, sm_dist_seeding_create(comm, &s));
    if (st != SM_OK) {
        sm_dist_seeding_destroy(s);
        return st == SM_ERR_NOMEM ? sm_world_fail(w, st, "sm_world_restore_share: out of memory") : st;
    }
    take_geometry(s, w);
    s->phase = PHASE_SHARE;
    w->keep = NULL; /* a census the world was built with (to store none of the scene's particles) */
    w->keep_user = NULL;
    const sm_restore_filter f = {s, restore_census, restore_cut, share_keep};
    st = agree(w, comm, read ? sm_world_restore_from(w, read, user, len, &f) : SM_ERR_INVALID);
    uint64_t mine = w->p.n, sum = 0;
    MPI_Allreduce(&mine, &sum, 1, MPI_UINT64_T, MPI_SUM, comm);
    if (st == SM_OK && sum != s->counted)
        st = sm_world_fail(w, SM_ERR_INVALID, "sm_world_restore_share: the ranks kept %llu of the checkpoint's %llu particles",
                           (unsigned long long)sum, (unsigned long long)s->counted);
    if (st == SM_OK) st = adopt_cuts(w, s, "sm_world_restore_share");
    sm_dist_seeding_destroy(s);
    return st;
}
