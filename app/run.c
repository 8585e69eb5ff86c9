/* The frame loop; see run.h. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "app/io/files.h"
#include "app/run.h"

double sm_run_wall(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double sm_run_elapsed(const sm_run_frame *fr) { return sm_run_wall() - fr->start_wall; }

/* Advances the world to frame f's time; a failure of the world or of the world_error check.
 * *interrupted: 1 if the stop flag ended the advance early (stop_at_step: run.h). */
static sm_status advance_to(const sm_run_config *cfg, int f, int *interrupted, char *err, size_t errlen) {
    sm_world *w = cfg->info.w;
    const double t0 = sm_world_time(w), t1 = f / cfg->info.fps;
    sm_world_reset_step_stats(w);
    sm_status s = sm_world_advance(w, t1);
    *interrupted = s == SM_OK && sm_world_interrupted(w);
    if (*interrupted) return SM_OK;
    const char *merr = cfg->world_error ? cfg->world_error(cfg->world_error_ctx) : NULL;
    if (merr) {
        snprintf(err, errlen, "%s", merr);
        return SM_ERR_INVALID;
    }
    if (s != SM_OK)
        snprintf(err, errlen, "frame %d (from t = %.6g s to %.6g s, stopped at t = %.6g s): %s", f, t0, t1, sm_world_time(w),
                 sm_world_errmsg(w));
    return s;
}

/* Test hook (tests/test_checkpoints.sh): SANDMPM_TEST_NAN_AT_FRAME=N writes NaN into the first
 * particle's velocity after frame N is written, so that the next step fails numerically. Only
 * read from the environment; a run without it is not affected. */
static void test_inject_nan(sm_world *w, int f) {
    const char *at = getenv("SANDMPM_TEST_NAN_AT_FRAME");
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    if (!at || atoi(at) != f || pv.n == 0) return;
    sm_world_particle_velocities(w)[0] = (sm_real)NAN;
}

/* The world the sinks see at this frame: w itself on one process; across ranks the writer's
 * gathered view (NULL on the other ranks). */
static sm_status sink_world(const sm_run_config *cfg, sm_world **view, char *err, size_t errlen) {
    *view = cfg->info.w;
    return cfg->ranks ? cfg->ranks->gather(cfg->ranks->ctx, cfg->info.w, view, err, errlen) : SM_OK;
}

/* Across ranks, the writer's status everywhere (the sinks run on the writer only). */
static sm_status agree(const sm_run_config *cfg, sm_status st, char *err, size_t errlen) {
    return cfg->ranks ? cfg->ranks->agree(cfg->ranks->ctx, st, err, errlen) : st;
}

/* sm_world_set_interrupt's poll: the stop flag (the library agrees it over the ranks). */
static int poll_stop(void *user) {
    const sm_run_config *cfg = user;
    return *cfg->stop != 0;
}

static int stop_requested(const sm_run_config *cfg) {
    const int stop = cfg->stop && *cfg->stop;
    return cfg->ranks ? cfg->ranks->any(cfg->ranks->ctx, stop) : stop;
}

/* Frame f handed to the sinks (none on a rank that does not write). */
static sm_status write_frame(sm_run_frame *fr, sm_diagnostics *d, sm_world *view, int f, sm_sink *sinks, int nsinks,
                             sm_run_result *res, char *err, size_t errlen) {
    if (!view) return SM_OK;
    sm_world_diagnostics(view, d);
    fr->frame = f;
    fr->w = view;
    fr->d = d;
    for (int i = 0; i < nsinks; i++) {
        sm_status st = sinks[i].frame(&sinks[i], fr, err, errlen);
        if (st != SM_OK) {
            res->failed_sink = sinks[i].name;
            return st;
        }
    }
    return SM_OK;
}

/* Frames first..frames; view: the sinks' world as the loop starts (sink_world). */
static sm_status frame_loop(const sm_run_config *cfg, sm_world *view, sm_sink *sinks, int nsinks, sm_run_result *res,
                            char *err, size_t errlen) {
    sm_run_frame fr;
    sm_diagnostics d;
    fr.out_dir = cfg->info.out_dir;
    fr.start_wall = sm_run_wall();
    res->frames_written = cfg->info.first_frame;
    for (int f = cfg->info.first_frame; f <= cfg->info.frames; f++) {
        if (f > 0) { /* after a resume, first_frame is one frame past the world's time */
            if (stop_requested(cfg)) {
                res->stopped = 1;
                return SM_OK;
            }
            int interrupted;
            sm_status st = advance_to(cfg, f, &interrupted, err, errlen);
            if (st == SM_OK && interrupted) {
                res->stopped = 1;
                return SM_OK;
            }
            if (st == SM_OK) st = sink_world(cfg, &view, err, errlen);
            if (st != SM_OK) return st;
        }
        sm_status st = agree(cfg, write_frame(&fr, &d, view, f, sinks, nsinks, res, err, errlen), err, errlen);
        if (st != SM_OK) return st;
        res->frames_written = f + 1;
        test_inject_nan(cfg->info.w, f);
    }
    return SM_OK;
}

sm_status sm_run_frames(const sm_run_config *cfg, sm_sink *sinks, int nsinks, sm_run_result *res, char *err,
                        size_t errlen) {
    memset(res, 0, sizeof *res);
    sm_world *view;
    sm_status st = sink_world(cfg, &view, err, errlen);
    if (st != SM_OK) return st;
    if (!view) nsinks = 0; /* a rank that does not write */
    sm_run_info info = cfg->info;
    info.w = view;
    int begun = 0;
    for (; begun < nsinks && st == SM_OK; begun++) {
        if (sinks[begun].begin) st = sinks[begun].begin(&sinks[begun], &info, err, errlen);
        if (st != SM_OK) res->failed_sink = sinks[begun].name;
    }
    if (st != SM_OK) begun--; /* the failed sink cleaned up after itself */
    st = agree(cfg, st, err, errlen);
    const int interrupt = cfg->stop_at_step && cfg->stop;
    if (interrupt) sm_world_set_interrupt(cfg->info.w, poll_stop, (void *)(uintptr_t)cfg);
    if (st == SM_OK) st = frame_loop(cfg, view, sinks, nsinks, res, err, errlen);
    if (interrupt) sm_world_set_interrupt(cfg->info.w, NULL, NULL);
    for (int i = 0; i < begun; i++) {
        if (!sinks[i].end) continue;
        char e2[SM_MSG_MAX];
        sm_status se = sinks[i].end(&sinks[i], st, e2, sizeof e2);
        if (se != SM_OK && st == SM_OK) {
            st = se;
            res->failed_sink = sinks[i].name;
            snprintf(err, errlen, "%s", e2);
        }
    }
    return agree(cfg, st, err, errlen);
}
