/* The run's banner, progress line and summary on stderr (a sink, app/run.h): on a terminal one
 * line rewritten per frame, else a line per frame; --verbose: a line per frame with the frame's
 * steps, dt range, largest speed and Newton/GMRES iterations; --quiet: nothing (warnings and
 * errors are printed by others). The rate and the ETA count this invocation's steps and frames
 * only (after a resume, not the checkpoint's), and are not shown before the first step. */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <unistd.h>

#include "cli/cli.h"

typedef struct progress_state {
    int tty;
    int frames, first_frame;
    sm_diagnostics start, prev; /* at the start of this invocation; at the previous frame */
    int last_frame;             /* the last frame seen (first_frame - 1: none) */
    double wall;                /* sm_run_elapsed at the last frame */
} progress_state;

static sm_status progress_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    const cli_progress_config *c = s->config;
    progress_state *p = calloc(1, sizeof *p);
    if (!p) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    p->tty = isatty(fileno(stderr)) && !c->verbose;
    p->frames = run->frames;
    p->first_frame = run->first_frame;
    p->last_frame = run->first_frame - 1;
    s->state = p;
    p->start = *run->d;
    p->prev = p->start;
    if (c->quiet) return SM_OK;
    fprintf(stderr, "sandmpm: %s (%s), %zu particles, %d frames at %g fps", c->scene_label, c->quality,
            p->start.particles, run->frames, run->fps);
    if (c->ranks > 1 && c->threads > 0) fprintf(stderr, ", %d ranks × %d threads", c->ranks, c->threads);
    else if (c->ranks > 1) fprintf(stderr, ", %d ranks (threads chosen per step in each)", c->ranks);
    fprintf(stderr, " -> %s/\n", run->out_dir);
    return SM_OK;
}

/* The frame's line, default form: the rate and ETA once this invocation has taken steps. */
static void line_default(const progress_state *p, const sm_run_frame *fr, double el) {
    const sm_diagnostics *d = fr->d;
    const uint64_t steps = d->steps - p->start.steps;
    fprintf(stderr, "%sframe %d/%d  t = %.4g s  steps %llu  particles %zu", p->tty ? "\r" : "", fr->frame, p->frames,
            d->time, (unsigned long long)d->steps, d->particles);
    const int done = fr->frame - p->first_frame;
    if (steps > 0 && el > 0 && done > 0)
        fprintf(stderr, "  %.3g particle-steps/s  ETA %.0f s", (double)d->particles * (double)steps / el,
                el / done * (p->frames - fr->frame));
    else if (fr->frame < p->frames)
        fprintf(stderr, "  computing frame %d ...", fr->frame + 1);
    fprintf(stderr, "%s", p->tty ? "   " : "\n");
}

/* --verbose: the frame's own figures. */
static void line_verbose(const progress_state *p, const sm_run_frame *fr, double el) {
    const sm_diagnostics *d = fr->d;
    const unsigned long long steps = (unsigned long long)(d->steps - p->prev.steps);
    fprintf(stderr, "frame %d/%d  t = %.6g s  %llu steps", fr->frame, p->frames, d->time, steps);
    if (steps > 0) fprintf(stderr, " (dt %.3g..%.3g s)", d->min_dt, d->max_dt);
    fprintf(stderr, "  particles %zu  max speed %.3g m/s  KE %.4g J", d->particles, d->max_speed, d->kinetic_energy);
    if (d->newton_iterations > p->prev.newton_iterations)
        fprintf(stderr, "  Newton %llu, GMRES %llu", (unsigned long long)(d->newton_iterations - p->prev.newton_iterations),
                (unsigned long long)(d->gmres_iterations - p->prev.gmres_iterations));
    fprintf(stderr, "  %.2f s\n", el - p->wall);
}

static sm_status progress_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    (void)err, (void)errlen;
    const cli_progress_config *c = s->config;
    progress_state *p = s->state;
    const double el = sm_run_elapsed(fr);
    if (c->verbose) line_verbose(p, fr, el);
    else if (!c->quiet) line_default(p, fr, el);
    p->prev = *fr->d;
    p->last_frame = fr->frame;
    p->wall = el;
    return SM_OK;
}

/* A run that wrote every frame ends with a summary line (others say what is complete elsewhere). */
static sm_status progress_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    (void)err, (void)errlen;
    const cli_progress_config *c = s->config;
    progress_state *p = s->state;
    if (p->tty && !c->quiet) fprintf(stderr, "\n");
    if (run_status == SM_OK && p->last_frame == p->frames && !c->quiet) {
        const unsigned long long steps = (unsigned long long)(p->prev.steps - p->start.steps);
        const int n = p->last_frame - p->first_frame + 1;
        fprintf(stderr, "sandmpm: done: %d frame%s (%d..%d), %llu steps, %.1f s wall", n, n == 1 ? "" : "s",
                p->first_frame, p->last_frame, steps, p->wall);
        if (p->wall > 0 && steps > 0)
            fprintf(stderr, ", %.3g particle-steps/s", (double)p->prev.particles * (double)steps / p->wall);
        fprintf(stderr, ", peak memory %.4g MB; files in %s/ (listed in %s)\n", cli_peak_memory_bytes() / 1e6, c->out_dir,
                SM_RUN_MANIFEST_NAME);
    }
    free(p);
    s->state = NULL;
    return SM_OK;
}

sm_sink cli_progress_sink(const cli_progress_config *config) {
    sm_sink s = {"progress", config, NULL, progress_begin, progress_frame, progress_end, SM_SINK_STATE, 0};
    return s;
}
