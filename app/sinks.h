/* The output sinks of a run (app/run.h), one per kind of file, each in the run's folder:
 *   ply       frame_NNNN.ply per frame (app/io/ply.h)
 *   vtk       frame_NNNN.vtp per frame and frames.pvd listing them (app/io/vtk.h)
 *   manifest  render.txt at the start, the colliders' poses of every frame in poses.csv
 *             (app/manifest.h)
 *   png       frame_NNNN.png per frame, rendered as `sandmpm render` would (app/render_job.h),
 *             the colliders at the world's poses of the frame; it reads render.txt, so it comes
 *             after the manifest sink
 *   csv       diagnostics.csv, a row per frame (app/io/csv.h)
 * The run manifest (run_manifest.txt) has its sink beside its format, app/run_manifest.h; it comes
 * after these, as it lists what they wrote.
 * Frame files are written atomically, the two CSV files a whole line at a time (app/io/files.h); a
 * failed run removes a CSV file that got no frame's line. */
#ifndef SM_APP_SINKS_H
#define SM_APP_SINKS_H

#include "app/render.h"
#include "app/run.h"

/* The camera of the render manifest. */
typedef struct sm_manifest_camera {
    int has_camera; /* 0: none (the renderer fits one) */
    double eye[3], target[3], up[3], fov;
} sm_manifest_camera;

/* The PNG sink's image. */
typedef struct sm_png_sink_config {
    int width, height;
    sm_color_mode color;
    int threads; /* 0 = OpenMP's default */
} sm_png_sink_config;

/* Frames as PLY / VTK (.vtp and frames.pvd); *z_up (NULL: 0): written z-up (app/io/fields.h). */
sm_sink sm_sink_ply(const int *z_up);
sm_sink sm_sink_vtk(const int *z_up);
sm_sink sm_sink_manifest(const sm_manifest_camera *camera);
sm_sink sm_sink_png(const sm_png_sink_config *config);
sm_sink sm_sink_csv(void);

#endif
