/* app/io/files.c: how output files are written when the disk is full or a run was killed.
 *
 * Full disk (the SANDMPM_FAULT_WRITE_BYTES hook: N bytes free, then ENOSPC; each case in a child
 * process, which reads the variable at its first write):
 *   - a stream (diagnostics.csv) keeps whole records only: a record that does not fit is cut off,
 *     the error names the file and "No space left on device";
 *   - an atomic file (a PLY frame, a PNG) that does not fit fails with the path and the reason,
 *     leaves no temporary, and the file that was there before under that name is unchanged.
 * Stale temporaries: of the ".NAME.tmp.PID" files in a folder, those of files sandmpm writes whose
 * process is gone are removed (and older versions' "NAME.tmp"); a live process's, and other
 * names, are kept. Folders: an empty name, a file in the way, a name too long are refused. */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "app/io/files.h"
#include "app/io/ply.h"
#include "app/io/png.h"
#include "test_util.h"

static char dir[256];

static void path_of(char *buf, size_t n, const char *name) { snprintf(buf, n, "%.255s/%.200s", dir, name); }

static long file_size(const char *p) {
    struct stat st;
    return stat(p, &st) == 0 ? (long)st.st_size : -1;
}

static void write_text(const char *p, const char *text) {
    FILE *f = fopen(p, "wb");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

static int same_text(const char *p, const char *text) {
    char buf[256] = {0};
    FILE *f = fopen(p, "rb");
    if (!f) return 0;
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    return n == strlen(text) && memcmp(buf, text, n) == 0;
}

/* A tiny 2D world: a few dozen particles. */
static sm_world *small_world(void) {
    sm_world_def def = sm_world_def_default();
    def.dim = 2;
    def.dx = 0.1;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) return NULL;
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    sm_world_add_material(w, &m, &mat);
    sm_shape b = sm_shape_default(SM_SHAPE_BOX);
    b.center[0] = b.center[1] = 0.5;
    b.half_extent[0] = b.half_extent[1] = 0.2;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sm_world_seed_shape(w, &b, &sd, NULL);
    return w;
}

/* ------------------------------------------------------------------------------------------ */
/* Full disk, in children                                                                       */

/* A stream with 10 bytes free: "header\n" (7) fits, an 11-byte record does not and is cut off. */
static void child_stream(void) {
    char p[512], err[SM_MSG_MAX];
    path_of(p, sizeof p, "diagnostics.csv");
    sm_stream s;
    CHECK(sm_stream_open(&s, p, err, sizeof err) == SM_OK);
    CHECK(sm_stream_append(&s, "header\n", 7, err, sizeof err) == SM_OK);
    CHECK(sm_stream_append(&s, "0,1,2,3,45\n", 11, err, sizeof err) == SM_ERR_IO);
    CHECK(strstr(err, p) != NULL && strstr(err, "No space left on device") != NULL);
    CHECK(sm_stream_close(&s, 0, err, sizeof err) == SM_OK);
    CHECK(same_text(p, "header\n"));
}

/* An atomic PLY that does not fit: the old file stays, no temporary is left. */
static void child_atomic(void) {
    char p[512], tmp[600], err[SM_MSG_MAX];
    path_of(p, sizeof p, "frame_0001.ply");
    write_text(p, "the previous frame\n");
    sm_world *w = small_world();
    CHECK(w != NULL);
    if (!w) return;
    CHECK(sm_write_ply(w, p, 0, err, sizeof err) == SM_ERR_IO);
    CHECK(strstr(err, p) != NULL && strstr(err, "No space left on device") != NULL);
    CHECK(same_text(p, "the previous frame\n"));
    CHECK(sm_temp_name(tmp, sizeof tmp, p, (long)getpid()) == 0 && file_size(tmp) < 0);
    /* the disk stays full: a PNG fails the same way */
    uint8_t rgb[16 * 16 * 3] = {0};
    path_of(p, sizeof p, "frame_0001.png");
    CHECK(sm_png_write(p, 16, 16, rgb, err, sizeof err) == SM_ERR_IO);
    CHECK(strstr(err, "No space left on device") != NULL);
    CHECK(file_size(p) < 0);
    CHECK(sm_temp_name(tmp, sizeof tmp, p, (long)getpid()) == 0 && file_size(tmp) < 0);
    sm_world_destroy(w);
}

/* Runs f in a child with SANDMPM_FAULT_WRITE_BYTES=bytes; its failed checks count here. */
static void in_child(void (*f)(void), const char *bytes) {
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        setenv("SANDMPM_FAULT_WRITE_BYTES", bytes, 1);
        f();
        _exit(sm_test_failures > 255 ? 255 : sm_test_failures);
    }
    int status = 0;
    CHECK(pid > 0 && waitpid(pid, &status, 0) == pid);
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

/* ------------------------------------------------------------------------------------------ */
/* Stale temporaries                                                                            */

static void test_stale(void) {
    /* a process that has ended: its pid is free (until reused, which the test cannot see) */
    pid_t dead = fork();
    if (dead == 0) _exit(0);
    waitpid(dead, NULL, 0);
    char p[512], name[128], first[256], err[SM_MSG_MAX];
    const char *removed_names[3], *kept_names[4];
    static char bufs[7][128];
    snprintf(bufs[0], 128, ".frame_0003.ply.tmp.%ld", (long)dead);
    snprintf(bufs[1], 128, ".frames.pvd.tmp.%ld", (long)dead);
    snprintf(bufs[2], 128, "frame_0004.vtp.tmp");              /* an older version's */
    snprintf(bufs[3], 128, ".frame_0005.png.tmp.%ld", (long)getppid()); /* a live process's */
    snprintf(bufs[4], 128, ".notes.txt.tmp.%ld", (long)dead);   /* not a file sandmpm writes */
    snprintf(bufs[5], 128, "frame_0003.ply");
    snprintf(bufs[6], 128, ".frame_12.ply.tmp.%ld", (long)dead); /* not a frame name */
    for (int i = 0; i < 3; i++) removed_names[i] = bufs[i];
    for (int i = 0; i < 4; i++) kept_names[i] = bufs[3 + i];
    for (int i = 0; i < 7; i++) {
        path_of(p, sizeof p, bufs[i]);
        write_text(p, "x");
    }
    int removed = -1;
    CHECK(sm_remove_stale_temporaries(dir, &removed, first, sizeof first, err, sizeof err) == SM_OK);
    CHECK(removed == 3);
    for (int i = 0; i < 3; i++) {
        path_of(p, sizeof p, removed_names[i]);
        CHECK(file_size(p) < 0);
    }
    for (int i = 0; i < 4; i++) {
        path_of(p, sizeof p, kept_names[i]);
        CHECK(file_size(p) == 1);
    }
    CHECK(sm_temp_name(name, sizeof name, "out/x/frame_0001.ply", 42) == 0 && !strcmp(name, "out/x/.frame_0001.ply.tmp.42"));
    CHECK(sm_temp_name(name, 10, "out/x/frame_0001.ply", 42) != 0);
}

static void test_folders(void) {
    char p[512], err[SM_MSG_MAX];
    CHECK(sm_make_dirs("", err, sizeof err) == SM_ERR_INVALID);
    path_of(p, sizeof p, "a/b/c");
    CHECK(sm_make_dirs(p, err, sizeof err) == SM_OK);
    CHECK(sm_make_dirs(p, err, sizeof err) == SM_OK); /* exists */
    path_of(p, sizeof p, "frame_0003.ply");           /* a file */
    CHECK(sm_make_dirs(p, err, sizeof err) == SM_ERR_IO && strstr(err, "not a folder") != NULL);
    path_of(p, sizeof p, "frame_0003.ply/sub");
    CHECK(sm_make_dirs(p, err, sizeof err) == SM_ERR_IO && strstr(err, "Not a directory") != NULL);
    char *longp = malloc(SM_PATH_MAX);
    if (longp) {
        memset(longp, 'a', SM_PATH_MAX - 40);
        longp[SM_PATH_MAX - 40] = 0;
        CHECK(sm_make_dirs(longp, err, sizeof err) == SM_ERR_INVALID && strstr(err, "bytes") != NULL);
        free(longp);
    }
}

int main(void) {
    snprintf(dir, sizeof dir, "%s/sm_test_files_XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    in_child(child_stream, "10");
    in_child(child_atomic, "200");
    test_stale();
    test_folders();
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
    return sm_test_summary("test_files");
}
