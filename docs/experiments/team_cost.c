/* The cost of an empty run of src/core/team.c's thread team against an empty OpenMP parallel
 * region, with and without 4 barriers inside, and how long the team's polling lasts before a
 * waiting thread sleeps. Behind src/core/team.h and docs/benchmarks.md "Small scenes, third look".
 *   gcc -O2 -fopenmp -Isrc docs/experiments/team_cost.c src/core/team.c -o /tmp/team_cost
 *   /tmp/team_cost 2
 *   strace -f -c /tmp/team_cost 2      (futex calls: OpenMP's, and the team's only when it sleeps)
 */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#include "core/team.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

static volatile double sink;

static void empty(void *arg, int t, int T) {
    (void)arg;
    (void)T;
    if (t == 0) sink += 1;
}

static void four_barriers(void *arg, int t, int T) {
    (void)arg;
    (void)T;
    for (int k = 0; k < 4; k++) {
        if (t == 0) sink += 1;
        sm_team_barrier();
    }
}

int main(int argc, char **argv) {
    const int threads = argc > 1 ? atoi(argv[1]) : 2, runs = 100000;
    double t0 = omp_get_wtime();
    for (int i = 0; i < runs; i++) {
#pragma omp parallel num_threads(threads)
        if (omp_get_thread_num() == 0) sink += 1;
    }
    double t1 = omp_get_wtime();
    for (int i = 0; i < runs; i++) {
#pragma omp parallel num_threads(threads)
        for (int k = 0; k < 4; k++) {
            if (omp_get_thread_num() == 0) sink += 1;
#pragma omp barrier
        }
    }
    double t2 = omp_get_wtime();
    for (int i = 0; i < runs; i++) sm_team_run(threads, empty, NULL);
    double t3 = omp_get_wtime();
    for (int i = 0; i < runs; i++) sm_team_run(threads, four_barriers, NULL);
    double t4 = omp_get_wtime();
#if defined(__x86_64__)
    for (int i = 0; i < 4096 * 100; i++) _mm_pause();
#endif
    double t5 = omp_get_wtime();
    printf("%d threads, us per region: OpenMP %.2f, with 4 barriers %.2f; team %.2f, with 4 barriers %.2f\n", threads,
           (t1 - t0) / runs * 1e6, (t2 - t1) / runs * 1e6, (t3 - t2) / runs * 1e6, (t4 - t3) / runs * 1e6);
    printf("4096 pause instructions: %.1f us\n", (t5 - t4) / 100 * 1e6);
    return 0;
}
