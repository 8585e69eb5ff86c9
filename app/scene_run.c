/* A scene's run in one call for bindings (app/scene_run.h): the folder claimed, the sinks of
 * app/run_outputs.h, the frame loop of app/run.h. */
#define _POSIX_C_SOURCE 200809L
#include "app/scene_run.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "app/io/files.h"
#include "app/run_folder.h"
#include "app/run_outputs.h"

sm_scene_run_opts sm_scene_run_opts_default(void) {
    sm_scene_run_opts o;
    memset(&o, 0, sizeof o);
    o.checkpoint_every = -1;
    return o;
}

/* The folder claimed for a run described by start (app/run_folder.h's rules, without resume),
 * with the refusals worded for a binding (overwrite instead of --overwrite). */
static sm_status claim(const char *out, const sm_run_manifest *start, int overwrite, char *err, size_t errlen) {
    sm_folder_claim c;
    sm_status st = sm_claim_folder(out, start, overwrite, &c, err, errlen);
    if (c.outcome == SM_CLAIM_REFUSED_UNLISTED)
        snprintf(err, errlen, "%s/ holds %d frame files (frame_NNNN.ply/.vtp/.png) but no %s; refusing to mix them with "
                              "this run (overwrite removes them)", out, c.found_files, SM_RUN_MANIFEST_NAME);
    else if (c.outcome == SM_CLAIM_REFUSED_OTHER)
        snprintf(err, errlen, "%s/ holds the frames of another run (%s, quality %s, scene hash %016llx; this run: %s, "
                              "quality %s, hash %016llx); refusing to mix the two runs (overwrite removes that run's files)",
                 out, c.old.scene, c.old.quality, (unsigned long long)c.old.scene_hash, start->scene, start->quality,
                 (unsigned long long)start->scene_hash);
    return st;
}

/* Created, cleared of a killed process's temporaries (and its checkpoints/ too). */
static sm_status prepare_folder(const char *out, char *err, size_t errlen) {
    sm_status st = sm_make_dirs(out, err, errlen);
    char first[256], ckpt[SM_PATH_MAX];
    int removed = 0;
    struct stat sb;
    if (st == SM_OK) st = sm_remove_stale_temporaries(out, &removed, first, sizeof first, err, errlen);
    if (st == SM_OK && snprintf(ckpt, sizeof ckpt, "%s/checkpoints", out) < (int)sizeof ckpt && stat(ckpt, &sb) == 0 &&
        S_ISDIR(sb.st_mode))
        st = sm_remove_stale_temporaries(ckpt, &removed, first, sizeof first, err, errlen);
    return st;
}

typedef struct frame_hook {
    int (*on_frame)(void *ctx, int frame);
    void *ctx;
    volatile sig_atomic_t *stop;
} frame_hook;

static sm_status hook_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    (void)err;
    (void)errlen;
    const frame_hook *h = s->config;
    if (h->on_frame(h->ctx, fr->frame)) *h->stop = 1;
    return SM_OK;
}

static const char *motion_error(void *scene) { return sm_scene_motion_error(scene); }

sm_status sm_scene_run(sm_scene *sc, const sm_scene_run_opts *o, int *frames_written, int *stopped, char *err,
                       size_t errlen) {
    *frames_written = 0;
    *stopped = 0;
    sm_world *w = sm_scene_world(sc);
    const sm_scene_settings *st = sm_scene_get_settings(sc);
    if (!w || !o->out) {
        snprintf(err, errlen, "%s", !w ? "the scene is not built (sm_scene_build)" : "no output folder");
        return SM_ERR_INVALID;
    }
    if (sm_world_time(w) != 0) {
        snprintf(err, errlen, "the scene's world is at t = %g s; a run starts from the scene as built, at t = 0",
                 sm_world_time(w));
        return SM_ERR_INVALID;
    }
    sm_run_request r;
    memset(&r, 0, sizeof r);
    r.scene = o->scene;
    r.quality = o->quality;
    r.scene_hash = sm_run_scene_hash(o->scene, o->params, o->nparams, o->quality);
    r.frames = o->frames > 0 ? o->frames : st->frames;
    r.render = o->render;
    r.threads = o->threads;
    r.checkpoint_every = sm_run_checkpoint_every(o->checkpoint_every, st);
    r.keep = o->keep > 0 ? o->keep : SM_RUN_KEEP_CHECKPOINTS;
    sm_run_manifest start;
    sm_run_describe(&r, st, &start);
    sm_status s = prepare_folder(o->out, err, errlen);
    if (s == SM_OK) s = claim(o->out, &start, o->overwrite, err, errlen);
    if (s != SM_OK) return s;
    sm_run_outputs outs;
    sm_run_outputs_choose(&outs, &r, st, &start);
    volatile sig_atomic_t stop = 0;
    frame_hook hook = {o->on_frame, o->ctx, &stop};
    if (o->on_frame) outs.sinks[outs.nsinks++] = (sm_sink){"on_frame", &hook, NULL, NULL, hook_frame, NULL, SM_SINK_WHOLE, 0};
    sm_run_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.info.out_dir = o->out;
    cfg.info.w = w;
    cfg.info.frames = r.frames;
    cfg.info.fps = st->fps;
    cfg.world_error = motion_error;
    cfg.world_error_ctx = sc;
    cfg.stop = &stop;
    sm_run_result res;
    s = sm_run_frames(&cfg, outs.sinks, outs.nsinks, &res, err, errlen);
    *frames_written = res.frames_written;
    *stopped = res.stopped;
    return s;
}
