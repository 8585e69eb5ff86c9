/* One file written by several ranks at once, each its own parts (a frame's particles in id order,
 * a checkpoint's stream): the writers of app/io (PLY, VTP) and the checkpoint sink write through
 * these operations when a run spans MPI ranks, and no rank holds the whole run. The operations
 * are the program's (cli/ranks_files.c: MPI-IO); app/ does not call MPI itself.
 *
 * A writer on every rank, in step:
 *   open(path)                 collective: a temporary next to path, created empty
 *   write_at(offset, bytes)    each rank its parts, the writer rank (rank 0) also what is not
 *                              particle data (headers, trailers); parts never overlap
 *   crc(bytes)                 collective, optional: the crc32 of [0, bytes) of what the ranks
 *                              wrote so far (their parts must tile it), on the writer rank
 *   close(ok)                  collective: synced and renamed to path if every rank's ok, else
 *                              removed; the status agreed over the ranks
 * Every status these return is the same on every rank, with a message naming the rank that failed. */
#ifndef SM_APP_IO_PART_FILE_H
#define SM_APP_IO_PART_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "sandmpm/sandmpm.h"

typedef struct sm_part_io {
    int writer;            /* 1 on the rank that writes headers and trailers (rank 0) */
    uint64_t first, total; /* this rank's particles: positions first .. first + n - 1 of total in
                              id order (the slice world holds them, in id order) */
    void *ctx;
    sm_status (*open)(void *ctx, const char *path, void **file, char *err, size_t errlen);
    int (*write_at)(void *file, uint64_t offset, const void *data, size_t len); /* 0 on success */
    sm_status (*crc)(void *file, uint64_t bytes, uint32_t *crc, char *err, size_t errlen);
    sm_status (*close)(void *file, int ok, char *err, size_t errlen);
    /* This rank's parts of the checkpoint stream of the whole run (the bytes sm_world_save of the
     * gathered world gives), each at its offset; *bytes the stream's length. Not collective. */
    sm_status (*save)(void *ctx, sm_pwrite_fn write, void *user, uint64_t *bytes);
    /* The worst of the ranks' statuses, with the message of the lowest rank that has it. */
    sm_status (*agree)(void *ctx, sm_status st, char *err, size_t errlen);
} sm_part_io;

#endif
