/* Checkpoint files: see checkpoint.h. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "app/checkpoint.h"
#include "app/io/files.h"

#define TRAILER_BYTES SM_CKPT_TRAILER_BYTES

typedef struct membuf {
    unsigned char *data;
    size_t len, cap;
} membuf;

static int mem_write(void *user, const void *p, size_t n) {
    membuf *b = user;
    if (b->len + n > b->cap) {
        size_t cap = (b->len + n) * 2;
        unsigned char *q = realloc(b->data, cap);
        if (!q) return 1;
        b->data = q;
        b->cap = cap;
    }
    memcpy(b->data + b->len, p, n);
    b->len += n;
    return 0;
}

static int write_all(int fd, const unsigned char *p, size_t n) {
    while (n > 0) {
        ssize_t k = write(fd, p, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return -1;
        p += k;
        n -= (size_t)k;
    }
    return 0;
}

/* A checkpoint file being written: bytes go through a 64 KiB buffer to the temporary, the crc32
 * and the length follow them (no copy of the stream in memory). */
typedef struct file_out {
    int fd, failed, err; /* err: errno of the first failure */
    size_t fill;
    uint64_t bytes;
    uLong crc;
    unsigned char buf[1 << 16];
} file_out;

static void flush_out(file_out *o) {
    if (!o->failed && o->fill && write_all(o->fd, o->buf, o->fill) != 0) {
        o->failed = 1;
        o->err = errno;
    }
    o->fill = 0;
}

static int file_write(void *user, const void *data, size_t n) {
    file_out *o = user;
    const unsigned char *p = data;
    o->crc = crc32_z(o->crc, p, n);
    o->bytes += n;
    while (n > 0 && !o->failed) {
        size_t k = sizeof o->buf - o->fill < n ? sizeof o->buf - o->fill : n;
        memcpy(o->buf + o->fill, p, k);
        o->fill += k;
        p += k;
        n -= k;
        if (o->fill == sizeof o->buf) flush_out(o);
    }
    return o->failed;
}

static void put_le(file_out *o, uint64_t v, int bytes) {
    unsigned char t[8];
    for (int i = 0; i < bytes; i++) t[i] = (unsigned char)(v >> (8 * i));
    file_write(o, t, (size_t)bytes);
}

/* The stream (from w, or the bytes of one saved earlier when w is NULL) and the trailer, written to
 * a temporary, fsynced, renamed to path, the folder fsynced. */
static sm_status write_durably(const char *dir, const char *path, const sm_world *w, const membuf *saved, int frame,
                               uint64_t scene_hash, char *err, size_t errlen) {
    char tmp[SM_PATH_MAX];
    if (sm_temp_name(tmp, sizeof tmp, path, (long)getpid()) != 0) {
        snprintf(err, errlen, "%s: name too long", path);
        return SM_ERR_IO;
    }
    file_out *o = calloc(1, sizeof *o);
    if (!o) {
        snprintf(err, errlen, "checkpoint of frame %d: out of memory", frame);
        return SM_ERR_NOMEM;
    }
    int slot = sm_track_temporary(tmp);
    o->fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    o->crc = crc32(0L, Z_NULL, 0);
    if (o->fd < 0) o->failed = 1, o->err = errno;
    if (!o->failed && w) sm_world_save(w, file_write, o);
    if (!o->failed && !w) file_write(o, saved->data, saved->len);
    const uint64_t stream = o->bytes;
    put_le(o, (uint64_t)frame, 4);
    put_le(o, scene_hash, 8);
    put_le(o, stream, 8);
    file_write(o, "SMCK", 4);
    put_le(o, o->crc, 4);
    flush_out(o);
    int ok = !o->failed && fsync(o->fd) == 0, e = o->failed ? o->err : errno;
    if (o->fd >= 0 && close(o->fd) != 0 && ok) ok = 0, e = errno;
    if (ok && rename(tmp, path) != 0) ok = 0, e = errno;
    free(o);
    if (!ok) unlink(tmp);
    if (slot >= 0) sm_untrack_temporary(slot);
    if (!ok) {
        snprintf(err, errlen, "%s: %s", path, strerror(e));
        return SM_ERR_IO;
    }
    int dfd = open(dir, O_RDONLY);
    if (dfd >= 0) {
        fsync(dfd);
        close(dfd);
    }
    return SM_OK;
}

/* Removes checkpoints older than the newest `keep` (names sort by frame: zero-padded). */
static void prune(const char *dir, int keep) {
    DIR *d = opendir(dir);
    if (!d) return;
    int frames[4096], n = 0;
    struct dirent *e;
    while ((e = readdir(d)) && n < 4096) {
        int f;
        char tail[8];
        if (sscanf(e->d_name, "ckpt_%d.sm%7s", &f, tail) == 2 && !strcmp(tail, "c")) frames[n++] = f;
    }
    closedir(d);
    for (int i = 0; i < n; i++) {
        int newer = 0;
        for (int j = 0; j < n; j++) newer += frames[j] > frames[i];
        if (newer >= keep) {
            char p[SM_PATH_MAX];
            if (snprintf(p, sizeof p, "%s/ckpt_%08d.smc", dir, frames[i]) < (int)sizeof p) unlink(p);
        }
    }
}

/* out_dir/checkpoints (made if missing) and the file name of frame's checkpoint in it. */
/* OUT/checkpoints and OUT/checkpoints/ckpt_FRAME.smc into dir and path. */
static sm_status checkpoint_name(const char *out_dir, int frame, char *dir, size_t dirlen, char *path, size_t pathlen,
                                 char *err, size_t errlen) {
    if (snprintf(dir, dirlen, "%s/checkpoints", out_dir) >= (int)dirlen - SM_NAME_RESERVE ||
        snprintf(path, pathlen, "%s/ckpt_%08d.smc", dir, frame) >= (int)pathlen) {
        snprintf(err, errlen, "%s: name too long for its checkpoints", out_dir);
        return SM_ERR_IO;
    }
    return SM_OK;
}

/* checkpoint_name, and the folder made. */
static sm_status checkpoint_path(const char *out_dir, int frame, char *dir, size_t dirlen, char *path, size_t pathlen,
                                 char *err, size_t errlen) {
    sm_status st = checkpoint_name(out_dir, frame, dir, dirlen, path, pathlen, err, errlen);
    return st == SM_OK ? sm_make_dirs(dir, err, errlen) : st;
}

sm_status sm_checkpoint_find(const char *out_dir, int frame, char *path, size_t pathlen, char *err, size_t errlen) {
    char dir[SM_PATH_MAX];
    sm_status st = checkpoint_name(out_dir, frame, dir, sizeof dir, path, pathlen, err, errlen);
    if (st != SM_OK || access(path, R_OK) == 0) return st;
    snprintf(err, errlen, "%s was not written", path);
    return SM_ERR_IO;
}

sm_status sm_checkpoint_write(const char *out_dir, const sm_world *w, int frame, uint64_t scene_hash, int keep, char *path,
                              size_t pathlen, char *err, size_t errlen) {
    char dir[SM_PATH_MAX];
    sm_status st = checkpoint_path(out_dir, frame, dir, sizeof dir, path, pathlen, err, errlen);
    if (st == SM_OK) st = write_durably(dir, path, w, NULL, frame, scene_hash, err, errlen);
    if (st == SM_OK) prune(dir, keep);
    return st;
}

/* The sink keeps the last frame's state in memory (one sm_world_save per frame: a copy of the
 * particle arrays; across ranks the run's id slice of that frame), so that a numerical failure in the
 * next frame, or a stop (in the middle of it, app/run.h: stop_at_step, or between frames), can
 * still write it. */
typedef struct ckpt_state {
    membuf last;        /* the stream of frame last_frame (one process) */
    const sm_part_io *io; /* across ranks: how the parts are written (NULL on one process); its id
                             slice, the run's own, stays that of last_frame until the next frame */
    int last_frame;     /* -1: none (the same on every rank) */
    const char *out;    /* the output folder */
} ckpt_state;

static int count_write(void *user, const void *data, size_t n) {
    (void)data;
    *(size_t *)user += n;
    return 0;
}

/* w's stream into b, whose capacity is made exactly the stream's size first (growing by doubling
 * would hold up to twice the particle data: docs/outputs.md, memory). */
static sm_status save_exactly(const sm_world *w, membuf *b) {
    size_t need = 0;
    sm_world_save(w, count_write, &need);
    if (need != b->cap) {
        unsigned char *q = realloc(b->data, need ? need : 1);
        if (!q) return SM_ERR_NOMEM;
        b->data = q;
        b->cap = need;
    }
    b->len = 0;
    return sm_world_save(w, mem_write, b);
}

static sm_status ckpt_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    ckpt_state *c = calloc(1, sizeof *c);
    if (!c) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    c->last_frame = -1;
    c->out = run->out_dir;
    s->state = c;
    return SM_OK;
}

/* Whether frame has its checkpoint by the schedule. */
static int scheduled(const sm_checkpoint_config *c, int frame) { return c->every > 0 && frame > 0 && frame % c->every == 0; }

/* The id slice as frame's checkpoint, across ranks (collective): rank 0 makes the folder and
 * prunes. */
static sm_status write_parts(const sm_checkpoint_config *c, ckpt_state *cs, int frame, char *err, size_t errlen) {
    char dir[SM_PATH_MAX], path[SM_PATH_MAX];
    sm_status st = cs->io->writer ? checkpoint_path(cs->out, frame, dir, sizeof dir, path, sizeof path, err, errlen)
                                  : checkpoint_name(cs->out, frame, dir, sizeof dir, path, sizeof path, err, errlen);
    st = cs->io->agree(cs->io->ctx, st, err, errlen);
    if (st == SM_OK) st = sm_ckpt_parts_write(cs->io, path, frame, c->scene_hash, err, errlen);
    if (st == SM_OK && cs->io->writer) prune(dir, c->keep);
    return st;
}

static sm_status ckpt_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    const sm_checkpoint_config *c = s->config;
    ckpt_state *cs = s->state;
    if (fr->part) { /* across ranks: written from the id slice, which the run keeps */
        cs->io = fr->part;
        cs->last_frame = fr->frame;
        return scheduled(c, fr->frame) ? write_parts(c, cs, fr->frame, err, errlen) : SM_OK;
    }
    cs->last.len = 0;
    cs->last_frame = save_exactly(fr->w, &cs->last) == SM_OK ? fr->frame : -1;
    if (!scheduled(c, fr->frame)) return SM_OK;
    char path[SM_PATH_MAX];
    return sm_checkpoint_write(fr->out_dir, fr->w, fr->frame, c->scene_hash, c->keep, path, sizeof path, err, errlen);
}

/* After a numerical failure, or a stop (in the middle of a frame or between frames): the last good
 * frame's state written as its checkpoint, unless it has one. The same decision on every rank
 * (the run's status, the stop and last_frame are agreed). */
static sm_status ckpt_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    const sm_checkpoint_config *c = s->config;
    ckpt_state *cs = s->state;
    sm_status st = SM_OK;
    if ((run_status == SM_ERR_NUMERICAL || (run_status == SM_OK && s->stopped)) && cs->last_frame >= 0 &&
        !scheduled(c, cs->last_frame)) {
        if (cs->io) {
            st = write_parts(c, cs, cs->last_frame, err, errlen);
        } else { /* the saved bytes, as they are */
            char dir[SM_PATH_MAX], path[SM_PATH_MAX];
            st = checkpoint_path(cs->out, cs->last_frame, dir, sizeof dir, path, sizeof path, err, errlen);
            if (st == SM_OK) st = write_durably(dir, path, NULL, &cs->last, cs->last_frame, c->scene_hash, err, errlen);
            if (st == SM_OK) prune(dir, c->keep);
        }
    }
    free(cs->last.data);
    free(cs);
    s->state = NULL;
    return st;
}

sm_sink sm_sink_checkpoint(const sm_checkpoint_config *config) {
    sm_sink s = {"checkpoint", config, NULL, ckpt_begin, ckpt_frame, ckpt_end, SM_SINK_PART, 0};
    return s;
}
