/* A checkpoint written across MPI ranks (checkpoint.h): every rank writes its parts of the stream
 * of the whole run (sm_part_io.save: its id slice's particle data at their offsets, rank 0 also
 * every byte that is not particle data) into one file; rank 0 adds the trailer, whose crc32 is
 * the ranks' pieces combined (app/io/part_file.h). The file has the bytes a one-process
 * checkpoint of the same world has, so it resumes on any number of ranks. The small writes of
 * the definitions are gathered into 64 KiB pieces first. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/checkpoint.h"

typedef struct coalesce {
    const sm_part_io *io;
    void *file;
    uint64_t off; /* of buf[0] */
    size_t len;
    int failed;
    unsigned char buf[1 << 16];
} coalesce;

static void flush(coalesce *c) {
    if (c->len && !c->failed && c->io->write_at(c->file, c->off, c->buf, c->len)) c->failed = 1;
    c->len = 0;
}

static int coalesce_write(void *user, uint64_t off, const void *data, size_t len) {
    coalesce *c = user;
    if (c->len && (off != c->off + c->len || c->len + len > sizeof c->buf)) flush(c);
    if (len >= sizeof c->buf) { /* the particle data: as it is */
        if (!c->failed && c->io->write_at(c->file, off, data, len)) c->failed = 1;
        return c->failed;
    }
    if (c->len == 0) c->off = off;
    memcpy(c->buf + c->len, data, len);
    c->len += len;
    return c->failed;
}

static void put_le(unsigned char *t, uint64_t v, int bytes) {
    for (int i = 0; i < bytes; i++) t[i] = (unsigned char)(v >> (8 * i));
}

sm_status sm_ckpt_parts_write(const sm_part_io *io, const char *path, int frame, uint64_t scene_hash, char *err,
                              size_t errlen) {
    coalesce *c = malloc(sizeof *c);
    sm_status st = c ? SM_OK : SM_ERR_NOMEM;
    if (!c) snprintf(err, errlen, "%s: out of memory", path);
    void *file = NULL;
    if ((st = io->agree(io->ctx, st, err, errlen)) == SM_OK) st = io->open(io->ctx, path, &file, err, errlen);
    if (st != SM_OK) {
        free(c);
        return st;
    }
    c->io = io;
    c->file = file;
    c->len = 0;
    c->failed = 0;
    uint64_t bytes = 0; /* the stream's length, the same on every rank (a failed write only stops the writing) */
    io->save(io->ctx, coalesce_write, c, &bytes);
    flush(c);
    free(c);
    unsigned char t[SM_CKPT_TRAILER_BYTES];
    put_le(t, (uint64_t)frame, 4);
    put_le(t + 4, scene_hash, 8);
    put_le(t + 12, bytes, 8);
    memcpy(t + 20, "SMCK", 4);
    if (io->writer) io->write_at(file, bytes, t, 24);
    uint32_t crc = 0;
    st = io->crc(file, bytes + 24, &crc, err, errlen); /* the crc covers everything before it */
    put_le(t + 24, crc, 4);
    if (st == SM_OK && io->writer) io->write_at(file, bytes + 24, t + 24, 4);
    return io->close(file, st == SM_OK, err, errlen);
}
