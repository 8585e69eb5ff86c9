/* A scene's run into an output folder in one call, for bindings (the Python package's
 * Scene.run): the same outputs as `sandmpm run` (the sinks of app/run_outputs.h, the run manifest,
 * checkpoints, renders) without the program's progress line, signals, resume and video. This
 * header includes only app/scene.h, so that a binding can declare it (python/cdef.cmake).
 *
 * The folder is claimed as `sandmpm run` claims it (cli/out_folder.c, docs/outputs.md): created;
 * temporaries of a killed process removed; an earlier run of the same scene hash, or one without
 * frames, has its listed files removed; another run's frames, or frame files without a run
 * manifest, are refused (SM_ERR_INVALID) unless overwrite, which removes what the manifest (or the
 * folder scan) lists, and only that. */
#ifndef SM_APP_SCENE_RUN_H
#define SM_APP_SCENE_RUN_H

#include <stddef.h>

#include "app/scene.h"

typedef struct sm_scene_run_opts {
    const char *out;              /* the output folder (created) */
    const char *scene;            /* the scene file, for the manifest and the scene hash (NULL: none) */
    const char *quality;          /* as given to sm_scene_load (NULL: "preview") */
    const sm_scene_param *params; /* as given to sm_scene_load */
    int nparams;
    int frames;           /* frames after frame 0; 0: the scene's */
    int render;           /* 1: frame_NNNN.png as `sandmpm run --render` */
    int threads;          /* the renderer's threads, 0 = OpenMP's default */
    int checkpoint_every; /* frames, 0: none, -1: the scene's, else SM_RUN_CHECKPOINT_EVERY */
    int keep;             /* checkpoints kept; 0: SM_RUN_KEEP_CHECKPOINTS */
    int overwrite;        /* 1: another run's files in out are removed first */
    /* NULL, or called after every frame's files are written and listed; non-zero stops the run
     * before the next frame (the manifest then says "stopped"). */
    int (*on_frame)(void *ctx, int frame);
    void *ctx;
} sm_scene_run_opts;

/* checkpoint_every = -1, everything else 0 / NULL. */
sm_scene_run_opts sm_scene_run_opts_default(void);

/* Runs the built scene sc (its world at t = 0, else SM_ERR_INVALID) into o->out: frames 0..frames. Returns SM_OK, or
 * the failure's status with its message in err (a claim refused, a sink's or the world's failure,
 * a motion function's error); *frames_written: frames 0..*frames_written - 1 are complete;
 * *stopped: 1 if on_frame stopped the run. */
sm_status sm_scene_run(sm_scene *sc, const sm_scene_run_opts *o, int *frames_written, int *stopped, char *err,
                       size_t errlen);

#endif
