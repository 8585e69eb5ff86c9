/* Files as the app opens, writes and closes them: every write and close is checked, and a failure
 * comes back as SM_ERR_IO with "PATH: reason" (or SM_ERR_INVALID for a path that cannot be one).
 *
 * Atomic files (frames, frames.pvd, render.txt, PNG): written under a temporary name in the same
 * folder, ".NAME.tmp.PID" (hidden, and naming the process that writes it), and renamed over NAME
 * only when every byte was written and the file closed without error; on any error the temporary
 * is removed. So a file under its final name is always whole. The temporaries open at a moment are
 * known, so a signal handler can remove them (sm_remove_open_temporaries); those of a process that
 * was killed (SIGKILL, a crash) are removed by the next run in the folder
 * (sm_remove_stale_temporaries).
 *
 * Streams (diagnostics.csv, poses.csv): appended a record at a time; a record is written whole or
 * not at all (on a failed write the file is cut back to the records before it).
 *
 * Test hook: the environment variable SANDMPM_FAULT_WRITE_BYTES=N makes the program behave as on a
 * disk with N bytes free: all atomic files and streams together may write N bytes, then writes
 * fail with ENOSPC ("No space left on device"). */
#ifndef SM_APP_IO_FILES_H
#define SM_APP_IO_FILES_H

#include <stdio.h>
#include <sys/types.h>

#include "sandmpm/sandmpm.h"

#define SM_PATH_MAX 4096              /* bytes of a path, the terminating NUL included */
#define SM_MSG_MAX (SM_PATH_MAX + 512) /* a message that holds a path and its reason */
#define SM_NAME_RESERVE 64            /* the longest name written into an output folder, "/" and
                                         temporary suffix included (".frame_10000000.png.tmp.PID") */

/* ------------------------------------------------------------------------------------------ */
/* Folders                                                                                      */

/* SM_OK, or SM_ERR_INVALID if a folder's name is empty or too long for the names of the files
 * written into it (SM_PATH_MAX - SM_NAME_RESERVE bytes). */
sm_status sm_check_folder_name(const char *dir, char *err, size_t errlen);

/* Creates dir and its parents as needed (mkdir -p) and checks that it is a folder. SM_OK;
 * SM_ERR_INVALID as sm_check_folder_name; SM_ERR_IO naming the part that could not be created. */
sm_status sm_make_dirs(const char *dir, char *err, size_t errlen);

/* ------------------------------------------------------------------------------------------ */
/* Atomic files                                                                                 */

typedef struct sm_atomic_file {
    FILE *f;                /* the temporary, open for binary writing; NULL once committed or aborted */
    char path[SM_PATH_MAX]; /* the final name */
    char tmp[SM_PATH_MAX];  /* the temporary's name */
    int slot;               /* its entry among the open temporaries */
    void *cookie;           /* the checked writer behind f */
} sm_atomic_file;

/* Creates the temporary of path. SM_OK, or SM_ERR_IO with "PATH: reason" in err. */
sm_status sm_atomic_open(sm_atomic_file *a, const char *path, char *err, size_t errlen);

/* Flushes and closes the temporary and renames it to the final name. On any write, close or
 * rename error the temporary is removed and SM_ERR_IO returned with the path and the reason. */
sm_status sm_atomic_commit(sm_atomic_file *a, char *err, size_t errlen);

/* Closes and removes the temporary (a failed write). Accepts an aborted or committed file. */
void sm_atomic_abort(sm_atomic_file *a);

/* The errno of the first failed write to an open atomic file, or 0. */
int sm_atomic_error(const sm_atomic_file *a);

/* The temporary's name for final path (".NAME.tmp.PID" beside it). 0, or -1 if it does not fit. */
int sm_temp_name(char *buf, size_t len, const char *path, long pid);

/* Registers / forgets a temporary made by someone else (e.g. ffmpeg's output), so that a signal
 * handler removes it too. sm_track_temporary returns a slot (or -1 if all are taken). */
int sm_track_temporary(const char *tmp);
void sm_untrack_temporary(int slot);

/* Removes the temporaries open right now. Async-signal-safe: for a signal handler. */
void sm_remove_open_temporaries(void);

/* Removes from dir the temporaries of the files sandmpm writes (frame_N.ply/.vtp/.png, frames.pvd,
 * render.txt, video.mp4, run_manifest.txt) left by a process that no longer runs, and the "NAME.tmp" of older
 * versions. *removed: how many; first: the first one's name. SM_OK or SM_ERR_IO. */
sm_status sm_remove_stale_temporaries(const char *dir, int *removed, char *first, size_t firstlen, char *err,
                                      size_t errlen);

/* ------------------------------------------------------------------------------------------ */
/* Streams                                                                                      */

typedef struct sm_stream {
    int fd;                 /* -1 when closed */
    off_t good;             /* bytes of whole records */
    char path[SM_PATH_MAX];
} sm_stream;

/* Creates (or empties) path. SM_OK or SM_ERR_IO with the path and the reason. */
sm_status sm_stream_open(sm_stream *s, const char *path, char *err, size_t errlen);

/* Appends n bytes, all or nothing: on a failure the file is cut back to its previous length and
 * SM_ERR_IO returned with the path and the reason. */
sm_status sm_stream_append(sm_stream *s, const char *buf, size_t n, char *err, size_t errlen);

/* Closes the stream (accepts a closed one); with remove, also removes the file (a stream that holds
 * nothing worth keeping). SM_OK or SM_ERR_IO. */
sm_status sm_stream_close(sm_stream *s, int remove, char *err, size_t errlen);

/* ------------------------------------------------------------------------------------------ */
/* Reading                                                                                      */

/* Opens path for reading (binary); NULL with "PATH: cannot open: reason" in err. */
FILE *sm_open_read(const char *path, char *err, size_t errlen);

#endif
