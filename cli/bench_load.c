/* sandmpm bench --load N: N busy processes beside the measurement (issue 18 item 3, a machine
 * shared with other work). Each is a forked child that spins on the CPU at the bench's own
 * priority until it is killed, or until the bench dies (PR_SET_PDEATHSIG): no child outlives it. */
#define _GNU_SOURCE
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cli/bench_load.h"

static void spin_forever(pid_t parent) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(0); /* the parent died before prctl */
    volatile unsigned long x = 0;
    for (;;) x = x * 6364136223846793005ul + 1;
}

int bench_load_start(int n, pid_t *pids, char *err, size_t errlen) {
    const pid_t self = getpid();
    fflush(NULL); /* the children must not flush the parent's buffers */
    for (int i = 0; i < n; i++) {
        pids[i] = fork();
        if (pids[i] == 0) spin_forever(self);
        if (pids[i] < 0) {
            snprintf(err, errlen, "--load: cannot start busy process %d of %d: %s", i + 1, n, strerror(errno));
            bench_load_stop(i, pids);
            return 0;
        }
    }
    return 1;
}

void bench_load_stop(int n, pid_t *pids) {
    for (int i = 0; i < n; i++)
        if (pids[i] > 0) kill(pids[i], SIGKILL);
    for (int i = 0; i < n; i++)
        if (pids[i] > 0) {
            while (waitpid(pids[i], NULL, 0) < 0 && errno == EINTR) {
            }
            pids[i] = 0;
        }
}
