/* The cost of an OpenMP parallel region that does nothing, with a team of one thread and of two,
 * and with an `if` clause (which still forms a team of one). Behind docs/benchmarks.md "Small
 * scenes, second look" and the former src/core/threads.h's SM_PARALLEL (now src/core/team.h): libgomp ends every team, even one
 * of a single thread, with a barrier whose last thread calls futex(FUTEX_WAKE), a system call.
 *   gcc -O2 -fopenmp docs/experiments/omp_region_cost.c -o /tmp/omp_region_cost
 *   /tmp/omp_region_cost 1; /tmp/omp_region_cost 2
 *   strace -f -c /tmp/omp_region_cost 1     (two futex calls per loop pass: one per region)
 */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv) {
    const int threads = argc > 1 ? atoi(argv[1]) : 1, regions = 100000;
    volatile double sink = 0;
    double t0 = omp_get_wtime();
    for (int i = 0; i < regions; i++) {
#pragma omp parallel num_threads(threads)
        sink += 1;
    }
    double t1 = omp_get_wtime();
    for (int i = 0; i < regions; i++) {
#pragma omp parallel num_threads(threads) if (threads > 1)
        sink += 1;
    }
    double t2 = omp_get_wtime();
    for (int i = 0; i < regions; i++) sink += 1;
    double t3 = omp_get_wtime();
    printf("%d thread(s): %.2f us per region, %.2f us with the if clause, %.3f us without a region\n", threads,
           (t1 - t0) / regions * 1e6, (t2 - t1) / regions * 1e6, (t3 - t2) / regions * 1e6);
    return 0;
}
