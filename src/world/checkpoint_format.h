/* The checkpoint stream's constants, shared by its writer (checkpoint.c) and its reader
 * (checkpoint_read.c); docs/checkpoints.md has the layout. */
#ifndef SM_WORLD_CHECKPOINT_FORMAT_H
#define SM_WORLD_CHECKPOINT_FORMAT_H

#define CKPT_MAGIC "SANDMPMC"
#define CKPT_VERSION 4u /* 2: positions are double in both builds (particles.h); 3: gmres_preconditioner, implicit stats;
                          4: contact_gap (the world definition's last field) */
#define CKPT_VERSION_OLDEST 3u /* version 3 is read too: its definition lacks contact_gap, taken as INFINITY
                                  (no contact gate: the run resumes as it was made) */
#define CKPT_ENDIAN 0x01020304u
#define CKPT_MAX_NAME 32

#endif
