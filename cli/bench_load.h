/* Busy processes beside a benchmark (sandmpm bench --load N). */
#ifndef SANDMPM_CLI_BENCH_LOAD_H
#define SANDMPM_CLI_BENCH_LOAD_H

#include <stddef.h>
#include <sys/types.h>

#define BENCH_MAX_LOAD 64

/* Starts n CPU-bound child processes (pids[n]); 0 with a message in err if one cannot start (the
 * ones started are stopped). */
int bench_load_start(int n, pid_t *pids, char *err, size_t errlen);
/* Kills and reaps the n children. */
void bench_load_stop(int n, pid_t *pids);

#endif
