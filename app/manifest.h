/* The run manifest: what `sandmpm render OUTDIR` needs to draw a run's frames without the scene
 * file. `sandmpm run` writes OUTDIR/render.txt once (dimension, domain, camera, collider shapes)
 * and appends the colliders' poses of every frame to OUTDIR/poses.csv. Plain text, one record a
 * line, so it can be read by people and other tools. */
#ifndef SM_APP_MANIFEST_H
#define SM_APP_MANIFEST_H

#include <stdio.h>

#include "sandmpm/sandmpm.h"

typedef struct sm_manifest {
    int dim;
    double domain_min[3], domain_max[3];
    int has_camera;
    double eye[3], target[3], up[3], fov;
    int ncolliders;
    sm_collider_def *colliders; /* ncolliders; poses from the definition (frame 0) */
    int nframes;                /* frames with poses */
    sm_pose *poses;             /* nframes * ncolliders */
} sm_manifest;

/* Writes render.txt (atomically) for a built world and camera (has_camera 0: none). SM_OK or
 * SM_ERR_IO with a message. */
sm_status sm_manifest_write(const char *path, const sm_world *w, int has_camera, const double eye[3],
                            const double target[3], const double up[3], double fov, char *err, size_t errlen);
#define SM_POSE_LINE_MAX 256 /* bytes of a poses.csv line, with room to spare */

/* The "frame,collider,px,py,pz,qw,qx,qy,qz" lines of every collider of w at a frame, into buf
 * (len >= sm_world_collider_count * SM_POSE_LINE_MAX). Returns their length. */
size_t sm_manifest_poses(char *buf, size_t len, int frame, const sm_world *w);
/* Reads OUTDIR/render.txt and OUTDIR/poses.csv (poses optional). SM_OK, SM_ERR_IO (no
 * render.txt), SM_ERR_INVALID (malformed) or SM_ERR_NOMEM, with a message. */
sm_status sm_manifest_read(const char *dir, sm_manifest *m, char *err, size_t errlen);
/* Colliders' poses at a frame (the last frame with poses, or the definitions' poses). */
const sm_pose *sm_manifest_frame_poses(const sm_manifest *m, int frame, sm_pose *scratch);
void sm_manifest_free(sm_manifest *m);

#endif
