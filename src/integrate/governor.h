/* The thread governor: how many threads the next step uses when the world's definition leaves it
 * to the library (def.threads = 0).
 *
 * Results never depend on the thread count (every parallel loop has a fixed split and a fixed
 * reduction order), so the choice is free to follow the machine: the governor times the steps
 * and, every so often, runs a short probe with the other candidate (one thread instead of all, or
 * all instead of one), then keeps the faster per particle-step. It exists for two cases:
 *   - small scenes, where the barriers of a parallel step cost more than the work they share;
 *   - a machine shared with other busy processes, where a thread that is descheduled stalls
 *     every barrier of the step for a time slice (measured: 1,001 steps of a 64-particle block
 *     took 21 ms per step with 2 threads beside a load of 14 on 2 cores, 0.1 ms with 1).
 * A probe ends early once it is clearly slower, so a bad candidate costs a few steps. Probes
 * back off (every 1, 2, 4, ... up to 256 windows of 16 steps) while the choice stays the same,
 * and are spaced further when the slower candidate's last window cost more than 2% of the time
 * until the next probe (one stalled step beside a busy process can cost 150 steps' time). */
#ifndef SM_INTEGRATE_GOVERNOR_H
#define SM_INTEGRATE_GOVERNOR_H

#include <stddef.h>
#include <stdint.h>

typedef struct sm_governor {
    int max;               /* threads of a parallel step (OpenMP's default); 1: nothing to choose */
    int current;           /* threads of the steps outside a probe */
    int probing;           /* 1 while the other candidate is timed */
    int window_steps;      /* steps timed in the current window */
    double window_sec;     /* their wall time, s */
    double window_work;    /* their particle-steps */
    double rate_current;   /* s per particle-step with `current` (last full window; 0: unknown) */
    uint64_t steps_to_probe; /* steps until the next probe */
    int backoff;           /* windows between probes: 1, 2, 4, ... 256 */
    uint64_t switches;     /* changes of `current` (diagnostics) */
} sm_governor;

/* Starts a governor for `max` threads. */
void sm_governor_init(sm_governor *g, int max);

/* Threads for the next step. */
int sm_governor_threads(const sm_governor *g);

/* Records a finished step: its wall time (s) and its particles. */
void sm_governor_record(sm_governor *g, double seconds, size_t particles);

#endif
