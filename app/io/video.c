/* Video through ffmpeg; see video.h. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>

#include "app/io/video.h"

static int has_ffmpeg(void) { return system("command -v ffmpeg >/dev/null 2>&1") == 0; }

sm_status sm_video_make(const char *dir, double fps, char *err, size_t errlen) {
    if (!has_ffmpeg()) {
        snprintf(err, errlen, "--video: ffmpeg is not installed (Debian: apt-get install ffmpeg); the PNG frames are in %s/",
                 dir);
        return SM_ERR_IO;
    }
    char cmd[8192];
    snprintf(cmd, sizeof cmd,
             "ffmpeg -loglevel error -y -framerate %g -i '%s/frame_%%04d.png' -c:v libx264 -pix_fmt yuv420p "
             "-vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' '%s/video.mp4'",
             fps, dir, dir);
    int r = system(cmd);
    if (r != 0) {
        snprintf(err, errlen, "ffmpeg failed (status %d) making %s/video.mp4", r, dir);
        return SM_ERR_IO;
    }
    return SM_OK;
}
