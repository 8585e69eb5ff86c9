/* Video through ffmpeg; see video.h. ffmpeg is started with an argument vector (app/io/spawn.h),
 * never through a shell. The folder is passed as an absolute path (so that no name is read as an
 * option, "-x", or a protocol, "x:"), with '%' doubled in the input pattern (ffmpeg's image
 * sequence expands %04d). The video is written to a temporary and renamed when ffmpeg succeeded. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/io/files.h"
#include "app/io/spawn.h"
#include "app/io/video.h"

/* dir/frame_%04d.png with dir's '%' doubled. 0, or -1 if it does not fit. */
static int input_pattern(char *buf, size_t len, const char *dir) {
    size_t k = 0;
    for (const char *p = dir; *p; p++) {
        if (k + 2 >= len) return -1;
        if (*p == '%') buf[k++] = '%';
        buf[k++] = *p;
    }
    int m = snprintf(buf + k, len - k, "/frame_%%04d.png");
    return m < 0 || (size_t)m >= len - k ? -1 : 0;
}

/* ffmpeg from the PNG frames to tmp. */
static sm_status run_ffmpeg(const char *dir, const char *input, const char *tmp, double fps, char *err, size_t errlen) {
    char rate[32];
    snprintf(rate, sizeof rate, "%.17g", fps);
    char *argv[] = {"ffmpeg", "-nostdin", "-loglevel", "error", "-y", "-framerate", rate, "-i", (char *)input,
                    "-c:v", "libx264", "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-f", "mp4",
                    (char *)tmp, NULL};
    sm_child c;
    int missing = 0;
    if (sm_spawn(argv, 0, &c, &missing, err, errlen) != SM_OK) {
        if (missing)
            snprintf(err, errlen, "--video: ffmpeg is not installed (Debian: apt-get install ffmpeg); the PNG frames are in %s/",
                     dir);
        return SM_ERR_IO;
    }
    int code, sig;
    if (sm_child_wait(&c, &code, &sig) != 0) {
        if (sig) snprintf(err, errlen, "ffmpeg was stopped by signal %d making %s/video.mp4", sig, dir);
        else snprintf(err, errlen, "ffmpeg failed (exit status %d) making %s/video.mp4; the PNG frames are in %s/", code, dir, dir);
        return SM_ERR_IO;
    }
    return SM_OK;
}

sm_status sm_video_make(const char *dir, double fps, char *err, size_t errlen) {
    char abs[PATH_MAX], input[SM_PATH_MAX], final[SM_PATH_MAX], tmp[SM_PATH_MAX];
    if (!realpath(dir, abs)) {
        snprintf(err, errlen, "%s: %s", dir, strerror(errno));
        return SM_ERR_IO;
    }
    if (input_pattern(input, sizeof input, abs) != 0 ||
        (size_t)snprintf(final, sizeof final, "%s/video.mp4", abs) >= sizeof final ||
        sm_temp_name(tmp, sizeof tmp, final, (long)getpid()) != 0) {
        snprintf(err, errlen, "%s/video.mp4: path too long", dir);
        return SM_ERR_INVALID;
    }
    int slot = sm_track_temporary(tmp);
    sm_status st = run_ffmpeg(dir, input, tmp, fps, err, errlen);
    if (st == SM_OK && rename(tmp, final) != 0) {
        snprintf(err, errlen, "%s/video.mp4: %s", dir, strerror(errno));
        st = SM_ERR_IO;
    }
    if (st != SM_OK) unlink(tmp);
    sm_untrack_temporary(slot);
    return st;
}
