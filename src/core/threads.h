/* OpenMP team queries that also compile without OpenMP. */
#ifndef SM_CORE_THREADS_H
#define SM_CORE_THREADS_H

#ifdef _OPENMP
#include <omp.h>
#endif

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
