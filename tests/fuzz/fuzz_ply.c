/* libFuzzer harness (and, through replay.c, a CTest case): the PLY reader on arbitrary bytes.
 *
 * sm_ply_read takes a path (it stats the file to check the header's counts against its size), so
 * each input is written to a file in /dev/shm (or $TMPDIR) named after the process. The reader must
 * return SM_OK with a consistent frame or an error with an empty frame and a message; never crash,
 * leak, allocate without bound or trip a sanitizer. Every value of a frame read is touched so that
 * reads of uninitialised or out-of-bounds memory are seen. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/frame.h"
#include "app/io/ply.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void fuzz_fail(const char *what, const char *err) {
    fprintf(stderr, "fuzz_ply: %s (message: \"%s\")\n", what, err);
    abort();
}

static const char *input_path(void) {
    static char path[256];
    if (path[0] == '\0') {
        const char *dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : getenv("TMPDIR");
        snprintf(path, sizeof path, "%s/sandmpm_fuzz_ply_%ld.ply", dir ? dir : "/tmp", (long)getpid());
    }
    return path;
}

/* Sums every stored value (the sum itself is meaningless: reading is the point). */
static double touch_frame(const sm_frame *f) {
    double sum = 0;
    for (size_t i = 0; i < f->n; i++) {
        for (int c = 0; c < 3; c++) sum += (double)f->x[3 * i + c] + (double)f->v[3 * i + c];
        sum += f->material[i] + (double)f->q[i];
        if (f->volume) sum += (double)f->volume[i];
        if (f->id) sum += f->id[i];
    }
    return sum;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    const char *path = input_path();
    FILE *fp = fopen(path, "wb");
    if (!fp) fuzz_fail("cannot write the input file", path);
    if (size && fwrite(data, 1, size, fp) != size) fuzz_fail("cannot write the input file", path);
    fclose(fp);
    sm_frame f;
    char err[512] = "";
    sm_status st = sm_ply_read(path, &f, err, sizeof err);
    if (st == SM_OK) {
        if (f.dim != 2 && f.dim != 3) fuzz_fail("frame with a bad dimension", err);
        if (f.n > 0 && (!f.x || !f.v || !f.material || !f.q)) fuzz_fail("frame without arrays", err);
        volatile double sink = touch_frame(&f);
        (void)sink;
    } else {
        if (f.n != 0 || f.x || f.v) fuzz_fail("an error with a non-empty frame", err);
        if (err[0] == '\0') fuzz_fail("an error without a message", err);
    }
    sm_frame_free(&f);
    unlink(path);
    return 0;
}
