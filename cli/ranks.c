/* `sandmpm run` across MPI ranks (mpirun -np N sandmpm run SCENE, N > 1): every rank loads and
 * builds the same scene and advances its share of the world (include/sandmpm/sandmpm_mpi.h); rank
 * 0 alone claims the output folder. At each frame the ranks cut the run into id slices and every
 * rank writes its slice's parts of the frame files and checkpoints (ranks_files.c, MPI-IO), so
 * that no rank holds the whole run and the files are the one-process bytes on any number of
 * ranks; rank 0 writes the small files (manifests, diagnostics) from its own part and the
 * diagnostics summed over the ranks. Only for PNG renders (--render) do the ranks save the world
 * collectively into rank 0's memory (every particle in id order: the one-rank checkpoint format),
 * and rank 0 restores it into the view, a second world it built from the scene (so that mesh
 * colliders, whose fields a checkpoint does not hold, and motion functions are there). The other
 * ranks print nothing (their standard output and error go to /dev/null once MPI is up): every
 * failure is agreed on, and rank 0 reports it.
 *
 * Without MPI (a build with SM_MPI off) these are the one-process answers, and a start under
 * mpirun with several ranks is refused. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/checkpoint.h"
#include "app/io/files.h"
#include "cli/cli.h"
#include "sandmpm/config.h"

int cli_ranks_launched(void) {
    const char *v = getenv("OMPI_COMM_WORLD_SIZE");
    if (!v) v = getenv("PMI_SIZE");
    const int n = v ? atoi(v) : 1;
    return n > 1 ? n : 1;
}

/* The checkpoint at path restored into the world of one process. */
static sm_status restore_one(sm_world *w, const char *path, char *err, size_t errlen) {
    sm_checkpoint_file f;
    sm_status st = sm_checkpoint_open(path, 0, &f, err, errlen);
    if (st != SM_OK) return st;
    st = sm_world_restore_read(w, sm_checkpoint_pread, &f, f.stream_bytes);
    sm_checkpoint_close(&f);
    snprintf(err, errlen, "%s", st == SM_OK ? "" : sm_world_errmsg(w));
    return st;
}

#if SM_HAVE_MPI
#include "sandmpm/sandmpm_mpi.h"

static int mpi_up;

int cli_ranks_init(int *argc, char ***argv) {
    if (cli_ranks_launched() <= 1) return 1;
    int provided;
    if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) return 0;
    mpi_up = 1;
    int rank;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    if (rank != 0 && (!freopen("/dev/null", "w", stdout) || !freopen("/dev/null", "w", stderr))) return 0;
    return 1;
}

void cli_ranks_finalize(void) {
    if (mpi_up) MPI_Finalize();
    mpi_up = 0;
}

int cli_rank(void) {
    int r = 0;
    if (mpi_up) MPI_Comm_rank(MPI_COMM_WORLD, &r);
    return r;
}

int cli_ranks_count(void) {
    int n = 1;
    if (mpi_up) MPI_Comm_size(MPI_COMM_WORLD, &n);
    return n;
}

sm_status cli_ranks_share_status(sm_status st) {
    int code = (int)st;
    if (mpi_up) MPI_Bcast(&code, 1, MPI_INT, 0, MPI_COMM_WORLD);
    return (sm_status)code;
}

sm_status cli_ranks_worst(sm_status st) {
    int code = (int)st, worst = code;
    if (mpi_up) MPI_Allreduce(&code, &worst, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return (sm_status)worst;
}

int cli_ranks_share_ints(int *v, int n) {
    if (mpi_up) MPI_Bcast(v, n, MPI_INT, 0, MPI_COMM_WORLD);
    return 1;
}

int cli_ranks_share_bytes(unsigned char **data, size_t *len) {
    if (!mpi_up) return 1;
    unsigned long long n = *len;
    MPI_Bcast(&n, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
    int ok = 1, all = 0;
    if (cli_rank() != 0) {
        *len = (size_t)n;
        *data = malloc(n ? (size_t)n : 1);
        ok = *data != NULL;
    }
    MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (!all) return 0;
    for (unsigned long long at = 0; at < n;) { /* MPI counts are int: 1 GiB pieces */
        const int piece = (int)(n - at < (1ull << 30) ? n - at : (1ull << 30));
        MPI_Bcast(*data + at, piece, MPI_BYTE, 0, MPI_COMM_WORLD);
        at += (unsigned long long)piece;
    }
    return 1;
}

/* ---- The frame loop's hooks (app/run.h: sm_run_ranks) ----------------------------------------- */

typedef struct mem_stream {
    unsigned char *data;
    size_t len, cap;
} mem_stream;

static int mem_write(void *user, const void *data, size_t len) {
    mem_stream *m = user;
    if (m->len + len > m->cap) {
        size_t cap = m->cap ? m->cap : 1 << 20;
        while (cap < m->len + len) cap *= 2;
        unsigned char *p = realloc(m->data, cap);
        if (!p) return 1;
        m->data = p;
        m->cap = cap;
    }
    memcpy(m->data + m->len, data, len);
    m->len += len;
    return 0;
}

/* The whole world into the view on rank 0 (collective), and each rank's particle count. */
static sm_status gather(void *ctx, const sm_world *w, sm_world **view, char *err, size_t errlen) {
    cli_ranks *r = ctx;
    const int no_view = r->rank == 0 && !r->view; /* cmd_run.c builds it when a sink needs the whole world */
    if (no_view) snprintf(err, errlen, "no world to gather the ranks' particles into (a bug)");
    if (cli_ranks_agree(ctx, no_view ? SM_ERR_INVALID : SM_OK, err, errlen) != SM_OK) return SM_ERR_INVALID;
    mem_stream m = {r->stream, 0, r->stream_cap};
    sm_status st = sm_world_save(w, mem_write, &m);
    r->stream = m.data;
    r->stream_cap = m.cap;
    cli_ranks_count_shares(r, w);
    if (st != SM_OK) snprintf(err, errlen, "gathering the ranks' particles on rank 0 failed (out of memory)");
    else if (r->rank == 0 && (st = sm_world_restore(r->view, m.data, m.len)) != SM_OK)
        snprintf(err, errlen, "the gathered world: %s", sm_world_errmsg(r->view));
    st = cli_ranks_share_status(st);
    *view = r->rank == 0 ? r->view : NULL;
    return st;
}

void cli_ranks_count_shares(cli_ranks *r, const sm_world *w) {
    sm_dist_stats ds;
    sm_world_dist_stats(w, &ds);
    unsigned long long mine = ds.particles;
    MPI_Gather(&mine, 1, MPI_UNSIGNED_LONG_LONG, r->shares, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
}

static int any(void *ctx, int flag) {
    (void)ctx;
    int all = 0;
    MPI_Allreduce(&flag, &all, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return all;
}

struct cli_seeding {
    sm_dist_seeding *share; /* the run's world */
    sm_dist_seeding *view;  /* rank 0's view: a census, so that it stores no particle */
    int resume;             /* the run's world a census too, its particles the checkpoint's */
};

static sm_status census_hook(void *user, sm_world *w) { return sm_world_seed_census(w, user); }
static void sum_hook(void *user, uint64_t *v, int n) {
    (void)user;
    MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
}
static sm_status share_hook(void *user, sm_world *w) { return sm_world_seed_share(w, user); }

void cli_seeding_free(cli_seeding *s) {
    if (!s) return;
    sm_dist_seeding_destroy(s->share);
    sm_dist_seeding_destroy(s->view);
    free(s);
}

sm_status cli_ranks_build(const char *cmd, const cli_scene_opts *so, sm_scene *sc, int resume, cli_seeding **seeding) {
    *seeding = NULL;
    if (cli_ranks_count() <= 1) return cli_build_scene(cmd, sc);
    cli_seeding *s = calloc(1, sizeof *s);
    sm_status st = s && sm_dist_seeding_create(MPI_COMM_WORLD, &s->share) == SM_OK &&
                           (cli_rank() != 0 || sm_dist_seeding_create(MPI_COMM_SELF, &s->view) == SM_OK)
                       ? SM_OK
                       : SM_ERR_NOMEM;
    if (st != SM_OK) fprintf(stderr, "sandmpm %s: out of memory\n", cmd);
    if (s) s->resume = resume;
    sm_scene *census = NULL;
    if (st == SM_OK && resume) sm_scene_on_world(sc, census_hook, s->share);
    else if (st == SM_OK) st = cli_build_again(cmd, so, census_hook, s->share, &census);
    sm_scene_destroy(census);
    st = cli_ranks_worst(st);
    sm_scene_on_sum(sc, sum_hook, NULL); /* the build's warnings count every rank's particles */
    if (st == SM_OK && resume) st = cli_ranks_worst(cli_build_scene(cmd, sc));
    else if (st == SM_OK) {
        sm_scene_on_world(sc, share_hook, s->share);
        st = cli_ranks_worst(cli_build_scene(cmd, sc));
    }
    if (st != SM_OK) cli_seeding_free(s);
    else *seeding = s;
    return st;
}

sm_status cli_ranks_build_view(const char *cmd, const cli_scene_opts *so, cli_seeding *seeding, sm_scene **view) {
    return cli_build_again(cmd, so, seeding ? census_hook : NULL, seeding ? seeding->view : NULL, view);
}

sm_status cli_ranks_open(cli_ranks *r, sm_world *w, sm_world *view, cli_seeding *seeding, char *err, size_t errlen) {
    memset(r, 0, sizeof *r);
    r->count = cli_ranks_count();
    r->rank = cli_rank();
    if (r->count <= 1) return SM_OK;
    r->view = r->rank == 0 ? view : NULL;
    r->shares = calloc((size_t)r->count, sizeof *r->shares);
    sm_status st = r->shares ? SM_OK : SM_ERR_NOMEM;
    if (st == SM_OK && seeding && seeding->resume) { /* distributed by cli_ranks_restore */
        sm_dist_stats ds;
        if (!sm_world_dist_stats(w, &ds)) snprintf(err, errlen, "the resumed world is not distributed (a bug)"), st = SM_ERR_INVALID;
    } else if (st == SM_OK &&
               (st = seeding ? sm_world_distribute_share(w, seeding->share) : sm_world_distribute(w, MPI_COMM_WORLD)) != SM_OK)
        snprintf(err, errlen, "%s", sm_world_errmsg(w));
    else if (st != SM_OK)
        snprintf(err, errlen, "out of memory");
    r->hooks = (sm_run_ranks){r, r->rank == 0, gather, cli_ranks_agree, any, cli_ranks_slice};
    return st;
}

sm_status cli_ranks_restore(sm_world *w, const char *path, char *err, size_t errlen) {
    if (cli_ranks_count() <= 1) return restore_one(w, path, err, errlen);
    sm_checkpoint_file f;
    char mine[SM_MSG_MAX] = "";
    const sm_status opened = sm_checkpoint_open(path, 0, &f, mine, sizeof mine);
    sm_status st = cli_ranks_agree(NULL, opened, mine, sizeof mine);
    if (st != SM_OK) {
        if (opened == SM_OK) sm_checkpoint_close(&f);
        snprintf(err, errlen, "%s", mine);
        return st;
    }
    st = sm_world_restore_share(w, MPI_COMM_WORLD, sm_checkpoint_pread, &f, f.stream_bytes);
    sm_checkpoint_close(&f);
    snprintf(err, errlen, "%s", st == SM_OK ? "" : sm_world_errmsg(w));
    return st;
}

void cli_ranks_close(cli_ranks *r) {
    sm_id_slice_destroy(r->slice);
    free(r->stream);
    free(r->shares);
    memset(r, 0, sizeof *r);
}

#else /* one process */

int cli_ranks_init(int *argc, char ***argv) {
    (void)argc, (void)argv;
    return cli_ranks_launched() <= 1;
}
void cli_ranks_finalize(void) {}
int cli_rank(void) { return 0; }
int cli_ranks_count(void) { return 1; }
sm_status cli_ranks_share_status(sm_status st) { return st; }
sm_status cli_ranks_worst(sm_status st) { return st; }
int cli_ranks_share_ints(int *v, int n) {
    (void)v, (void)n;
    return 1;
}
int cli_ranks_share_bytes(unsigned char **data, size_t *len) {
    (void)data, (void)len;
    return 1;
}
sm_status cli_ranks_build(const char *cmd, const cli_scene_opts *so, sm_scene *sc, int resume, cli_seeding **seeding) {
    (void)so, (void)resume;
    *seeding = NULL;
    return cli_build_scene(cmd, sc);
}
sm_status cli_ranks_build_view(const char *cmd, const cli_scene_opts *so, cli_seeding *seeding, sm_scene **view) {
    (void)seeding;
    return cli_build_again(cmd, so, NULL, NULL, view);
}
void cli_seeding_free(cli_seeding *s) { (void)s; }
sm_status cli_ranks_restore(sm_world *w, const char *path, char *err, size_t errlen) {
    return restore_one(w, path, err, errlen);
}
sm_status cli_ranks_open(cli_ranks *r, sm_world *w, sm_world *view, cli_seeding *seeding, char *err, size_t errlen) {
    (void)w, (void)view, (void)seeding, (void)err, (void)errlen;
    memset(r, 0, sizeof *r);
    r->count = 1;
    return SM_OK;
}
void cli_ranks_close(cli_ranks *r) { memset(r, 0, sizeof *r); }

#endif
