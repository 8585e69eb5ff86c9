/* Checkpoint files of `sandmpm run` (docs/checkpoints.md): the library's checkpoint stream
 * (sm_world_save) with a trailer, written every N frames to OUT/checkpoints/ckpt_FRAME.smc.
 *
 *   file    = stream | trailer
 *   trailer = frame (uint32) | scene hash (uint64) | stream bytes (uint64) | "SMCK" | crc32 (uint32)
 * crc32 (zlib) covers everything before it. A file is written to a temporary beside it, fsynced,
 * renamed, and the folder fsynced: a crash leaves the old set or the new one, never a torn file
 * under the final name. The last `keep` checkpoints are kept. */
#ifndef SM_APP_CHECKPOINT_H
#define SM_APP_CHECKPOINT_H

#include <stdint.h>

#include "app/run.h"

typedef struct sm_checkpoint_config {
    int every;           /* frames between checkpoints (0: none) */
    int keep;            /* checkpoints kept (>= 1) */
    uint64_t scene_hash; /* hash of the scene file and its parameters, stored in the trailer */
} sm_checkpoint_config;

/* The sink that writes them (frames every, 2 every, ...). */
sm_sink sm_sink_checkpoint(const sm_checkpoint_config *config);

/* The path of frame's checkpoint in out_dir/checkpoints/; SM_OK if it is there to read, else
 * SM_ERR_IO with err. */
sm_status sm_checkpoint_find(const char *out_dir, int frame, char *path, size_t pathlen, char *err, size_t errlen);

/* Writes the checkpoint of w at frame into out_dir/checkpoints/. SM_OK or SM_ERR_IO with err. */
sm_status sm_checkpoint_write(const char *out_dir, const sm_world *w, int frame, uint64_t scene_hash, int keep, char *path,
                              size_t pathlen, char *err, size_t errlen);

/* ---- A checkpoint across MPI ranks (checkpoint_parts.c): every rank its parts ----------------- */
#define SM_CKPT_TRAILER_BYTES (4 + 8 + 8 + 4 + 4)
/* frame's checkpoint file path (its folder exists) written by every rank at once from its id slice
 * (collective): the same bytes sm_checkpoint_write of the gathered world writes. */
sm_status sm_ckpt_parts_write(const sm_part_io *io, const char *path, int frame, uint64_t scene_hash, char *err,
                              size_t errlen);

/* ---- Reading (checkpoint_read.c) ------------------------------------------------------------ */
/* A checkpoint file open for reading its stream at offsets. */
typedef struct sm_checkpoint_file {
    int fd;
    int frame;             /* the trailer's */
    uint64_t scene_hash;   /* the trailer's */
    uint64_t stream_bytes; /* the library stream's length (the file less its trailer) */
} sm_checkpoint_file;

/* Opens path and checks its trailer, and with verify its checksum (reading the file through
 * 64 KiB at a time). SM_OK, or SM_ERR_IO / SM_ERR_INVALID with err (the file closed). */
sm_status sm_checkpoint_open(const char *path, int verify, sm_checkpoint_file *f, char *err, size_t errlen);
/* sm_pread_fn over the stream of an open checkpoint file (user: the sm_checkpoint_file). */
int sm_checkpoint_pread(void *user, uint64_t offset, void *data, size_t len);
void sm_checkpoint_close(sm_checkpoint_file *f);

/* Checks a checkpoint file's trailer and checksum; on SM_OK *stream and *len are the library stream
 * (malloc'd, free it) and *frame, *scene_hash its trailer's. SM_ERR_INVALID / SM_ERR_IO with err. */
sm_status sm_checkpoint_read(const char *path, unsigned char **stream, size_t *len, int *frame, uint64_t *scene_hash,
                             char *err, size_t errlen);

#endif
