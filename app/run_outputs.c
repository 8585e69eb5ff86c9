/* The outputs of a scene's run (app/run_outputs.h): the sink choice `sandmpm run` and the Python
 * package share. */
#include "app/run_outputs.h"

#include <stdio.h>
#include <string.h>

uint64_t sm_run_scene_hash(const char *path, const sm_scene_param *params, int nparams, const char *quality) {
    uint64_t h = 1469598103934665603ull;
#define MIX(byte) (h = (h ^ (unsigned char)(byte)) * 1099511628211ull)
    FILE *f = path ? fopen(path, "rb") : NULL;
    if (f) {
        int c;
        while ((c = getc(f)) != EOF) MIX(c);
        fclose(f);
    }
    MIX(0);
    for (int i = 0; i < nparams; i++) {
        for (const char *p = params[i].key; *p; p++) MIX(*p);
        MIX('=');
        for (const char *p = params[i].value; *p; p++) MIX(*p);
        MIX(0);
    }
    for (const char *p = quality ? quality : "preview"; *p; p++) MIX(*p);
#undef MIX
    return h;
}

int sm_run_checkpoint_every(int asked, const sm_scene_settings *st) {
    if (asked >= 0) return asked;
    return st->checkpoint_every >= 0 ? st->checkpoint_every : SM_RUN_CHECKPOINT_EVERY;
}

void sm_run_describe(const sm_run_request *r, const sm_scene_settings *st, sm_run_manifest *m) {
    sm_run_manifest_init(m);
    snprintf(m->scene, sizeof m->scene, "%s", r->scene ? r->scene : "(built in) scenes/default.lua");
    m->scene_hash = r->scene_hash;
    snprintf(m->quality, sizeof m->quality, "%s", r->quality ? r->quality : "preview");
    m->fps = st->fps;
    m->frames = r->frames;
    m->files = SM_RUNFILE_RENDER | SM_RUNFILE_POSES | SM_RUNFILE_CHECKPOINTS | (st->out_vtk ? SM_RUNFILE_PVD : 0u) |
               (st->out_csv ? SM_RUNFILE_CSV : 0u) | (r->video ? SM_RUNFILE_VIDEO : 0u);
}

void sm_run_outputs_choose(sm_run_outputs *o, const sm_run_request *r, const sm_scene_settings *st,
                           const sm_run_manifest *start) {
    memset(o, 0, sizeof *o);
    o->camera.has_camera = st->has_camera;
    memcpy(o->camera.eye, st->eye, sizeof st->eye);
    memcpy(o->camera.target, st->target, sizeof st->target);
    memcpy(o->camera.up, st->up, sizeof st->up);
    o->camera.fov = st->fov;
    o->png.width = 1280;
    o->png.height = 720;
    o->png.color = SM_COLOR_SAND;
    o->png.threads = r->threads;
    o->ckpt.every = r->checkpoint_every;
    o->ckpt.keep = r->keep;
    o->ckpt.scene_hash = r->scene_hash;
    o->manifest.start = *start;
    if (st->out_ply || r->render) o->sinks[o->nsinks++] = sm_sink_ply(&st->out_z_up); /* `render` reads them later */
    if (st->out_vtk) o->sinks[o->nsinks++] = sm_sink_vtk(&st->out_z_up);
    o->sinks[o->nsinks++] = sm_sink_manifest(&o->camera);
    if (r->render) o->sinks[o->nsinks++] = sm_sink_png(&o->png);
    if (st->out_csv) o->sinks[o->nsinks++] = sm_sink_csv();
    o->manifest.written = (st->out_ply || r->render ? 1u << SM_FRAME_PLY : 0) | (st->out_vtk ? 1u << SM_FRAME_VTP : 0) |
                          (r->render ? 1u << SM_FRAME_PNG : 0);
    /* The run manifest records a frame before its checkpoint exists: a run killed between the two
     * resumes from the checkpoint before, with the manifest listing every frame up to it. (In
     * the other order, a kill just after the checkpoint left the manifest a frame behind it, and
     * the resume listed only the frames after the checkpoint: test_checkpoints.sh caught it.) */
    o->sinks[o->nsinks++] = sm_sink_run_manifest(&o->manifest);
    if (o->ckpt.every > 0 || r->keep_last) o->sinks[o->nsinks++] = sm_sink_checkpoint(&o->ckpt);
}
