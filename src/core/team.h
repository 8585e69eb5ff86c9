/* The step's own thread team: a pool of worker threads that runs a function on T threads and
 * synchronises them with a barrier, without system calls while the threads are busy.
 *
 * Why not OpenMP here: libgomp's barrier (which also ends every parallel region and starts the
 * next) wakes its waiters with futex(FUTEX_WAKE), a system call, whether or not a thread sleeps:
 * about 1 us each on this project's virtual machines, 3 us per empty two-thread region, and an
 * explicit step makes 19 such calls (strace; docs/benchmarks.md "Small scenes, third look").
 * Here a waiting thread spins for a while (SM_TEAM_SPIN) and only then sleeps on a condition
 * variable (it does not spin where a thread it waits for last ran on its own core); the thread
 * that releases it signals only when one sleeps. A machine shared with busy
 * processes (issue 18 item 3) therefore sees sleeping workers between steps, and the governor
 * (integrate/governor.h) chooses one thread when two do not pay.
 *
 * The split of work among threads is the callers': a static share (sm_team_split, sm_team_for), as
 * with OpenMP's static schedule, or chunks claimed from both ends (sm_team_claim) where which thread
 * does an item changes no result; the team decides nothing that reaches a result, so the bits do
 * not depend on it.
 * Each calling thread has its own pool (thread-local), made on its first run of T > 1 threads and
 * grown when a run asks for more; a pool's workers end with the thread that owns it. */
#ifndef SM_CORE_TEAM_H
#define SM_CORE_TEAM_H

#include <stdatomic.h>

/* A team's work: called once per thread t = 0 .. T-1 (t = 0 on the calling thread). */
typedef void (*sm_team_fn)(void *arg, int t, int T);

/* Runs fn(arg, t, T) on T threads and returns when every call has returned. With T <= 1, or when
 * called inside a run, fn(arg, 0, 1) runs on this thread alone. When threads cannot be made, the
 * run uses the threads there are (the callers' results do not depend on T). */
void sm_team_run(int T, sm_team_fn fn, void *arg);

/* Inside fn: returns when every thread of the run has called it (a no-op in a run of one). */
void sm_team_barrier(void);

/* A loop's work: items [lo, hi) of a range, on one thread. */
typedef void (*sm_team_range_fn)(void *arg, long lo, long hi);

/* Runs fn on each thread's share (sm_team_split) of the items 0 .. n-1: OpenMP's `parallel for
 * schedule(static)`. */
void sm_team_for(int T, long n, sm_team_range_fn fn, void *arg);

/* The largest of *m and v, kept in *m (a reduction across a run's threads; relaxed: the run's
 * end orders it before the caller reads it). */
static inline void sm_team_max(_Atomic double *m, double v) {
    double cur = atomic_load_explicit(m, memory_order_relaxed);
    while (v > cur && !atomic_compare_exchange_weak_explicit(m, &cur, v, memory_order_relaxed, memory_order_relaxed)) {
    }
}

/* Items [0, n) that the threads of a run take in chunks, for stages whose items are independent
 * (their results do not depend on which thread does which). With 2 threads, thread 0 takes from
 * the front and thread 1 from the back until they meet: each keeps to its end, as with the static
 * split (its data stays in its cache), but a thread that the machine slows down leaves the rest to
 * the other. A chunk is a quarter of what is left (at least `min_chunk` items). With another
 * thread count, each thread takes its static share (sm_team_split) in such chunks. */
typedef struct sm_team_claims {
    _Atomic unsigned long long ends; /* 2 threads: front | back << 32 */
    long n;
} sm_team_claims;

/* Before the run (n < 2^32). */
void sm_team_claims_init(sm_team_claims *cl, long n);

/* A thread's cursor on the claims. */
typedef struct sm_team_claimer {
    sm_team_claims *cl;
    int t, T;
    long next, end; /* other thread counts: what is left of the static share */
} sm_team_claimer;

void sm_team_claimer_init(sm_team_claimer *c, sm_team_claims *cl, int t, int T);

/* The next chunk [*lo, *hi) for this thread; 0 when none is left. */
int sm_team_claim(sm_team_claimer *c, long min_chunk, long *lo, long *hi);

/* The contiguous share [lo, hi) of n items of thread t of T: OpenMP's schedule(static) split
 * (the first n % T threads take one more). */
static inline void sm_team_split(long n, int T, int t, long *lo, long *hi) {
    const long q = n / T, r = n % T;
    *lo = t * q + (t < r ? t : r);
    *hi = *lo + q + (t < r ? 1 : 0);
}

#endif
