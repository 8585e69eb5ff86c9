/* The output sinks; see sinks.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "app/io/files.h"
#include "app/io/csv.h"
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

/* ------------------------------------------------------------------------------------------ */
/* ply                                                                                          */

static sm_status ply_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    char path[SM_PATH_MAX];
    (void)s;
    sm_status st = frame_path(path, sizeof path, fr->out_dir, fr->frame, "ply", err, errlen);
    return st == SM_OK ? sm_write_ply(fr->w, path, err, errlen) : st;
}

sm_sink sm_sink_ply(void) { return (sm_sink){"ply", NULL, NULL, NULL, ply_frame, NULL}; }

/* ------------------------------------------------------------------------------------------ */
/* vtk                                                                                          */

typedef struct vtk_state {
    int count, cap;
    char **names;  /* frame_NNNN.vtp of the frames written */
    double *times; /* their times */
} vtk_state;

static sm_status vtk_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    vtk_state *v = calloc(1, sizeof *v);
    if (!v) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    (void)run;
    s->state = v;
    return SM_OK;
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
    if (!vtk_grow(v) || !(v->names[v->count] = strdup(name))) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    v->times[v->count++] = fr->d->time;
    sm_status st = join(path, sizeof path, fr->out_dir, name, err, errlen);
    if (st == SM_OK) st = sm_write_vtp(fr->w, path, err, errlen);
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
    free(v);
    s->state = NULL;
    return SM_OK;
}

sm_sink sm_sink_vtk(void) { return (sm_sink){"vtk", NULL, NULL, vtk_begin, vtk_frame, vtk_end}; }

/* ------------------------------------------------------------------------------------------ */
/* manifest                                                                                     */

static sm_status manifest_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    const sm_manifest_camera *c = s->config;
    char path[SM_PATH_MAX];
    sm_status st = join(path, sizeof path, run->out_dir, "render.txt", err, errlen);
    if (st == SM_OK) st = sm_manifest_write(path, run->w, c->has_camera, c->eye, c->target, c->up, c->fov, err, errlen);
    if (st == SM_OK) st = join(path, sizeof path, run->out_dir, "poses.csv", err, errlen);
    if (st != SM_OK) return st;
    s->state = fopen(path, "w");
    return SM_OK;
}

static sm_status manifest_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    (void)err, (void)errlen;
    if (s->state) sm_manifest_poses(s->state, fr->frame, fr->w);
    return SM_OK;
}

static sm_status manifest_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    (void)run_status, (void)err, (void)errlen;
    if (s->state) fclose(s->state);
    s->state = NULL;
    return SM_OK;
}

sm_sink sm_sink_manifest(const sm_manifest_camera *camera) {
    return (sm_sink){"manifest", camera, NULL, manifest_begin, manifest_frame, manifest_end};
}

/* ------------------------------------------------------------------------------------------ */
/* png                                                                                          */


static sm_status png_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    const sm_png_sink_config *c = s->config;
    sm_render_job *p = calloc(1, sizeof *p);
    if (!p) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    sm_status st = sm_render_job_open(p, run->out_dir, c->width, c->height, c->color, c->threads, err, errlen);
    if (st != SM_OK) {
        sm_render_job_close(p);
        free(p);
        return st;
    }
    s->state = p;
    return SM_OK;
}

static sm_status png_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    char path[SM_PATH_MAX];
    sm_frame f;
    sm_status st = sm_frame_from_world(fr->w, &f, err, errlen);
    if (st == SM_OK) st = frame_path(path, sizeof path, fr->out_dir, fr->frame, "png", err, errlen);
    if (st == SM_OK) st = sm_render_job_frame(s->state, &f, fr->frame, path, err, errlen);
    sm_frame_free(&f);
    return st;
}

static sm_status png_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    (void)run_status, (void)err, (void)errlen;
    sm_render_job_close(s->state);
    free(s->state);
    s->state = NULL;
    return SM_OK;
}

sm_sink sm_sink_png(const sm_png_sink_config *config) {
    return (sm_sink){"png", config, NULL, png_begin, png_frame, png_end};
}

/* ------------------------------------------------------------------------------------------ */
/* csv                                                                                          */

typedef struct csv_state {
    FILE *f;
    char path[SM_PATH_MAX];
} csv_state;

static sm_status csv_begin(sm_sink *s, const sm_run_info *run, char *err, size_t errlen) {
    csv_state *c = calloc(1, sizeof *c);
    if (!c) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    sm_status st = join(c->path, sizeof c->path, run->out_dir, "diagnostics.csv", err, errlen);
    if (st == SM_OK && !(c->f = fopen(c->path, "w"))) {
        snprintf(err, errlen, "%s: %s", c->path, strerror(errno));
        st = SM_ERR_IO;
    }
    if (st != SM_OK) {
        free(c);
        return st;
    }
    sm_csv_header(c->f);
    s->state = c;
    return SM_OK;
}

static sm_status csv_frame(sm_sink *s, const sm_run_frame *fr, char *err, size_t errlen) {
    (void)err, (void)errlen;
    csv_state *c = s->state;
    sm_csv_row(c->f, fr->frame, fr->d, sm_run_elapsed(fr));
    return SM_OK;
}

static sm_status csv_end(sm_sink *s, sm_status run_status, char *err, size_t errlen) {
    (void)run_status;
    csv_state *c = s->state;
    sm_status st = SM_OK;
    if (fclose(c->f) != 0) {
        snprintf(err, errlen, "%s: %s", c->path, strerror(errno));
        st = SM_ERR_IO;
    }
    free(c);
    s->state = NULL;
    return st;
}

sm_sink sm_sink_csv(void) { return (sm_sink){"csv", NULL, NULL, csv_begin, csv_frame, csv_end}; }
