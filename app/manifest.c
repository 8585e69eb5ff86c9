/* Run manifest: see manifest.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "app/io/files.h"
#include "app/manifest.h"

static void write_collider(FILE *f, const sm_collider_def *c, const sm_pose *p) {
    fprintf(f, "collider %d %d %d %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", c->shape_count, c->inside_out,
            (int)c->mode, p->position[0], p->position[1], p->position[2], p->rotation[0], p->rotation[1], p->rotation[2],
            p->rotation[3]);
    for (int k = 0; k < c->shape_count; k++) {
        const sm_shape *s = &c->shapes[k];
        fprintf(f, "shape %d %d %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n",
                (int)s->kind, s->inside_out, s->center[0], s->center[1], s->center[2], s->normal[0], s->normal[1],
                s->normal[2], s->half_extent[0], s->half_extent[1], s->half_extent[2], s->radius, s->half_height,
                s->rotation[0], s->rotation[1], s->rotation[2], s->rotation[3]);
    }
}

sm_status sm_manifest_write(const char *path, const sm_world *w, int has_camera, const double eye[3],
                            const double target[3], const double up[3], double fov, char *err, size_t errlen) {
    sm_atomic_file a;
    sm_status st = sm_atomic_open(&a, path, err, errlen);
    if (st != SM_OK) return st;
    FILE *f = a.f;
    const sm_world_def *d = sm_world_get_def(w);
    fprintf(f, "sandmpm-render 1\ndim %d\ndomain %.17g %.17g %.17g %.17g %.17g %.17g\n", d->dim, d->domain_min[0],
            d->domain_min[1], d->domain_min[2], d->domain_max[0], d->domain_max[1], d->domain_max[2]);
    if (has_camera)
        fprintf(f, "camera %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", eye[0], eye[1], eye[2],
                target[0], target[1], target[2], up[0], up[1], up[2], fov);
    int nc = sm_world_collider_count(w);
    fprintf(f, "colliders %d\n", nc);
    for (int i = 0; i < nc; i++) {
        sm_pose p;
        sm_world_collider_pose(w, i, &p);
        write_collider(f, sm_world_collider_def(w, i), &p);
    }
    return sm_atomic_commit(&a, err, errlen);
}

size_t sm_manifest_poses(char *buf, size_t len, int frame, const sm_world *w) {
    int nc = sm_world_collider_count(w);
    size_t k = 0;
    for (int i = 0; i < nc && k < len; i++) {
        sm_pose p;
        sm_world_collider_pose(w, i, &p);
        int m = snprintf(buf + k, len - k, "%d,%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", frame, i, p.position[0],
                         p.position[1], p.position[2], p.rotation[0], p.rotation[1], p.rotation[2], p.rotation[3]);
        if (m < 0) break;
        k += (size_t)m;
    }
    return k < len ? k : len;
}

void sm_manifest_free(sm_manifest *m) {
    free(m->colliders);
    free(m->poses);
    memset(m, 0, sizeof *m);
}

/* ------------------------------------------------------------------------------------------ */
/* Reading                                                                                      */

/* Where the render.txt parser is: the collider being read (-1: none yet) and its next shape. */
typedef struct read_pos {
    int ci, si;
} read_pos;

static int parse_collider(sm_manifest *m, const char *rest, read_pos *rp) {
    rp->ci++;
    rp->si = 0;
    if (rp->ci >= m->ncolliders) return 0;
    sm_collider_def *c = &m->colliders[rp->ci];
    *c = sm_collider_def_default();
    int mode = 0;
    int ok = sscanf(rest, "%d %d %d %lf %lf %lf %lf %lf %lf %lf", &c->shape_count, &c->inside_out, &mode,
                    &c->pose.position[0], &c->pose.position[1], &c->pose.position[2], &c->pose.rotation[0],
                    &c->pose.rotation[1], &c->pose.rotation[2], &c->pose.rotation[3]) == 10 &&
             c->shape_count >= 1 && c->shape_count <= SM_MAX_COLLIDER_SHAPES;
    c->mode = (sm_collide_mode)mode;
    return ok;
}

static int parse_shape(sm_manifest *m, const char *rest, read_pos *rp) {
    if (rp->ci < 0 || rp->si >= m->colliders[rp->ci].shape_count) return 0;
    sm_shape *s = &m->colliders[rp->ci].shapes[rp->si++];
    int kind = 0;
    int ok = sscanf(rest, "%d %d %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &kind, &s->inside_out,
                    &s->center[0], &s->center[1], &s->center[2], &s->normal[0], &s->normal[1], &s->normal[2],
                    &s->half_extent[0], &s->half_extent[1], &s->half_extent[2], &s->radius, &s->half_height,
                    &s->rotation[0], &s->rotation[1], &s->rotation[2], &s->rotation[3]) == 17 &&
             kind >= 0 && kind <= 3;
    s->kind = (sm_shape_kind)kind;
    return ok;
}

/* One line of render.txt after the first; 0 if it is malformed. */
static int parse_line(sm_manifest *m, const char *line, read_pos *rp) {
    if (!strncmp(line, "dim ", 4)) return sscanf(line + 4, "%d", &m->dim) == 1 && (m->dim == 2 || m->dim == 3);
    if (!strncmp(line, "domain ", 7))
        return sscanf(line + 7, "%lf %lf %lf %lf %lf %lf", &m->domain_min[0], &m->domain_min[1], &m->domain_min[2],
                      &m->domain_max[0], &m->domain_max[1], &m->domain_max[2]) == 6;
    if (!strncmp(line, "camera ", 7)) {
        m->has_camera = sscanf(line + 7, "%lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &m->eye[0], &m->eye[1], &m->eye[2],
                               &m->target[0], &m->target[1], &m->target[2], &m->up[0], &m->up[1], &m->up[2],
                               &m->fov) == 10;
        return m->has_camera;
    }
    if (!strncmp(line, "colliders ", 10)) {
        if (sscanf(line + 10, "%d", &m->ncolliders) != 1 || m->ncolliders < 0 || m->ncolliders >= 100000) return 0;
        if (m->ncolliders) m->colliders = calloc((size_t)m->ncolliders, sizeof *m->colliders);
        return m->ncolliders == 0 || m->colliders != NULL;
    }
    if (!strncmp(line, "collider ", 9)) return parse_collider(m, line + 9, rp);
    if (!strncmp(line, "shape ", 6)) return parse_shape(m, line + 6, rp);
    return line[0] == '\n';
}

/* poses.csv: "frame,collider,px,py,pz,qw,qx,qy,qz" lines; malformed lines are skipped, missing
 * poses are the definitions'. */
static void read_poses(sm_manifest *m, FILE *f) {
    char line[2048];
    int cap = 0;
    while (fgets(line, sizeof line, f)) {
        int fr, id;
        sm_pose p;
        if (sscanf(line, "%d,%d,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &fr, &id, &p.position[0], &p.position[1], &p.position[2],
                   &p.rotation[0], &p.rotation[1], &p.rotation[2], &p.rotation[3]) != 9 ||
            fr < 0 || fr > 10000000 || id < 0 || id >= m->ncolliders)
            continue;
        if (fr >= cap) {
            int nc2 = cap ? cap : 64;
            while (nc2 <= fr) nc2 *= 2;
            sm_pose *q = realloc(m->poses, (size_t)nc2 * (size_t)m->ncolliders * sizeof *q);
            if (!q) break;
            for (size_t k = (size_t)cap * m->ncolliders; k < (size_t)nc2 * m->ncolliders; k++)
                q[k] = m->colliders[k % (size_t)m->ncolliders].pose;
            m->poses = q;
            cap = nc2;
        }
        m->poses[(size_t)fr * m->ncolliders + (size_t)id] = p;
        if (fr + 1 > m->nframes) m->nframes = fr + 1;
    }
}

sm_status sm_manifest_read(const char *dir, sm_manifest *m, char *err, size_t errlen) {
    memset(m, 0, sizeof *m);
    char path[SM_PATH_MAX];
    snprintf(path, sizeof path, "%s/render.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        snprintf(err, errlen, "%s: %s (not a sandmpm run directory?)", path, strerror(errno));
        return SM_ERR_IO;
    }
    char line[2048];
    int ok = fgets(line, sizeof line, f) && !strncmp(line, "sandmpm-render 1", 16);
    read_pos rp = {-1, 0};
    while (ok && fgets(line, sizeof line, f)) ok = parse_line(m, line, &rp);
    fclose(f);
    if (!ok || m->dim == 0 || rp.ci + 1 != m->ncolliders) {
        snprintf(err, errlen, "%s: malformed render manifest", path);
        sm_manifest_free(m);
        return SM_ERR_INVALID;
    }
    snprintf(path, sizeof path, "%s/poses.csv", dir);
    f = fopen(path, "r");
    if (f && m->ncolliders > 0) read_poses(m, f);
    if (f) fclose(f);
    return SM_OK;
}

const sm_pose *sm_manifest_frame_poses(const sm_manifest *m, int frame, sm_pose *scratch) {
    if (m->nframes > 0) {
        if (frame >= m->nframes) frame = m->nframes - 1;
        if (frame < 0) frame = 0;
        return m->poses + (size_t)frame * m->ncolliders;
    }
    for (int i = 0; i < m->ncolliders; i++) scratch[i] = m->colliders[i].pose;
    return scratch;
}
