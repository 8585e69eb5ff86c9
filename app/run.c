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

/* The worlds the sinks see at a frame. On one process every one is the world; across ranks the
 * writer's gathered view (NULL elsewhere) when a WHOLE sink runs, and this rank's id slice when a
 * PART sink does. */
typedef struct sink_worlds {
    int need_whole, need_part; /* across ranks: some sink of that scope is in the list */
    sm_world *view;
    const sm_world *slice;
    const sm_part_io *part;
    sm_diagnostics d; /* the run's (across ranks: every rank's particles, summed in rank order) */
} sink_worlds;

static void sink_needs(const sm_run_config *cfg, const sm_sink *sinks, int nsinks, sink_worlds *sw) {
    memset(sw, 0, sizeof *sw);
    for (int i = 0; i < nsinks && cfg->ranks; i++) {
        sw->need_whole |= sinks[i].scope == SM_SINK_WHOLE;
        sw->need_part |= sinks[i].scope == SM_SINK_PART;
    }
}

static sm_status sink_world(const sm_run_config *cfg, sink_worlds *sw, char *err, size_t errlen) {
    sm_world *w = cfg->info.w;
    sm_status st = SM_OK;
    sw->view = w;
    sw->slice = w;
    sw->part = NULL;
    if (cfg->ranks && sw->need_whole) st = cfg->ranks->gather(cfg->ranks->ctx, w, &sw->view, err, errlen);
    else if (cfg->ranks) sw->view = NULL;
    if (st == SM_OK && cfg->ranks && sw->need_part)
        st = cfg->ranks->slice(cfg->ranks->ctx, w, &sw->slice, &sw->part, err, errlen);
    if (st == SM_OK) sm_world_diagnostics(w, &sw->d); /* collective for a distributed world */
    return st;
}

/* Across ranks, the worst status of all ranks everywhere, with the first failing rank's message. */
static sm_status agree(const sm_run_config *cfg, sm_status st, char *err, size_t errlen) {
    return cfg->ranks ? cfg->ranks->agree(cfg->ranks->ctx, st, err, errlen) : st;
}

/* Whether sink s runs on this rank. */
static int runs_here(const sm_run_config *cfg, const sm_sink *s) {
    return !cfg->ranks || s->scope == SM_SINK_PART || cfg->ranks->writer;
}

/* Across ranks, a PART sink is called on every rank in step: before it the ranks agree on the
 * status so far, and a failure on any rank stops every rank at the same sink. */
static int stop_before(const sm_run_config *cfg, const sm_sink *s, sm_status *st, char *err, size_t errlen) {
    if (cfg->ranks && s->scope == SM_SINK_PART) *st = agree(cfg, *st, err, errlen);
    return cfg->ranks && s->scope == SM_SINK_PART && *st != SM_OK;
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

/* Frame f handed to the sinks that run on this rank, each with the world of its scope. */
static sm_status write_frame(const sm_run_config *cfg, sm_run_frame *fr, const sink_worlds *sw, int f, sm_sink *sinks,
                             int nsinks, sm_run_result *res, char *err, size_t errlen) {
    fr->frame = f;
    fr->d = &sw->d;
    sm_status st = SM_OK;
    for (int i = 0; i < nsinks; i++) {
        sm_sink *s = &sinks[i];
        if (stop_before(cfg, s, &st, err, errlen)) break;
        if (st != SM_OK || !runs_here(cfg, s)) continue;
        fr->w = s->scope == SM_SINK_WHOLE ? sw->view : s->scope == SM_SINK_PART ? sw->slice : cfg->info.w;
        fr->part = s->scope == SM_SINK_PART ? sw->part : NULL;
        st = s->frame(s, fr, err, errlen);
        if (st != SM_OK) res->failed_sink = s->name;
    }
    return st;
}

/* Frames first..frames; view: the sinks' world as the loop starts (sink_world). */
static sm_status frame_loop(const sm_run_config *cfg, sink_worlds *sw, sm_sink *sinks, int nsinks, sm_run_result *res,
                            char *err, size_t errlen) {
    sm_run_frame fr;
    memset(&fr, 0, sizeof fr);
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
            if (st == SM_OK) st = sink_world(cfg, sw, err, errlen);
            if (st != SM_OK) return st;
        }
        sm_status st = agree(cfg, write_frame(cfg, &fr, sw, f, sinks, nsinks, res, err, errlen), err, errlen);
        if (st != SM_OK) return st;
        res->frames_written = f + 1;
        test_inject_nan(cfg->info.w, f);
    }
    return SM_OK;
}

/* The sinks' begins (those that run on this rank); began[i]: sink i's end is to be called. */
static sm_status begin_sinks(const sm_run_config *cfg, const sink_worlds *sw, sm_sink *sinks, int nsinks, char *began,
                             sm_run_result *res, char *err, size_t errlen) {
    sm_run_info info = cfg->info;
    info.d = &sw->d;
    info.writer = !cfg->ranks || cfg->ranks->writer;
    sm_status st = SM_OK;
    for (int i = 0; i < nsinks; i++) {
        sm_sink *s = &sinks[i];
        if (stop_before(cfg, s, &st, err, errlen)) break;
        if (st != SM_OK || !runs_here(cfg, s)) continue;
        info.w = s->scope == SM_SINK_WHOLE ? sw->view : cfg->info.w;
        if (s->begin) st = s->begin(s, &info, err, errlen);
        if (st != SM_OK) res->failed_sink = s->name; /* the failed sink cleaned up after itself */
        else began[i] = 1;
    }
    return agree(cfg, st, err, errlen);
}

sm_status sm_run_frames(const sm_run_config *cfg, sm_sink *sinks, int nsinks, sm_run_result *res, char *err,
                        size_t errlen) {
    memset(res, 0, sizeof *res);
    sink_worlds sw;
    sink_needs(cfg, sinks, nsinks, &sw);
    char *began = calloc(nsinks > 0 ? (size_t)nsinks : 1, 1);
    sm_status st = began ? SM_OK : SM_ERR_NOMEM;
    if (!began) snprintf(err, errlen, "out of memory");
    st = agree(cfg, st, err, errlen);
    if (st == SM_OK) st = sink_world(cfg, &sw, err, errlen);
    if (st == SM_OK) st = begin_sinks(cfg, &sw, sinks, nsinks, began, res, err, errlen);
    const int interrupt = cfg->stop_at_step && cfg->stop;
    if (interrupt) sm_world_set_interrupt(cfg->info.w, poll_stop, (void *)(uintptr_t)cfg);
    if (st == SM_OK) st = frame_loop(cfg, &sw, sinks, nsinks, res, err, errlen);
    if (interrupt) sm_world_set_interrupt(cfg->info.w, NULL, NULL);
    for (int i = 0; i < nsinks && began; i++) {
        if (!began[i] || !sinks[i].end) continue;
        char e2[SM_MSG_MAX];
        sinks[i].stopped = res->stopped;
        sm_status se = sinks[i].end(&sinks[i], st, e2, sizeof e2);
        if (se != SM_OK && st == SM_OK) {
            st = se;
            res->failed_sink = sinks[i].name;
            snprintf(err, errlen, "%s", e2);
        }
    }
    free(began);
    return agree(cfg, st, err, errlen);
}
