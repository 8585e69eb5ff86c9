/* Reading checkpoint files (checkpoint.h): the trailer checked, the crc32 computed over the file
 * 64 KiB at a time, the stream then read at offsets (pread), so that neither the check nor a
 * restore (sm_world_restore_read, sm_world_restore_share) needs the file in memory. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "app/checkpoint.h"

static uint64_t get_le(const unsigned char *p, int bytes) {
    uint64_t v = 0;
    for (int i = 0; i < bytes; i++) v |= (uint64_t)p[i] << (8 * i);
    return v;
}

/* Reads exactly n bytes at off; 0 on success. */
static int read_at(int fd, uint64_t off, void *data, size_t n) {
    unsigned char *p = data;
    while (n > 0) {
        const ssize_t k = pread(fd, p, n, (off_t)off);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return 1;
        p += k, off += (uint64_t)k, n -= (size_t)k;
    }
    return 0;
}

int sm_checkpoint_pread(void *user, uint64_t offset, void *data, size_t len) {
    const sm_checkpoint_file *f = user;
    return offset > f->stream_bytes || len > f->stream_bytes - offset || read_at(f->fd, offset, data, len);
}

/* The crc32 of the file's first n bytes; 0 on success. */
static int crc_of(int fd, uint64_t n, uint32_t *crc) {
    unsigned char *chunk = malloc(1 << 16);
    uLong c = crc32(0L, Z_NULL, 0);
    int bad = chunk == NULL;
    for (uint64_t at = 0; at < n && !bad; at += 1 << 16) {
        const size_t k = n - at < (1 << 16) ? (size_t)(n - at) : (size_t)1 << 16;
        if ((bad = read_at(fd, at, chunk, k)) == 0) c = crc32(c, chunk, (uInt)k);
    }
    free(chunk);
    *crc = (uint32_t)c;
    return bad;
}

/* Why f's trailer (and with verify its checksum) is not a checkpoint's; NULL if it is. */
static const char *check(sm_checkpoint_file *f, uint64_t size, int verify) {
    unsigned char t[SM_CKPT_TRAILER_BYTES];
    if (size < SM_CKPT_TRAILER_BYTES) return "too short to be a checkpoint (truncated?)";
    if (read_at(f->fd, size - SM_CKPT_TRAILER_BYTES, t, sizeof t)) return "reading failed";
    if (memcmp(t + 20, "SMCK", 4) != 0) return "no checkpoint trailer (truncated?)";
    uint32_t crc;
    if (verify && crc_of(f->fd, size - 4, &crc)) return "reading failed";
    if (verify && get_le(t + 24, 4) != crc) return "checksum mismatch (corrupt)";
    if (get_le(t + 12, 8) != size - SM_CKPT_TRAILER_BYTES) return "stream length mismatch";
    f->frame = (int)get_le(t, 4);
    f->scene_hash = get_le(t + 4, 8);
    f->stream_bytes = size - SM_CKPT_TRAILER_BYTES;
    return NULL;
}

sm_status sm_checkpoint_open(const char *path, int verify, sm_checkpoint_file *f, char *err, size_t errlen) {
    memset(f, 0, sizeof *f);
    f->fd = open(path, O_RDONLY);
    struct stat sb;
    if (f->fd < 0 || fstat(f->fd, &sb) != 0) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        sm_checkpoint_close(f);
        return SM_ERR_IO;
    }
    const char *why = check(f, (uint64_t)sb.st_size, verify);
    if (why) {
        snprintf(err, errlen, "%s: %s", path, why);
        sm_checkpoint_close(f);
        return SM_ERR_INVALID;
    }
    return SM_OK;
}

void sm_checkpoint_close(sm_checkpoint_file *f) {
    if (f->fd >= 0) close(f->fd);
    f->fd = -1;
}

sm_status sm_checkpoint_read(const char *path, unsigned char **stream, size_t *len, int *frame, uint64_t *scene_hash,
                             char *err, size_t errlen) {
    *stream = NULL;
    sm_checkpoint_file f;
    sm_status st = sm_checkpoint_open(path, 1, &f, err, errlen);
    if (st != SM_OK) return st;
    unsigned char *data = f.stream_bytes < SIZE_MAX ? malloc(f.stream_bytes ? (size_t)f.stream_bytes : 1) : NULL;
    if (!data) snprintf(err, errlen, "%s: out of memory for %llu bytes", path, (unsigned long long)f.stream_bytes), st = SM_ERR_NOMEM;
    else if (sm_checkpoint_pread(&f, 0, data, (size_t)f.stream_bytes))
        snprintf(err, errlen, "%s: reading failed", path), st = SM_ERR_IO;
    sm_checkpoint_close(&f);
    if (st != SM_OK) {
        free(data);
        return st;
    }
    *stream = data;
    *len = (size_t)f.stream_bytes;
    *frame = f.frame;
    *scene_hash = f.scene_hash;
    return SM_OK;
}
