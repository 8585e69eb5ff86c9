/* OpenMP team queries that also compile without OpenMP. */
#ifndef SM_CORE_THREADS_H
#define SM_CORE_THREADS_H

#ifdef _OPENMP
#include <omp.h>
#endif

#define SM_PRAGMA_(x) _Pragma(#x)

/* A parallel region of `threads` threads with the given OpenMP clauses around the block (the
 * variadic argument), or, when threads <= 1, the block on this thread with no team at all.
 * libgomp ends even a team of one with a barrier that makes a futex system call: 1.5 us per
 * region on this project's 2-core virtual machines, and an explicit step opens about 13 (perf:
 * 11% of a 1,000-particle 2D step on one thread; docs/benchmarks.md). Without a team,
 * sm_thread_team gives 0 and 1, orphaned `omp for` loops run whole and orphaned barriers return
 * at once, as in a team of one: the same bits. A reduction's variable is updated in place, which
 * is the team's result for the reductions used here (integer sums, max, |, &). */
#define SM_PARALLEL(threads, clauses, ...)                             \
    do {                                                               \
        if ((threads) > 1) {                                           \
            SM_PRAGMA_(omp parallel num_threads(threads) clauses)      \
            __VA_ARGS__                                                \
        } else {                                                       \
            __VA_ARGS__                                                \
        }                                                              \
    } while (0)

/* `for (header) body` split among `threads` threads (OpenMP `parallel for` with the clauses), or
 * run on this thread with no team when threads <= 1 (SM_PARALLEL says why). The header must not
 * hold a comma outside parentheses. */
#define SM_PARALLEL_FOR(threads, clauses, header, ...)                 \
    do {                                                               \
        if ((threads) > 1) {                                           \
            SM_PRAGMA_(omp parallel for num_threads(threads) clauses)  \
            for (header) __VA_ARGS__                                   \
        } else {                                                       \
            for (header) __VA_ARGS__                                   \
        }                                                              \
    } while (0)

/* This thread's number and the team's size inside a parallel region (0 and 1 without OpenMP). */
static inline void sm_thread_team(int *t, int *T) {
#ifdef _OPENMP
    *t = omp_get_thread_num();
    *T = omp_get_num_threads();
#else
    *t = 0;
    *T = 1;
#endif
}

#endif
