/* The checkpoint stream's constants, shared by its writer (checkpoint.c) and its reader
 * (checkpoint_read.c); docs/checkpoints.md has the layout. */
#ifndef SM_WORLD_CHECKPOINT_FORMAT_H
#define SM_WORLD_CHECKPOINT_FORMAT_H

#define CKPT_MAGIC "SANDMPMC"
#define CKPT_VERSION 3u /* 2: positions are double in both builds (particles.h); 3: gmres_preconditioner, implicit stats */
#define CKPT_ENDIAN 0x01020304u
#define CKPT_MAX_NAME 32

#endif
