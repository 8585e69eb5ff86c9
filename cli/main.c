/* sandmpm: the command-line program (DESIGN §2: thin — arguments, progress, exit codes).
 *
 *   sandmpm run [SCENE] [--out DIR] [--frames N | --end SECONDS] [--set KEY=VALUE]...
 *               [--threads N] [--quality preview|paper|test] [--render] [--video]
 *   sandmpm info SCENE [--set KEY=VALUE]... [--quality Q]
 *   sandmpm render OUTDIR [--color sand|speed|material|q] [--size WxH] [--threads N] [--video]
 *   sandmpm bench [--dim 2,3] [--precision float,double] [--threads 1,2] [--particles N] [--steps S]
 *                 [--warmup W] [--csv [--no-header]]
 *   sandmpm --help | COMMAND --help | --version
 *
 * Exit codes: 0 done, 2 bad input, 3 numerical failure, 4 I/O failure, 5 out of memory. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "app/bench.h"
#include "app/manifest.h"
#include "app/output.h"
#include "app/render.h"
#include "app/scene.h"
#include "sandmpm/sandmpm.h"

enum { EXIT_DONE = 0, EXIT_BAD_INPUT = 2, EXIT_NUMERICAL = 3, EXIT_IO = 4, EXIT_NOMEM = 5 };

extern const char sm_default_scene[]; /* scenes/default.lua, embedded at build time */

#define MAX_PARAMS 64

static double wall(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void usage(FILE *f) {
    fprintf(f, "sandmpm %s: dry sand with the Material Point Method (Klar 2016)\n\n"
               "usage: sandmpm COMMAND [ARGS]\n\n"
               "commands:\n"
               "  run [SCENE]     run a scene file (Lua); without SCENE the built-in default:\n"
               "                  a 3D sand column collapsing on the ground\n"
               "  info SCENE      print the resolved scene (particles, grid, time steps, memory) without running it\n"
               "  render OUTDIR   turn a run's frames (OUTDIR/frame_NNNN.ply) into PNG images\n"
               "  bench           particle-steps/s per stage: 2D and 3D, float and double, 1 and 2 threads\n\n"
               "  --help          this text; `sandmpm COMMAND --help` for a command's options\n"
               "  --version       version and precision\n\n"
               "exit codes: 0 done, 2 bad input, 3 numerical failure, 4 I/O failure, 5 out of memory\n"
               "scene format: docs/scene-format.md\n",
            sm_version());
}

static void usage_run(FILE *f) {
    fprintf(f, "usage: sandmpm run [SCENE] [OPTIONS]\n\n"
               "Runs SCENE (a Lua scene file, docs/scene-format.md), or without SCENE the built-in default\n"
               "scene: a sand column (radius 0.1 m, height 0.4 m) collapsing on a sticky ground.\n\n"
               "  --out DIR          output directory (default: out/NAME, NAME = the scene file's stem or \"default\")\n"
               "  --frames N         frames after frame 0 (default: the scene's)\n"
               "  --end SECONDS      simulated end time instead of --frames\n"
               "  --set KEY=VALUE    scene parameter, seen by the scene as params.KEY (repeatable)\n"
               "  --quality Q        preview (default), paper (the thesis's resolution) or test (tiny, for CI)\n"
               "  --threads N        OpenMP threads (default: all cores); results do not depend on it\n"
               "  --render           also render each frame to OUTDIR/frame_NNNN.png\n"
               "  --video            with --render: assemble OUTDIR/video.mp4 with ffmpeg at the end\n\n"
               "Writes per frame (as the scene's outputs table says): frame_NNNN.ply (binary PLY),\n"
               "frame_NNNN.vtp with frames.pvd (VTK/ParaView), and diagnostics.csv; each file atomically.\n");
}

static void usage_info(FILE *f) {
    fprintf(f, "usage: sandmpm info SCENE [--set KEY=VALUE]... [--quality preview|paper|test]\n\n"
               "Loads and builds SCENE without running it and prints: particles (estimated and seeded), the\n"
               "grid, the time-step bounds, frames, and the memory estimate. A scene whose memory estimate\n"
               "exceeds this machine's memory is refused (exit 2) with the estimate in the message.\n");
}

static void usage_render(FILE *f) {
    fprintf(f, "usage: sandmpm render OUTDIR [--color sand|speed|material|q] [--size WxH] [--threads N] [--video]\n\n"
               "Renders every OUTDIR/frame_NNNN.ply of a run into OUTDIR/frame_NNNN.png: particles as lit\n"
               "spheres with shadows (disks in 2D), random brown tones (or colour by speed, material, or\n"
               "hardening q), the ground and the colliders (from OUTDIR/render.txt, written by `run`).\n"
               "  --size WxH   image size (default 1280x720)\n"
               "  --video      assemble OUTDIR/video.mp4 with ffmpeg (if installed)\n");
}

static int parse_int(const char *s, long lo, long hi, int *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || end == s || v < lo || v > hi) return 0;
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
    if (n == 0 || n >= sizeof buf) {
        errno = ENAMETOOLONG;
        return -1;
    }
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

static double machine_bytes(void) {
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    return (pages > 0 && page > 0) ? (double)pages * (double)page : 0;
}

/* Options shared by run and info. */
typedef struct scene_opts {
    const char *scene;
    sm_scene_param params[MAX_PARAMS];
    int nparams;
    const char *quality;
    int threads;
} scene_opts;

/* Parses --set/--quality/--threads; returns 1 if argv[*i] was one of them, 0 if not, -1 on error. */
static int parse_scene_opt(const char *cmd, int argc, char **argv, int *i, scene_opts *so, char *keybuf,
                           size_t keybuf_len, size_t *keybuf_used) {
    const char *a = argv[*i];
    if (!strcmp(a, "--set")) {
        if (*i + 1 >= argc) {
            fprintf(stderr, "sandmpm %s: --set needs KEY=VALUE\n", cmd);
            return -1;
        }
        const char *kv = argv[++*i];
        const char *eq = strchr(kv, '=');
        if (!eq || eq == kv) {
            fprintf(stderr, "sandmpm %s: --set: expected KEY=VALUE, got \"%s\"\n", cmd, kv);
            return -1;
        }
        if (so->nparams >= MAX_PARAMS) {
            fprintf(stderr, "sandmpm %s: --set: at most %d parameters\n", cmd, MAX_PARAMS);
            return -1;
        }
        size_t kl = (size_t)(eq - kv);
        if (*keybuf_used + kl + 1 > keybuf_len) {
            fprintf(stderr, "sandmpm %s: --set: keys too long\n", cmd);
            return -1;
        }
        char *k = keybuf + *keybuf_used;
        memcpy(k, kv, kl);
        k[kl] = 0;
        *keybuf_used += kl + 1;
        so->params[so->nparams].key = k;
        so->params[so->nparams].value = eq + 1;
        so->nparams++;
        return 1;
    }
    if (!strcmp(a, "--quality")) {
        if (*i + 1 >= argc) {
            fprintf(stderr, "sandmpm %s: --quality needs preview, paper or test\n", cmd);
            return -1;
        }
        so->quality = argv[++*i];
        if (strcmp(so->quality, "preview") && strcmp(so->quality, "paper") && strcmp(so->quality, "test")) {
            fprintf(stderr, "sandmpm %s: --quality: expected \"preview\", \"paper\" or \"test\", got \"%s\"\n", cmd,
                    so->quality);
            return -1;
        }
        return 1;
    }
    if (!strcmp(a, "--threads")) {
        if (*i + 1 >= argc || !parse_int(argv[*i + 1], 1, 1024, &so->threads)) {
            fprintf(stderr, "sandmpm %s: --threads: expected a number 1..1024, got \"%s\"\n", cmd,
                    *i + 1 < argc ? argv[*i + 1] : "");
            return -1;
        }
        ++*i;
        return 1;
    }
    return 0;
}

/* Loads the scene (file or the embedded default). Returns an exit code. */
static int load_scene(const char *cmd, const scene_opts *so, sm_scene **sc) {
    char err[1024];
    const char *path = so->scene ? so->scene : "default.lua";
    const char *source = so->scene ? NULL : sm_default_scene;
    int rc = sm_scene_load(path, source, so->params, so->nparams, so->quality, so->threads, sc, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "sandmpm %s: %s\n", cmd, err);
        return rc == 5 ? EXIT_NOMEM : EXIT_BAD_INPUT;
    }
    return EXIT_DONE;
}

static int check_memory(const char *cmd, const sm_scene_settings *st) {
    double have = machine_bytes();
    if (have > 0 && (double)st->estimated_bytes > 0.9 * have) {
        fprintf(stderr,
                "sandmpm %s: the scene needs about %.1f GB (%zu particles, grid included) but this machine has %.1f GB; "
                "use a coarser quality or a larger dx\n",
                cmd, (double)st->estimated_bytes / 1e9, st->estimated_particles + st->estimated_emitted, have / 1e9);
        return EXIT_BAD_INPUT;
    }
    return EXIT_DONE;
}

static int build_scene(const char *cmd, sm_scene *sc) {
    char err[1024];
    int rc = sm_scene_build(sc, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "sandmpm %s: %s\n", cmd, err);
        return rc == 5 ? EXIT_NOMEM : EXIT_BAD_INPUT;
    }
    return EXIT_DONE;
}

/* ------------------------------------------------------------------------------------------ */
/* info                                                                                         */

static int cmd_info(int argc, char **argv) {
    scene_opts so = {0};
    char keybuf[4096];
    size_t used = 0;
    for (int i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage_info(stdout);
            return EXIT_DONE;
        }
        int r = parse_scene_opt("info", argc, argv, &i, &so, keybuf, sizeof keybuf, &used);
        if (r < 0) return EXIT_BAD_INPUT;
        if (r > 0) continue;
        if (argv[i][0] == '-' || so.scene) {
            fprintf(stderr, "sandmpm info: unexpected argument \"%s\" (see sandmpm info --help)\n", argv[i]);
            return EXIT_BAD_INPUT;
        }
        so.scene = argv[i];
    }
    sm_scene *sc = NULL;
    int rc = load_scene("info", &so, &sc);
    if (rc) return rc;
    const sm_scene_settings *st = sm_scene_get_settings(sc);
    const sm_world_def *d = sm_scene_world_def(sc);
    printf("scene        %s (quality %s)\n", so.scene ? so.scene : "built-in default", so.quality ? so.quality : "preview");
    printf("dimension    %d\n", d->dim);
    printf("dx           %g m\n", d->dx);
    printf("domain       [%g, %g] x [%g, %g]", d->domain_min[0], d->domain_max[0], d->domain_min[1], d->domain_max[1]);
    if (d->dim == 3) printf(" x [%g, %g]", d->domain_min[2], d->domain_max[2]);
    printf(" m\n");
    printf("frames       %d at %g fps (end time %g s)\n", st->frames, st->fps, st->end_time);
    printf("estimate     %zu particles seeded, %zu emitted; memory %.3f GB (machine %.1f GB)\n", st->estimated_particles,
           st->estimated_emitted, (double)st->estimated_bytes / 1e9, machine_bytes() / 1e9);
    rc = check_memory("info", st);
    if (rc) {
        sm_scene_destroy(sc);
        return rc;
    }
    rc = build_scene("info", sc);
    if (rc) {
        sm_scene_destroy(sc);
        return rc;
    }
    sm_world *w = sm_scene_world(sc);
    const sm_world_def *wd = sm_world_get_def(w);
    int n[3];
    sm_world_grid_size(w, n);
    sm_diagnostics dg;
    sm_world_diagnostics(w, &dg);
    printf("particles    %zu (mass %.6g kg)\n", dg.particles, dg.total_mass);
    printf("grid         %d x %d", n[0], n[1]);
    if (wd->dim == 3) printf(" x %d", n[2]);
    printf(" nodes\n");
    printf("materials    %d:", sm_scene_material_count(sc));
    for (int m = 0; m < sm_scene_material_count(sc); m++) printf(" %s", sm_scene_material_name(sc, m));
    printf("\ncolliders    %d\n", sm_world_collider_count(w));
    printf("integrator   %s, kernel %s, transfer %s\n", wd->integrator == SM_INTEGRATOR_IMPLICIT ? "implicit" : "explicit",
           wd->kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic",
           wd->transfer == SM_TRANSFER_APIC ? "APIC" : wd->transfer == SM_TRANSFER_PIC ? "PIC" : "FLIP");
    double first = sm_world_next_dt(w, 1e30);
    printf("time step    max %g s, CFL %g; first step %g s\n", wd->max_dt, wd->cfl, first);
    sm_scene_destroy(sc);
    return EXIT_DONE;
}

/* ------------------------------------------------------------------------------------------ */
/* render                                                                                       */

static int has_ffmpeg(void) { return system("command -v ffmpeg >/dev/null 2>&1") == 0; }

static int make_video(const char *dir, double fps) {
    if (!has_ffmpeg()) {
        fprintf(stderr, "sandmpm: --video: ffmpeg is not installed (Debian: apt-get install ffmpeg); the PNG frames "
                        "are in %s/\n", dir);
        return EXIT_IO;
    }
    char cmd[8192];
    snprintf(cmd, sizeof cmd,
             "ffmpeg -loglevel error -y -framerate %g -i '%s/frame_%%04d.png' -c:v libx264 -pix_fmt yuv420p "
             "-vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' '%s/video.mp4'",
             fps, dir, dir);
    int r = system(cmd);
    if (r != 0) {
        fprintf(stderr, "sandmpm: ffmpeg failed (status %d) making %s/video.mp4\n", r, dir);
        return EXIT_IO;
    }
    fprintf(stderr, "sandmpm: wrote %s/video.mp4\n", dir);
    return EXIT_DONE;
}

typedef struct render_cfg {
    sm_render_opts o;
    sm_manifest m;
    int have_manifest;
    uint8_t *rgb;
} render_cfg;

static int render_setup(render_cfg *rc, const char *dir, int width, int height, sm_color_mode color, int threads,
                        char *err, size_t errlen) {
    memset(rc, 0, sizeof *rc);
    rc->o = sm_render_opts_default();
    rc->o.width = width;
    rc->o.height = height;
    rc->o.color = color;
    rc->o.threads = threads;
    int r = sm_manifest_read(dir, &rc->m, err, errlen);
    if (r == 2) return r;
    rc->have_manifest = (r == 0);
    if (rc->have_manifest) {
        rc->o.has_domain = 1;
        memcpy(rc->o.domain_min, rc->m.domain_min, sizeof rc->o.domain_min);
        memcpy(rc->o.domain_max, rc->m.domain_max, sizeof rc->o.domain_max);
        if (rc->m.has_camera) {
            rc->o.has_camera = 1;
            memcpy(rc->o.camera.eye, rc->m.eye, sizeof rc->m.eye);
            memcpy(rc->o.camera.target, rc->m.target, sizeof rc->m.target);
            memcpy(rc->o.camera.up, rc->m.up, sizeof rc->m.up);
            rc->o.camera.fov_deg = rc->m.fov;
        }
        rc->o.colliders = rc->m.colliders;
        rc->o.ncolliders = rc->m.ncolliders;
        /* A half-space collider is the ground (the renderer draws it); without one, a ground plane
         * at the domain's bottom. */
        for (int i = 0; i < rc->m.ncolliders; i++)
            if (rc->m.colliders[i].shape_count == 1 && rc->m.colliders[i].shapes[0].kind == SM_SHAPE_HALFSPACE &&
                !rc->m.colliders[i].inside_out)
                rc->o.ground = SM_GROUND_NONE;
    }
    rc->rgb = malloc((size_t)width * (size_t)height * 3);
    if (!rc->rgb) {
        snprintf(err, errlen, "out of memory for a %dx%d image", width, height);
        return 5;
    }
    return 0;
}

static void render_free(render_cfg *rc) {
    sm_manifest_free(&rc->m);
    free(rc->rgb);
}

static int render_one(render_cfg *rc, const sm_frame *fr, int frame, const char *png, char *err, size_t errlen) {
    sm_pose *scratch = NULL;
    if (rc->have_manifest && rc->m.ncolliders > 0) {
        scratch = malloc((size_t)rc->m.ncolliders * sizeof *scratch);
        if (!scratch) {
            snprintf(err, errlen, "out of memory");
            return 5;
        }
        rc->o.poses = sm_manifest_frame_poses(&rc->m, frame, scratch);
    }
    int r = sm_render(fr, &rc->o, rc->rgb, err, errlen);
    if (r == 0) r = sm_png_write(png, rc->o.width, rc->o.height, rc->rgb, err, errlen);
    free(scratch);
    rc->o.poses = NULL;
    return r;
}

static int exit_of(int r) { return r == 0 ? EXIT_DONE : r == 4 ? EXIT_IO : r == 5 ? EXIT_NOMEM : EXIT_BAD_INPUT; }

static int cmd_render(int argc, char **argv) {
    const char *dir = NULL;
    int width = 1280, height = 720, threads = 0, video = 0;
    sm_color_mode color = SM_COLOR_SAND;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage_render(stdout);
            return EXIT_DONE;
        } else if (!strcmp(a, "--color") && i + 1 < argc) {
            const char *c = argv[++i];
            if (!strcmp(c, "sand")) color = SM_COLOR_SAND;
            else if (!strcmp(c, "speed")) color = SM_COLOR_SPEED;
            else if (!strcmp(c, "material")) color = SM_COLOR_MATERIAL;
            else if (!strcmp(c, "q")) color = SM_COLOR_Q;
            else {
                fprintf(stderr, "sandmpm render: --color: expected sand, speed, material or q, got \"%s\"\n", c);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--size") && i + 1 < argc) {
            if (sscanf(argv[++i], "%dx%d", &width, &height) != 2 || width < 16 || height < 16 || width > 16384 ||
                height > 16384) {
                fprintf(stderr, "sandmpm render: --size: expected WxH (16..16384), got \"%s\"\n", argv[i]);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--threads") && i + 1 < argc) {
            if (!parse_int(argv[++i], 1, 1024, &threads)) {
                fprintf(stderr, "sandmpm render: --threads: expected 1..1024, got \"%s\"\n", argv[i]);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--video")) {
            video = 1;
        } else if (a[0] == '-' || dir) {
            fprintf(stderr, "sandmpm render: unexpected argument \"%s\" (see sandmpm render --help)\n", a);
            return EXIT_BAD_INPUT;
        } else {
            dir = a;
        }
    }
    if (!dir) {
        fprintf(stderr, "sandmpm render: which run? usage: sandmpm render OUTDIR\n");
        return EXIT_BAD_INPUT;
    }
    DIR *dd = opendir(dir);
    if (!dd) {
        fprintf(stderr, "sandmpm render: %s: %s\n", dir, strerror(errno));
        return EXIT_IO;
    }
    int maxf = -1, count = 0;
    struct dirent *de;
    while ((de = readdir(dd))) {
        int fno;
        char tail[8];
        if (sscanf(de->d_name, "frame_%d.pl%1[y]", &fno, tail) == 2 && strlen(de->d_name) == 14) {
            count++;
            if (fno > maxf) maxf = fno;
        }
    }
    closedir(dd);
    if (count == 0) {
        fprintf(stderr, "sandmpm render: %s: no frame_NNNN.ply files (run `sandmpm run --out %s` first)\n", dir, dir);
        return EXIT_IO;
    }
    char err[1024];
    render_cfg rc;
    int r = render_setup(&rc, dir, width, height, color, threads, err, sizeof err);
    if (r) {
        fprintf(stderr, "sandmpm render: %s\n", err);
        render_free(&rc);
        return exit_of(r);
    }
    double t0 = wall();
    int done = 0;
    for (int f = 0; f <= maxf; f++) {
        char ply[4096], png[4096];
        snprintf(ply, sizeof ply, "%s/frame_%04d.ply", dir, f);
        snprintf(png, sizeof png, "%s/frame_%04d.png", dir, f);
        if (access(ply, F_OK) != 0) continue;
        sm_frame fr;
        r = sm_ply_read(ply, &fr, err, sizeof err);
        if (r == 0) {
            r = render_one(&rc, &fr, f, png, err, sizeof err);
            sm_frame_free(&fr);
        }
        if (r) {
            fprintf(stderr, "sandmpm render: %s\n", err);
            render_free(&rc);
            return exit_of(r);
        }
        done++;
        if (isatty(fileno(stderr))) fprintf(stderr, "\rrendered %d/%d", done, count);
    }
    fprintf(stderr, "%srendered %d frames to %s/frame_NNNN.png in %.1f s\n", isatty(fileno(stderr)) ? "\r" : "", done, dir, wall() - t0);
    render_free(&rc);
    if (video) {
        /* The frame rate from diagnostics.csv (time of frame 1), else 24. */
        double fps = 24;
        char p[4096];
        snprintf(p, sizeof p, "%s/diagnostics.csv", dir);
        FILE *csv = fopen(p, "r");
        if (csv) {
            char line[1024];
            int fr1;
            double t1;
            while (fgets(line, sizeof line, csv))
                if (sscanf(line, "%d,%lf", &fr1, &t1) == 2 && fr1 == 1 && t1 > 0) fps = 1.0 / t1;
            fclose(csv);
        }
        return make_video(dir, fps);
    }
    return EXIT_DONE;
}

/* ------------------------------------------------------------------------------------------ */
/* run                                                                                          */

static int cmd_run(int argc, char **argv) {
    scene_opts so = {0};
    char keybuf[4096];
    size_t used = 0;
    const char *out = NULL;
    int frames = -1, render = 0, video = 0;
    double end = -1;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage_run(stdout);
            return EXIT_DONE;
        }
        int r = parse_scene_opt("run", argc, argv, &i, &so, keybuf, sizeof keybuf, &used);
        if (r < 0) return EXIT_BAD_INPUT;
        if (r > 0) continue;
        if (!strcmp(a, "--out") && i + 1 < argc) {
            out = argv[++i];
        } else if (!strcmp(a, "--frames") && i + 1 < argc) {
            if (!parse_int(argv[++i], 1, 10000000, &frames)) {
                fprintf(stderr, "sandmpm run: --frames: expected a whole number >= 1, got \"%s\"\n", argv[i]);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--end") && i + 1 < argc) {
            if (!parse_double(argv[++i], &end) || !(end > 0)) {
                fprintf(stderr, "sandmpm run: --end: expected seconds > 0, got \"%s\"\n", argv[i]);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--render")) {
            render = 1;
        } else if (!strcmp(a, "--video")) {
            video = 1;
        } else if (a[0] == '-' || so.scene) {
            fprintf(stderr, "sandmpm run: unexpected argument \"%s\" (see sandmpm run --help)\n", a);
            return EXIT_BAD_INPUT;
        } else {
            so.scene = a;
        }
    }
    if (frames > 0 && end > 0) {
        fprintf(stderr, "sandmpm run: give --frames or --end, not both\n");
        return EXIT_BAD_INPUT;
    }
    if (video && !render) render = 1;
    sm_scene *sc = NULL;
    int rc = load_scene("run", &so, &sc);
    if (rc) return rc;
    const sm_scene_settings *st = sm_scene_get_settings(sc);
    double fps = st->fps;
    int nframes = st->frames;
    if (frames > 0) nframes = frames;
    if (end > 0) nframes = (int)ceil(end * fps - 1e-9);
    rc = check_memory("run", st);
    if (!rc) rc = build_scene("run", sc);
    if (rc) {
        sm_scene_destroy(sc);
        return rc;
    }
    /* Only now, with a valid scene, touch the file system. */
    char outbuf[4096];
    if (!out) {
        snprintf(outbuf, sizeof outbuf, "out/%s", so.scene ? st->name : "default");
        out = outbuf;
    }
    if (mkdir_p(out) != 0) {
        fprintf(stderr, "sandmpm run: cannot create output directory %s: %s\n", out, strerror(errno));
        sm_scene_destroy(sc);
        return EXIT_IO;
    }
    sm_world *w = sm_scene_world(sc);
    char path[4096], err[1024];
    FILE *csv = NULL, *poses = NULL;
    if (st->out_csv) {
        snprintf(path, sizeof path, "%s/diagnostics.csv", out);
        csv = fopen(path, "w");
        if (!csv) {
            fprintf(stderr, "sandmpm run: %s: %s\n", path, strerror(errno));
            sm_scene_destroy(sc);
            return EXIT_IO;
        }
        sm_csv_header(csv);
    }
    snprintf(path, sizeof path, "%s/render.txt", out);
    if (sm_manifest_write(path, w, st->has_camera, st->eye, st->target, st->up, st->fov, err, sizeof err) != 0) {
        fprintf(stderr, "sandmpm run: %s\n", err);
        if (csv) fclose(csv);
        sm_scene_destroy(sc);
        return EXIT_IO;
    }
    snprintf(path, sizeof path, "%s/poses.csv", out);
    poses = fopen(path, "w");
    render_cfg rcfg;
    int have_render = 0;
    char **vtp_names = NULL;
    double *vtp_times = NULL;
    if (render) {
        if (render_setup(&rcfg, out, 1280, 720, SM_COLOR_SAND, so.threads, err, sizeof err) != 0) {
            fprintf(stderr, "sandmpm run: %s\n", err);
            render_free(&rcfg);
            rc = EXIT_NOMEM;
            goto finish;
        }
        have_render = 1;
    }
    if (st->out_vtk) {
        vtp_names = calloc((size_t)nframes + 1, sizeof *vtp_names);
        vtp_times = calloc((size_t)nframes + 1, sizeof *vtp_times);
        if (!vtp_names || !vtp_times) {
            fprintf(stderr, "sandmpm run: out of memory\n");
            rc = EXIT_NOMEM;
            goto finish;
        }
    }
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    int tty = isatty(fileno(stderr));
    fprintf(stderr, "sandmpm: %s (%s), %zu particles, %d frames at %g fps -> %s/\n",
            so.scene ? so.scene : "default scene", so.quality ? so.quality : "preview", d.particles, nframes, fps, out);
    double t0 = wall();
    for (int f = 0; f <= nframes && rc == EXIT_DONE; f++) {
        if (f > 0) {
            sm_world_reset_step_stats(w);
            sm_status s = sm_world_advance(w, f / fps);
            const char *merr = sm_scene_motion_error(sc);
            if (s != SM_OK || merr) {
                fprintf(stderr, "%ssandmpm run: %s\n", tty ? "\n" : "", merr ? merr : sm_world_errmsg(w));
                rc = merr ? EXIT_BAD_INPUT : s == SM_ERR_NUMERICAL ? EXIT_NUMERICAL : s == SM_ERR_NOMEM ? EXIT_NOMEM
                                                                                                   : EXIT_BAD_INPUT;
                break;
            }
        }
        sm_world_diagnostics(w, &d);
        if (st->out_ply || have_render) {
            snprintf(path, sizeof path, "%s/frame_%04d.ply", out, f);
            if (sm_write_ply(w, path, err, sizeof err) != 0) {
                fprintf(stderr, "%ssandmpm run: %s\n", tty ? "\n" : "", err);
                rc = EXIT_IO;
                break;
            }
        }
        if (st->out_vtk) {
            char name[64];
            snprintf(name, sizeof name, "frame_%04d.vtp", f);
            snprintf(path, sizeof path, "%s/%s", out, name);
            vtp_names[f] = strdup(name);
            vtp_times[f] = d.time;
            snprintf(err, sizeof err, "out of memory");
            if (!vtp_names[f] || sm_write_vtp(w, path, err, sizeof err) != 0) {
                fprintf(stderr, "%ssandmpm run: %s\n", tty ? "\n" : "", err);
                rc = EXIT_IO;
                break;
            }
            snprintf(path, sizeof path, "%s/frames.pvd", out);
            if (sm_write_pvd(path, (const char *const *)vtp_names, vtp_times, f + 1, err, sizeof err) != 0) {
                fprintf(stderr, "%ssandmpm run: %s\n", tty ? "\n" : "", err);
                rc = EXIT_IO;
                break;
            }
        }
        if (poses) sm_manifest_poses(poses, f, w);
        if (have_render) {
            sm_frame fr;
            int r = sm_frame_from_world(w, &fr, err, sizeof err);
            snprintf(path, sizeof path, "%s/frame_%04d.png", out, f);
            if (r == 0) r = render_one(&rcfg, &fr, f, path, err, sizeof err);
            sm_frame_free(&fr);
            if (r) {
                fprintf(stderr, "%ssandmpm run: %s\n", tty ? "\n" : "", err);
                rc = exit_of(r);
                break;
            }
        }
        double el = wall() - t0;
        if (csv) sm_csv_row(csv, f, &d, el);
        double rate = el > 0 ? (double)d.particles * (double)d.steps / el : 0;
        double eta = f > 0 ? el / f * (nframes - f) : 0;
        fprintf(stderr, "%sframe %d/%d  t = %.4g s  steps %llu  particles %zu  %.3g particle-steps/s  ETA %.0f s%s",
                tty ? "\r" : "", f, nframes, d.time, (unsigned long long)d.steps, d.particles, rate, eta,
                tty ? "   " : "\n");
    }
    if (tty) fprintf(stderr, "\n");
finish:
    if (csv && fclose(csv) != 0 && rc == EXIT_DONE) rc = EXIT_IO;
    if (poses) fclose(poses);
    if (vtp_names)
        for (int f = 0; f <= nframes; f++) free(vtp_names[f]);
    free(vtp_names);
    free(vtp_times);
    if (have_render) render_free(&rcfg);
    sm_scene_destroy(sc);
    if (rc == EXIT_DONE && video) rc = make_video(out, fps);
    return rc;
}

/* ------------------------------------------------------------------------------------------ */
/* bench                                                                                        */

/* The program of the other precision, in this program's directory (CMake: SM_SIBLING); "" if
 * the build has none. */
#ifndef SM_BENCH_SIBLING
#define SM_BENCH_SIBLING ""
#endif

#define BENCH_MAX_THREADS 16

static void usage_bench(FILE *f) {
    fprintf(f, "usage: sandmpm bench [--dim 2,3] [--precision float,double] [--threads 1,2] [--particles N]\n"
               "                     [--steps S] [--warmup W] [--csv [--no-header]]\n\n"
               "Measures the explicit step on a block of sand collapsing onto a sticky ground (hardening,\n"
               "quadratic kernel, APIC, every stage; 8 particles per cell in 3D, 4 in 2D): W warm-up steps,\n"
               "then S measured steps per case, one case per dimension, precision and thread count. Prints\n"
               "particle-steps/s in total and per stage, heap bytes per particle and heap allocations per\n"
               "step. This program is built in one precision (%s); the other runs in %s next to it.\n\n"
               "  --dim LIST         2, 3 or 2,3 (default 2,3)\n"
               "  --precision LIST   float, double or float,double (default float,double)\n"
               "  --threads LIST     thread counts, e.g. 1,2 (default 1,2)\n"
               "  --particles N      particles per case, about (default 1e6; at least 100)\n"
               "  --steps S          measured steps (default 20)\n"
               "  --warmup W         unmeasured steps before them (default 10)\n"
               "  --csv              one row per case: %s\n"
               "  --no-header        with --csv: no header line\n",
            sm_real_is_double() ? "double" : "float", SM_BENCH_SIBLING[0] ? SM_BENCH_SIBLING : "(none in this build)",
            "dim,precision,threads,particles,particle_steps_per_s,bytes_per_particle");
}

typedef struct bench_opts {
    int dim_mask;  /* bit d: dimension d */
    int prec_mask; /* bit 0 float, bit 1 double */
    int prec_given;
    int threads[BENCH_MAX_THREADS];
    int nthreads;
    sm_bench_case c; /* particles, warmup, steps */
    int csv, header;
    int raw;      /* hidden: the sibling's mode, lossless rows (app/bench.h) and only this precision */
    int progress; /* a progress line on stderr */
} bench_opts;

/* Splits a comma list into at most max items of at most 31 characters. Returns the count or -1. */
static int split_list(const char *s, char items[][32], int max) {
    int n = 0;
    const char *p = s;
    for (;;) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == 0 || len >= 32 || n >= max) return -1;
        memcpy(items[n], p, len);
        items[n][len] = 0;
        n++;
        if (!e) return n;
        p = e + 1;
    }
}

static int bench_parse(int argc, char **argv, bench_opts *o) {
    memset(o, 0, sizeof *o);
    o->dim_mask = 1 << 2 | 1 << 3;
    o->prec_mask = 3;
    o->threads[0] = 1;
    o->threads[1] = 2;
    o->nthreads = 2;
    o->c.particles = 1e6;
    o->c.steps = 20;
    o->c.warmup = 10;
    o->header = 1;
    char items[BENCH_MAX_THREADS][32];
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        int takes = !strcmp(a, "--dim") || !strcmp(a, "--precision") || !strcmp(a, "--threads") ||
                    !strcmp(a, "--particles") || !strcmp(a, "--steps") || !strcmp(a, "--warmup");
        if (takes && i + 1 >= argc) {
            fprintf(stderr, "sandmpm bench: %s needs a value (see sandmpm bench --help)\n", a);
            return EXIT_BAD_INPUT;
        }
        const char *v = takes ? argv[++i] : NULL;
        if (!strcmp(a, "--dim")) {
            int n = split_list(v, items, BENCH_MAX_THREADS);
            o->dim_mask = 0;
            for (int k = 0; k < n; k++) {
                if (strcmp(items[k], "2") && strcmp(items[k], "3")) n = -1;
                else o->dim_mask |= 1 << (items[k][0] - '0');
            }
            if (n < 1) {
                fprintf(stderr, "sandmpm bench: --dim: expected 2, 3 or 2,3, got \"%s\"\n", v);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--precision")) {
            int n = split_list(v, items, BENCH_MAX_THREADS);
            o->prec_mask = 0;
            o->prec_given = 1;
            for (int k = 0; k < n; k++) {
                if (!strcmp(items[k], "float")) o->prec_mask |= 1;
                else if (!strcmp(items[k], "double")) o->prec_mask |= 2;
                else n = -1;
            }
            if (n < 1) {
                fprintf(stderr, "sandmpm bench: --precision: expected float, double or float,double, got \"%s\"\n", v);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--threads")) {
            int n = split_list(v, items, BENCH_MAX_THREADS);
            for (int k = 0; k < n; k++) {
                if (!parse_int(items[k], 1, 1024, &o->threads[k])) n = -1;
                for (int j = 0; j < k && n > 0; j++)
                    if (o->threads[j] == o->threads[k]) n = -1;
            }
            if (n < 1) {
                fprintf(stderr,
                        "sandmpm bench: --threads: expected a comma list of different thread counts 1..1024 (at most "
                        "%d), got \"%s\"\n",
                        BENCH_MAX_THREADS, v);
                return EXIT_BAD_INPUT;
            }
            o->nthreads = n;
        } else if (!strcmp(a, "--particles")) {
            if (!parse_double(v, &o->c.particles) || o->c.particles < 100 || o->c.particles > 1e9) {
                fprintf(stderr, "sandmpm bench: --particles: expected a number from 100 to 1e9, got \"%s\"\n", v);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--steps")) {
            if (!parse_int(v, 1, 1000000, &o->c.steps)) {
                fprintf(stderr, "sandmpm bench: --steps: expected a whole number >= 1, got \"%s\"\n", v);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--warmup")) {
            if (!parse_int(v, 0, 1000000, &o->c.warmup)) {
                fprintf(stderr, "sandmpm bench: --warmup: expected a whole number >= 0, got \"%s\"\n", v);
                return EXIT_BAD_INPUT;
            }
        } else if (!strcmp(a, "--csv")) {
            o->csv = 1;
        } else if (!strcmp(a, "--no-header")) {
            o->header = 0;
        } else if (!strcmp(a, "--sibling-rows")) {
            o->raw = 1;
        } else if (!strcmp(a, "--sibling-progress")) {
            o->progress = 1;
        } else {
            fprintf(stderr, "sandmpm bench: unknown option \"%s\" (see sandmpm bench --help)\n", a);
            return EXIT_BAD_INPUT;
        }
    }
    if (!o->header && !o->csv && !o->raw) {
        fprintf(stderr, "sandmpm bench: --no-header goes with --csv\n");
        return EXIT_BAD_INPUT;
    }
    if (!o->raw && !o->csv) o->progress = 1;
    if (o->progress && !isatty(fileno(stderr))) o->progress = 0;
    return EXIT_DONE;
}

static void bench_emit(const bench_opts *o, const sm_bench_result *r) {
    if (o->raw) sm_bench_raw_row(stdout, r);
    else if (o->csv) sm_bench_csv_row(stdout, r);
    else sm_bench_table_row(stdout, r);
    fflush(stdout);
}

/* The cases of this program's precision, in process. */
static int bench_local(const bench_opts *o) {
    for (int dim = 2; dim <= 3; dim++) {
        if (!(o->dim_mask & (1 << dim))) continue;
        for (int t = 0; t < o->nthreads; t++) {
            sm_bench_case c = o->c;
            c.dim = dim;
            c.threads = o->threads[t];
            const char *prec = sm_bench_precision_name(sm_real_is_double());
            int len = 0;
            if (o->progress)
                len = fprintf(stderr, "running %dD %s, %d thread%s, about %.0f particles, %d + %d steps ...", dim, prec,
                              c.threads, c.threads == 1 ? "" : "s", c.particles, c.warmup, c.steps);
            sm_bench_result r;
            char err[1024];
            int rc = sm_bench_run(&c, &r, err, sizeof err);
            if (o->progress && len > 0) fprintf(stderr, "\r%*s\r", len, "");
            if (rc) {
                fprintf(stderr, "sandmpm bench: %dD %s, %d thread%s: %s\n", dim, prec, c.threads,
                        c.threads == 1 ? "" : "s", err);
                return rc == 5 ? EXIT_NOMEM : rc == 3 ? EXIT_NUMERICAL : EXIT_BAD_INPUT;
            }
            bench_emit(o, &r);
        }
    }
    return EXIT_DONE;
}

/* Path of the sibling program (the other precision) next to this one, via /proc/self/exe.
 * Returns 1 if it exists and is executable, 0 if not (path still filled when it can be). */
static int bench_sibling(char *path, size_t len) {
    path[0] = 0;
    if (!SM_BENCH_SIBLING[0]) return 0;
    char self[4096];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0) return 0;
    self[n] = 0;
    char *slash = strrchr(self, '/');
    if (!slash) return 0;
    *slash = 0;
    if ((size_t)snprintf(path, len, "%s/%s", self, SM_BENCH_SIBLING) >= len) {
        path[0] = 0;
        return 0;
    }
    return access(path, X_OK) == 0;
}

/* Runs the cases of the other precision in the sibling program and emits its rows as they come. */
static int bench_remote(const bench_opts *o, const char *path, int is_double) {
    char dims[8] = "", threads[BENCH_MAX_THREADS * 6] = "", particles[32], steps[16], warmup[16];
    size_t k = 0;
    for (int d = 2; d <= 3; d++)
        if (o->dim_mask & (1 << d)) k += (size_t)snprintf(dims + k, sizeof dims - k, "%s%d", k ? "," : "", d);
    k = 0;
    for (int t = 0; t < o->nthreads; t++)
        k += (size_t)snprintf(threads + k, sizeof threads - k, "%s%d", t ? "," : "", o->threads[t]);
    snprintf(particles, sizeof particles, "%.17g", o->c.particles);
    snprintf(steps, sizeof steps, "%d", o->c.steps);
    snprintf(warmup, sizeof warmup, "%d", o->c.warmup);
    const char *prec = sm_bench_precision_name(is_double);
    char *args[] = {(char *)path,      "bench",    "--sibling-rows", "--precision", (char *)prec, "--dim", dims,
                    "--threads",       threads,    "--particles",    particles,     "--steps",    steps,   "--warmup",
                    warmup,            o->progress ? "--sibling-progress" : NULL, NULL};
    int fd[2];
    if (pipe(fd) != 0) {
        fprintf(stderr, "sandmpm bench: pipe: %s\n", strerror(errno));
        return EXIT_IO;
    }
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid < 0) {
        fprintf(stderr, "sandmpm bench: fork: %s\n", strerror(errno));
        close(fd[0]);
        close(fd[1]);
        return EXIT_IO;
    }
    if (pid == 0) {
        close(fd[0]);
        if (dup2(fd[1], STDOUT_FILENO) < 0) _exit(EXIT_IO);
        close(fd[1]);
        execv(path, args);
        fprintf(stderr, "sandmpm bench: cannot run %s: %s\n", path, strerror(errno));
        _exit(EXIT_IO);
    }
    close(fd[1]);
    FILE *in = fdopen(fd[0], "r");
    int rc = EXIT_DONE;
    if (!in) {
        fprintf(stderr, "sandmpm bench: %s\n", strerror(errno));
        close(fd[0]);
        rc = EXIT_IO;
    } else {
        char *line = NULL;
        size_t cap = 0;
        while (getline(&line, &cap, in) > 0) {
            if (rc) continue; /* drain, so the sibling is not stopped by a broken pipe */
            sm_bench_result r;
            char err[256];
            if (sm_bench_parse_raw(line, &r, err, sizeof err) != 0) {
                fprintf(stderr, "sandmpm bench: %s: %s\n", path, err);
                rc = EXIT_IO;
            } else if (r.is_double != is_double) {
                fprintf(stderr, "sandmpm bench: %s measured %s, not %s\n", path, sm_bench_precision_name(r.is_double),
                        prec);
                rc = EXIT_IO;
            } else {
                bench_emit(o, &r);
            }
        }
        free(line);
        fclose(in);
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) {
            fprintf(stderr, "sandmpm bench: waitpid: %s\n", strerror(errno));
            return EXIT_IO;
        }
    if (WIFSIGNALED(status)) {
        fprintf(stderr, "sandmpm bench: %s (the %s cases) was killed by signal %d%s\n", path, prec, WTERMSIG(status),
                WTERMSIG(status) == SIGKILL ? " (out of memory?)" : "");
        return WTERMSIG(status) == SIGKILL ? EXIT_NOMEM : EXIT_NUMERICAL;
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) != 0) {
        fprintf(stderr, "sandmpm bench: %s (the %s cases) failed with exit code %d\n", path, prec, WEXITSTATUS(status));
        return WEXITSTATUS(status);
    }
    return rc;
}

static int cmd_bench(int argc, char **argv) {
    for (int i = 0; i < argc; i++)
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage_bench(stdout);
            return EXIT_DONE;
        }
    bench_opts o;
    int rc = bench_parse(argc, argv, &o);
    if (rc) return rc;
    const int own = sm_real_is_double() ? 2 : 1, other = 3 - own;
    const char *own_name = sm_bench_precision_name(own == 2), *other_name = sm_bench_precision_name(other == 2);
    char sib[4096] = "";
    if (o.raw) {
        /* The sibling's side: only this precision, never another sibling. */
        if (o.prec_mask != own) {
            fprintf(stderr, "sandmpm bench: --sibling-rows: this program measures %s only\n", own_name);
            return EXIT_BAD_INPUT;
        }
    } else if ((o.prec_mask & other) && !bench_sibling(sib, sizeof sib)) {
        char why[4200];
        if (!SM_BENCH_SIBLING[0])
            snprintf(why, sizeof why, "this build has no %s program (CMake option SM_SIBLING=OFF)", other_name);
        else
            snprintf(why, sizeof why, "%s is missing (it is built with the CMake option SM_SIBLING=ON, the default)",
                     sib[0] ? sib : SM_BENCH_SIBLING);
        if (o.prec_given) {
            fprintf(stderr, "sandmpm bench: this program is %s; %s cannot be measured: %s\n", own_name, other_name, why);
            return EXIT_BAD_INPUT;
        }
        fprintf(stderr, "sandmpm bench: note: %s; measuring %s only\n", why, own_name);
        o.prec_mask = own;
    }
    if (o.csv && o.header) sm_bench_csv_header(stdout);
    if (!o.csv && !o.raw) sm_bench_table_header(stdout, &o.c);
    fflush(stdout);
    for (int p = 1; p <= 2 && rc == EXIT_DONE; p++) { /* float, then double */
        if (!(o.prec_mask & p)) continue;
        rc = p == own ? bench_local(&o) : bench_remote(&o, sib, p == 2);
    }
    return rc;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        usage(stderr);
        return EXIT_BAD_INPUT;
    }
    const char *c = argv[1];
    if (!strcmp(c, "--help") || !strcmp(c, "-h") || !strcmp(c, "help")) {
        usage(stdout);
        return EXIT_DONE;
    }
    if (!strcmp(c, "--version")) {
        printf("sandmpm %s (%s precision)\n", sm_version(), sm_real_is_double() ? "double" : "float");
        return EXIT_DONE;
    }
    if (!strcmp(c, "run")) return cmd_run(argc - 2, argv + 2);
    if (!strcmp(c, "info")) return cmd_info(argc - 2, argv + 2);
    if (!strcmp(c, "render")) return cmd_render(argc - 2, argv + 2);
    if (!strcmp(c, "bench")) return cmd_bench(argc - 2, argv + 2);
    fprintf(stderr, "sandmpm: unknown command \"%s\" (see sandmpm --help)\n", c);
    return EXIT_BAD_INPUT;
}
