/* Rendering a run's frames to PNG files: the render options come from the run's manifest
 * (OUTDIR/render.txt and poses.csv: domain, camera, colliders and their poses per frame), so that
 * `sandmpm render OUTDIR` and `sandmpm run --render` draw the same pictures. */
#ifndef SM_APP_RENDER_JOB_H
#define SM_APP_RENDER_JOB_H

#include <stddef.h>
#include <stdint.h>

#include "app/manifest.h"
#include "app/render.h"

typedef struct sm_render_job {
    sm_render_opts o;
    sm_manifest m;
    int have_manifest; /* 0: no render.txt in the folder (the renderer's defaults then) */
    uint8_t *rgb;      /* o.width x o.height x 3 */
    sm_pose *poses;    /* scratch for the colliders' poses of a frame */
} sm_render_job;

/* Sets up rendering for run folder dir at width x height with a colour mode and threads (0 =
 * OpenMP's default). A missing manifest is allowed; a malformed one is SM_ERR_INVALID. SM_OK or a
 * status with a message; sm_render_job_close in either case. */
sm_status sm_render_job_open(sm_render_job *j, const char *dir, int width, int height, sm_color_mode color,
                             int threads, char *err, size_t errlen);

/* Renders frame number `frame` into the PNG file png, the colliders at their poses of that frame
 * in the manifest; frame -1: at the poses in j->poses (the caller's, e.g. a world's now). */
sm_status sm_render_job_frame(sm_render_job *j, const sm_frame *fr, int frame, const char *png, char *err,
                              size_t errlen);

void sm_render_job_close(sm_render_job *j);

#endif
