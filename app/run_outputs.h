/* The outputs of a scene's run, chosen once for every caller (`sandmpm run`, cli/cmd_run.c, and the
 * Python package through app/scene_run.h): which sinks (app/sinks.h, app/checkpoint.h,
 * app/run_manifest.h) see the frames and how they are configured, what the run manifest says of
 * the run, and the scene hash that checkpoints and manifests carry. A caller may append its own
 * sinks after the chosen ones (the CLI's progress line): they see each frame once every file of it
 * is written and listed. */
#ifndef SM_APP_RUN_OUTPUTS_H
#define SM_APP_RUN_OUTPUTS_H

#include <stdint.h>

#include "app/checkpoint.h"
#include "app/run_manifest.h"
#include "app/scene.h"
#include "app/sinks.h"

/* Frames between checkpoints when neither the caller nor the scene says: a preview frame of the
 * default scene (29,796 particles) took about 1.7 to 2.3 s of wall time on the 2-core test machine
 * (docs/checkpoints.md), so 20 frames lose at most about 40 s. */
#define SM_RUN_CHECKPOINT_EVERY 20
#define SM_RUN_KEEP_CHECKPOINTS 2  /* checkpoints kept */
#define SM_RUN_OUTPUT_SINKS 10     /* room in sm_run_outputs.sinks (the chosen ones take at most 7) */

/* What a run asks for beyond the scene's outputs table. */
typedef struct sm_run_request {
    const char *scene;    /* the scene file, for the manifest; NULL: the built-in default */
    const char *quality;  /* NULL: "preview" */
    uint64_t scene_hash;  /* sm_run_scene_hash */
    int frames;           /* frames after frame 0 */
    int render;           /* 1: frame_NNNN.png (and the PLY frames they are drawn from) */
    int video;            /* 1: the manifest will list video.mp4 */
    int threads;          /* the renderer's threads, 0 = OpenMP's default */
    int checkpoint_every; /* frames, 0: none (sm_run_checkpoint_every) */
    int keep;             /* checkpoints kept, >= 1 */
    int keep_last;        /* 1: the checkpoint sink even without checkpoints (checkpoint_every 0), to
                             write the last frame's state when a stop or a failure ends the run */
} sm_run_request;

/* Everything the sinks are configured with; alive through the run (the sinks point into it). */
typedef struct sm_run_outputs {
    sm_manifest_camera camera;
    sm_png_sink_config png;
    sm_checkpoint_config ckpt;
    sm_run_manifest_config manifest;
    sm_sink sinks[SM_RUN_OUTPUT_SINKS];
    int nsinks;
} sm_run_outputs;

/* FNV-1a over the scene file's bytes (none for path NULL), the KEY=VALUE pairs and the quality
 * (NULL: "preview"): what a resume must match (docs/checkpoints.md). */
uint64_t sm_run_scene_hash(const char *path, const sm_scene_param *params, int nparams, const char *quality);

/* Frames between checkpoints: asked if >= 0, else the scene's checkpoint_every, else
 * SM_RUN_CHECKPOINT_EVERY. */
int sm_run_checkpoint_every(int asked, const sm_scene_settings *st);

/* The run manifest's description of the run, before any frame (app/run_manifest.h). */
void sm_run_describe(const sm_run_request *r, const sm_scene_settings *st, sm_run_manifest *m);

/* Fills o with the sinks in the order they see each frame: frame files (PLY, VTK), the render
 * manifest, renders (which read it), diagnostics, checkpoints, the run manifest (which lists what
 * the others wrote, starting from *start). */
void sm_run_outputs_choose(sm_run_outputs *o, const sm_run_request *r, const sm_scene_settings *st,
                           const sm_run_manifest *start);

#endif
