/* Run manifest: see manifest.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "app/manifest.h"

int sm_manifest_write(const char *path, const sm_world *w, int has_camera, const double eye[3],
                      const double target[3], const double up[3], double fov, char *err, size_t errlen) {
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "w");
    if (!f) {
        snprintf(err, errlen, "%s: %s", tmp, strerror(errno));
        return -1;
    }
    const sm_world_def *d = sm_world_get_def(w);
    fprintf(f, "sandmpm-render 1\ndim %d\ndomain %.17g %.17g %.17g %.17g %.17g %.17g\n", d->dim, d->domain_min[0],
            d->domain_min[1], d->domain_min[2], d->domain_max[0], d->domain_max[1], d->domain_max[2]);
    if (has_camera)
        fprintf(f, "camera %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", eye[0], eye[1], eye[2],
                target[0], target[1], target[2], up[0], up[1], up[2], fov);
    int nc = sm_world_collider_count(w);
    fprintf(f, "colliders %d\n", nc);
    for (int i = 0; i < nc; i++) {
        const sm_collider_def *c = sm_world_collider_def(w, i);
        sm_pose p;
        sm_world_collider_pose(w, i, &p);
        fprintf(f, "collider %d %d %d %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", c->shape_count, c->inside_out,
                (int)c->mode, p.position[0], p.position[1], p.position[2], p.rotation[0], p.rotation[1], p.rotation[2],
                p.rotation[3]);
        for (int k = 0; k < c->shape_count; k++) {
            const sm_shape *s = &c->shapes[k];
            fprintf(f, "shape %d %d %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n",
                    (int)s->kind, s->inside_out, s->center[0], s->center[1], s->center[2], s->normal[0], s->normal[1],
                    s->normal[2], s->half_extent[0], s->half_extent[1], s->half_extent[2], s->radius, s->half_height,
                    s->rotation[0], s->rotation[1], s->rotation[2], s->rotation[3]);
        }
    }
    if (fclose(f) != 0 || rename(tmp, path) != 0) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        remove(tmp);
        return -1;
    }
    return 0;
}

void sm_manifest_poses(FILE *f, int frame, const sm_world *w) {
    int nc = sm_world_collider_count(w);
    for (int i = 0; i < nc; i++) {
        sm_pose p;
        sm_world_collider_pose(w, i, &p);
        fprintf(f, "%d,%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", frame, i, p.position[0], p.position[1],
                p.position[2], p.rotation[0], p.rotation[1], p.rotation[2], p.rotation[3]);
    }
    fflush(f);
}

void sm_manifest_free(sm_manifest *m) {
    free(m->colliders);
    free(m->poses);
    memset(m, 0, sizeof *m);
}

int sm_manifest_read(const char *dir, sm_manifest *m, char *err, size_t errlen) {
    memset(m, 0, sizeof *m);
    char path[4096];
    snprintf(path, sizeof path, "%s/render.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        snprintf(err, errlen, "%s: %s (not a sandmpm run directory?)", path, strerror(errno));
        return 4;
    }
    char line[2048];
    int ok = fgets(line, sizeof line, f) && !strncmp(line, "sandmpm-render 1", 16);
    int ci = -1, si = 0;
    while (ok && fgets(line, sizeof line, f)) {
        if (!strncmp(line, "dim ", 4)) ok = sscanf(line + 4, "%d", &m->dim) == 1 && (m->dim == 2 || m->dim == 3);
        else if (!strncmp(line, "domain ", 7))
            ok = sscanf(line + 7, "%lf %lf %lf %lf %lf %lf", &m->domain_min[0], &m->domain_min[1], &m->domain_min[2],
                        &m->domain_max[0], &m->domain_max[1], &m->domain_max[2]) == 6;
        else if (!strncmp(line, "camera ", 7)) {
            ok = sscanf(line + 7, "%lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &m->eye[0], &m->eye[1], &m->eye[2],
                        &m->target[0], &m->target[1], &m->target[2], &m->up[0], &m->up[1], &m->up[2], &m->fov) == 10;
            m->has_camera = ok;
        } else if (!strncmp(line, "colliders ", 10)) {
            ok = sscanf(line + 10, "%d", &m->ncolliders) == 1 && m->ncolliders >= 0 && m->ncolliders < 100000;
            if (ok && m->ncolliders) {
                m->colliders = calloc((size_t)m->ncolliders, sizeof *m->colliders);
                ok = m->colliders != NULL;
            }
        } else if (!strncmp(line, "collider ", 9)) {
            ci++;
            si = 0;
            ok = ci < m->ncolliders;
            if (ok) {
                sm_collider_def *c = &m->colliders[ci];
                *c = sm_collider_def_default();
                int mode = 0;
                ok = sscanf(line + 9, "%d %d %d %lf %lf %lf %lf %lf %lf %lf", &c->shape_count, &c->inside_out, &mode,
                            &c->pose.position[0], &c->pose.position[1], &c->pose.position[2], &c->pose.rotation[0],
                            &c->pose.rotation[1], &c->pose.rotation[2], &c->pose.rotation[3]) == 10 &&
                     c->shape_count >= 1 && c->shape_count <= SM_MAX_COLLIDER_SHAPES;
                c->mode = (sm_collide_mode)mode;
            }
        } else if (!strncmp(line, "shape ", 6)) {
            ok = ci >= 0 && si < m->colliders[ci].shape_count;
            if (ok) {
                sm_shape *s = &m->colliders[ci].shapes[si++];
                int kind = 0;
                ok = sscanf(line + 6, "%d %d %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &kind,
                            &s->inside_out, &s->center[0], &s->center[1], &s->center[2], &s->normal[0], &s->normal[1],
                            &s->normal[2], &s->half_extent[0], &s->half_extent[1], &s->half_extent[2], &s->radius,
                            &s->half_height, &s->rotation[0], &s->rotation[1], &s->rotation[2], &s->rotation[3]) == 17 &&
                     kind >= 0 && kind <= 3;
                s->kind = (sm_shape_kind)kind;
            }
        } else if (line[0] != '\n') {
            ok = 0;
        }
    }
    fclose(f);
    if (!ok || m->dim == 0 || ci + 1 != m->ncolliders) {
        snprintf(err, errlen, "%s: malformed render manifest", path);
        sm_manifest_free(m);
        return 2;
    }
    /* Poses per frame (optional). */
    snprintf(path, sizeof path, "%s/poses.csv", dir);
    f = fopen(path, "r");
    if (f && m->ncolliders > 0) {
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
    if (f) fclose(f);
    return 0;
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
