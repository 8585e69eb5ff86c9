/* The run manifest; see run_manifest.h. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/io/files.h"
#include "app/run_manifest.h"

static const char *const kind_ext[SM_FRAME_KINDS] = {"ply", "vtp", "png"};
static const char *const runfile_names[SM_RUNFILE_COUNT] = {"frames.pvd", "diagnostics.csv", "render.txt",
                                                            "poses.csv",  "video.mp4",       "checkpoints"};

const char *sm_frame_kind_ext(sm_frame_kind k) { return k < SM_FRAME_KINDS ? kind_ext[k] : "?"; }

const char *sm_runfile_name(unsigned bit) {
    for (int b = 0; b < SM_RUNFILE_COUNT; b++)
        if (bit == 1u << b) return runfile_names[b];
    return "?";
}

void sm_run_manifest_init(sm_run_manifest *m) {
    memset(m, 0, sizeof *m);
    snprintf(m->state, sizeof m->state, "running");
    for (int k = 0; k < SM_FRAME_KINDS; k++) m->first[k] = 0, m->last[k] = -1;
}

int sm_run_manifest_count(const sm_run_manifest *m, sm_frame_kind k) {
    return m->last[k] >= m->first[k] ? m->last[k] - m->first[k] + 1 : 0;
}

/* dir/name into buf; SM_ERR_IO if it does not fit. */
static sm_status join(char *buf, size_t len, const char *dir, const char *name, char *err, size_t errlen) {
    if ((size_t)snprintf(buf, len, "%s/%s", dir, name) < len) return SM_OK;
    snprintf(err, errlen, "%s/%s: path too long", dir, name);
    return SM_ERR_IO;
}

/* ------------------------------------------------------------------------------------------ */
/* Writing and reading                                                                          */

sm_status sm_run_manifest_write(const char *dir, const sm_run_manifest *m, char *err, size_t errlen) {
    char path[SM_PATH_MAX], scene[sizeof m->scene];
    sm_status st = join(path, sizeof path, dir, SM_RUN_MANIFEST_NAME, err, errlen);
    sm_atomic_file a;
    if (st == SM_OK) st = sm_atomic_open(&a, path, err, errlen);
    if (st != SM_OK) return st;
    size_t n = 0;
    for (; m->scene[n]; n++) scene[n] = (unsigned char)m->scene[n] < 32 ? '?' : m->scene[n]; /* one line */
    scene[n] = 0;
    fprintf(a.f, "sandmpm-run 1\nversion %s\nscene %s\nscene_hash %016llx\nquality %s\nfps %.17g\nframes %d\nstate %s\n",
            sm_version(), scene, (unsigned long long)m->scene_hash, m->quality, m->fps, m->frames, m->state);
    for (int k = 0; k < SM_FRAME_KINDS; k++)
        if (sm_run_manifest_count(m, (sm_frame_kind)k) > 0)
            fprintf(a.f, "frame_files %s %d %d\n", kind_ext[k], m->first[k], m->last[k]);
    for (int b = 0; b < SM_RUNFILE_COUNT; b++)
        if (m->files & (1u << b)) fprintf(a.f, "file %s\n", runfile_names[b]);
    if (m->ranks > 1) {
        fprintf(a.f, "ranks %d\n", m->ranks);
        if (m->threads > 0) fprintf(a.f, "threads_per_rank %d\n", m->threads);
        else fprintf(a.f, "threads_per_rank auto\n");
        fprintf(a.f, "rank_particles");
        for (int r = 0; r < m->ranks && m->rank_particles; r++) fprintf(a.f, " %llu", m->rank_particles[r]);
        fprintf(a.f, "\n");
    }
    return sm_atomic_commit(&a, err, errlen);
}

/* One "KEY VALUE" line into m; 0 if malformed. */
static int parse_line(char *line, sm_run_manifest *m) {
    char *sp = strchr(line, ' ');
    if (!sp) return 0;
    *sp = 0;
    const char *key = line, *val = sp + 1;
    unsigned long long h;
    char ext[8];
    int a, b;
    if (!strcmp(key, "scene")) snprintf(m->scene, sizeof m->scene, "%s", val);
    else if (!strcmp(key, "scene_hash")) {
        if (sscanf(val, "%16llx", &h) != 1) return 0;
        m->scene_hash = h;
    } else if (!strcmp(key, "quality")) snprintf(m->quality, sizeof m->quality, "%s", val);
    else if (!strcmp(key, "fps")) return sscanf(val, "%lf", &m->fps) == 1;
    else if (!strcmp(key, "frames")) return sscanf(val, "%d", &m->frames) == 1;
    else if (!strcmp(key, "state")) snprintf(m->state, sizeof m->state, "%s", val);
    else if (!strcmp(key, "frame_files")) {
        if (sscanf(val, "%7s %d %d", ext, &a, &b) != 3 || a < 0 || b < a) return 0;
        for (int k = 0; k < SM_FRAME_KINDS; k++)
            if (!strcmp(ext, kind_ext[k])) m->first[k] = a, m->last[k] = b;
    } else if (!strcmp(key, "file")) {
        for (int k = 0; k < SM_RUNFILE_COUNT; k++)
            if (!strcmp(val, runfile_names[k])) m->files |= 1u << k;
    }
    return 1; /* sandmpm-run, version and unknown keys: skipped */
}

sm_status sm_run_manifest_read(const char *dir, sm_run_manifest *m, int *found, char *err, size_t errlen) {
    char path[SM_PATH_MAX], line[2048];
    sm_run_manifest_init(m);
    m->state[0] = 0;
    *found = 0;
    sm_status st = join(path, sizeof path, dir, SM_RUN_MANIFEST_NAME, err, errlen);
    if (st != SM_OK) return st;
    FILE *f = fopen(path, "r");
    if (!f) {
        *found = errno != ENOENT;
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        return SM_ERR_IO;
    }
    *found = 1;
    int lineno = 0;
    while (st == SM_OK && fgets(line, sizeof line, f)) {
        lineno++;
        line[strcspn(line, "\r\n")] = 0;
        if (lineno == 1 && strcmp(line, "sandmpm-run 1") != 0) {
            snprintf(err, errlen, "%s:1: not a sandmpm run manifest (expected \"sandmpm-run 1\")", path);
            st = SM_ERR_INVALID;
        } else if (line[0] && !parse_line(line, m)) {
            snprintf(err, errlen, "%s:%d: malformed line", path, lineno);
            st = SM_ERR_INVALID;
        }
    }
    if (st == SM_OK && lineno == 0) {
        snprintf(err, errlen, "%s: empty", path);
        st = SM_ERR_INVALID;
    }
    fclose(f);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* A folder without a manifest, and removal                                                     */

/* The frame number and kind of a name "frame_NNNN.EXT" (at least 4 digits); -1 if not one. */
static int frame_name(const char *name, sm_frame_kind *kind) {
    size_t n = strlen(name), d = 6;
    if (n < 14 || strncmp(name, "frame_", 6) != 0 || name[n - 4] != '.') return -1;
    while (d < n - 4 && name[d] >= '0' && name[d] <= '9') d++;
    if (d != n - 4 || d - 6 < 4 || d - 6 > 9) return -1;
    for (int k = 0; k < SM_FRAME_KINDS; k++)
        if (!strcmp(name + n - 3, kind_ext[k])) {
            *kind = (sm_frame_kind)k;
            return atoi(name + 6);
        }
    return -1;
}

sm_status sm_run_manifest_scan(const char *dir, sm_run_manifest *m, int *nfound, char *err, size_t errlen) {
    sm_run_manifest_init(m);
    snprintf(m->state, sizeof m->state, "unknown");
    *nfound = 0;
    DIR *d = opendir(dir);
    if (!d) {
        snprintf(err, errlen, "%s: %s", dir, strerror(errno));
        return SM_ERR_IO;
    }
    struct dirent *e;
    int lo[SM_FRAME_KINDS], hi[SM_FRAME_KINDS];
    for (int k = 0; k < SM_FRAME_KINDS; k++) lo[k] = -1, hi[k] = -1;
    while ((e = readdir(d))) {
        sm_frame_kind k;
        int f = frame_name(e->d_name, &k);
        if (f < 0) continue;
        ++*nfound;
        if (lo[k] < 0 || f < lo[k]) lo[k] = f;
        if (f > hi[k]) hi[k] = f;
    }
    closedir(d);
    for (int k = 0; k < SM_FRAME_KINDS; k++)
        if (lo[k] >= 0) m->first[k] = lo[k], m->last[k] = hi[k];
    m->files = (1u << SM_RUNFILE_COUNT) - 1;
    return SM_OK;
}

/* Removes path if it exists; counts it. */
static sm_status remove_one(const char *path, int *removed, char *err, size_t errlen) {
    if (unlink(path) == 0) {
        ++*removed;
        return SM_OK;
    }
    if (errno == ENOENT) return SM_OK;
    snprintf(err, errlen, "cannot remove %s: %s", path, strerror(errno));
    return SM_ERR_IO;
}

/* checkpoints/ckpt_*.smc, then the folder if it is empty. */
static sm_status remove_checkpoints(const char *dir, int *removed, char *err, size_t errlen) {
    char cdir[SM_PATH_MAX], path[SM_PATH_MAX];
    if (join(cdir, sizeof cdir, dir, "checkpoints", err, errlen) != SM_OK) return SM_ERR_IO;
    DIR *d = opendir(cdir);
    if (!d) return SM_OK;
    struct dirent *e;
    sm_status st = SM_OK;
    while (st == SM_OK && (e = readdir(d))) {
        size_t n = strlen(e->d_name);
        if (strncmp(e->d_name, "ckpt_", 5) != 0 || n < 9 || strcmp(e->d_name + n - 4, ".smc") != 0) continue;
        st = join(path, sizeof path, cdir, e->d_name, err, errlen);
        if (st == SM_OK) st = remove_one(path, removed, err, errlen);
    }
    closedir(d);
    if (st == SM_OK) rmdir(cdir); /* fails, harmlessly, if anything else is in it */
    return st;
}

sm_status sm_run_manifest_remove(const char *dir, const sm_run_manifest *m, int *removed, char *err, size_t errlen) {
    char path[SM_PATH_MAX], name[48];
    sm_status st = SM_OK;
    *removed = 0;
    for (int k = 0; k < SM_FRAME_KINDS && st == SM_OK; k++)
        for (int f = m->first[k]; f <= m->last[k] && st == SM_OK; f++) {
            snprintf(name, sizeof name, "frame_%04d.%s", f, kind_ext[k]);
            st = join(path, sizeof path, dir, name, err, errlen);
            if (st == SM_OK) st = remove_one(path, removed, err, errlen);
        }
    for (int b = 0; b < SM_RUNFILE_COUNT && st == SM_OK; b++) {
        if (!(m->files & (1u << b))) continue;
        if (1u << b == SM_RUNFILE_CHECKPOINTS) st = remove_checkpoints(dir, removed, err, errlen);
        else if ((st = join(path, sizeof path, dir, runfile_names[b], err, errlen)) == SM_OK)
            st = remove_one(path, removed, err, errlen);
    }
    if (st == SM_OK) st = join(path, sizeof path, dir, SM_RUN_MANIFEST_NAME, err, errlen);
    if (st == SM_OK) st = remove_one(path, removed, err, errlen);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* The sink                                                                                     */

typedef struct manifest_sink_state {
    sm_run_manifest m;
    unsigned written;
    const char *dir;
    int frames, last_frame; /* the run's last frame, and the last one written */
} manifest_sink_state;

static sm_status rm_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    const sm_run_manifest_config *c = s->config;
    manifest_sink_state *p = malloc(sizeof *p);
    if (!p) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    p->m = c->start;
    p->written = c->written;
    p->dir = run->out_dir;
    p->frames = run->frames;
    p->last_frame = run->first_frame - 1;
    snprintf(p->m.state, sizeof p->m.state, "running");
    /* Kinds written from first_frame on: their list continues the earlier one if it reaches the
     * frame before, else starts afresh. */
    for (int k = 0; k < SM_FRAME_KINDS; k++) {
        if (!(p->written & (1u << k))) continue;
        if (sm_run_manifest_count(&p->m, (sm_frame_kind)k) == 0 || p->m.last[k] < run->first_frame - 1)
            p->m.first[k] = run->first_frame;
        p->m.last[k] = run->first_frame - 1;
    }
    sm_status st = sm_run_manifest_write(run->out_dir, &p->m, err, errlen);
    if (st != SM_OK) free(p);
    else s->state = p;
    return st;
}

static sm_status rm_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    manifest_sink_state *p = s->state;
    for (int k = 0; k < SM_FRAME_KINDS; k++)
        if (p->written & (1u << k)) p->m.last[k] = fr->frame;
    p->last_frame = fr->frame;
    return sm_run_manifest_write(fr->out_dir, &p->m, err, errlen);
}

/* The final state; the frame lists are already those on disk. */
static sm_status rm_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    manifest_sink_state *p = s->state;
    snprintf(p->m.state, sizeof p->m.state, "%s",
             run_status != SM_OK ? "failed" : p->last_frame < p->frames ? "stopped" : "complete");
    sm_status st = sm_run_manifest_write(p->dir, &p->m, err, errlen);
    free(p);
    s->state = NULL;
    return st;
}

sm_sink sm_sink_run_manifest(const sm_run_manifest_config *config) {
    sm_sink s = {"run manifest", config, NULL, rm_begin, rm_frame, rm_end, SM_SINK_STATE, 0};
    return s;
}
