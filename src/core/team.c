/* The step's thread team (team.h).
 *
 * A pool: the calling thread (number 0) and workers 1 .. n, each waiting for the next run on
 * `dispatch` (run number << 32 | T). A run publishes fn and arg, then a new dispatch word; the
 * workers numbered below T call fn, and every thread of the run ends in the barrier, after which
 * the caller returns. The barrier is a counter of arrivals and a generation number that the last
 * thread to arrive advances.
 *
 * Waiting: poll the word, yield, then sleep on the pool's condition variable (below). A
 * thread about to sleep first counts itself in `sleepers` and then checks the word under the
 * mutex; one that changes a word stores it first and then reads `sleepers`. Both in sequentially
 * consistent order, so either the sleeper sees the new word or the changer sees the sleeper and
 * broadcasts (under the mutex): no wake-up is lost, and none is paid for when nobody sleeps. */
#define _GNU_SOURCE /* sched_getaffinity; pthread_sigmask, sigfillset */

#include "core/team.h"

#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define CPU_RELAX() _mm_pause()
#else
#define CPU_RELAX() ((void)0)
#endif

/* Waiting: SM_TEAM_SPIN polls with a pause between them (about 0.35 ms here: 4096 pauses take
 * 82-91 us, docs/experiments/team_cost.c), then SM_TEAM_YIELDS polls that give the core away
 * (sched_yield: a thread the wait is for may be waiting for a core), then sleep. Long enough to
 * span a step's serial parts (with 1,024 polls, 2D at 16k particles on 2 threads gave 1.81e7
 * particle-steps/s against libgomp's 2.20e7, best of three each; libgomp's threads poll for
 * milliseconds), short enough that idle workers sleep
 * between frames and when the governor runs one thread. A run of more threads than the process
 * has cores polls SM_TEAM_SPIN_OVER times only: a poller holds the core that the thread it waits
 * for needs (3 threads on 2 cores, 4 barriers a run: 530 us a run with 4,096 polls, 16 us with
 * 16; libgomp 57 us). */
#define SM_TEAM_SPIN 16384
#define SM_TEAM_SPIN_OVER 16
#define SM_TEAM_YIELDS 16

/* A waiter also stops polling when a thread it may be waiting for last reported the waiter's
 * own core (sched_getcpu: a read of the kernel's rseq area): a busy process beside the run can
 * leave two threads of a run on one core, where polling only delays the thread it waits for by
 * the poll (a run fixed at 2 threads beside one busy process, 2D 5,000 particles: docs/
 * benchmarks.md "Two threads on one core"). Threads report at the start of a run, on arriving at
 * a barrier and when they wait; the first SM_TEAM_CPU_SLOTS thread numbers are tracked, and the
 * check is repeated every SM_TEAM_CPU_RECHECK polls. */
#define SM_TEAM_CPU_SLOTS 64
#define SM_TEAM_CPU_RECHECK 1024

#define QUIT_T 0u /* a dispatch word's T that ends the workers */

typedef struct sm_pool sm_pool;

typedef struct worker {
    sm_pool *pool;
    int index;      /* the worker's thread number in a run: 1 .. */
    uint64_t start; /* the dispatch word when it was made */
    pthread_t tid;
} worker;

struct sm_pool {
    _Alignas(64) _Atomic uint64_t dispatch; /* run number << 32 | T */
    _Alignas(64) _Atomic unsigned arrived;  /* threads in the barrier */
    _Alignas(64) _Atomic uint64_t barrier_gen;
    _Alignas(64) _Atomic int sleepers;
    _Atomic unsigned run_T;                 /* the latest run's thread count */
    _Alignas(64) _Atomic int cpu[SM_TEAM_CPU_SLOTS]; /* the core each thread number last reported (-1: none) */
    sm_team_fn fn; /* the current run's, written before its dispatch word */
    void *arg;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int nworkers;
    worker **workers;
};

static _Thread_local sm_pool *tl_run;  /* the pool of the run this thread is in */
static _Thread_local int tl_T = 1;     /* that run's thread count (1: none) */
static _Thread_local int tl_depth;     /* runs this thread is inside */
static _Thread_local int tl_spin = SM_TEAM_SPIN; /* polls before yielding, for this run */
static _Thread_local int tl_t;                   /* this thread's number in its pool's runs */

static pthread_once_t once = PTHREAD_ONCE_INIT;
static pthread_key_t pool_key; /* the pool the calling thread owns (freed when it ends) */
static int cores = 1; /* the cores this process may run on (its affinity mask) */

/* Thread t reports core `me`: written only when it changed, so that in the usual case the slots'
 * cache lines stay shared between the cores and a barrier moves no line for them. */
static void note_core(sm_pool *p, int t, int me) {
    if (t < SM_TEAM_CPU_SLOTS && atomic_load_explicit(&p->cpu[t], memory_order_relaxed) != me)
        atomic_store_explicit(&p->cpu[t], me, memory_order_relaxed);
}

/* Records this thread's core; returns 1 when another thread of the latest run last reported the
 * same core (polling would hold the core that thread needs). */
static int report_core(sm_pool *p) {
    const int me = sched_getcpu();
    note_core(p, tl_t, me);
    if (me < 0) return 0;
    const unsigned T = atomic_load_explicit(&p->run_T, memory_order_relaxed);
    for (unsigned u = 0; u < T && u < SM_TEAM_CPU_SLOTS; u++)
        if ((int)u != tl_t && atomic_load_explicit(&p->cpu[u], memory_order_relaxed) == me) return 1;
    return 0;
}

static uint64_t wait_change(sm_pool *p, _Atomic uint64_t *word, uint64_t old) {
    int spin = report_core(p) ? 0 : tl_spin;
    for (int i = 0; i < spin; i++) {
        const uint64_t v = atomic_load_explicit(word, memory_order_acquire);
        if (v != old) return v;
        CPU_RELAX();
        if ((i + 1) % SM_TEAM_CPU_RECHECK == 0 && report_core(p)) break;
    }
    for (int i = 0; i < SM_TEAM_YIELDS; i++) {
        const uint64_t v = atomic_load_explicit(word, memory_order_acquire);
        if (v != old) return v;
        sched_yield();
    }
    atomic_fetch_add(&p->sleepers, 1);
    pthread_mutex_lock(&p->mu);
    uint64_t v;
    while ((v = atomic_load(word)) == old) pthread_cond_wait(&p->cv, &p->mu);
    pthread_mutex_unlock(&p->mu);
    atomic_fetch_sub(&p->sleepers, 1);
    return v;
}

static void publish(sm_pool *p, _Atomic uint64_t *word, uint64_t v) {
    atomic_store(word, v);
    if (atomic_load(&p->sleepers) > 0) {
        pthread_mutex_lock(&p->mu);
        pthread_cond_broadcast(&p->cv);
        pthread_mutex_unlock(&p->mu);
    }
}

void sm_team_barrier(void) {
    if (tl_T <= 1) return;
    sm_pool *p = tl_run;
    /* The generation cannot advance before this thread arrives. */
    const uint64_t g = atomic_load_explicit(&p->barrier_gen, memory_order_acquire);
    note_core(p, tl_t, sched_getcpu());
    if (atomic_fetch_add_explicit(&p->arrived, 1, memory_order_acq_rel) == (unsigned)tl_T - 1) {
        atomic_store_explicit(&p->arrived, 0, memory_order_relaxed);
        publish(p, &p->barrier_gen, g + 1);
    } else {
        wait_change(p, &p->barrier_gen, g);
    }
}

static void run_as(sm_pool *p, int t, int T) {
    tl_spin = T > cores ? SM_TEAM_SPIN_OVER : SM_TEAM_SPIN; /* also for the wait for the next run */
    tl_run = p;
    tl_T = T;
    tl_t = t;
    note_core(p, t, sched_getcpu());
    tl_depth++;
    p->fn(p->arg, t, T);
    sm_team_barrier();
    tl_depth--;
    tl_T = 1;
    tl_run = NULL;
}

static void *worker_main(void *arg) {
    const worker *wk = arg;
    sm_pool *p = wk->pool;
    uint64_t seen = wk->start;
    tl_t = wk->index;
    for (;;) {
        seen = wait_change(p, &p->dispatch, seen);
        const unsigned T = (unsigned)(seen & 0xffffffffu);
        if (T == QUIT_T) return NULL;
        if (wk->index < (int)T) run_as(p, wk->index, (int)T);
    }
}

/* Ends a pool's workers and frees it (its owner thread is ending, or the pool is incomplete). */
static void pool_free(void *v) {
    sm_pool *p = v;
    if (!p) return;
    const uint64_t d = atomic_load(&p->dispatch);
    publish(p, &p->dispatch, (((d >> 32) + 1) << 32) | QUIT_T);
    for (int i = 0; i < p->nworkers; i++) {
        pthread_join(p->workers[i]->tid, NULL);
        free(p->workers[i]);
    }
    free(p->workers);
    pthread_cond_destroy(&p->cv);
    pthread_mutex_destroy(&p->mu);
    free(p);
}

/* In a child of fork() only the forking thread exists: its pool's workers are gone. */
static void forget_pool_in_child(void) { pthread_setspecific(pool_key, NULL); }

static void init_once(void) {
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0) cores = CPU_COUNT(&set);
    pthread_key_create(&pool_key, pool_free);
    pthread_atfork(NULL, NULL, forget_pool_in_child);
}

/* Adds one worker; 0 when the thread cannot be made. Workers block every signal: handlers run
 * on the threads that the program made. */
static int add_worker(sm_pool *p) {
    worker **list = realloc(p->workers, (size_t)(p->nworkers + 1) * sizeof *list);
    if (!list) return 0;
    p->workers = list;
    worker *wk = malloc(sizeof *wk);
    if (!wk) return 0;
    wk->pool = p;
    wk->index = p->nworkers + 1;
    wk->start = atomic_load(&p->dispatch);
    sigset_t all, old;
    sigfillset(&all);
    pthread_sigmask(SIG_SETMASK, &all, &old);
    const int err = pthread_create(&wk->tid, NULL, worker_main, wk);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    if (err != 0) {
        free(wk);
        return 0;
    }
    list[p->nworkers++] = wk;
    return 1;
}

/* This thread's pool with at least `need` workers if they can be made (NULL: no pool). */
static sm_pool *pool_get(int need) {
    pthread_once(&once, init_once);
    sm_pool *p = pthread_getspecific(pool_key);
    if (!p) {
        p = calloc(1, sizeof *p);
        if (!p) return NULL;
        for (int u = 0; u < SM_TEAM_CPU_SLOTS; u++) atomic_init(&p->cpu[u], -1);
        if (pthread_mutex_init(&p->mu, NULL) != 0) {
            free(p);
            return NULL;
        }
        if (pthread_cond_init(&p->cv, NULL) != 0) {
            pthread_mutex_destroy(&p->mu);
            free(p);
            return NULL;
        }
        if (pthread_setspecific(pool_key, p) != 0) {
            pthread_cond_destroy(&p->cv);
            pthread_mutex_destroy(&p->mu);
            free(p);
            return NULL;
        }
    }
    while (p->nworkers < need && add_worker(p)) {
    }
    return p;
}

void sm_team_run(int T, sm_team_fn fn, void *arg) {
    sm_pool *p = (T > 1 && tl_depth == 0) ? pool_get(T - 1) : NULL;
    if (p && T > p->nworkers + 1) T = p->nworkers + 1;
    if (!p || T <= 1) {
        const int saved = tl_T;
        tl_T = 1;
        tl_depth++;
        fn(arg, 0, 1);
        tl_depth--;
        tl_T = saved;
        return;
    }
    p->fn = fn;
    p->arg = arg;
    atomic_store_explicit(&p->run_T, (unsigned)T, memory_order_relaxed);
    const uint64_t d = atomic_load(&p->dispatch);
    publish(p, &p->dispatch, (((d >> 32) + 1) << 32) | (uint64_t)T);
    run_as(p, 0, T);
}

typedef struct team_for {
    sm_team_range_fn fn;
    void *arg;
    long n;
} team_for;

static void team_for_share(void *arg, int t, int T) {
    const team_for *f = arg;
    long lo, hi;
    sm_team_split(f->n, T, t, &lo, &hi);
    if (lo < hi) f->fn(f->arg, lo, hi);
}

void sm_team_for(int T, long n, sm_team_range_fn fn, void *arg) {
    if (n <= 0) return;
    team_for f = {fn, arg, n};
    sm_team_run(T > n ? (int)n : T, team_for_share, &f);
}

void sm_team_claims_init(sm_team_claims *cl, long n) {
    cl->n = n;
    atomic_init(&cl->ends, (unsigned long long)n << 32);
}

void sm_team_claimer_init(sm_team_claimer *c, sm_team_claims *cl, int t, int T) {
    c->cl = cl;
    c->t = t;
    c->T = T;
    sm_team_split(cl->n, T, t, &c->next, &c->end);
}

static long chunk_of(long left, long min_chunk) {
    const long k = left / 4;
    return k > min_chunk ? k : min_chunk;
}

int sm_team_claim(sm_team_claimer *c, long min_chunk, long *lo, long *hi) {
    if (c->T != 2) {
        if (c->next >= c->end) return 0;
        *lo = c->next;
        *hi = c->next + chunk_of(c->end - c->next, min_chunk);
        if (*hi > c->end) *hi = c->end;
        c->next = *hi;
        return 1;
    }
    unsigned long long e = atomic_load_explicit(&c->cl->ends, memory_order_relaxed);
    for (;;) {
        const long front = (long)(e & 0xffffffffu), back = (long)(e >> 32);
        if (front >= back) return 0;
        const long k = chunk_of(back - front, min_chunk);
        long nf = front, nb = back;
        if (c->t == 0) nf = front + k < back ? front + k : back;
        else nb = back - k > front ? back - k : front;
        const unsigned long long ne = (unsigned long long)nf | (unsigned long long)nb << 32;
        if (atomic_compare_exchange_weak_explicit(&c->cl->ends, &e, ne, memory_order_relaxed, memory_order_relaxed)) {
            *lo = c->t == 0 ? front : nb;
            *hi = c->t == 0 ? nf : back;
            return 1;
        }
    }
}
