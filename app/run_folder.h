/* The output folder claimed for a run (docs/outputs.md), one set of rules for the program
 * (cli/out_folder.c words the outcome) and the bindings (app/scene_run.c):
 *   empty, or holding nothing of a run          the run starts
 *   an earlier run of the same scene (hash)     its listed files are removed, then the run starts
 *   another run without frames                  its listed files are removed
 *   another run's frames, or frame files        refused unless overwrite, which removes the listed
 *   without a manifest                          (or found) files, and only those, first
 * Removing a run's files also removes the frame after the last one its manifest lists (a killed
 * run may have written it: the manifest follows each frame). Resuming is the caller's. */
#ifndef SM_APP_RUN_FOLDER_H
#define SM_APP_RUN_FOLDER_H

#include <stddef.h>

#include "app/run_manifest.h"

typedef enum sm_claim_outcome {
    SM_CLAIM_EMPTY,            /* nothing of a run there */
    SM_CLAIM_SAME_SCENE,       /* an earlier run of the same scene: its files removed */
    SM_CLAIM_NO_FRAMES,        /* another run that wrote no frames: its files removed */
    SM_CLAIM_OVERWRITTEN,      /* another run (or a malformed manifest's frames): removed by overwrite */
    SM_CLAIM_REFUSED_UNLISTED, /* frame files without a manifest (found_files of them) */
    SM_CLAIM_REFUSED_MANIFEST, /* a manifest that does not parse (err says why) */
    SM_CLAIM_REFUSED_OTHER,    /* another run's frames (old) */
    SM_CLAIM_FAILED            /* reading or removing failed (err) */
} sm_claim_outcome;

typedef struct sm_folder_claim {
    sm_claim_outcome outcome;
    int unlisted;        /* 1: old is a scan of frame files, not a manifest */
    sm_run_manifest old; /* the folder's manifest, or the scan of its frame files */
    int found_files;     /* frame files found without a manifest */
    int removed;         /* files removed */
} sm_folder_claim;

/* Claims the existing folder out for a run described by start. SM_OK for the outcomes that start
 * the run, SM_ERR_INVALID for the refusals, SM_ERR_IO (or the manifest reader's status) for
 * SM_CLAIM_FAILED; err holds the reader's or remover's message where there is one. */
sm_status sm_claim_folder(const char *out, const sm_run_manifest *start, int overwrite, sm_folder_claim *c, char *err,
                          size_t errlen);

/* "frames 0..N" or "no frames" of a manifest (its longest frame list). */
void sm_run_manifest_frames_text(const sm_run_manifest *m, char *buf, size_t len);

#endif
