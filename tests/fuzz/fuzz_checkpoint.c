/* libFuzzer harness (and, through replay.c, a CTest case): the checkpoint readers on arbitrary bytes.
 *
 * The first byte picks the reader, so that mutations reach both:
 *   even: the rest is a library stream for sm_world_load (no checksum: hostile bytes reach the
 *         parser itself);
 *   odd:  the rest is a checkpoint file (stream + trailer with its zlib crc32) for the program's
 *         sm_checkpoint_read (written to /dev/shm: it takes a path), then sm_world_load.
 * Either must fail with a status and a message, or succeed with a world that saves again to a
 * stream that loads to the same state hash (the round trip); never crash, leak, read out of bounds
 * or trip a sanitizer. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/checkpoint.h"
#include "sandmpm/sandmpm.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void fuzz_fail(const char *what, const char *err) {
    fprintf(stderr, "fuzz_checkpoint: %s (message: \"%s\")\n", what, err);
    abort();
}

typedef struct membuf {
    unsigned char *data;
    size_t len, cap;
} membuf;

static int mem_write(void *user, const void *data, size_t len) {
    membuf *b = user;
    if (b->len + len > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->len + len) cap *= 2;
        unsigned char *p = realloc(b->data, cap);
        if (!p) return 1;
        b->data = p, b->cap = cap;
    }
    memcpy(b->data + b->len, data, len);
    b->len += len;
    return 0;
}

/* Loads a stream; a world that loads must survive save + load with its state hash. */
static void load_stream(const unsigned char *s, size_t len) {
    sm_world *w = NULL;
    char err[512] = "";
    if (sm_world_load(s, len, &w, err, sizeof err) != SM_OK) {
        if (w) fuzz_fail("a refused stream returned a world", err);
        if (err[0] == '\0') fuzz_fail("a refused stream without a message", err);
        return;
    }
    membuf b = {0};
    if (sm_world_save(w, mem_write, &b) != SM_OK) fuzz_fail("a loaded world does not save", "");
    sm_world *w2 = NULL;
    if (sm_world_load(b.data, b.len, &w2, err, sizeof err) != SM_OK) fuzz_fail("a saved world does not load", err);
    if (sm_world_state_hash(w) != sm_world_state_hash(w2)) fuzz_fail("the round trip changed the state", "");
    sm_world_destroy(w2);
    sm_world_destroy(w);
    free(b.data);
}

static const char *input_path(void) {
    static char path[256];
    if (path[0] == '\0') {
        const char *dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : getenv("TMPDIR");
        snprintf(path, sizeof path, "%s/sandmpm_fuzz_ckpt_%ld.smc", dir ? dir : "/tmp", (long)getpid());
    }
    return path;
}

static void read_file(const uint8_t *data, size_t size) {
    const char *path = input_path();
    FILE *fp = fopen(path, "wb");
    if (!fp) fuzz_fail("cannot write the input file", path);
    if (size && fwrite(data, 1, size, fp) != size) fuzz_fail("cannot write the input file", path);
    fclose(fp);
    unsigned char *stream = NULL;
    size_t len = 0;
    int frame = -1;
    uint64_t hash = 0;
    char err[512] = "";
    sm_status st = sm_checkpoint_read(path, &stream, &len, &frame, &hash, err, sizeof err);
    unlink(path);
    if (st != SM_OK) {
        if (err[0] == '\0') fuzz_fail("a refused file without a message", err);
        free(stream);
        return;
    }
    if (!stream && len) fuzz_fail("an accepted file without its stream", "");
    load_stream(stream, len);
    free(stream);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size == 0) return 0;
    if (data[0] & 1) read_file(data + 1, size - 1);
    else load_stream(data + 1, size - 1);
    return 0;
}
