/* Rendering a run's frames; see app/render_job.h. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/io/png.h"
#include "app/render_job.h"

/* Domain, camera and colliders from the manifest. A half-space collider is the ground (the
 * renderer draws it); without one, a ground plane at the domain's bottom. */
static void opts_from_manifest(sm_render_opts *o, const sm_manifest *m) {
    o->has_domain = 1;
    memcpy(o->domain_min, m->domain_min, sizeof o->domain_min);
    memcpy(o->domain_max, m->domain_max, sizeof o->domain_max);
    if (m->has_camera) {
        o->has_camera = 1;
        memcpy(o->camera.eye, m->eye, sizeof m->eye);
        memcpy(o->camera.target, m->target, sizeof m->target);
        memcpy(o->camera.up, m->up, sizeof m->up);
        o->camera.fov_deg = m->fov;
    }
    o->colliders = m->colliders;
    o->ncolliders = m->ncolliders;
    for (int i = 0; i < m->ncolliders; i++)
        if (m->colliders[i].shape_count == 1 && m->colliders[i].shapes[0].kind == SM_SHAPE_HALFSPACE &&
            !m->colliders[i].inside_out)
            o->ground = SM_GROUND_NONE;
}

sm_status sm_render_job_open(sm_render_job *j, const char *dir, int width, int height, sm_color_mode color,
                             int threads, char *err, size_t errlen) {
    memset(j, 0, sizeof *j);
    j->o = sm_render_opts_default();
    j->o.width = width;
    j->o.height = height;
    j->o.color = color;
    j->o.legend = color != SM_COLOR_SAND; /* a colour that means something says what */
    j->o.threads = threads;
    sm_status st = sm_manifest_read(dir, &j->m, err, errlen);
    if (st != SM_OK && st != SM_ERR_IO) return st; /* SM_ERR_IO: no manifest */
    j->have_manifest = st == SM_OK;
    if (j->have_manifest) opts_from_manifest(&j->o, &j->m);
    j->rgb = malloc((size_t)width * (size_t)height * 3);
    if (!j->rgb) {
        snprintf(err, errlen, "out of memory for a %dx%d image", width, height);
        return SM_ERR_NOMEM;
    }
    if (j->have_manifest && j->m.ncolliders > 0 && !(j->poses = malloc((size_t)j->m.ncolliders * sizeof *j->poses))) {
        snprintf(err, errlen, "out of memory");
        return SM_ERR_NOMEM;
    }
    return SM_OK;
}

sm_status sm_render_job_frame(sm_render_job *j, const sm_frame *fr, int frame, const char *png, char *err,
                              size_t errlen) {
    if (frame >= 0) j->o.poses = j->poses ? sm_manifest_frame_poses(&j->m, frame, j->poses) : NULL;
    else j->o.poses = j->poses;
    sm_status st = sm_render(fr, &j->o, j->rgb, err, errlen);
    if (st == SM_OK) st = sm_png_write(png, j->o.width, j->o.height, j->rgb, err, errlen);
    j->o.poses = NULL;
    return st;
}

void sm_render_job_close(sm_render_job *j) {
    sm_manifest_free(&j->m);
    free(j->rgb);
    free(j->poses);
    j->rgb = NULL;
    j->poses = NULL;
}
