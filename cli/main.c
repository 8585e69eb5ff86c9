/* sandmpm: the command-line program.
 *
 *   sandmpm run [--out DIR] [--frames N | --end SECONDS] [--threads N]
 *   sandmpm --help | --version
 *
 * `run` without a scene runs the built-in default scene: a 3D column of sand (radius 0.1 m,
 * height 0.4 m, hardening sand of the thesis's Table 4.2) collapsing on a sticky ground.
 * Frames go to DIR/frame_NNNN.ply (binary PLY) and DIR/diagnostics.csv.
 * Exit codes: 0 done, 2 bad input, 3 numerical failure, 4 I/O failure. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "app/output.h"
#include "sandmpm/sandmpm.h"

enum { EXIT_DONE = 0, EXIT_BAD_INPUT = 2, EXIT_NUMERICAL = 3, EXIT_IO = 4 };

static double wall(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void usage(FILE *f) {
    fprintf(f, "usage: sandmpm COMMAND [OPTIONS]\n\n"
               "commands:\n"
               "  run        run a scene (without SCENE: the built-in default, a 3D sand column collapsing)\n\n"
               "options:\n"
               "  --help     this text; `sandmpm COMMAND --help` for a command's options\n"
               "  --version  print the version\n\n"
               "exit codes: 0 done, 2 bad input, 3 numerical failure, 4 I/O failure\n");
}

static void usage_run(FILE *f) {
    fprintf(f, "usage: sandmpm run [--out DIR] [--frames N | --end SECONDS] [--threads N]\n\n"
               "Runs the built-in default scene: a sand column (radius 0.1 m, height 0.4 m, dx 0.015 m,\n"
               "8 particles per cell, hardening 35/9/0.2/10) collapsing on a sticky ground, 24 frames/s.\n"
               "Scene files (Lua) are not supported yet.\n\n"
               "  --out DIR       output directory (default: out); frame_NNNN.ply and diagnostics.csv\n"
               "  --frames N      number of frames after frame 0 (default 30)\n"
               "  --end SECONDS   simulated end time instead of --frames\n"
               "  --threads N     OpenMP threads (default: all cores); results do not depend on it\n");
}

static int parse_int(const char *s, int *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || end == s || v < 0 || v > 1000000) return 0;
    *out = (int)v;
    return 1;
}

static int parse_double(const char *s, double *out) {
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || *end || end == s || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

static int mkdir_p(const char *dir) {
    char buf[4096];
    size_t n = strlen(dir);
    if (n == 0 || n >= sizeof buf) return -1;
    memcpy(buf, dir, n + 1);
    for (size_t i = 1; i <= n; i++) {
        if (buf[i] == '/' || buf[i] == 0) {
            char c = buf[i];
            buf[i] = 0;
            if (mkdir(buf, 0777) != 0 && errno != EEXIST) return -1;
            buf[i] = c;
        }
    }
    return 0;
}

/* The default scene. */
static int build_default(sm_world **out, int threads, char *err, size_t errlen) {
    sm_world_def def = sm_world_def_default();
    def.dim = 3;
    def.dx = 0.015;
    def.threads = threads;
    def.max_dt = 1e-3;
    def.domain_min[0] = def.domain_min[2] = -0.6;
    def.domain_max[0] = def.domain_max[2] = 0.6;
    def.domain_min[1] = -0.05;
    def.domain_max[1] = 0.5;
    if (sm_world_create(&def, out, err, errlen) != SM_OK) return -1;
    sm_world *w = *out;
    sm_material_def sand = sm_material_def_sand();
    int mat = sm_world_add_material(w, &sand);
    sm_collider_def ground = sm_collider_def_default();
    ground.shape_count = 1;
    ground.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    ground.shapes[0].normal[1] = 1;
    ground.mode = SM_COLLIDE_STICKY;
    if (mat < 0 || sm_world_add_collider(w, &ground) < 0) {
        snprintf(err, errlen, "%s", sm_world_errmsg(w));
        return -1;
    }
    sm_shape col = sm_shape_default(SM_SHAPE_CYLINDER);
    col.center[1] = 0.2;
    col.radius = 0.1;
    col.half_height = 0.2;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = 8;
    if (sm_world_seed_shape(w, &col, &sd, NULL) != SM_OK) {
        snprintf(err, errlen, "%s", sm_world_errmsg(w));
        return -1;
    }
    return 0;
}

static int cmd_run(int argc, char **argv) {
    const char *out = "out";
    int frames = 30, threads = 0;
    double end = -1, fps = 24;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage_run(stdout);
            return EXIT_DONE;
        } else if (!strcmp(a, "--out") && i + 1 < argc) {
            out = argv[++i];
        } else if (!strcmp(a, "--frames") && i + 1 < argc) {
            if (!parse_int(argv[++i], &frames) || frames < 1) {
                fprintf(stderr, "sandmpm run: --frames: expected a whole number >= 1, got \"%s\"\n", argv[i]);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--end") && i + 1 < argc) {
            if (!parse_double(argv[++i], &end) || !(end > 0)) {
                fprintf(stderr, "sandmpm run: --end: expected seconds > 0, got \"%s\"\n", argv[i]);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--threads") && i + 1 < argc) {
            if (!parse_int(argv[++i], &threads) || threads < 1 || threads > 1024) {
                fprintf(stderr, "sandmpm run: --threads: expected 1..1024, got \"%s\"\n", argv[i]);
                return EXIT_BAD_INPUT;
            }
        } else if (a[0] == '-') {
            fprintf(stderr, "sandmpm run: unknown or incomplete option \"%s\" (see sandmpm run --help)\n", a);
            return EXIT_BAD_INPUT;
        } else {
            fprintf(stderr, "sandmpm run: scene files are not supported yet (got \"%s\"); run without a scene for the "
                            "built-in default\n", a);
            return EXIT_BAD_INPUT;
        }
    }
    if (end > 0) frames = (int)ceil(end * fps - 1e-9);
    char err[512];
    sm_world *w = NULL;
    if (build_default(&w, threads, err, sizeof err) != 0) {
        fprintf(stderr, "sandmpm run: %s\n", err);
        sm_world_destroy(w);
        return EXIT_BAD_INPUT;
    }
    if (mkdir_p(out) != 0) {
        fprintf(stderr, "sandmpm run: cannot create output directory %s: %s\n", out, strerror(errno));
        sm_world_destroy(w);
        return EXIT_IO;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/diagnostics.csv", out);
    FILE *csv = fopen(path, "w");
    if (!csv) {
        fprintf(stderr, "sandmpm run: %s: %s\n", path, strerror(errno));
        sm_world_destroy(w);
        return EXIT_IO;
    }
    sm_csv_header(csv);
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    int tty = isatty(fileno(stderr));
    fprintf(stderr, "sandmpm: default scene, %zu particles, %d frames at %g fps -> %s/\n", d.particles, frames, fps, out);
    double t0 = wall();
    int rc = EXIT_DONE;
    for (int f = 0; f <= frames; f++) {
        if (f > 0) {
            sm_world_reset_step_stats(w);
            sm_status st = sm_world_advance(w, f / fps);
            if (st != SM_OK) {
                fprintf(stderr, "%ssandmpm run: %s\n", tty ? "\n" : "", sm_world_errmsg(w));
                rc = st == SM_ERR_NUMERICAL ? EXIT_NUMERICAL : EXIT_BAD_INPUT;
                break;
            }
        }
        sm_world_diagnostics(w, &d);
        snprintf(path, sizeof path, "%s/frame_%04d.ply", out, f);
        if (sm_write_ply(w, path, err, sizeof err) != 0) {
            fprintf(stderr, "%ssandmpm run: %s\n", tty ? "\n" : "", err);
            rc = EXIT_IO;
            break;
        }
        double el = wall() - t0;
        sm_csv_row(csv, f, &d, el);
        double rate = el > 0 ? (double)d.particles * (double)d.steps / el : 0;
        double eta = f > 0 ? el / f * (frames - f) : 0;
        fprintf(stderr, "%sframe %d/%d  t = %.3f s  steps %llu  particles %zu  %.3g particle-steps/s  ETA %.0f s%s",
                tty ? "\r" : "", f, frames, d.time, (unsigned long long)d.steps, d.particles, rate, eta,
                tty ? "   " : "\n");
    }
    if (tty) fprintf(stderr, "\n");
    if (fclose(csv) != 0 && rc == EXIT_DONE) rc = EXIT_IO;
    sm_world_destroy(w);
    return rc;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        usage(stderr);
        return EXIT_BAD_INPUT;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return EXIT_DONE;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("sandmpm %s (%s precision)\n", sm_version(), sm_real_is_double() ? "double" : "float");
        return EXIT_DONE;
    }
    if (!strcmp(argv[1], "run")) return cmd_run(argc - 2, argv + 2);
    fprintf(stderr, "sandmpm: unknown command \"%s\" (see sandmpm --help)\n", argv[1]);
    return EXIT_BAD_INPUT;
}
