/* sm_scene_build: the world from a validated scene (materials in name order, colliders with their
 * motion, objects seeded, emitters). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>

#include "app/scene/scene_internal.h"

/* A library failure as the scene reports it: out of memory stays so, anything else is bad input. */
static sm_status scene_status(sm_status st) { return st == SM_ERR_NOMEM ? SM_ERR_NOMEM : SM_ERR_INVALID; }

static sm_status add_colliders(sm_scene *s, sm_world *w, char *err, size_t errlen) {
    for (int i = 0; i < s->ncol; i++) {
        scene_collider *c = &s->cols[i];
        if (c->motion != MOTION_RIGID) {
            c->def.motion = sc_scene_motion;
            c->def.motion_user = c;
        }
        sm_status st = sm_world_add_collider(w, &c->def, NULL);
        char key[64], at[1100];
        snprintf(key, sizeof key, "colliders[%d]", i + 1);
        if (st != SM_OK)
            return sc_fail_msg(err, errlen, scene_status(st), "%s: %s: %s", sc_where(s, key, at, sizeof at), key,
                               sm_world_errmsg(w));
        if (s->motion_err[0]) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s", s->motion_err);
    }
    return SM_OK;
}

static sm_status seed_objects(sm_scene *s, sm_world *w, char *err, size_t errlen) {
    for (int i = 0; i < s->nobj; i++) {
        scene_object *o = &s->objs[i];
        sm_seed_def sd = o->seed;
        sd.clip = o->has_clip ? &o->clip : NULL;
        size_t added = 0;
        sm_status st = sm_world_seed_shape(w, &o->shape, &sd, &added);
        char key[64], at[1100];
        snprintf(key, sizeof key, "objects[%d]", i + 1);
        if (st != SM_OK)
            return sc_fail_msg(err, errlen, scene_status(st), "%s: %s: %s", sc_where(s, key, at, sizeof at), key,
                               sm_world_errmsg(w));
        if (added == 0)
            return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                               "%s: %s: no particles: no seeding point of the domain's usable region (2 cells inside its "
                               "walls) is inside the shape%s",
                               sc_where(s, key, at, sizeof at), key, o->has_clip ? " and its clip" : "");
    }
    return SM_OK;
}

sm_status sm_scene_build(sm_scene *s, char *err, size_t errlen) {
    if (err && errlen) err[0] = 0;
    if (!s) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "sm_scene_build: scene is NULL");
    if (s->built) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s: the scene is already built", s->path);
    s->built = 1;
    char msg[512];
    sm_world *w = NULL;
    sm_status st = sm_world_create(&s->def, &w, msg, sizeof msg);
    if (st != SM_OK) return sc_fail_msg(err, errlen, scene_status(st), "%s: %s", s->path, msg);
    for (int i = 0; i < s->nmat && st == SM_OK; i++)
        if ((st = sm_world_add_material(w, &s->mats[i], NULL)) != SM_OK)
            st = sc_fail_msg(err, errlen, scene_status(st), "%s: materials.%s: %s", s->path, s->mat_names[i],
                             sm_world_errmsg(w));
    if (st == SM_OK) st = add_colliders(s, w, err, errlen);
    if (st == SM_OK) st = seed_objects(s, w, err, errlen);
    for (int i = 0; i < s->nemit && st == SM_OK; i++)
        if ((st = sm_world_add_emitter(w, &s->emits[i], NULL)) != SM_OK)
            st = sc_fail_msg(err, errlen, scene_status(st), "%s: emitters[%d]: %s", s->path, i + 1, sm_world_errmsg(w));
    if (st != SM_OK) {
        sm_world_destroy(w);
        return st;
    }
    s->world = w;
    return SM_OK;
}
