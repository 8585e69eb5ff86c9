/* sandmpm: the command-line program (DESIGN §2: thin — arguments, progress, exit codes).
 *
 *   sandmpm run [SCENE] [--out DIR] [--frames N | --end SECONDS] [--set KEY=VALUE]...
 *               [--threads N] [--quality preview|paper|test] [--render] [--video]
 *   sandmpm info SCENE [--set KEY=VALUE]... [--quality Q]
 *   sandmpm render OUTDIR [--color sand|speed|material|q] [--size WxH] [--threads N] [--video]
 *   sandmpm --help | COMMAND --help | --version
 *
 * Exit codes: 0 done, 2 bad input, 3 numerical failure, 4 I/O failure, 5 out of memory. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

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
               "  render OUTDIR   turn a run's frames (OUTDIR/frame_NNNN.ply) into PNG images\n\n"
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
    fprintf(stderr, "sandmpm: unknown command \"%s\" (see sandmpm --help)\n", c);
    return EXIT_BAD_INPUT;
}
