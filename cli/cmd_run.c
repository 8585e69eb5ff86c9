/* sandmpm run [SCENE]: load and build the scene, claim the output folder (out_folder.c), then the
 * frame loop (app/run.h) with the output sinks the scene's outputs table asks for (chosen by
 * app/run_outputs.h, as for the Python package), the run manifest and the progress line. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <string.h>

#include <dirent.h>
#include <sys/stat.h>
#include <stdlib.h>
#include <unistd.h>

#include "app/checkpoint.h"
#include "app/io/files.h"
#include "app/run_outputs.h"
#include "cli/cli.h"

typedef struct run_args {
    cli_scene_opts so;
    const char *out;
    int frames, render, video;
    double end;
    int ckpt_every, keep, resume, force; /* --checkpoint-every (-1: default), --keep-checkpoints */
    int overwrite;                       /* --overwrite: another run's files in --out are removed */
    int quiet, verbose;                  /* -q/--quiet, -v/--verbose (the progress sink) */
} run_args;

static sm_status parse_args(int argc, char **argv, run_args *a) {
    memset(a, 0, sizeof *a);
    a->frames = -1;
    a->end = -1;
    a->ckpt_every = -1; /* the scene's checkpoint_every, else CLI_CHECKPOINT_EVERY */
    a->keep = CLI_KEEP_CHECKPOINTS;
    for (int i = 0; i < argc; i++) {
        const char *s = argv[i];
        int r = cli_parse_scene_opt("run", argc, argv, &i, &a->so);
        if (r < 0) return SM_ERR_INVALID;
        if (r > 0) continue;
        if (!strcmp(s, "--out") && i + 1 < argc) {
            a->out = argv[++i];
        } else if (!strcmp(s, "--frames") && i + 1 < argc) {
            if (!cli_parse_int(argv[++i], 1, 10000000, &a->frames)) {
                fprintf(stderr, "sandmpm run: --frames: expected a whole number >= 1, got \"%s\"\n", argv[i]);
                return SM_ERR_INVALID;
            }
        } else if (!strcmp(s, "--end") && i + 1 < argc) {
            if (!cli_parse_double(argv[++i], &a->end) || !(a->end > 0)) {
                fprintf(stderr, "sandmpm run: --end: expected seconds > 0, got \"%s\"\n", argv[i]);
                return SM_ERR_INVALID;
            }
        } else if (!strcmp(s, "--checkpoint-every") && i + 1 < argc) {
            if (!cli_parse_int(argv[++i], 0, 10000000, &a->ckpt_every)) {
                fprintf(stderr, "sandmpm run: --checkpoint-every: expected frames >= 0 (0: none), got \"%s\"\n", argv[i]);
                return SM_ERR_INVALID;
            }
        } else if (!strcmp(s, "--keep-checkpoints") && i + 1 < argc) {
            if (!cli_parse_int(argv[++i], 1, 1000, &a->keep)) {
                fprintf(stderr, "sandmpm run: --keep-checkpoints: expected a whole number >= 1, got \"%s\"\n", argv[i]);
                return SM_ERR_INVALID;
            }
        } else if (!strcmp(s, "--resume")) {
            a->resume = 1;
        } else if (!strcmp(s, "--force")) {
            a->force = 1;
        } else if (!strcmp(s, "--overwrite")) {
            a->overwrite = 1;
        } else if (!strcmp(s, "-q") || !strcmp(s, "--quiet")) {
            a->quiet = 1;
        } else if (!strcmp(s, "-v") || !strcmp(s, "--verbose")) {
            a->verbose = 1;
        } else if (!strcmp(s, "--render")) {
            a->render = 1;
        } else if (!strcmp(s, "--video")) {
            a->video = 1;
        } else if (s[0] == '-' || a->so.scene) {
            fprintf(stderr, "sandmpm run: unexpected argument \"%s\" (see sandmpm run --help)\n", s);
            return SM_ERR_INVALID;
        } else {
            a->so.scene = s;
        }
    }
    if (a->frames > 0 && a->end > 0) {
        fprintf(stderr, "sandmpm run: give --frames or --end, not both\n");
        return SM_ERR_INVALID;
    }
    if (a->resume && a->overwrite) {
        fprintf(stderr, "sandmpm run: give --resume (continue the run in the folder) or --overwrite (replace it), not both\n");
        return SM_ERR_INVALID;
    }
    if (a->quiet && a->verbose) {
        fprintf(stderr, "sandmpm run: give -q/--quiet or -v/--verbose, not both\n");
        return SM_ERR_INVALID;
    }
    if (a->video && !a->render) {
        if (!a->quiet)
            fprintf(stderr, "sandmpm run: note: --video needs the frames as pictures, so it renders them too (as "
                            "--render: frame_NNNN.png)\n");
        a->render = 1;
    }
    return SM_OK;
}

/* The request to the shared sink choice (app/run_outputs.h). */
static sm_run_request run_request(const run_args *a, uint64_t hash, int nframes) {
    sm_run_request r;
    memset(&r, 0, sizeof r);
    r.scene = a->so.scene;
    r.quality = a->so.quality;
    r.scene_hash = hash;
    r.frames = nframes;
    r.render = a->render;
    r.video = a->video;
    r.threads = a->so.threads;
    r.checkpoint_every = a->ckpt_every;
    r.keep_last = cli_ranks_count() > 1; /* across ranks no rank holds the world to write at a stop */
    r.keep = a->keep;
    return r;
}

/* The outputs of app/run_outputs.h, then the progress line and the interrupt note. */
static void choose_sinks(const run_args *a, const sm_run_request *r, const sm_scene_settings *st, const sm_run_manifest *start,
                         sm_run_outputs *o, cli_progress_config *progress) {
    sm_run_outputs_choose(o, r, st, start);
    progress->scene_label = a->so.scene ? a->so.scene : "default scene";
    progress->quality = a->so.quality ? a->so.quality : "preview";
    progress->quiet = a->quiet;
    progress->verbose = a->verbose;
    o->sinks[o->nsinks++] = cli_progress_sink(progress);
    o->sinks[o->nsinks++] = cli_interrupt_note_sink();
}

static const char *motion_error(void *scene) { return sm_scene_motion_error(scene); }

/* The frames to run: --frames, --end or the scene's, within what a run can hold. */
static sm_status frame_count(const run_args *a, const sm_scene_settings *set, int *nframes) {
    const double fps = set->fps;
    if (!(fps > 0) || !isfinite(fps)) {
        fprintf(stderr, "sandmpm run: the scene's fps must be a number > 0, got %g\n", fps);
        return SM_ERR_INVALID;
    }
    double n = a->frames > 0 ? a->frames : set->frames;
    if (a->end > 0) {
        n = ceil(a->end * fps - 1e-9);
        if (!(n >= 1)) {
            fprintf(stderr, "sandmpm run: --end %g s is less than one frame at %g fps (a frame is %g s)\n", a->end, fps,
                    1 / fps);
            return SM_ERR_INVALID;
        }
        if (fabs(n - a->end * fps) > 1e-6 * fmax(1, n) && n <= CLI_MAX_FRAMES)
            fprintf(stderr, "sandmpm run: warning: --end %g s is not a whole number of frames at %g fps (%.4g frames); "
                            "running %.0f frames, to t = %.6g s\n", a->end, fps, a->end * fps, n, n / fps);
    }
    if (!(n >= 1 && n <= CLI_MAX_FRAMES)) {
        fprintf(stderr, "sandmpm run: %s%.0f frames at %g fps; a run has 1 to %d frames\n",
                a->end > 0 ? "--end gives " : a->frames > 0 ? "" : "the scene asks for ", n, fps, CLI_MAX_FRAMES);
        return SM_ERR_INVALID;
    }
    if (!isfinite(n / fps)) {
        fprintf(stderr, "sandmpm run: %.0f frames at %g fps end at an infinite time\n", n, fps);
        return SM_ERR_INVALID;
    }
    *nframes = (int)n;
    return SM_OK;
}

/* After a numerical failure: the scene settings that make the steps smaller or the material
 * softer (the library's message speaks of dt; a scene's author sets these). */
static void say_what_to_change(void) {
    fprintf(stderr, "sandmpm run: to get past it, change the scene (docs/scene-format.md): a smaller max_dt (the largest "
                    "step), a smaller cfl or elastic_cfl (the step bounds from speed and stiffness), or a smaller E "
                    "(stiffer materials need smaller steps); an initial velocity or a collider's speed that is too "
                    "large for dx does the same\n");
}

/* What the folder holds after a run that did not finish. */
static void say_what_is_complete(const char *out, int frames_written, int nframes) {
    if (frames_written > 0)
        fprintf(stderr, "sandmpm run: frames 0..%d of 0..%d are complete in %s/\n", frames_written - 1, nframes, out);
    else
        fprintf(stderr, "sandmpm run: no frame was completed in %s/\n", out);
}

/* Whether a signal stops the run at the next step (app/run.h): when the last frame is kept
 * elsewhere than in the world: in the checkpoint sink's copy (across ranks always, each rank its
 * parts; on one process with --checkpoint-every > 0). Else it stops after the frame in progress. */
static int stop_at_step(const run_args *a, const cli_ranks *ranks) { return ranks->count > 1 || a->ckpt_every > 0; }

/* The frame loop into out; the message of a failure or a stop printed. *stopped: the signal that
 * stopped it early, or 0. */
static sm_status run_frames(const run_args *a, sm_scene *sc, const char *out, int nframes, int first, uint64_t hash,
                            const sm_run_manifest *manifest, const cli_ranks *ranks, int *stopped) {
    const sm_scene_settings *st = sm_scene_get_settings(sc);
    const sm_run_request req = run_request(a, hash, nframes);
    sm_run_outputs o;
    cli_progress_config progress;
    memset(&progress, 0, sizeof progress);
    progress.out_dir = out;
    progress.ranks = ranks->count;
    progress.threads = a->so.threads;
    choose_sinks(a, &req, st, manifest, &o, &progress);
    sm_run_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.info.out_dir = out;
    cfg.info.w = sm_scene_world(sc);
    cfg.info.frames = nframes;
    cfg.info.fps = st->fps;
    cfg.info.first_frame = first;
    cfg.world_error = motion_error;
    cfg.world_error_ctx = sc;
    cfg.stop = &cli_stop;
    cfg.stop_at_step = stop_at_step(a, ranks);
    cfg.ranks = ranks->count > 1 ? &ranks->hooks : NULL;
    sm_run_result res;
    char err[SM_MSG_MAX];
    sm_status s = sm_run_frames(&cfg, o.sinks, o.nsinks, &res, err, sizeof err);
    *stopped = res.stopped ? (int)cli_stop : 0;
    if (s != SM_OK) fprintf(stderr, "sandmpm run: %s\n", err);
    if (s == SM_ERR_NUMERICAL) say_what_to_change();
    if (*stopped)
        fprintf(stderr, "sandmpm run: stopped by %s after frame %d (t = %.6g s)\n", cli_signal_name(*stopped),
                res.frames_written - 1, (res.frames_written - 1) / st->fps);
    if (*stopped && res.frames_written > 0 && ranks->rank == 0) {
        char path[SM_PATH_MAX], e2[SM_MSG_MAX];
        const int frame = res.frames_written - 1;
        sm_status cs;
        if (req.keep_last || o.ckpt.every > 0) /* the checkpoint sink wrote the last frame's state */
            cs = sm_checkpoint_find(out, frame, path, sizeof path, e2, sizeof e2);
        else /* one process, stopped between frames: the world is at the frame's time */
            cs = sm_checkpoint_write(out, cfg.info.w, frame, hash, a->keep, path, sizeof path, e2, sizeof e2);
        char launcher[32] = "";
        if (ranks->count > 1) snprintf(launcher, sizeof launcher, "mpirun -np %d ", ranks->count);
        if (cs == SM_OK)
            fprintf(stderr, "sandmpm run: state at frame %d kept in %s; continue with: %ssandmpm run %s%s--out %s --resume%s\n",
                    res.frames_written - 1, path, launcher, a->so.scene ? a->so.scene : "", a->so.scene ? " " : "", out,
                    ranks->count > 1 ? " (on any number of ranks)" : "");
        else
            fprintf(stderr, "sandmpm run: could not write the checkpoint: %s\n", e2);
    }
    if (s == SM_ERR_NUMERICAL && a->ckpt_every > 0 && res.frames_written > 0)
        fprintf(stderr, "sandmpm run: the last good state (frame %d) is in %s/checkpoints/ckpt_%08d.smc\n",
                res.frames_written - 1, out, res.frames_written - 1);
    if (s != SM_OK || *stopped) say_what_is_complete(out, res.frames_written, nframes);
    return s;
}

/* The output folder: created, and cleared of temporaries that a killed run left. */
static sm_status prepare_folder(const char *out) {
    char err[SM_MSG_MAX];
    sm_status st = sm_make_dirs(out, err, sizeof err);
    if (st != SM_OK) {
        fprintf(stderr, "sandmpm run: %s\n", err);
        return st;
    }
    st = cli_remove_stale("run", out);
    char ckpt[SM_PATH_MAX];
    struct stat sb;
    if (st == SM_OK && snprintf(ckpt, sizeof ckpt, "%s/checkpoints", out) < (int)sizeof ckpt && stat(ckpt, &sb) == 0 &&
        S_ISDIR(sb.st_mode))
        st = cli_remove_stale("run", ckpt);
    return st;
}

/* The scene file's bytes, the --set pairs and the quality: what a resume must match. */
static uint64_t scene_hash(const cli_scene_opts *so) {
    return sm_run_scene_hash(so->scene, so->params, so->nparams, so->quality);
}

/* The run manifest's description of this run, before any frame (app/run_outputs.h). */
static void describe_run(const run_args *a, const sm_scene_settings *set, uint64_t hash, int nframes, sm_run_manifest *m) {
    const sm_run_request r = run_request(a, hash, nframes);
    sm_run_describe(&r, set, m);
}

static int run_command(int argc, char **argv) {
    if (cli_help_requested(argc, argv)) {
        cli_usage_run(stdout);
        return cli_exit_code(SM_OK);
    }
    run_args a;
    sm_status st = parse_args(argc, argv, &a);
    if (st != SM_OK) return cli_exit_code(st);
    sm_scene *sc = NULL;
    if ((st = cli_load_scene("run", &a.so, &sc)) != SM_OK) return cli_exit_code(st);
    const sm_scene_settings *set = sm_scene_get_settings(sc);
    const double fps = set->fps;
    int nframes = 0, stopped = 0;
    st = frame_count(&a, set, &nframes);
    if (st == SM_OK) st = cli_check_memory("run", set);
    cli_seeding *seeding = NULL; /* over several ranks: each rank builds only its share of the particles */
    if (st == SM_OK) st = cli_ranks_build("run", &a.so, sc, a.resume, &seeding);
    /* Only now, with a valid scene, touch the file system. */
    char outbuf[SM_PATH_MAX];
    const char *out = a.out;
    if (st == SM_OK && !out) {
        snprintf(outbuf, sizeof outbuf, "out/%s", a.so.scene ? set->name : "default");
        out = outbuf;
    }
    st = cli_ranks_worst(st); /* e.g. one rank's machine without the memory */
    if (st == SM_OK && cli_rank() == 0) st = prepare_folder(out);
    const uint64_t hash = scene_hash(&a.so);
    a.ckpt_every = sm_run_checkpoint_every(a.ckpt_every, set);
    int first = 0;
    sm_run_manifest manifest;
    describe_run(&a, set, hash, nframes, &manifest);
    const cli_claim claim = {a.resume, a.overwrite};
    if (st == SM_OK && cli_rank() == 0) st = cli_claim_folder(out, &claim, &manifest);
    st = cli_ranks_share_status(st);
    if (st == SM_OK && a.resume) st = cli_resume(sm_scene_world(sc), out, hash, a.force, &first);
    cli_ranks ranks;
    sm_scene *view = NULL; /* rank 0 of several, rendering: the scene built again, for the gathered world */
    if (st == SM_OK && a.render && cli_ranks_count() > 1 && cli_rank() == 0)
        st = cli_ranks_build_view("run", &a.so, seeding, &view);
    st = cli_ranks_worst(st);
    char err[SM_MSG_MAX];
    sm_status rs = st == SM_OK ? cli_ranks_open(&ranks, sm_scene_world(sc), view ? sm_scene_world(view) : NULL, seeding, err,
                                                sizeof err)
                               : SM_OK;
    if (rs != SM_OK) fprintf(stderr, "sandmpm run: %s\n", err);
    if (st == SM_OK && (st = rs) == SM_OK) {
        manifest.ranks = ranks.count;
        manifest.threads = a.so.threads;
        manifest.rank_particles = ranks.shares;
        cli_signals_install();
        if (stop_at_step(&a, &ranks)) cli_signals_stop_at_step();
        st = run_frames(&a, sc, out, nframes, first, hash, &manifest, &ranks, &stopped);
        cli_ranks_close(&ranks);
    }
    sm_scene_destroy(sc);
    if (view) sm_scene_destroy(view);
    cli_seeding_free(seeding);
    if (stopped) return cli_exit_code_signal(stopped);
    if (st == SM_OK && a.video && cli_rank() == 0) st = cli_make_video(out, fps);
    if (cli_stop) return cli_exit_code_signal(cli_stop); /* during the video */
    return cli_exit_code(st);
}

int cli_run(int argc, char **argv) { return run_command(argc, argv); }
