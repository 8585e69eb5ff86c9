/* The output sinks; see sinks.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "app/io/files.h"
#include "app/io/csv.h"
#include "app/io/files.h"
#include "app/io/ply.h"
#include "app/io/vtk.h"
#include "app/manifest.h"
#include "app/render_job.h"
#include "app/sinks.h"

/* dir/name into buf; SM_ERR_IO if it does not fit. */
static sm_status join(char *buf, size_t len, const char *dir, const char *name, char *err, size_t errlen) {
    if ((size_t)snprintf(buf, len, "%s/%s", dir, name) >= len) {
        snprintf(err, errlen, "%s/%s: path too long (more than %zu bytes)", dir, name, len - 1);
        return SM_ERR_IO;
    }
    return SM_OK;
}

/* dir/frame_NNNN.ext */
static sm_status frame_path(char *buf, size_t len, const char *dir, int frame, const char *ext, char *err,
                            size_t errlen) {
    char name[48];
    snprintf(name, sizeof name, "frame_%04d.%s", frame, ext);
    return join(buf, len, dir, name, err, errlen);
}

/* A sink's state, zeroed; NULL with "out of memory" in err. */
static void *new_state(size_t size, char *err, size_t errlen) {
    void *p = calloc(1, size);
    if (!p) snprintf(err, errlen, "out of memory");
    return p;
}

/* After a resume from frame first - 1 (run->first_frame = first > 0): the rows of frames before
 * first that the interrupted run wrote into path (read before the stream truncates it), so that an
 * accumulating file holds every frame once. NULL if there is nothing to carry (or no memory: the
 * file then starts at the resumed frame). */
static char *rows_before(const char *path, int first) {
    if (first <= 0) return NULL;
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap), *out = NULL;
    size_t k;
    while (buf && (k = fread(buf + n, 1, cap - n - 1, f)) > 0) {
        n += k;
        if (n + 1 == cap) {
            char *q = realloc(buf, cap *= 2);
            if (!q) break;
            buf = q;
        }
    }
    fclose(f);
    if (buf && (out = malloc(n + 1))) {
        buf[n] = 0;
        size_t o = 0;
        for (char *line = buf; *line;) {
            char *end = strchr(line, '\n');
            size_t len = end ? (size_t)(end - line) + 1 : strlen(line);
            if (end && line[0] >= '0' && line[0] <= '9' && atoi(line) < first) {
                memcpy(out + o, line, len);
                o += len;
            }
            line += len;
        }
        out[o] = 0;
    }
    free(buf);
    return out;
}

/* Appends the carried rows (and frees them). */
static sm_status carry_rows(sm_stream *f, char *rows, char *err, size_t errlen) {
    sm_status st = rows && rows[0] ? sm_stream_append(f, rows, strlen(rows), err, errlen) : SM_OK;
    free(rows);
    return st;
}

/* The end of a begin: with st SM_OK the sink keeps p as its state, else p is freed. */
static sm_status keep_state(sm_sink *s, void *p, sm_status st) {
    if (st != SM_OK) {
        free(p);
        return st;
    }
    s->state = p;
    return SM_OK;
}

/* The end of an end: the state freed, st returned. */
static sm_status drop_state(sm_sink *s, sm_status st) {
    free(s->state);
    s->state = NULL;
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* ply                                                                                          */

static sm_status ply_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    char path[SM_PATH_MAX];
    sm_status st = frame_path(path, sizeof path, fr->out_dir, fr->frame, "ply", err, errlen);
    const int *z_up = s->config;
    if (st != SM_OK) return st; /* the same on every rank: a name too long */
    return fr->part ? sm_write_ply_part(fr->w, fr->part, path, z_up && *z_up, err, errlen)
                    : sm_write_ply(fr->w, path, z_up && *z_up, err, errlen);
}

sm_sink sm_sink_ply(const int *z_up) {
    sm_sink s = {"ply", z_up, NULL, NULL, ply_frame, NULL, SM_SINK_PART, 0};
    return s;
}

/* ------------------------------------------------------------------------------------------ */
/* vtk                                                                                          */

typedef struct vtk_state {
    int count, cap;
    char **names;  /* frame_NNNN.vtp of the frames written */
    double *times; /* their times */
} vtk_state;

static int vtk_grow(vtk_state *v);

/* After a resume, frames.pvd lists the frames before it too (their files are on disk; frame f's
 * time is f / fps exactly, as the frame loop lands on it). */
static sm_status vtk_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    vtk_state *v = new_state(sizeof *v, err, errlen);
    if (!v) return SM_ERR_NOMEM;
    for (int f = 0; f < run->first_frame; f++) {
        char name[48];
        snprintf(name, sizeof name, "frame_%04d.vtp", f);
        if (!vtk_grow(v) || !(v->names[v->count] = strdup(name))) {
            snprintf(err, errlen, "out of memory");
            return SM_ERR_NOMEM; /* the partial list is leaked only in this failure */
        }
        v->times[v->count++] = f / run->fps;
    }
    return keep_state(s, v, SM_OK);
}

static int vtk_grow(vtk_state *v) {
    if (v->count < v->cap) return 1;
    int cap = v->cap ? 2 * v->cap : 64;
    char **n = realloc(v->names, (size_t)cap * sizeof *n);
    if (!n) return 0;
    v->names = n;
    double *t = realloc(v->times, (size_t)cap * sizeof *t);
    if (!t) return 0;
    v->times = t;
    v->cap = cap;
    return 1;
}

static sm_status vtk_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    vtk_state *v = s->state;
    char name[48], path[SM_PATH_MAX];
    snprintf(name, sizeof name, "frame_%04d.vtp", fr->frame);
    sm_status st = SM_OK;
    if (!vtk_grow(v) || !(v->names[v->count] = strdup(name))) {
        snprintf(err, errlen, "out of memory");
        st = SM_ERR_NOMEM;
    } else {
        v->times[v->count++] = fr->d->time;
        st = join(path, sizeof path, fr->out_dir, name, err, errlen);
    }
    const int *z_up = s->config;
    if (fr->part) st = fr->part->agree(fr->part->ctx, st, err, errlen); /* every rank writes, or none */
    if (st == SM_OK && fr->part) st = sm_write_vtp_part(fr->w, fr->part, path, z_up && *z_up, err, errlen);
    else if (st == SM_OK) st = sm_write_vtp(fr->w, path, z_up && *z_up, err, errlen);
    if (fr->part && !fr->part->writer) return st; /* the writer lists the frames */
    if (st == SM_OK) st = join(path, sizeof path, fr->out_dir, "frames.pvd", err, errlen);
    if (st == SM_OK) st = sm_write_pvd(path, (const char *const *)v->names, v->times, v->count, err, errlen);
    return st;
}

static sm_status vtk_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    (void)run_status, (void)err, (void)errlen;
    vtk_state *v = s->state;
    for (int i = 0; i < v->count; i++) free(v->names[i]);
    free(v->names);
    free(v->times);
    return drop_state(s, SM_OK);
}

sm_sink sm_sink_vtk(const int *z_up) {
    sm_sink s = {"vtk", z_up, NULL, vtk_begin, vtk_frame, vtk_end, SM_SINK_PART, 0};
    return s;
}

/* ------------------------------------------------------------------------------------------ */
/* manifest                                                                                     */

typedef struct manifest_state {
    sm_stream poses; /* poses.csv */
    int frames;      /* frames in it */
    char *lines;     /* a frame's lines */
    size_t cap;
} manifest_state;

static sm_status manifest_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    const sm_manifest_camera *c = s->config;
    char path[SM_PATH_MAX];
    sm_status st = join(path, sizeof path, run->out_dir, "render.txt", err, errlen);
    if (st == SM_OK) st = sm_manifest_write(path, run->w, c->has_camera, c->eye, c->target, c->up, c->fov, err, errlen);
    if (st == SM_OK) st = join(path, sizeof path, run->out_dir, "poses.csv", err, errlen);
    if (st != SM_OK) return st;
    manifest_state *m = new_state(sizeof *m, err, errlen);
    if (!m) return SM_ERR_NOMEM;
    m->cap = (size_t)sm_world_collider_count(run->w) * SM_POSE_LINE_MAX + 1;
    if (!(m->lines = malloc(m->cap))) {
        snprintf(err, errlen, "out of memory");
        st = SM_ERR_NOMEM;
    }
    char *rows = st == SM_OK ? rows_before(path, run->first_frame) : NULL;
    if (st == SM_OK) st = sm_stream_open(&m->poses, path, err, errlen); /* fails if poses.csv is a folder */
    if (st == SM_OK) st = carry_rows(&m->poses, rows, err, errlen);
    else free(rows);
    if (st != SM_OK) free(m->lines);
    return keep_state(s, m, st);
}

static sm_status manifest_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    manifest_state *m = s->state;
    size_t n = sm_manifest_poses(m->lines, m->cap, fr->frame, fr->w);
    sm_status st = sm_stream_append(&m->poses, m->lines, n, err, errlen);
    m->frames += st == SM_OK;
    return st;
}

static sm_status manifest_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    manifest_state *m = s->state;
    sm_status st = sm_stream_close(&m->poses, run_status != SM_OK && m->frames == 0, err, errlen);
    free(m->lines);
    return drop_state(s, st);
}

sm_sink sm_sink_manifest(const sm_manifest_camera *camera) {
    sm_sink s = {"manifest", camera, NULL, manifest_begin, manifest_frame, manifest_end, SM_SINK_STATE, 0}; /* the definitions and the colliders' poses */
    return s;
}

/* ------------------------------------------------------------------------------------------ */
/* png                                                                                          */


static sm_status png_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    const sm_png_sink_config *c = s->config;
    sm_render_job *p = new_state(sizeof *p, err, errlen);
    if (!p) return SM_ERR_NOMEM;
    sm_status st = sm_render_job_open(p, run->out_dir, c->width, c->height, c->color, c->threads, err, errlen);
    if (st != SM_OK) sm_render_job_close(p);
    return keep_state(s, p, st);
}

/* The colliders are drawn where the world has them now (its poses, in render.txt's order). */
static sm_status png_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    sm_render_job *job = s->state;
    char path[SM_PATH_MAX];
    sm_frame f;
    sm_status st = sm_frame_from_world(fr->w, &f, err, errlen);
    if (st == SM_OK) st = frame_path(path, sizeof path, fr->out_dir, fr->frame, "png", err, errlen);
    if (st == SM_OK && job->poses)
        for (int i = 0; i < job->m.ncolliders && i < sm_world_collider_count(fr->w); i++)
            sm_world_collider_pose(fr->w, i, &job->poses[i]);
    if (st == SM_OK) st = sm_render_job_frame(job, &f, job->poses ? -1 : fr->frame, path, err, errlen);
    sm_frame_free(&f);
    return st;
}

static sm_status png_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    (void)run_status, (void)err, (void)errlen;
    sm_render_job_close(s->state);
    return drop_state(s, SM_OK);
}

sm_sink sm_sink_png(const sm_png_sink_config *config) {
    return (sm_sink){"png", config, NULL, png_begin, png_frame, png_end, SM_SINK_WHOLE, 0};
}

/* ------------------------------------------------------------------------------------------ */
/* csv                                                                                          */

typedef struct csv_state {
    sm_stream f;
    int rows;            /* frame rows written */
    sm_diagnostics prev; /* the previous frame's, for the _frame columns */
    double prev_wall;    /* its sm_run_elapsed */
} csv_state;

static sm_status csv_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    csv_state *c = new_state(sizeof *c, err, errlen);
    if (!c) return SM_ERR_NOMEM;
    c->prev = *run->d; /* frame 0's, or the resumed checkpoint's */
    char path[SM_PATH_MAX], line[SM_CSV_LINE_MAX];
    sm_status st = join(path, sizeof path, run->out_dir, "diagnostics.csv", err, errlen);
    char *rows = st == SM_OK ? rows_before(path, run->first_frame) : NULL;
    if (st == SM_OK) st = sm_stream_open(&c->f, path, err, errlen);
    const int opened = st == SM_OK;
    if (st == SM_OK) st = sm_stream_append(&c->f, line, (size_t)sm_csv_header(line, sizeof line), err, errlen);
    if (st == SM_OK) st = carry_rows(&c->f, rows, err, errlen);
    else free(rows);
    if (st != SM_OK && opened) {
        char ignored[8];
        sm_stream_close(&c->f, 1, ignored, sizeof ignored); /* the append's message is the one to keep */
    }
    return keep_state(s, c, st);
}

static sm_status csv_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    csv_state *c = s->state;
    char line[SM_CSV_LINE_MAX];
    const double wall = sm_run_elapsed(fr);
    int n = sm_csv_row(line, sizeof line, fr->frame, fr->d, &c->prev, wall - c->prev_wall, wall);
    c->prev = *fr->d;
    c->prev_wall = wall;
    sm_status st = sm_stream_append(&c->f, line, n < (int)sizeof line ? (size_t)n : sizeof line - 1, err, errlen);
    c->rows += st == SM_OK;
    return st;
}

/* A failed run that wrote no row leaves no diagnostics.csv (a header alone says nothing). */
static sm_status csv_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    csv_state *c = s->state;
    return drop_state(s, sm_stream_close(&c->f, run_status != SM_OK && c->rows == 0, err, errlen));
}

sm_sink sm_sink_csv(void) {
    sm_sink s = {"csv", NULL, NULL, csv_begin, csv_frame, csv_end, SM_SINK_STATE, 0};
    return s;
}
