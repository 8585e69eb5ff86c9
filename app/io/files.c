/* Files; see files.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <string.h>

#include "app/io/files.h"

sm_status sm_atomic_open(sm_atomic_file *a, const char *path, char *err, size_t errlen) {
    a->f = NULL;
    a->tmp[0] = 0;
    if (snprintf(a->path, sizeof a->path, "%s", path) >= (int)sizeof a->path ||
        snprintf(a->tmp, sizeof a->tmp, "%s.tmp", path) >= (int)sizeof a->tmp) {
        a->tmp[0] = 0;
        snprintf(err, errlen, "%s: path too long", path);
        return SM_ERR_IO;
    }
    a->f = fopen(a->tmp, "wb");
    if (!a->f) {
        snprintf(err, errlen, "%s: %s", a->tmp, strerror(errno));
        a->tmp[0] = 0;
        return SM_ERR_IO;
    }
    return SM_OK;
}

sm_status sm_atomic_commit(sm_atomic_file *a, char *err, size_t errlen) {
    errno = 0;
    int ok = !ferror(a->f);
    int e = ok ? 0 : (errno ? errno : EIO);
    if (fclose(a->f) != 0 && ok) {
        ok = 0;
        e = errno;
    }
    a->f = NULL;
    if (ok && rename(a->tmp, a->path) != 0) {
        ok = 0;
        e = errno;
    }
    if (!ok) {
        snprintf(err, errlen, "%s: %s", a->path, strerror(e ? e : EIO));
        remove(a->tmp);
    }
    a->tmp[0] = 0;
    return ok ? SM_OK : SM_ERR_IO;
}

void sm_atomic_abort(sm_atomic_file *a) {
    if (a->f) fclose(a->f);
    a->f = NULL;
    if (a->tmp[0]) remove(a->tmp);
    a->tmp[0] = 0;
}

FILE *sm_open_read(const char *path, char *err, size_t errlen) {
    FILE *f = fopen(path, "rb");
    if (!f) snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
    return f;
}
