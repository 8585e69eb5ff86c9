/* The collider API of the world: the checks of a definition (the library's limits, usable
 * without a world), adding a collider (before the domain walls, which stay last; it retains its
 * mesh fields until the world is destroyed), queries. */
#include <stdio.h>
#include <string.h>

#include "world/world.h"

int sm_shape_check(const sm_shape *s, int dim, const char *name, char *err, size_t errlen) {
    double c3[3] = {s->center[0], s->center[1], s->center[2]};
    if (!sm_finite3(c3)) return (sm_check_fail(err, errlen, "%s.center: must be finite", name), 0);
    switch (s->kind) {
    case SM_SHAPE_HALFSPACE: {
        double nn = s->normal[0] * s->normal[0] + s->normal[1] * s->normal[1] + (dim == 3 ? s->normal[2] * s->normal[2] : 0);
        if (!(nn > 0) || !isfinite(nn)) return (sm_check_fail(err, errlen, "%s.normal: must be a finite non-zero vector", name), 0);
        break;
    }
    case SM_SHAPE_BOX:
        for (int a = 0; a < dim; a++)
            if (!(s->half_extent[a] > 0) || !isfinite(s->half_extent[a]))
                return (sm_check_fail(err, errlen, "%s.half_extent: must be > 0, got %g", name, s->half_extent[a]), 0);
        break;
    case SM_SHAPE_SPHERE:
        if (!(s->radius > 0) || !isfinite(s->radius)) return (sm_check_fail(err, errlen, "%s.radius: must be > 0, got %g", name, s->radius), 0);
        break;
    case SM_SHAPE_CYLINDER:
        if (!(s->radius > 0) || !isfinite(s->radius)) return (sm_check_fail(err, errlen, "%s.radius: must be > 0, got %g", name, s->radius), 0);
        if (!(s->half_height > 0) || !isfinite(s->half_height)) return (sm_check_fail(err, errlen, "%s.half_height: must be > 0, got %g", name, s->half_height), 0);
        break;
    case SM_SHAPE_MESH:
        if (!s->mesh) return (sm_check_fail(err, errlen, "%s.mesh: a mesh shape needs a field (sm_mesh_field_create)", name), 0);
        if (sm_mesh_field_get_stats(s->mesh)->dim != dim)
            return (sm_check_fail(err, errlen, "%s.mesh: a %dD field in a %dD world (a mesh shape needs a field of the world's dimension)", name,
                                  sm_mesh_field_get_stats(s->mesh)->dim, dim), 0);
        break;
    default: return (sm_check_fail(err, errlen, "%s.kind: unknown value %d", name, (int)s->kind), 0);
    }
    double qn = 0;
    for (int k = 0; k < 4; k++) qn += s->rotation[k] * s->rotation[k];
    if (!(fabs(qn - 1) < 1e-6)) return (sm_check_fail(err, errlen, "%s.rotation: must be a unit quaternion (|q|^2 = %g)", name, qn), 0);
    return 1;
}

sm_status sm_collider_def_check(const sm_collider_def *c, int dim, char *err, size_t errlen) {
    if (!c) return sm_check_fail(err, errlen, "collider definition is NULL");
    if (dim != 2 && dim != 3) return sm_check_fail(err, errlen, "collider check: dim must be 2 or 3, got %d", dim);
    if (c->shape_count < 1 || c->shape_count > SM_MAX_COLLIDER_SHAPES)
        return sm_check_fail(err, errlen, "collider shapes: need 1 to %d, got %d", SM_MAX_COLLIDER_SHAPES, c->shape_count);
    for (int i = 0; i < c->shape_count; i++) {
        char name[32];
        snprintf(name, sizeof name, "shapes[%d]", i);
        if (!sm_shape_check(&c->shapes[i], dim, name, err, errlen)) return SM_ERR_INVALID;
    }
    if (c->mode != SM_COLLIDE_STICKY && c->mode != SM_COLLIDE_SLIP && c->mode != SM_COLLIDE_SEPARATE)
        return sm_check_fail(err, errlen, "collider mode: unknown value %d", (int)c->mode);
    if (!(c->friction >= 0) || !isfinite(c->friction))
        return sm_check_fail(err, errlen, "collider friction: must be >= 0, got %g", c->friction);
    if (!sm_finite3(c->velocity) || !sm_finite3(c->angular_velocity) || !sm_finite3(c->pose.position))
        return sm_check_fail(err, errlen, "collider motion: velocity, angular velocity and position must be finite");
    double qn = 0;
    for (int k = 0; k < 4; k++) qn += c->pose.rotation[k] * c->pose.rotation[k];
    if (!(fabs(qn - 1) < 1e-6)) return sm_check_fail(err, errlen, "collider pose.rotation: must be a unit quaternion");
    return SM_OK;
}

sm_status sm_world_add_collider(sm_world *w, const sm_collider_def *c, int *id) {
    if (id) *id = -1;
    if (sm_collider_def_check(c, w->dim, w->err, sizeof w->err) != SM_OK) return SM_ERR_INVALID;
    if (w->ncolliders + w->nwalls + 1 > w->colliders_cap) {
        int cap = 2 * (w->ncolliders + w->nwalls + 1);
        sm_collider *q = sm_realloc(w->colliders, (size_t)cap * sizeof *q);
        if (!q) return sm_world_fail(w, SM_ERR_NOMEM, "out of memory");
        w->colliders = q;
        w->colliders_cap = cap;
    }
    /* The walls live after the user colliders: move them up one place. */
    memmove(&w->colliders[w->ncolliders + 1], &w->colliders[w->ncolliders], (size_t)w->nwalls * sizeof *w->colliders);
    sm_collider_init(&w->colliders[w->ncolliders], c);
    sm_collider_retain_meshes(&w->colliders[w->ncolliders]);
    if (w->time != 0) {
        /* Added mid-run: evaluate a scripted pose at the current time. */
        if (c->motion) {
            c->motion(c->motion_user, w->time, &w->colliders[w->ncolliders].pose0);
            w->colliders[w->ncolliders].pose1 = w->colliders[w->ncolliders].pose0;
            sm_quat_to_mat(w->colliders[w->ncolliders].pose0.rotation, w->colliders[w->ncolliders].R0);
            memcpy(w->colliders[w->ncolliders].R1, w->colliders[w->ncolliders].R0, sizeof(double) * 9);
        }
    }
    if (id) *id = w->ncolliders;
    w->ncolliders++;
    return SM_OK;
}

double sm_world_collider_distance(const sm_world *w, int id, const double x[3], double grad[3]) {
    if (id < 0 || id >= w->ncolliders) return INFINITY;
    return sm_collider_phi(&w->colliders[id], w->dim, 0, x, grad);
}

int sm_world_collider_count(const sm_world *w) { return w->ncolliders; }

const sm_collider_def *sm_world_collider_def(const sm_world *w, int id) {
    return (id >= 0 && id < w->ncolliders) ? &w->colliders[id].def : NULL;
}

void sm_world_collider_pose(const sm_world *w, int id, sm_pose *pose) {
    if (id < 0 || id >= w->ncolliders) return;
    *pose = w->colliders[id].pose0;
}

