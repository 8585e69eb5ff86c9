/* The thread governor (governor.h): times windows of steps with the current thread count and
 * probes the other candidate now and then. Timing only chooses the thread count; it never
 * reaches the results. */
#include "integrate/governor.h"

#define WINDOW 16          /* steps per timed window */
#define WARMUP 2           /* first steps not timed (first binning, allocations) */
#define MAX_BACKOFF 256    /* windows between probes at most (4096 steps) */
#define ABORT_FACTOR 1.5   /* a probe this much slower per particle-step ends at once */
#define SWITCH_FACTOR 0.95 /* a probe must be this much faster to be adopted */

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

/* Ends a probe: adopt the other candidate or not, and when to probe next. */
static void end_probe(sm_governor *g, int adopt, double rate_probe) {
    if (adopt) {
        g->current = other(g);
        g->rate_current = rate_probe;
        g->switches++;
        g->backoff = 1; /* confirm soon: the machine's load may be changing */
    } else {
        g->backoff = g->backoff * 2 > MAX_BACKOFF ? MAX_BACKOFF : g->backoff * 2;
    }
    g->probing = 0;
    g->steps_to_probe = (uint64_t)g->backoff * WINDOW;
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
