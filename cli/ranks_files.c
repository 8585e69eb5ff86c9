/* `sandmpm run` across MPI ranks: the part sinks' files (app/io/part_file.h) written with MPI-IO,
 * each rank its parts of one file at their offsets, so that no rank holds the whole run; the id
 * slice every frame's part sinks read (sandmpm_mpi.h: sm_world_id_slice); and the agreement of a
 * status over the ranks, with the message of the first rank that failed.
 *
 * A file: rank 0 names a temporary next to it (its pid) and every rank opens it with
 * MPI_File_open and truncates it; writes go in pieces of at most 1 GiB (MPI counts are int), each
 * piece's crc32 recorded (contiguous pieces merged with zlib's crc32_combine); the crc of
 * [0, bytes) is the ranks' pieces sorted by offset and combined on rank 0, after checking that
 * they tile [0, bytes) exactly; close syncs (if every rank wrote all it had), closes, and rank 0
 * renames the temporary over the file and syncs the folder, or removes it. */
#define _POSIX_C_SOURCE 200809L
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#include "app/io/files.h"
#include "cli/cli.h"
#include "sandmpm/config.h"

#if SM_HAVE_MPI
#include "sandmpm/sandmpm_mpi.h"

sm_status cli_ranks_agree(void *ctx, sm_status st, char *err, size_t errlen) {
    (void)ctx;
    int rank, me, first;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    me = st != SM_OK ? rank : INT_MAX;
    MPI_Allreduce(&me, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (first == INT_MAX) return SM_OK;
    int code = (int)st;
    char msg[SM_MSG_MAX] = "";
    if (rank == first) snprintf(msg, sizeof msg, "%s", err);
    MPI_Bcast(&code, 1, MPI_INT, first, MPI_COMM_WORLD);
    MPI_Bcast(msg, (int)sizeof msg, MPI_CHAR, first, MPI_COMM_WORLD);
    if (rank != first) {
        if (first == 0) snprintf(err, errlen, "%s", msg);
        else snprintf(err, errlen, "rank %d: %s", first, msg);
    }
    return (sm_status)code;
}

typedef struct part_piece {
    uint64_t off, len, crc;
} part_piece;

typedef struct part_file {
    MPI_File fh;
    int rank, failed, slot;
    char path[SM_PATH_MAX], tmp[SM_PATH_MAX], why[SM_MSG_MAX];
    part_piece *pieces;
    size_t n, cap;
} part_file;

static void mpi_why(part_file *f, const char *what, int code) {
    char s[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(code, s, &len);
    if (!f->failed) snprintf(f->why, sizeof f->why, "%s: %s: %s", f->path, what, s);
    f->failed = 1;
}

static void part_free(part_file *f) {
    if (f->slot >= 0) sm_untrack_temporary(f->slot);
    free(f->pieces);
    free(f);
}

static sm_status part_open(void *ctx, const char *path, void **file, char *err, size_t errlen) {
    part_file *f = calloc(1, sizeof *f);
    sm_status st = f ? SM_OK : SM_ERR_NOMEM;
    if (!f) snprintf(err, errlen, "%s: out of memory", path);
    if (f) {
        f->slot = -1;
        f->fh = MPI_FILE_NULL;
        MPI_Comm_rank(MPI_COMM_WORLD, &f->rank);
        snprintf(f->path, sizeof f->path, "%s", path);
        if (sm_temp_name(f->tmp, sizeof f->tmp, path, (long)getpid()) != 0) {
            snprintf(err, errlen, "%s: name too long", path);
            st = SM_ERR_IO;
        }
    }
    if ((st = cli_ranks_agree(ctx, st, err, errlen)) != SM_OK) {
        if (f) part_free(f);
        return st;
    }
    MPI_Bcast(f->tmp, (int)sizeof f->tmp, MPI_CHAR, 0, MPI_COMM_WORLD); /* rank 0's pid names it */
    if (f->rank == 0) f->slot = sm_track_temporary(f->tmp);
    int code = MPI_File_open(MPI_COMM_WORLD, f->tmp, MPI_MODE_WRONLY | MPI_MODE_CREATE, MPI_INFO_NULL, &f->fh);
    if (code != MPI_SUCCESS) mpi_why(f, "cannot create its temporary", code);
    if (f->failed) snprintf(err, errlen, "%s", f->why);
    st = cli_ranks_agree(ctx, f->failed ? SM_ERR_IO : SM_OK, err, errlen);
    if (st == SM_OK && (code = MPI_File_set_size(f->fh, 0)) != MPI_SUCCESS) { /* a stale temporary's bytes */
        mpi_why(f, "cannot truncate its temporary", code);
        snprintf(err, errlen, "%s", f->why);
    }
    if (st == SM_OK) st = cli_ranks_agree(ctx, f->failed ? SM_ERR_IO : SM_OK, err, errlen);
    if (st != SM_OK) {
        if (f->fh != MPI_FILE_NULL) MPI_File_close(&f->fh);
        if (f->rank == 0) unlink(f->tmp);
        part_free(f);
        return st;
    }
    *file = f;
    return SM_OK;
}

/* The piece [off, off + len) with its crc, merged into the last one when it follows it. */
static int record_piece(part_file *f, uint64_t off, const unsigned char *p, size_t len) {
    const uint64_t crc = crc32_z(crc32(0L, Z_NULL, 0), p, len);
    part_piece *last = f->n ? &f->pieces[f->n - 1] : NULL;
    if (last && last->off + last->len == off) {
        last->crc = crc32_combine((uLong)last->crc, (uLong)crc, (z_off_t)len);
        last->len += len;
        return 0;
    }
    if (f->n == f->cap) {
        size_t cap = f->cap ? 2 * f->cap : 64;
        part_piece *q = realloc(f->pieces, cap * sizeof *q);
        if (!q) return 1;
        f->pieces = q;
        f->cap = cap;
    }
    f->pieces[f->n++] = (part_piece){off, len, crc};
    return 0;
}

static int part_write_at(void *file, uint64_t offset, const void *data, size_t len) {
    part_file *f = file;
    const unsigned char *p = data;
    if (f->failed) return 1;
    if (len && record_piece(f, offset, p, len)) {
        snprintf(f->why, sizeof f->why, "%s: out of memory", f->path);
        f->failed = 1;
        return 1;
    }
    while (len > 0) {
        const int piece = (int)(len < (1u << 30) ? len : (1u << 30));
        MPI_Status ms;
        int code = MPI_File_write_at(f->fh, (MPI_Offset)offset, p, piece, MPI_BYTE, &ms);
        int wrote = 0;
        if (code == MPI_SUCCESS) MPI_Get_count(&ms, MPI_BYTE, &wrote);
        if (code != MPI_SUCCESS || wrote != piece) {
            mpi_why(f, "write failed", code);
            return 1;
        }
        p += piece;
        offset += (uint64_t)piece;
        len -= (size_t)piece;
    }
    return 0;
}

static int by_offset(const void *a, const void *b) {
    const part_piece *x = a, *y = b;
    return x->off < y->off ? -1 : x->off > y->off;
}

/* Rank 0: the pieces below bytes tile [0, bytes); their crcs combined in offset order. */
static int combine(part_piece *all, size_t n, uint64_t bytes, uint32_t *crc) {
    qsort(all, n, sizeof *all, by_offset);
    uLong c = crc32(0L, Z_NULL, 0);
    uint64_t at = 0;
    for (size_t i = 0; i < n && all[i].off < bytes; i++) {
        if (all[i].off != at || all[i].len > bytes - at) return 0;
        c = crc32_combine(c, (uLong)all[i].crc, (z_off_t)all[i].len);
        at += all[i].len;
    }
    *crc = (uint32_t)c;
    return at == bytes;
}

static sm_status part_crc(void *file, uint64_t bytes, uint32_t *crc, char *err, size_t errlen) {
    part_file *f = file;
    if (f->failed) snprintf(err, errlen, "%s", f->why);
    sm_status failed = cli_ranks_agree(NULL, f->failed ? SM_ERR_IO : SM_OK, err, errlen);
    if (failed != SM_OK) return failed; /* a write failed: no checksum to make */
    int size, mine = (int)(3 * f->n);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    int *counts = f->rank == 0 ? calloc((size_t)size, sizeof *counts) : NULL;
    int *displs = f->rank == 0 ? calloc((size_t)size, sizeof *displs) : NULL;
    MPI_Gather(&mine, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
    long long total = 0;
    for (int r = 0; f->rank == 0 && counts && displs && r < size; r++) {
        displs[r] = (int)total;
        total += counts[r];
    }
    part_piece *all = f->rank == 0 ? malloc((size_t)(total ? total : 1) * sizeof(uint64_t)) : NULL;
    sm_status st = f->rank == 0 && (!counts || !displs || !all || total > INT_MAX) ? SM_ERR_NOMEM : SM_OK;
    int go = st == SM_OK, all_go = 0;
    MPI_Allreduce(&go, &all_go, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (all_go)
        MPI_Gatherv(f->pieces, mine, MPI_UINT64_T, all, counts, displs, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    if (st != SM_OK) snprintf(err, errlen, "%s: out of memory for its checksum", f->path);
    else if (f->rank == 0 && !combine(all, (size_t)total / 3, bytes, crc)) {
        snprintf(err, errlen, "%s: the ranks' parts do not tile its %llu bytes (a bug)", f->path,
                 (unsigned long long)bytes);
        st = SM_ERR_IO;
    }
    free(counts);
    free(displs);
    free(all);
    return cli_ranks_agree(NULL, st, err, errlen);
}

/* The folder of path synced, so that the rename survives a crash. */
static void sync_folder(const char *path) {
    char dir[SM_PATH_MAX];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash) *slash = 0;
    int fd = open(slash ? dir : ".", O_RDONLY);
    if (fd >= 0) {
        fsync(fd);
        close(fd);
    }
}

/* ok: the same on every rank (an agreed status); without it the temporary is removed and err
 * keeps the caller's message. */
static sm_status part_close(void *file, int ok, char *err, size_t errlen) {
    part_file *f = file;
    sm_status st = SM_ERR_IO;
    if (ok) {
        if (f->failed) snprintf(err, errlen, "%s", f->why);
        st = cli_ranks_agree(NULL, f->failed ? SM_ERR_IO : SM_OK, err, errlen);
    }
    if (st == SM_OK) { /* collective: every rank calls it or none */
        int code = MPI_File_sync(f->fh);
        if (code != MPI_SUCCESS) mpi_why(f, "sync failed", code);
        if (f->failed) snprintf(err, errlen, "%s", f->why);
        st = cli_ranks_agree(NULL, f->failed ? SM_ERR_IO : SM_OK, err, errlen);
    }
    MPI_File_close(&f->fh);
    sm_status mine = SM_OK;
    if (f->rank == 0 && st == SM_OK && rename(f->tmp, f->path) != 0) {
        snprintf(err, errlen, "%s: cannot rename its temporary into place", f->path);
        mine = SM_ERR_IO;
    }
    if (st == SM_OK) st = cli_ranks_agree(NULL, mine, err, errlen);
    if (f->rank == 0 && st != SM_OK) unlink(f->tmp);
    if (f->rank == 0 && st == SM_OK) sync_folder(f->path);
    part_free(f);
    return st;
}

static sm_status part_save(void *ctx, sm_pwrite_fn write, void *user, uint64_t *bytes) {
    cli_ranks *r = ctx;
    return sm_id_slice_save(r->slice, write, user, bytes);
}

sm_status cli_ranks_slice(void *ctx, const sm_world *w, const sm_world **slice, const sm_part_io **part, char *err,
                          size_t errlen) {
    cli_ranks *r = ctx;
    sm_id_slice_destroy(r->slice);
    r->slice = NULL;
    sm_status st = sm_world_id_slice(w, &r->slice); /* the same status on every rank */
    cli_ranks_count_shares(r, w);
    if (st != SM_OK) {
        snprintf(err, errlen, "cutting the run's particles into id slices: out of memory");
        return st;
    }
    r->part = (sm_part_io){r->rank == 0, sm_id_slice_first(r->slice), sm_id_slice_total(r->slice), r, part_open,
                           part_write_at, part_crc, part_close, part_save, cli_ranks_agree};
    *slice = sm_id_slice_world(r->slice);
    *part = &r->part;
    return SM_OK;
}

#endif
