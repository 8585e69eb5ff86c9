/* Running another program by an argument vector (posix_spawnp): no shell between us and it, so a
 * file name is one argument whatever it holds (quotes, semicolons, spaces). */
#ifndef SM_APP_IO_SPAWN_H
#define SM_APP_IO_SPAWN_H

#include <stddef.h>
#include <sys/types.h>

#include "sandmpm/sandmpm.h"

typedef struct sm_child {
    pid_t pid;
    int out_fd; /* the read end of its stdout, or -1 if not captured */
} sm_child;

/* Starts argv[0] (searched in PATH unless it holds a '/') with argv; its stdout into a pipe if
 * capture_stdout. SM_OK; SM_ERR_IO with "NAME: not found" (not installed) or the reason. *missing
 * is set to 1 if the program does not exist (may be NULL). */
sm_status sm_spawn(char *const argv[], int capture_stdout, sm_child *c, int *missing, char *err, size_t errlen);

/* Waits for the child to end. Returns 0 if it exited with status 0; else *exit_code (or -1) and
 * *signal (or 0) say how it ended, and the return is -1. */
int sm_child_wait(sm_child *c, int *exit_code, int *signal);

#endif
