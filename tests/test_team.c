/* The step's thread team (src/core/team.h): every thread number runs once per run, the barrier
 * separates phases, loops cover their items once, runs nest, and the pool survives its workers
 * sleeping, its owner thread ending, a fork, and its threads sharing one core. */
#define _GNU_SOURCE /* fork, nanosleep, waitpid; pthread_setaffinity_np, sched_getcpu */

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "core/team.h"
#include "test_util.h"

#define MAXT 8

typedef struct calls {
    atomic_int count[MAXT];
    atomic_int bad_T, not_caller;
    int T;
    pthread_t caller;
} calls;

static void count_calls(void *arg, int t, int T) {
    calls *c = arg;
    if (T != c->T) atomic_store(&c->bad_T, 1);
    if (t == 0 && !pthread_equal(pthread_self(), c->caller)) atomic_store(&c->not_caller, 1);
    if (t >= 0 && t < MAXT) atomic_fetch_add(&c->count[t], 1);
}

static void test_each_thread_once(void) {
    for (int T = 1; T <= 5; T++) {
        calls c = {.T = T, .caller = pthread_self()};
        sm_team_run(T, count_calls, &c);
        for (int t = 0; t < MAXT; t++) CHECK(atomic_load(&c.count[t]) == (t < T ? 1 : 0));
        CHECK(atomic_load(&c.bad_T) == 0);
        CHECK(atomic_load(&c.not_caller) == 0);
    }
}

/* Each thread writes its phase number (plain stores), waits, reads every other's, waits again. */
typedef struct phases {
    int slot[MAXT];
    atomic_int mismatches;
    int rounds;
} phases;

static void phase_work(void *arg, int t, int T) {
    phases *ph = arg;
    for (int k = 1; k <= ph->rounds; k++) {
        ph->slot[t] = k;
        sm_team_barrier();
        for (int u = 0; u < T; u++)
            if (ph->slot[u] != k) atomic_fetch_add(&ph->mismatches, 1);
        sm_team_barrier();
    }
}

static void test_barrier_phases(void) {
    for (int T = 2; T <= 4; T++) {
        phases ph = {.rounds = 2000};
        sm_team_run(T, phase_work, &ph);
        CHECK(atomic_load(&ph.mismatches) == 0);
        for (int t = 0; t < T; t++) CHECK(ph.slot[t] == ph.rounds);
    }
}

typedef struct cover {
    atomic_int hits[1000];
    atomic_int bad_range;
    long n;
} cover;

static void cover_range(void *arg, long lo, long hi) {
    cover *cv = arg;
    if (lo < 0 || hi > cv->n || lo >= hi) atomic_store(&cv->bad_range, 1);
    for (long i = lo; i < hi && i < cv->n; i++) atomic_fetch_add(&cv->hits[i], 1);
}

static void test_for_covers_once(void) {
    const long ns[] = {0, 1, 3, 7, 1000};
    const int Ts[] = {1, 2, 3, 8};
    for (int a = 0; a < 5; a++)
        for (int b = 0; b < 4; b++) {
            cover *cv = calloc(1, sizeof *cv);
            cv->n = ns[a];
            sm_team_for(Ts[b], cv->n, cover_range, cv);
            int once = 1;
            for (long i = 0; i < cv->n; i++) once &= atomic_load(&cv->hits[i]) == 1;
            CHECK(once);
            CHECK(atomic_load(&cv->bad_range) == 0);
            free(cv);
        }
    /* The split: contiguous, in thread order, sizes differing by at most one. */
    for (int T = 1; T <= 5; T++) {
        long prev = 0;
        for (int t = 0; t < T; t++) {
            long lo, hi;
            sm_team_split(11, T, t, &lo, &hi);
            CHECK(lo == prev);
            CHECK(hi - lo == 11 / T || hi - lo == 11 / T + 1);
            prev = hi;
        }
        CHECK(prev == 11);
    }
}

/* Claims: every item once, in chunks of at least min_chunk (but the last), thread 0's from the
 * front upward and thread 1's from the back downward when there are 2; with a thread that sleeps
 * first, the other takes the rest. */
typedef struct claim_run {
    sm_team_claims cl;
    atomic_int hits[1000];
    atomic_int order_bad, chunk_bad, count[MAXT];
    long min_chunk;
    int slow_thread; /* sleeps 20 ms before claiming (-1: none) */
} claim_run;

static void claim_work(void *arg, int t, int T) {
    claim_run *cr = arg;
    if (t == cr->slow_thread) {
        struct timespec ts = {0, 20 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
    sm_team_claimer c;
    sm_team_claimer_init(&c, &cr->cl, t, T);
    long lo, hi, prev_lo = -1, prev_hi = -1;
    while (sm_team_claim(&c, cr->min_chunk, &lo, &hi)) {
        if (!(lo < hi && lo >= 0 && hi <= cr->cl.n)) atomic_store(&cr->chunk_bad, 1);
        if (T == 2 && prev_lo >= 0 && (t == 0 ? lo != prev_hi : hi != prev_lo)) atomic_store(&cr->order_bad, 1);
        for (long i = lo; i < hi; i++) atomic_fetch_add(&cr->hits[i], 1);
        atomic_fetch_add(&cr->count[t], (int)(hi - lo));
        prev_lo = lo;
        prev_hi = hi;
    }
}

static void test_claims(void) {
    const long ns[] = {0, 1, 2, 9, 1000};
    for (int a = 0; a < 5; a++)
        for (int T = 1; T <= 3; T++)
            for (int slow = -1; slow < (ns[a] == 1000 ? 2 : 0); slow++) {
                claim_run *cr = calloc(1, sizeof *cr);
                sm_team_claims_init(&cr->cl, ns[a]);
                cr->min_chunk = 3;
                cr->slow_thread = slow < T ? slow : -1;
                sm_team_run(T, claim_work, cr);
                int once = 1, total = 0;
                for (long i = 0; i < ns[a]; i++) once &= atomic_load(&cr->hits[i]) == 1;
                for (int t = 0; t < MAXT; t++) total += atomic_load(&cr->count[t]);
                CHECK(once);
                CHECK(total == ns[a]);
                CHECK(atomic_load(&cr->chunk_bad) == 0);
                CHECK(atomic_load(&cr->order_bad) == 0);
                /* 2 threads, one asleep for 20 ms: the other has taken nearly everything. */
                if (T == 2 && cr->slow_thread >= 0) CHECK(atomic_load(&cr->count[1 - cr->slow_thread]) >= 900);
                free(cr);
            }
}

/* A run inside a run is done by the thread that asks, alone. */
typedef struct nest {
    atomic_int inner_calls, inner_bad;
} nest;

static void inner(void *arg, int t, int T) {
    nest *ns = arg;
    if (t != 0 || T != 1) atomic_store(&ns->inner_bad, 1);
    atomic_fetch_add(&ns->inner_calls, 1);
}

static void outer(void *arg, int t, int T) {
    (void)t;
    (void)T;
    sm_team_run(3, inner, arg);
    sm_team_barrier();
}

static void test_nested(void) {
    nest ns = {0};
    sm_team_run(2, outer, &ns);
    CHECK(atomic_load(&ns.inner_calls) == 2);
    CHECK(atomic_load(&ns.inner_bad) == 0);
}

typedef struct maxes {
    _Atomic double m;
} maxes;

static void max_work(void *arg, int t, int T) {
    maxes *mx = arg;
    for (int k = 0; k < 1000; k++) sm_team_max(&mx->m, (double)(k * T + t));
}

static void test_max(void) {
    maxes mx = {0};
    sm_team_run(3, max_work, &mx);
    CHECK(atomic_load(&mx.m) == 999.0 * 3 + 2);
}

/* Runs after the workers have fallen asleep (they poll for about 0.35 ms). */
static void test_after_sleep(void) {
    for (int k = 0; k < 5; k++) {
        struct timespec ts = {0, 5 * 1000 * 1000};
        nanosleep(&ts, NULL);
        calls c = {.T = 2, .caller = pthread_self()};
        sm_team_run(2, count_calls, &c);
        CHECK(atomic_load(&c.count[0]) == 1 && atomic_load(&c.count[1]) == 1);
    }
}

/* A thread with its own pool ends: the pool's workers end with it (pthread_join would hang
 * otherwise, and ctest's timeout fail the test). */
static void *own_pool(void *arg) {
    int *ok = arg;
    phases ph = {.rounds = 50};
    sm_team_run(3, phase_work, &ph);
    *ok = atomic_load(&ph.mismatches) == 0 && ph.slot[2] == 50;
    return NULL;
}

static void test_thread_pools(void) {
    for (int k = 0; k < 10; k++) {
        pthread_t th;
        int ok = 0;
        CHECK(pthread_create(&th, NULL, own_pool, &ok) == 0);
        CHECK(pthread_join(th, NULL) == 0);
        CHECK(ok);
    }
}

/* After fork() the child has no workers: its first run makes a new pool. */
static void test_fork(void) {
    calls c0 = {.T = 2, .caller = pthread_self()};
    sm_team_run(2, count_calls, &c0); /* the parent's pool exists */
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        phases ph = {.rounds = 100};
        sm_team_run(2, phase_work, &ph);
        _exit(atomic_load(&ph.mismatches) == 0 && ph.slot[1] == 100 ? 0 : 1);
    }
    CHECK(pid > 0);
    int status = -1;
    CHECK(waitpid(pid, &status, 0) == pid);
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

/* Many short runs with barriers, also with more threads than cores (workers then sleep and are
 * woken often). */
static void test_many_runs(void) {
    for (int T = 2; T <= 3; T++) {
        phases ph = {.rounds = 2};
        int bad = 0;
        for (int k = 0; k < 20000; k++) {
            sm_team_run(T, phase_work, &ph);
            bad += ph.slot[T - 1] != 2;
            ph.slot[T - 1] = 0;
        }
        CHECK(bad == 0);
        CHECK(atomic_load(&ph.mismatches) == 0);
    }
}

/* Two threads of a run on one core (as a busy process beside the run can leave them): each
 * thread pins itself to the caller's core, then the phases run; afterwards every thread takes the
 * cores it had back. A waiter that sees the thread it waits for on its own core yields instead of
 * polling (team.c); here the phases must simply come out right. */
typedef struct pinned {
    phases ph;
    int core;
    cpu_set_t before[MAXT];
    atomic_int pin_failed, on_core;
} pinned;

static void pinned_work(void *arg, int t, int T) {
    pinned *pn = arg;
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(pn->core, &one);
    if (pthread_getaffinity_np(pthread_self(), sizeof pn->before[t], &pn->before[t]) != 0 ||
        pthread_setaffinity_np(pthread_self(), sizeof one, &one) != 0) {
        atomic_store(&pn->pin_failed, 1);
        return;
    }
    sm_team_barrier();
    if (sched_getcpu() == pn->core) atomic_fetch_add(&pn->on_core, 1);
    phase_work(&pn->ph, t, T);
    pthread_setaffinity_np(pthread_self(), sizeof pn->before[t], &pn->before[t]);
}

static void test_one_core(void) {
    const int core = sched_getcpu();
    if (core < 0) return;
    for (int T = 2; T <= 3; T++) {
        pinned pn = {.ph = {.rounds = 2000}, .core = core};
        sm_team_run(T, pinned_work, &pn);
        if (atomic_load(&pn.pin_failed)) {
            printf("test_team: pinning to core %d refused; the one-core case is not run\n", core);
            return;
        }
        CHECK(atomic_load(&pn.on_core) == T);
        CHECK(atomic_load(&pn.ph.mismatches) == 0);
        for (int t = 0; t < T; t++) CHECK(pn.ph.slot[t] == pn.ph.rounds);
    }
    calls c = {.T = 2, .caller = pthread_self()};
    sm_team_run(2, count_calls, &c); /* the threads work on after taking their cores back */
    CHECK(atomic_load(&c.count[0]) == 1 && atomic_load(&c.count[1]) == 1);
}

int main(void) {
    test_each_thread_once();
    test_barrier_phases();
    test_for_covers_once();
    test_claims();
    test_nested();
    test_max();
    test_after_sleep();
    test_thread_pools();
    test_fork();
    test_many_runs();
    test_one_core();
    return sm_test_summary("test_team");
}
