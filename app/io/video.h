/* A run's PNG frames (frame_NNNN.png) to an H.264 video (video.mp4) with ffmpeg, if installed. */
#ifndef SM_APP_IO_VIDEO_H
#define SM_APP_IO_VIDEO_H

#include <stddef.h>

#include "sandmpm/sandmpm.h"

/* Makes dir/video.mp4 from dir/frame_%04d.png at fps frames per second. SM_OK, or SM_ERR_IO with
 * a message (ffmpeg missing, or failed). */
sm_status sm_video_make(const char *dir, double fps, char *err, size_t errlen);

#endif
