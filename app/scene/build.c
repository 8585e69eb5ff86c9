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

/* Particles [first, end) inside a collider (phi < 0 at t = 0; containers count from their inside
 * out) are a mistake: they are pushed out or fall through the wall. One warning per object and
 * collider. */
static void warn_inside_colliders(sm_scene *s, sm_world *w, int obj, size_t first) {
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    for (int c = 0; c < s->ncol; c++) {
        size_t inside = 0;
        for (size_t i = first; i < pv.n; i++) {
            double x[3] = {0, 0, 0};
            for (int k = 0; k < pv.dim; k++) x[k] = (double)pv.x[i * (size_t)pv.dim + (size_t)k];
            inside += sm_world_collider_distance(w, c, x, NULL) < 0;
        }
        if (inside == 0) continue;
        char key[64], at[1100];
        snprintf(key, sizeof key, "objects[%d]", obj + 1);
        sc_warn_msg(s,
                    "%s: %s: %zu of its %zu particles are seeded inside colliders[%d]; they will be pushed out of it "
                    "or fall through it (make the object smaller or move the collider)",
                    sc_where(s, key, at, sizeof at), key, inside, pv.n - first, c + 1);
    }
}

static sm_status seed_objects(sm_scene *s, sm_world *w, char *err, size_t errlen) {
    for (int i = 0; i < s->nobj; i++) {
        scene_object *o = &s->objs[i];
        sm_seed_def sd = o->seed;
        sd.clip = o->has_clip ? &o->clip : NULL;
        sm_particles_view pv;
        sm_world_particles(w, &pv);
        size_t added = 0, before = pv.n;
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
        warn_inside_colliders(s, w, i, before);
    }
    return SM_OK;
}

void sm_scene_on_world(sm_scene *s, sm_scene_world_hook hook, void *user) {
    s->on_world = hook;
    s->on_world_user = user;
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
    if (s->on_world && (st = s->on_world(s->on_world_user, w)) != SM_OK)
        st = sc_fail_msg(err, errlen, st, "%s: %s", s->path, sm_world_errmsg(w));
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
