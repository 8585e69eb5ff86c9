/* Files as the app opens, writes and closes them.
 *
 * Atomic output files: a file is written under a temporary name in its folder and renamed over
 * its final name only when every byte of it was written and the file closed without error, so
 * that a reader never sees half a file under the final name. */
#ifndef SM_APP_IO_FILES_H
#define SM_APP_IO_FILES_H

#include <stdio.h>

#include "sandmpm/sandmpm.h"

#define SM_PATH_MAX 4096 /* bytes of a path, the terminating NUL included */

typedef struct sm_atomic_file {
    FILE *f;                /* the temporary, open for binary writing; NULL once committed or aborted */
    char path[SM_PATH_MAX]; /* the final name */
    char tmp[SM_PATH_MAX];  /* the temporary's name */
} sm_atomic_file;

/* Creates the temporary of path. Returns SM_OK, or SM_ERR_IO with "PATH: reason" in err. */
sm_status sm_atomic_open(sm_atomic_file *a, const char *path, char *err, size_t errlen);

/* Closes the temporary and renames it to the final name. On any write, close or rename error the
 * temporary is removed and SM_ERR_IO returned with the path and the reason. */
sm_status sm_atomic_commit(sm_atomic_file *a, char *err, size_t errlen);

/* Closes and removes the temporary (a failed write). Accepts an aborted or committed file. */
void sm_atomic_abort(sm_atomic_file *a);

/* Opens path for reading (binary); NULL with "PATH: cannot open: reason" in err. */
FILE *sm_open_read(const char *path, char *err, size_t errlen);

#endif
