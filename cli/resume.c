/* `sandmpm run --resume`: the newest valid checkpoint in OUT/checkpoints restored into the run's
 * world, on one process or across ranks. Rank 0 picks the checkpoint (trailer and crc32 checked,
 * the file read 64 KiB at a time, and written for this scene unless --force); every rank then
 * reads the stream from the file itself (cli_ranks_restore: on several ranks each stores only its
 * share, sm_world_restore_share), so no process holds the file or the whole run in memory. A
 * corrupt, truncated or unreadable checkpoint is reported and the previous one tried. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/checkpoint.h"
#include "app/io/files.h"
#include "cli/cli.h"

#define MAX_CHECKPOINTS 4096

/* The frames of the checkpoints in dir (at most MAX_CHECKPOINTS); a killed run's temporaries removed. */
static int list_checkpoints(const char *dir, int *frames) {
    int n = 0;
    DIR *d = opendir(dir);
    struct dirent *e;
    while (d && (e = readdir(d)) && n < MAX_CHECKPOINTS) {
        int f;
        char tail[8];
        if (sscanf(e->d_name, "ckpt_%d.sm%7s", &f, tail) == 2 && !strcmp(tail, "c")) frames[n++] = f;
        if (!strncmp(e->d_name, ".ckpt_", 6) && strstr(e->d_name, ".tmp.")) {
            char p[SM_PATH_MAX];
            if (snprintf(p, sizeof p, "%s/%s", dir, e->d_name) < (int)sizeof p) unlink(p);
        }
    }
    if (d) closedir(d);
    return n;
}

/* Rank 0: the newest checkpoint not tried yet (its frame then marked -1) that checks and was
 * written for this scene, into path and *frame. SM_ERR_IO when none is left, SM_ERR_INVALID for
 * another scene's (without force): both reported. */
static sm_status next_checkpoint(const char *dir, int *frames, int n, uint64_t hash, int force, char *path, int *frame) {
    for (;;) {
        int best = -1;
        for (int i = 0; i < n; i++)
            if (frames[i] >= 0 && (best < 0 || frames[i] > frames[best])) best = i;
        if (best < 0) break;
        char err[SM_MSG_MAX];
        const int made = snprintf(path, SM_PATH_MAX, "%s/ckpt_%08d.smc", dir, frames[best]);
        frames[best] = -1;
        sm_checkpoint_file f;
        if (made >= SM_PATH_MAX) continue;
        if (sm_checkpoint_open(path, 1, &f, err, sizeof err) != SM_OK) {
            fprintf(stderr, "sandmpm run: %s; trying the previous checkpoint\n", err);
            continue;
        }
        sm_checkpoint_close(&f);
        if (f.scene_hash != hash && !force) {
            fprintf(stderr, "sandmpm run: %s was written for another scene file, --set values or --quality "
                            "(hash %016llx, now %016llx); refusing to resume (--force resumes anyway)\n",
                    path, (unsigned long long)f.scene_hash, (unsigned long long)hash);
            return SM_ERR_INVALID;
        }
        *frame = f.frame;
        return SM_OK;
    }
    fprintf(stderr, "sandmpm run: --resume: no valid checkpoint in %s/\n", dir);
    return SM_ERR_IO;
}

/* path (rank 0's) on every rank. */
static int share_path(char *path) {
    unsigned char *bytes = NULL;
    size_t len = 0;
    if (cli_rank() == 0) {
        len = strlen(path) + 1;
        if (!(bytes = malloc(len))) return 0;
        memcpy(bytes, path, len);
    }
    const int ok = cli_ranks_share_bytes(&bytes, &len) && len > 0 && len <= SM_PATH_MAX;
    if (ok && cli_rank() != 0) memcpy(path, bytes, len), path[len - 1] = 0;
    free(bytes);
    return ok;
}

sm_status cli_resume(sm_world *w, const char *out, uint64_t hash, int force, int *first) {
    char dir[SM_PATH_MAX], path[SM_PATH_MAX] = "";
    if (snprintf(dir, sizeof dir, "%s/checkpoints", out) >= (int)sizeof dir - SM_NAME_RESERVE) return SM_ERR_IO;
    static int frames[MAX_CHECKPOINTS];
    const int n = cli_rank() == 0 ? list_checkpoints(dir, frames) : 0;
    for (;;) {
        int frame = -1;
        sm_status st = cli_rank() == 0 ? next_checkpoint(dir, frames, n, hash, force, path, &frame) : SM_OK;
        if ((st = cli_ranks_share_status(st)) != SM_OK) return st;
        if (!cli_ranks_share_ints(&frame, 1) || !share_path(path)) return cli_ranks_worst(SM_ERR_NOMEM);
        char err[SM_MSG_MAX];
        if (cli_ranks_restore(w, path, err, sizeof err) == SM_OK) { /* collective: the same on every rank */
            fprintf(stderr, "sandmpm run: resuming from %s (frame %d)\n", path, frame);
            *first = frame + 1;
            return SM_OK;
        }
        fprintf(stderr, "sandmpm run: %s: %s; trying the previous checkpoint\n", path, err);
    }
}
