/* sandmpm render OUTDIR: a run's PLY frames to PNG images (and a video). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <string.h>
#include <stdlib.h>
#include <unistd.h>

#include "app/io/files.h"
#include "app/io/csv.h"
#include "app/io/ply.h"
#include "app/render_job.h"
#include "cli/cli.h"

typedef struct render_args {
    const char *dir;
    int width, height, threads, video;
    int from, to; /* --frames FROM..TO (default: all, 0..INT_MAX) */
    sm_color_mode color;
} render_args;

/* --frames N, FROM..TO, FROM.. or ..TO into *a; 0 if malformed. */
static int parse_range(const char *s, render_args *a) {
    const char *dots = strstr(s, "..");
    char lo[32] = "", hi[32] = "";
    if (!dots) {
        if (!cli_parse_int(s, 0, INT_MAX, &a->from)) return 0;
        a->to = a->from;
        return 1;
    }
    if ((size_t)(dots - s) >= sizeof lo || strlen(dots + 2) >= sizeof hi) return 0;
    memcpy(lo, s, (size_t)(dots - s));
    snprintf(hi, sizeof hi, "%s", dots + 2);
    if (lo[0] && !cli_parse_int(lo, 0, INT_MAX, &a->from)) return 0;
    if (hi[0] && !cli_parse_int(hi, 0, INT_MAX, &a->to)) return 0;
    return (lo[0] || hi[0]) && a->from <= a->to;
}

static sm_status parse_args(int argc, char **argv, render_args *a) {
    memset(a, 0, sizeof *a);
    a->width = 1280;
    a->height = 720;
    a->color = SM_COLOR_SAND;
    a->to = INT_MAX;
    for (int i = 0; i < argc; i++) {
        const char *s = argv[i];
        if (!strcmp(s, "--color") && i + 1 < argc) {
            const char *c = argv[++i];
            if (!strcmp(c, "sand")) a->color = SM_COLOR_SAND;
            else if (!strcmp(c, "speed")) a->color = SM_COLOR_SPEED;
            else if (!strcmp(c, "material")) a->color = SM_COLOR_MATERIAL;
            else if (!strcmp(c, "q")) a->color = SM_COLOR_Q;
            else {
                fprintf(stderr, "sandmpm render: --color: expected sand, speed, material or q, got \"%s\"\n", c);
                return SM_ERR_INVALID;
            }
        } else if (!strcmp(s, "--size") && i + 1 < argc) {
            if (sscanf(argv[++i], "%dx%d", &a->width, &a->height) != 2 || a->width < 16 || a->height < 16 ||
                a->width > 16384 || a->height > 16384) {
                fprintf(stderr, "sandmpm render: --size: expected WxH (16..16384), got \"%s\"\n", argv[i]);
                return SM_ERR_INVALID;
            }
        } else if (!strcmp(s, "--threads") && i + 1 < argc) {
            if (!cli_parse_int(argv[++i], 1, 1024, &a->threads)) {
                fprintf(stderr, "sandmpm render: --threads: expected 1..1024, got \"%s\"\n", argv[i]);
                return SM_ERR_INVALID;
            }
            cli_warn_threads("render", a->threads);
        } else if (!strcmp(s, "--video")) {
            a->video = 1;
        } else if (!strcmp(s, "--frames") && i + 1 < argc) {
            if (!parse_range(argv[++i], a)) {
                fprintf(stderr, "sandmpm render: --frames: expected N, FROM..TO, FROM.. or ..TO (frame numbers, "
                                "FROM <= TO), got \"%s\"\n", argv[i]);
                return SM_ERR_INVALID;
            }
        } else if (s[0] == '-' || a->dir) {
            fprintf(stderr, "sandmpm render: unexpected argument \"%s\" (see sandmpm render --help)\n", s);
            return SM_ERR_INVALID;
        } else {
            a->dir = s;
        }
    }
    if (!a->dir) {
        fprintf(stderr, "sandmpm render: which run? usage: sandmpm render OUTDIR\n");
        return SM_ERR_INVALID;
    }
    char err[SM_MSG_MAX];
    sm_status st = sm_check_folder_name(a->dir, err, sizeof err);
    if (st != SM_OK) fprintf(stderr, "sandmpm render: %s\n", err);
    return st;
}

/* The frames to render: those OUTDIR/run_manifest.txt lists (*m, *listed = 1), or in a folder
 * without one (an older version's run) every frame_NNNN.ply found, with a note. */
static sm_status find_frames(const char *dir, sm_run_manifest *m, int *listed, int *count) {
    char err[SM_MSG_MAX];
    int found = 0, n = 0;
    sm_status st = sm_run_manifest_read(dir, m, &found, err, sizeof err);
    *listed = st == SM_OK;
    if (found && st != SM_OK) {
        fprintf(stderr, "sandmpm render: %s\n", err);
        return st == SM_ERR_INVALID ? SM_ERR_INVALID : SM_ERR_IO;
    }
    if (!found) {
        st = sm_run_manifest_scan(dir, m, &n, err, sizeof err);
        if (st != SM_OK) {
            fprintf(stderr, "sandmpm render: %s\n", err);
            return st;
        }
    }
    *count = sm_run_manifest_count(m, SM_FRAME_PLY);
    if (*count == 0) {
        if (*listed)
            fprintf(stderr, "sandmpm render: %s/%s lists no PLY frames (the scene's outputs.ply is off; run it with "
                            "--render, or with outputs.ply = true)\n", dir, SM_RUN_MANIFEST_NAME);
        else
            fprintf(stderr, "sandmpm render: %s: no frame_NNNN.ply files (run `sandmpm run --out %s` first)\n", dir, dir);
        return SM_ERR_IO;
    }
    if (!*listed)
        fprintf(stderr, "sandmpm render: note: %s/ has no %s (a run of an older sandmpm?): rendering every "
                        "frame_NNNN.ply in it, frames %d..%d\n", dir, SM_RUN_MANIFEST_NAME, m->first[SM_FRAME_PLY],
                m->last[SM_FRAME_PLY]);
    return SM_OK;
}

/* The run manifest lists the PNG frames rendered too (so that --overwrite removes them). */
static void list_pngs(const char *dir, sm_run_manifest *m, int first, int last) {
    char err[SM_MSG_MAX];
    if (sm_run_manifest_count(m, SM_FRAME_PNG) > 0) {
        if (m->first[SM_FRAME_PNG] < first) first = m->first[SM_FRAME_PNG];
        if (m->last[SM_FRAME_PNG] > last) last = m->last[SM_FRAME_PNG];
    }
    m->first[SM_FRAME_PNG] = first;
    m->last[SM_FRAME_PNG] = last;
    if (sm_run_manifest_write(dir, m, err, sizeof err) != SM_OK)
        fprintf(stderr, "sandmpm render: warning: could not list the PNG files in the run manifest: %s\n", err);
}

/* Frame f's PLY to its PNG (nothing if there is no such PLY). *done counts the frames rendered. */
static sm_status render_frame(sm_render_job *job, const char *dir, int f, int *done, char *err, size_t errlen) {
    char ply[SM_PATH_MAX], png[SM_PATH_MAX];
    snprintf(ply, sizeof ply, "%s/frame_%04d.ply", dir, f);
    snprintf(png, sizeof png, "%s/frame_%04d.png", dir, f);
    if (access(ply, F_OK) != 0) return SM_OK;
    sm_frame fr;
    sm_status st = sm_ply_read(ply, &fr, err, errlen);
    if (st == SM_OK) {
        st = sm_render_job_frame(job, &fr, f, png, err, errlen);
        sm_frame_free(&fr);
    }
    if (st == SM_OK) ++*done;
    return st;
}

/* The frame rate from diagnostics.csv (the time of frame 1), else 24. */
static sm_status make_video(const char *dir) {
    char p[SM_PATH_MAX];
    snprintf(p, sizeof p, "%s/diagnostics.csv", dir);
    return cli_make_video(dir, sm_csv_read_fps(p, 24));
}

/* Renders frames first..last in order; stops early after a frame if cli_stop is set. */
static sm_status render_all(const render_args *a, int count, int first, int last, int *done) {
    char err[SM_MSG_MAX], note[SM_MSG_MAX];
    sm_render_job job;
    sm_status st = sm_render_job_open(&job, a->dir, a->width, a->height, a->color, a->threads, err, sizeof err);
    const int tty = isatty(fileno(stderr));
    const double t0 = sm_run_wall();
    *done = 0;
    for (int f = first; f <= last && st == SM_OK && !cli_stop; f++) {
        st = render_frame(&job, a->dir, f, done, err, sizeof err);
        if (st == SM_OK && tty) fprintf(stderr, "\rrendered %d/%d", *done, count);
        snprintf(note, sizeof note, "sandmpm render: stopped at once; %d frames rendered to %s/", *done, a->dir);
        cli_signals_note(note);
    }
    sm_render_job_close(&job);
    if (st != SM_OK) {
        fprintf(stderr, "%ssandmpm render: %s\n", tty ? "\n" : "", err);
        return st;
    }
    fprintf(stderr, "%srendered %d frames to %s/frame_NNNN.png in %.1f s\n", tty ? "\r" : "", *done, a->dir,
            sm_run_wall() - t0);
    return SM_OK;
}

static int render_command(int argc, char **argv) {
    if (cli_help_requested(argc, argv)) {
        cli_usage_render(stdout);
        return cli_exit_code(SM_OK);
    }
    render_args a;
    sm_run_manifest m;
    int count = 0, listed = 0, done = 0;
    sm_status st = parse_args(argc, argv, &a);
    if (st == SM_OK) st = find_frames(a.dir, &m, &listed, &count);
    if (st == SM_OK) st = cli_remove_stale("render", a.dir);
    if (st != SM_OK) return cli_exit_code(st);
    cli_signals_install();
    const int first = a.from > m.first[SM_FRAME_PLY] ? a.from : m.first[SM_FRAME_PLY];
    const int last = a.to < m.last[SM_FRAME_PLY] ? a.to : m.last[SM_FRAME_PLY];
    if (first > last) {
        fprintf(stderr, "sandmpm render: --frames: the run in %s/ has frames %d..%d, none of them asked for\n", a.dir,
                m.first[SM_FRAME_PLY], m.last[SM_FRAME_PLY]);
        return cli_exit_code(SM_ERR_INVALID);
    }
    count = last - first + 1;
    st = render_all(&a, count, first, last, &done);
    if (listed && done > 0) list_pngs(a.dir, &m, first, last);
    if (cli_stop) {
        fprintf(stderr, "sandmpm render: stopped by %s after %d of %d frames\n", cli_signal_name(cli_stop), done, count);
        return cli_exit_code_signal(cli_stop);
    }
    if (st == SM_OK && a.video) st = make_video(a.dir);
    if (cli_stop) return cli_exit_code_signal(cli_stop);
    return cli_exit_code(st);
}

int cli_render(int argc, char **argv) { return render_command(argc, argv); }
