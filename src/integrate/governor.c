/* The thread governor (governor.h): times windows of steps with the current thread count and
 * probes the other candidate now and then. Timing only chooses the thread count; it never
 * reaches the results. */
#include "integrate/governor.h"

#include <math.h>

#define WINDOW 16          /* steps per timed window */
#define WARMUP 2           /* first steps not timed (first binning, allocations) */
#define MAX_BACKOFF 256    /* windows between probes at most (4096 steps) */
#define ABORT_FACTOR 1.5   /* a probe this much slower per particle-step ends at once */
#define SWITCH_FACTOR 0.95 /* a probe must be this much faster to be adopted */
#define PROBE_BUDGET 0.02  /* the slower candidate's extra time at most this share of the time between probes */
#define MAX_INTERVAL (4 * MAX_BACKOFF * WINDOW) /* steps between probes at most, whatever the budget says */

void sm_governor_init(sm_governor *g, int max) {
    g->max = max < 1 ? 1 : max;
    g->current = g->max;
    g->probing = 0;
    g->window_steps = -WARMUP;
    g->window_sec = g->window_work = 0;
    g->rate_current = 0;
    g->steps_to_probe = 0;
    g->backoff = 1;
    g->switches = 0;
}

static int other(const sm_governor *g) { return g->current == 1 ? g->max : 1; }

int sm_governor_threads(const sm_governor *g) { return g->probing ? other(g) : g->current; }

static void new_window(sm_governor *g) {
    g->window_steps = 0;
    g->window_sec = g->window_work = 0;
}

/* Steps until the next probe: the backoff's windows, or more when the window just timed on the
 * slower candidate cost `excess` seconds beyond the faster one, so that such a probe takes at most
 * PROBE_BUDGET of the run's time. A descheduled thread can stall one step for tens of ms (measured
 * here: 73 ms against 0.45 ms for the step), which the windows alone would pay every few hundred
 * steps. */
static uint64_t probe_interval(const sm_governor *g, double excess, double step_sec) {
    double steps = (double)g->backoff * WINDOW;
    if (excess > 0 && step_sec > 0 && excess / (PROBE_BUDGET * step_sec) > steps)
        steps = excess / (PROBE_BUDGET * step_sec);
    return steps < MAX_INTERVAL ? (uint64_t)ceil(steps) : MAX_INTERVAL;
}

/* Ends a probe: adopt the other candidate or not, and when to probe next. */
static void end_probe(sm_governor *g, int adopt, double rate_probe) {
    const double rate_fast = adopt ? rate_probe : g->rate_current;
    const double excess = g->window_work * (adopt ? g->rate_current - rate_probe : rate_probe - g->rate_current);
    const double step_sec = g->window_steps > 0 ? rate_fast * g->window_work / g->window_steps : 0;
    if (adopt) {
        g->current = other(g);
        g->rate_current = rate_probe;
        g->switches++;
        g->backoff = 1; /* confirm soon (the load may be changing), within the probe budget */
    } else {
        g->backoff = g->backoff * 2 > MAX_BACKOFF ? MAX_BACKOFF : g->backoff * 2;
    }
    g->probing = 0;
    g->steps_to_probe = probe_interval(g, excess, step_sec);
    new_window(g);
}

void sm_governor_record(sm_governor *g, double seconds, size_t particles) {
    if (g->max == 1 || particles == 0) return;
    if (g->window_steps < 0) { /* warm-up */
        g->window_steps++;
        return;
    }
    g->window_steps++;
    g->window_sec += seconds;
    g->window_work += (double)particles;
    const double rate = g->window_sec / g->window_work;
    if (g->probing) {
        if (rate > ABORT_FACTOR * g->rate_current) end_probe(g, 0, rate);
        else if (g->window_steps >= WINDOW) end_probe(g, rate < SWITCH_FACTOR * g->rate_current, rate);
        return;
    }
    if (g->window_steps < WINDOW) return;
    g->rate_current = rate;
    g->steps_to_probe = g->steps_to_probe > WINDOW ? g->steps_to_probe - WINDOW : 0;
    new_window(g);
    if (g->steps_to_probe == 0) g->probing = 1;
}
