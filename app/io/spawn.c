/* Child processes; see spawn.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <spawn.h>
#include <stdio.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "app/io/spawn.h"

extern char **environ;

sm_status sm_spawn(char *const argv[], int capture_stdout, sm_child *c, int *missing, char *err, size_t errlen) {
    c->pid = -1;
    c->out_fd = -1;
    if (missing) *missing = 0;
    int fd[2] = {-1, -1};
    if (capture_stdout && pipe(fd) != 0) {
        snprintf(err, errlen, "pipe: %s", strerror(errno));
        return SM_ERR_IO;
    }
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    if (capture_stdout) {
        posix_spawn_file_actions_addclose(&fa, fd[0]);
        posix_spawn_file_actions_adddup2(&fa, fd[1], STDOUT_FILENO);
        posix_spawn_file_actions_addclose(&fa, fd[1]);
    }
    fflush(stdout);
    fflush(stderr);
    int r = posix_spawnp(&c->pid, argv[0], &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (capture_stdout) close(fd[1]);
    if (r != 0) {
        if (capture_stdout) close(fd[0]);
        if (missing) *missing = r == ENOENT;
        snprintf(err, errlen, r == ENOENT ? "%s: not found" : "cannot run %s: %s", argv[0], strerror(r));
        c->pid = -1;
        return SM_ERR_IO;
    }
    c->out_fd = capture_stdout ? fd[0] : -1;
    return SM_OK;
}

int sm_child_wait(sm_child *c, int *exit_code, int *signal) {
    int status = 0;
    *exit_code = -1;
    *signal = 0;
    if (c->pid <= 0) return -1;
    while (waitpid(c->pid, &status, 0) < 0)
        if (errno != EINTR) return -1;
    c->pid = -1;
    if (WIFEXITED(status)) *exit_code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) *signal = WTERMSIG(status);
    return *exit_code == 0 ? 0 : -1;
}
