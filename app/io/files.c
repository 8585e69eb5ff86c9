/* Files; see files.h. */
#define _GNU_SOURCE /* fopencookie: the atomic files' FILE over our own checked writes */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "app/io/files.h"

/* ------------------------------------------------------------------------------------------ */
/* Writing bytes: the one place every output byte passes, with the test hook's budget          */

static long long fault_budget = -2; /* -2: not read yet; -1: no hook; else bytes left */

static long long budget_left(void) {
    if (fault_budget == -2) {
        const char *s = getenv("SANDMPM_FAULT_WRITE_BYTES");
        char *end;
        long long v = s && *s ? strtoll(s, &end, 10) : -1;
        fault_budget = (s && *s && !*end && v >= 0) ? v : -1;
    }
    return fault_budget;
}

/* write(2) of all n bytes (retrying short writes and EINTR). -1 with errno on failure (some
 * bytes may have been written). */
static int write_all(int fd, const char *buf, size_t n) {
    while (n > 0) {
        size_t chunk = n;
        long long left = budget_left();
        if (left >= 0 && (long long)chunk > left) chunk = (size_t)left;
        if (chunk == 0) {
            errno = ENOSPC;
            return -1;
        }
        ssize_t w = write(fd, buf, chunk);
        if (w < 0) {
            if (errno == EINTR) continue;
            return -1;
        }
        if (left >= 0) fault_budget -= w;
        buf += w;
        n -= (size_t)w;
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Folders                                                                                      */

/* mkdir of the prefix dir[0..n) (n < SM_PATH_MAX). 0, or -1 with errno. */
static int mkdir_prefix(const char *dir, size_t n) {
    char buf[SM_PATH_MAX];
    memcpy(buf, dir, n);
    buf[n] = 0;
    if (mkdir(buf, 0777) == 0 || errno == EEXIST) return 0;
    return -1;
}

sm_status sm_check_folder_name(const char *dir, char *err, size_t errlen) {
    const size_t n = strlen(dir);
    if (n == 0) {
        snprintf(err, errlen, "the output folder's name is empty");
        return SM_ERR_INVALID;
    }
    if (n + SM_NAME_RESERVE >= SM_PATH_MAX) {
        snprintf(err, errlen, "the output folder's path is %zu bytes long; with the names of the files written into it, "
                              "it must be under %d bytes (\"%.60s...\")",
                 n, SM_PATH_MAX - SM_NAME_RESERVE, dir);
        return SM_ERR_INVALID;
    }
    return SM_OK;
}

sm_status sm_make_dirs(const char *dir, char *err, size_t errlen) {
    const size_t n = strlen(dir);
    sm_status named = sm_check_folder_name(dir, err, errlen);
    if (named != SM_OK) return named;
    for (size_t i = 1; i <= n; i++) {
        if (dir[i] != '/' && dir[i] != 0) continue;
        if (dir[i - 1] == '/') continue; /* "a//b" */
        if (mkdir_prefix(dir, i) != 0) {
            snprintf(err, errlen, "cannot create the folder %.*s: %s", (int)i, dir, strerror(errno));
            return SM_ERR_IO;
        }
    }
    struct stat st;
    if (stat(dir, &st) != 0) {
        snprintf(err, errlen, "%s: %s", dir, strerror(errno));
        return SM_ERR_IO;
    }
    if (!S_ISDIR(st.st_mode)) {
        snprintf(err, errlen, "%s exists and is not a folder", dir);
        return SM_ERR_IO;
    }
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* The open temporaries, for a signal handler                                                   */

#define TEMP_SLOTS 8
static struct {
    volatile sig_atomic_t used;
    char path[SM_PATH_MAX];
} temps[TEMP_SLOTS];

int sm_track_temporary(const char *tmp) {
    for (int i = 0; i < TEMP_SLOTS; i++) {
        if (temps[i].used) continue;
        snprintf(temps[i].path, sizeof temps[i].path, "%s", tmp);
        atomic_signal_fence(memory_order_seq_cst); /* the name before the flag */
        temps[i].used = 1;
        return i;
    }
    return -1;
}

void sm_untrack_temporary(int slot) {
    if (slot >= 0 && slot < TEMP_SLOTS) temps[slot].used = 0;
}

void sm_remove_open_temporaries(void) {
    for (int i = 0; i < TEMP_SLOTS; i++)
        if (temps[i].used) unlink(temps[i].path);
}

int sm_temp_name(char *buf, size_t len, const char *path, long pid) {
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    int dirlen = slash ? (int)(slash - path + 1) : 0;
    int k = snprintf(buf, len, "%.*s.%s.tmp.%ld", dirlen, path, name, pid);
    return k < 0 || (size_t)k >= len ? -1 : 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Atomic files                                                                                 */

/* The FILE of an atomic file writes through write_all and keeps the first error. */
typedef struct cookie {
    int fd;
    int error; /* errno of the first failed write, or 0 */
} cookie;

static ssize_t cookie_write(void *c, const char *buf, size_t n) {
    cookie *k = c;
    if (k->error) {
        errno = k->error;
        return -1;
    }
    if (write_all(k->fd, buf, n) != 0) {
        k->error = errno;
        return -1;
    }
    return (ssize_t)n;
}

static int cookie_close(void *c) {
    cookie *k = c;
    int r = close(k->fd);
    int e = errno;
    if (r != 0 && !k->error) k->error = e;
    return r;
}

sm_status sm_atomic_open(sm_atomic_file *a, const char *path, char *err, size_t errlen) {
    a->f = NULL;
    a->tmp[0] = 0;
    a->slot = -1;
    a->cookie = NULL;
    if (snprintf(a->path, sizeof a->path, "%s", path) >= (int)sizeof a->path ||
        sm_temp_name(a->tmp, sizeof a->tmp, path, (long)getpid()) != 0) {
        a->tmp[0] = 0;
        snprintf(err, errlen, "%.200s...: path too long (at most %d bytes)", path, SM_PATH_MAX - 1);
        return SM_ERR_INVALID;
    }
    a->slot = sm_track_temporary(a->tmp);
    cookie *k = malloc(sizeof *k);
    int fd = k ? open(a->tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666) : -1;
    if (fd >= 0) {
        k->fd = fd;
        k->error = 0;
        cookie_io_functions_t io = {NULL, cookie_write, NULL, cookie_close};
        a->f = fopencookie(k, "wb", io);
    }
    if (!a->f) {
        int e = k ? errno : ENOMEM;
        if (fd >= 0) {
            close(fd);
            unlink(a->tmp);
        }
        free(k);
        sm_untrack_temporary(a->slot);
        snprintf(err, errlen, "cannot create %s: %s", path, strerror(e));
        a->tmp[0] = 0;
        return SM_ERR_IO;
    }
    a->cookie = k;
    return SM_OK;
}

sm_status sm_atomic_commit(sm_atomic_file *a, char *err, size_t errlen) {
    cookie *k = a->cookie;
    int e = 0;
    if (fflush(a->f) != 0 || ferror(a->f)) e = k->error ? k->error : EIO;
    if (fclose(a->f) != 0 && !e) e = k->error ? k->error : EIO;
    free(k);
    a->f = NULL;
    a->cookie = NULL;
    if (!e && rename(a->tmp, a->path) != 0) e = errno;
    if (e) {
        unlink(a->tmp);
        snprintf(err, errlen, "%s: %s", a->path, strerror(e));
    }
    sm_untrack_temporary(a->slot);
    a->tmp[0] = 0;
    return e ? SM_ERR_IO : SM_OK;
}

int sm_atomic_error(const sm_atomic_file *a) { return a->cookie ? ((const cookie *)a->cookie)->error : 0; }

void sm_atomic_abort(sm_atomic_file *a) {
    if (a->f) {
        cookie *k = a->cookie;
        fclose(a->f);
        free(k);
    }
    a->f = NULL;
    a->cookie = NULL;
    if (a->tmp[0]) unlink(a->tmp);
    sm_untrack_temporary(a->slot);
    a->tmp[0] = 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Stale temporaries                                                                            */

/* 1 if name (without the temporary's dot and suffix) is a file sandmpm writes atomically. */
static int is_our_file(const char *name, size_t n) {
    static const char *const fixed[] = {"frames.pvd", "render.txt", "video.mp4", "run_manifest.txt"};
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        if (n == strlen(fixed[i]) && !memcmp(name, fixed[i], n)) return 1;
    if (n == 17 && !memcmp(name, "ckpt_", 5) && !memcmp(name + 13, ".smc", 4)) { /* ckpt_NNNNNNNN.smc */
        for (size_t i = 5; i < 13; i++)
            if (name[i] < '0' || name[i] > '9') return 0;
        return 1;
    }
    if (n < 14 || memcmp(name, "frame_", 6) != 0) return 0; /* frame_NNNN.ext */
    size_t d = 6;
    while (d < n && name[d] >= '0' && name[d] <= '9') d++;
    if (d - 6 < 4 || n - d != 4) return 0;
    return !memcmp(name + d, ".ply", 4) || !memcmp(name + d, ".vtp", 4) || !memcmp(name + d, ".png", 4);
}

/* 1 if entry e of a folder is a temporary of ours that no running process owns. */
static int is_stale(const char *e) {
    size_t n = strlen(e);
    const char *dot = NULL;
    if (n > 4 && !strcmp(e + n - 4, ".tmp")) return is_our_file(e, n - 4); /* an older version's */
    if (e[0] != '.') return 0;
    for (const char *p = e + n; p > e; p--)
        if (p[-1] == '.') {
            dot = p - 1; /* ".tmp.PID" starts 4 before it */
            break;
        }
    if (!dot || dot - e < 5 || memcmp(dot - 4, ".tmp", 4) != 0 || !dot[1]) return 0;
    char *end;
    long pid = strtol(dot + 1, &end, 10);
    if (*end || pid <= 0) return 0;
    if (!is_our_file(e + 1, (size_t)(dot - 4 - (e + 1)))) return 0;
    if (pid == (long)getpid()) return 0;
    return kill((pid_t)pid, 0) != 0 && errno == ESRCH;
}

sm_status sm_remove_stale_temporaries(const char *dir, int *removed, char *first, size_t firstlen, char *err,
                                      size_t errlen) {
    *removed = 0;
    if (firstlen) first[0] = 0;
    DIR *d = opendir(dir);
    if (!d) {
        snprintf(err, errlen, "%s: %s", dir, strerror(errno));
        return SM_ERR_IO;
    }
    struct dirent *de;
    char path[SM_PATH_MAX];
    sm_status st = SM_OK;
    while ((de = readdir(d)) && st == SM_OK) {
        if (!is_stale(de->d_name)) continue;
        if ((size_t)snprintf(path, sizeof path, "%s/%s", dir, de->d_name) >= sizeof path) continue;
        if (unlink(path) != 0 && errno != ENOENT) {
            snprintf(err, errlen, "cannot remove the stale temporary %s: %s", path, strerror(errno));
            st = SM_ERR_IO;
            break;
        }
        if (++*removed == 1 && firstlen) snprintf(first, firstlen, "%s", de->d_name);
    }
    closedir(d);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Streams                                                                                      */

sm_status sm_stream_open(sm_stream *s, const char *path, char *err, size_t errlen) {
    s->good = 0;
    if (snprintf(s->path, sizeof s->path, "%s", path) >= (int)sizeof s->path) {
        s->fd = -1;
        snprintf(err, errlen, "%.200s...: path too long (at most %d bytes)", path, SM_PATH_MAX - 1);
        return SM_ERR_INVALID;
    }
    s->fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (s->fd < 0) {
        snprintf(err, errlen, "cannot create %s: %s", path, strerror(errno));
        return SM_ERR_IO;
    }
    return SM_OK;
}

sm_status sm_stream_append(sm_stream *s, const char *buf, size_t n, char *err, size_t errlen) {
    if (write_all(s->fd, buf, n) == 0) {
        s->good += (off_t)n;
        return SM_OK;
    }
    int e = errno;
    /* Cut a partly written record off (and put the offset back where the next one goes). */
    if (ftruncate(s->fd, s->good) != 0 || lseek(s->fd, s->good, SEEK_SET) < 0) {
        snprintf(err, errlen, "%s: %s (and it could not be cut back to its last whole line: %s)", s->path, strerror(e),
                 strerror(errno));
        return SM_ERR_IO;
    }
    snprintf(err, errlen, "%s: %s", s->path, strerror(e));
    return SM_ERR_IO;
}

sm_status sm_stream_close(sm_stream *s, int remove, char *err, size_t errlen) {
    if (s->fd < 0) return SM_OK;
    int r = close(s->fd);
    s->fd = -1;
    if (remove) unlink(s->path);
    if (r != 0) {
        snprintf(err, errlen, "%s: %s", s->path, strerror(errno));
        return SM_ERR_IO;
    }
    return SM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Reading                                                                                      */

FILE *sm_open_read(const char *path, char *err, size_t errlen) {
    FILE *f = fopen(path, "rb");
    if (!f) snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
    return f;
}
