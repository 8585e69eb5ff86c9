/* sm_scene_build: the world from a validated scene (materials in name order, colliders with their
 * motion, objects seeded, emitters). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>

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

/* Particles inside a collider at t = 0 (phi < 0; containers count from their inside out) are a
 * mistake: they are pushed out or fall through the wall. Counted per object and collider while
 * seeding (count[o * (ncol + 1)]: the object's particles, then one per collider), summed over the
 * processes that build together (sm_scene_on_sum), then one warning per object and collider. */
static void count_inside_colliders(sm_scene *s, sm_world *w, size_t first, uint64_t *count) {
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    count[0] = pv.n - first;
    for (int c = 0; c < s->ncol; c++)
        for (size_t i = first; i < pv.n; i++) {
            double x[3] = {0, 0, 0};
            for (int k = 0; k < pv.dim; k++) x[k] = (double)pv.x[i * (size_t)pv.dim + (size_t)k];
            count[1 + c] += sm_world_collider_distance(w, c, x, NULL) < 0;
        }
}

static void warn_inside_colliders(sm_scene *s, const uint64_t *count) {
    for (int o = 0; o < s->nobj; o++)
        for (int c = 0; c < s->ncol; c++) {
            const uint64_t *n = count + (size_t)o * (size_t)(s->ncol + 1);
            if (n[1 + c] == 0) continue;
            char key[64], at[1100];
            snprintf(key, sizeof key, "objects[%d]", o + 1);
            sc_warn_msg(s,
                        "%s: %s: %llu of its %llu particles are seeded inside colliders[%d]; they will be pushed out of "
                        "it or fall through it (make the object smaller or move the collider)",
                        sc_where(s, key, at, sizeof at), key, (unsigned long long)n[1 + c], (unsigned long long)n[0], c + 1);
        }
}

static sm_status seed_objects(sm_scene *s, sm_world *w, uint64_t *count, char *err, size_t errlen) {
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
        count_inside_colliders(s, w, before, count + (size_t)i * (size_t)(s->ncol + 1));
    }
    return SM_OK;
}

/* Whether this process or another that builds with it failed (sm_scene_on_sum: collective). */
static int any_failed(sm_scene *s, int failed) {
    uint64_t f = (uint64_t)(failed != 0);
    if (s->sum) s->sum(s->sum_user, &f, 1);
    return f != 0;
}

/* Objects seeded, and their warnings from the counts summed over the processes that build
 * together: the sums are taken (collectively) only when no process failed before them. */
static sm_status seed_and_warn(sm_scene *s, sm_world *w, sm_status st, char *err, size_t errlen) {
    const int n = s->nobj * (s->ncol + 1);
    uint64_t *count = calloc((size_t)n + 1, sizeof *count);
    if (!count && st == SM_OK) st = sc_fail_msg(err, errlen, SM_ERR_NOMEM, "%s: out of memory", s->path);
    if (st == SM_OK) st = seed_objects(s, w, count, err, errlen);
    if (!any_failed(s, st != SM_OK)) {
        if (s->sum && n > 0) s->sum(s->sum_user, count, n);
        warn_inside_colliders(s, count);
    }
    free(count);
    return st;
}

void sm_scene_on_world(sm_scene *s, sm_scene_world_hook hook, void *user) {
    s->on_world = hook;
    s->on_world_user = user;
}

void sm_scene_on_sum(sm_scene *s, sm_scene_sum_hook hook, void *user) {
    s->sum = hook;
    s->sum_user = user;
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
    st = seed_and_warn(s, w, st, err, errlen);
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
