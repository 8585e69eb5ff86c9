/* Collider motion: quaternions, keyframes (position linear, rotation slerp, held outside their
 * range) evaluated in C, and Lua motion functions called through lua_pcall from the library's
 * sm_motion_fn (once per step per collider), each call with its own instruction limit. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>

#include "app/scene/scene_internal.h"

/* Quaternion (w,x,y,z) of a rotation by deg degrees about an axis (normalised here). */
int sc_quat_axis_angle(double ax, double ay, double az, double deg, double q[4]) {
    double n = sqrt(ax * ax + ay * ay + az * az);
    if (!(n > 0) || !isfinite(n) || !isfinite(deg)) return 0;
    double h = 0.5 * deg * (3.14159265358979323846 / 180.0), s = sin(h) / n;
    q[0] = cos(h);
    q[1] = ax * s;
    q[2] = ay * s;
    q[3] = az * s;
    return 1;
}

void sc_quat_identity(double q[4]) {
    q[0] = 1;
    q[1] = q[2] = q[3] = 0;
}

static void slerp(const double a[4], const double b_in[4], double u, double out[4]) {
    double b[4] = {b_in[0], b_in[1], b_in[2], b_in[3]};
    double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    if (dot < 0) {
        dot = -dot;
        for (int k = 0; k < 4; k++) b[k] = -b[k];
    }
    double wa, wb;
    if (dot > 0.9995) {
        wa = 1 - u;
        wb = u;
    } else {
        double th = acos(dot), s = sin(th);
        wa = sin((1 - u) * th) / s;
        wb = sin(u * th) / s;
    }
    double n = 0;
    for (int k = 0; k < 4; k++) {
        out[k] = wa * a[k] + wb * b[k];
        n += out[k] * out[k];
    }
    n = sqrt(n);
    for (int k = 0; k < 4; k++) out[k] /= n;
}

static void keyframe_pose(const scene_collider *c, double t, sm_pose *p) {
    const keyframe *k = c->kf;
    int n = c->nkf, i = 0;
    if (t <= k[0].t || n == 1) {
        memcpy(p->position, k[0].pos, sizeof p->position);
        memcpy(p->rotation, k[0].rot, sizeof p->rotation);
        return;
    }
    if (t >= k[n - 1].t) {
        memcpy(p->position, k[n - 1].pos, sizeof p->position);
        memcpy(p->rotation, k[n - 1].rot, sizeof p->rotation);
        return;
    }
    int lo = 0, hi = n - 1; /* k[lo].t <= t < k[hi].t */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (k[mid].t <= t) lo = mid;
        else hi = mid;
    }
    i = lo;
    double u = (t - k[i].t) / (k[i + 1].t - k[i].t);
    for (int a = 0; a < 3; a++) p->position[a] = k[i].pos[a] + u * (k[i + 1].pos[a] - k[i].pos[a]);
    slerp(k[i].rot, k[i + 1].rot, u, p->rotation);
}

void sc_motion_error_text(const sm_scene *s, const scene_collider *c, double t, const char *msg, char *out,
                              size_t n) {
    if (sc_has_position(msg)) snprintf(out, n, "%.900s (colliders[%d].motion at t = %.6g)", msg, c->index, t);
    else if (c->fn_line > 0)
        snprintf(out, n, "%.300s:%d: colliders[%d].motion at t = %.6g: %.600s", s->path, c->fn_line, c->index, t, msg);
    else snprintf(out, n, "%.300s: colliders[%d].motion at t = %.6g: %.600s", s->path, c->index, t, msg);
}

/* Reads a vector of n numbers from the table at idx without raising; returns 0 with a message. */
static int read_vec_raw(lua_State *L, int idx, int n, double *out, const char *what, const char *label, char *err,
                        size_t errlen) {
    if (lua_type(L, idx) != LUA_TTABLE) {
        snprintf(err, errlen, "returned %s: expected %s, got %s", what, label, luaL_typename(L, idx));
        return 0;
    }
    if (lua_rawlen(L, idx) != (lua_Unsigned)n) {
        snprintf(err, errlen, "returned %s: expected %s: %d numbers, got %llu", what, label, n,
                 (unsigned long long)lua_rawlen(L, idx));
        return 0;
    }
    for (int i = 0; i < n; i++) {
        int ty = lua_rawgeti(L, idx, i + 1);
        double x = ty == LUA_TNUMBER ? (double)lua_tonumber(L, -1) : NAN;
        lua_pop(L, 1);
        if (ty != LUA_TNUMBER || !isfinite(x)) {
            char nb[32];
            snprintf(err, errlen, "returned %s[%d]: expected a finite number, got %s", what, i + 1,
                     ty == LUA_TNUMBER ? sc_fmt_num(nb, x) : lua_typename(L, ty));
            return 0;
        }
        out[i] = x;
    }
    return 1;
}

/* Protected: (collider, t) -> calls the motion function, checks its results into c->tmp. */
int sc_motion_call(lua_State *L) {
    scene_collider *c = lua_touserdata(L, 1);
    double t = (double)lua_tonumber(L, 2);
    int dim = c->scene->def.dim;
    lua_settop(L, 0);
    lua_rawgeti(L, LUA_REGISTRYINDEX, c->fn_ref);
    lua_pushnumber(L, t);
    lua_call(L, 1, 2);
    char err[256];
    sm_pose p;
    memset(&p, 0, sizeof p);
    if (!read_vec_raw(L, 1, dim, p.position, "position", sc_vec_label(dim), err, sizeof err))
        return luaL_error(L, "%s", err);
    if (lua_isnil(L, 2)) {
        sc_quat_identity(p.rotation);
    } else {
        if (!read_vec_raw(L, 2, 4, p.rotation, "rotation", "{w, x, y, z} (e.g. axis_angle(0, 1, 0, degrees))", err,
                          sizeof err))
            return luaL_error(L, "%s", err);
        double n = sqrt(p.rotation[0] * p.rotation[0] + p.rotation[1] * p.rotation[1] + p.rotation[2] * p.rotation[2] +
                        p.rotation[3] * p.rotation[3]);
        if (!(n > 0.5 && n < 2))
            return luaL_error(L, "returned rotation: expected a unit quaternion {w, x, y, z}, |q| = %f", n);
        for (int k = 0; k < 4; k++) p.rotation[k] /= n;
        if (dim == 2 && (fabs(p.rotation[1]) > 1e-9 || fabs(p.rotation[2]) > 1e-9))
            return luaL_error(L, "returned rotation: in 2D a rotation must be about z");
    }
    c->tmp = p;
    return 0;
}

/* The library's sm_motion_fn: keyframes in C, motion functions through lua_pcall. Never raises. */
void sc_scene_motion(void *user, double t, sm_pose *pose) {
    scene_collider *c = user;
    sm_scene *s = c->scene;
    if (c->motion == MOTION_KEYFRAMES) {
        keyframe_pose(c, t, pose);
        return;
    }
    if (s->motion_err[0]) {
        *pose = c->last;
        return;
    }
    lua_State *L = s->L;
    sc_set_budget(s, sc_scene_limits.motion_insn, sc_scene_limits.motion_time, "a motion-function call");
    int top = lua_gettop(L);
    lua_pushcfunction(L, sc_motion_call);
    lua_pushlightuserdata(L, c);
    lua_pushnumber(L, t);
    int st = lua_pcall(L, 2, 0, 0);
    if (st == LUA_OK) {
        c->last = c->tmp;
    } else {
        char msg[1024];
        sc_pop_error(L, st, msg, sizeof msg);
        sc_motion_error_text(s, c, t, msg, s->motion_err, sizeof s->motion_err);
    }
    lua_settop(L, top);
    *pose = c->last;
}
