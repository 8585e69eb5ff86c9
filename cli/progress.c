/* The run's banner and progress line on stderr (a sink, app/run.h): on a terminal one line
 * rewritten per frame, else a line per frame. */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <unistd.h>

#include "cli/cli.h"

typedef struct progress_state {
    int tty;
    int frames;
} progress_state;

static sm_status progress_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    const cli_progress_config *c = s->config;
    progress_state *p = malloc(sizeof *p);
    if (!p) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    p->tty = isatty(fileno(stderr));
    p->frames = run->frames;
    s->state = p;
    sm_diagnostics d;
    sm_world_diagnostics(run->w, &d);
    fprintf(stderr, "sandmpm: %s (%s), %zu particles, %d frames at %g fps -> %s/\n", c->scene_label, c->quality,
            d.particles, run->frames, run->fps, run->out_dir);
    return SM_OK;
}

static sm_status progress_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    (void)err, (void)errlen;
    const progress_state *p = s->state;
    const sm_diagnostics *d = fr->d;
    const int f = fr->frame;
    double el = sm_run_elapsed(fr);
    double rate = el > 0 ? (double)d->particles * (double)d->steps / el : 0;
    double eta = f > 0 ? el / f * (p->frames - f) : 0;
    fprintf(stderr, "%sframe %d/%d  t = %.4g s  steps %llu  particles %zu  %.3g particle-steps/s  ETA %.0f s%s",
            p->tty ? "\r" : "", f, p->frames, d->time, (unsigned long long)d->steps, d->particles, rate, eta,
            p->tty ? "   " : "\n");
    return SM_OK;
}

static sm_status progress_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    (void)run_status, (void)err, (void)errlen;
    progress_state *p = s->state;
    if (p->tty) fprintf(stderr, "\n");
    free(p);
    s->state = NULL;
    return SM_OK;
}

sm_sink cli_progress_sink(const cli_progress_config *config) {
    return (sm_sink){"progress", config, NULL, progress_begin, progress_frame, progress_end};
}
