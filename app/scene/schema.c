/* The scene schema's typed fields: a table's keys checked against the allowed ones, numbers in
 * their ranges, whole numbers, booleans, enums, vectors, rotations, tables, required keys, and the
 * one list parser; also the loader's two string helpers. The parsers (parse_scene.c,
 * parse_items.c) call them inside lua_pcall: a wrong value raises a Lua error through sc_fail
 * (messages.c), so nothing is allocated outside the scene struct (which sm_scene_destroy frees). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>

#include "app/scene/scene_internal.h"

void sc_copy_str(char *dst, size_t n, const char *src) {
    if (!dst || n == 0) return;
    snprintf(dst, n, "%s", src ? src : "");
}

char *sc_dup_str(const char *s) {
    size_t n = strlen(s) + 1;
    char *p = malloc(n);
    if (p) memcpy(p, s, n);
    return p;
}

/* Pushes t[key] (raw access: scene tables are plain data) and returns its type. */
int sc_get(vctx *v, int t, const char *key) {
    lua_pushstring(v->L, key);
    return lua_rawget(v->L, t);
}

void sc_check_keys(vctx *v, int t, const char *const *allowed, int n, const char *what) {
    lua_State *L = v->L;
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        if (lua_type(L, -1) != LUA_TSTRING) {
            char kb[64];
            if (lua_isinteger(L, -1)) snprintf(kb, sizeof kb, "[%lld]", (long long)lua_tointeger(L, -1));
            else snprintf(kb, sizeof kb, "a %s key", luaL_typename(L, -1));
            sc_fail(v, "unexpected entry %s: %s has named keys (key = value), not a list", kb, what);
        }
        const char *k = lua_tostring(L, -1);
        int ok = 0;
        for (int i = 0; i < n && !ok; i++) ok = !strcmp(k, allowed[i]);
        if (!ok) sc_fail_unknown_key(v, k, allowed, n, what);
    }
}

/* The number of entries of the list at t, which must be a sequence 1..n. */
int sc_list_len(vctx *v, int t, const char *example) {
    lua_State *L = v->L;
    lua_Unsigned n = lua_rawlen(L, t);
    lua_Unsigned count = 0;
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        int isnum;
        lua_Integer i = lua_tointegerx(L, -1, &isnum);
        if (lua_type(L, -1) != LUA_TNUMBER || !isnum || i < 1 || (lua_Unsigned)i > n) {
            char buf[96];
            sc_fail(v, "expected a list %s, found key %s", example,
                  lua_type(L, -1) == LUA_TSTRING ? (snprintf(buf, sizeof buf, "\"%s\"", lua_tostring(L, -1)), buf)
                                                 : luaL_typename(L, -1));
        }
        count++;
    }
    if (count != n) sc_fail(v, "expected a list %s without holes", example);
    if (n > SCENE_MAX_LIST) sc_fail(v, "too many entries (%llu)", (unsigned long long)n);
    return (int)n;
}

/* The value on top must be a finite number. */
double sc_num_top(vctx *v) {
    char b[64], nb[32];
    if (lua_type(v->L, -1) != LUA_TNUMBER) sc_fail(v, "expected a number, got %s", sc_got(v->L, -1, b, sizeof b));
    double x = (double)lua_tonumber(v->L, -1);
    if (!isfinite(x)) sc_fail(v, "must be a finite number, got %s", sc_fmt_num(nb, x));
    return x;
}

/* x in the interval (lo, hi), each end open or closed (an infinite end is no bound). */
void sc_range(vctx *v, double x, double lo, int lo_closed, double hi, int hi_closed) {
    char a[32], b[32], c[32];
    int ok_lo = isinf(lo) || (lo_closed ? x >= lo : x > lo);
    int ok_hi = isinf(hi) || (hi_closed ? x <= hi : x < hi);
    if (ok_lo && ok_hi) return;
    if (isinf(hi)) sc_fail(v, "must be %s %s, got %s", lo_closed ? ">=" : ">", sc_fmt_num(a, lo), sc_fmt_num(c, x));
    if (isinf(lo)) sc_fail(v, "must be %s %s, got %s", hi_closed ? "<=" : "<", sc_fmt_num(b, hi), sc_fmt_num(c, x));
    sc_fail(v, "must be in %c%s, %s%c, got %s", lo_closed ? '[' : '(', sc_fmt_num(a, lo), sc_fmt_num(b, hi),
          hi_closed ? ']' : ')', sc_fmt_num(c, x));
}

/* Opens t[key]: returns LUA_TNIL (nothing pushed) if it is absent, else pushes the value and the
 * key onto the path (its old length in *old) and returns the value's type; field_close undoes both. */
static int field_open(vctx *v, int t, const char *key, size_t *old) {
    int ty = sc_get(v, t, key);
    if (ty == LUA_TNIL) lua_pop(v->L, 1);
    else *old = sc_push_key(v, key);
    return ty;
}

static void field_close(vctx *v, size_t old) {
    sc_pop_key(v, old);
    lua_pop(v->L, 1);
}

/* t[key] as a number in a range; def if absent (*present = 0). */
double sc_num_field(vctx *v, int t, const char *key, double def, int *present, double lo, int lo_closed, double hi,
                    int hi_closed) {
    size_t old = 0;
    int ty = field_open(v, t, key, &old);
    if (present) *present = ty != LUA_TNIL;
    if (ty == LUA_TNIL) return def;
    double x = sc_num_top(v);
    sc_range(v, x, lo, lo_closed, hi, hi_closed);
    field_close(v, old);
    return x;
}

long long sc_int_field(vctx *v, int t, const char *key, long long def, int *present, long long lo, long long hi) {
    char b[64];
    size_t old = 0;
    int ty = field_open(v, t, key, &old);
    if (present) *present = ty != LUA_TNIL;
    if (ty == LUA_TNIL) return def;
    if (ty != LUA_TNUMBER) sc_fail(v, "expected a whole number, got %s", sc_got(v->L, -1, b, sizeof b));
    int isint;
    lua_Integer i = lua_tointegerx(v->L, -1, &isint);
    if (!isint) {
        char nb[32];
        sc_fail(v, "expected a whole number, got %s", sc_fmt_num(nb, (double)lua_tonumber(v->L, -1)));
    }
    if (i < lo || i > hi) sc_fail(v, "must be in %lld .. %lld, got %lld", lo, hi, (long long)i);
    field_close(v, old);
    return (long long)i;
}

int sc_bool_field(vctx *v, int t, const char *key, int def) {
    char b[64];
    size_t old = 0;
    int ty = field_open(v, t, key, &old);
    if (ty == LUA_TNIL) return def;
    if (ty != LUA_TBOOLEAN) sc_fail(v, "expected true or false, got %s", sc_got(v->L, -1, b, sizeof b));
    int r = lua_toboolean(v->L, -1);
    field_close(v, old);
    return r;
}

int sc_enum_field(vctx *v, int t, const char *key, const char *const *names, int n, int def) {
    size_t old = 0;
    int ty = field_open(v, t, key, &old);
    if (ty == LUA_TNIL) return def;
    if (ty == LUA_TSTRING) {
        const char *str = lua_tostring(v->L, -1);
        for (int i = 0; i < n; i++)
            if (!strcmp(str, names[i])) {
                field_close(v, old);
                return i;
            }
    }
    sc_fail_enum(v, names, n);
}

/* The value on top as a vector of exactly n finite numbers; label like "{x, y, z}". */
void sc_vec_top(vctx *v, int n, const char *label, double *out) {
    lua_State *L = v->L;
    char b[64];
    int t = lua_gettop(L);
    if (lua_type(L, t) != LUA_TTABLE) sc_fail(v, "expected %s, got %s", label, sc_got(L, t, b, sizeof b));
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        int isnum;
        lua_Integer i = lua_tointegerx(L, -1, &isnum);
        if (lua_type(L, -1) != LUA_TNUMBER || !isnum || i < 1 || i > n) {
            if (lua_type(L, -1) == LUA_TSTRING)
                sc_fail(v, "expected %s (%d numbers), found key \"%s\"", label, n, lua_tostring(L, -1));
            sc_fail(v, "expected %s: %d numbers, got %llu", label, n, (unsigned long long)lua_rawlen(L, t));
        }
    }
    if (lua_rawlen(L, t) != (lua_Unsigned)n)
        sc_fail(v, "expected %s: %d numbers, got %llu", label, n, (unsigned long long)lua_rawlen(L, t));
    for (int i = 0; i < n; i++) {
        size_t old = sc_push_index(v, i + 1);
        lua_rawgeti(L, t, i + 1);
        out[i] = sc_num_top(v);
        lua_pop(L, 1);
        sc_pop_key(v, old);
    }
}

const char *sc_vec_label(int dim) { return dim == 2 ? "{x, y}" : "{x, y, z}"; }

/* t[key] as a dim-vector (z = 0 in 2D); returns whether present (out untouched if absent). */
int sc_vec_field(vctx *v, int t, const char *key, double out[3]) {
    int dim = v->s->def.dim;
    size_t old = 0;
    if (field_open(v, t, key, &old) == LUA_TNIL) return 0;
    double tmp[3] = {0, 0, 0};
    sc_vec_top(v, dim, sc_vec_label(dim), tmp);
    memcpy(out, tmp, sizeof tmp);
    field_close(v, old);
    return 1;
}

/* angular_velocity: a number (about z) in 2D, a 3-vector in 3D. */
int sc_angvel_field(vctx *v, int t, const char *key, double out[3]) {
    if (v->s->def.dim == 3) return sc_vec_field(v, t, key, out);
    size_t old = 0;
    if (field_open(v, t, key, &old) == LUA_TNIL) return 0;
    int ty = lua_type(v->L, -1);
    char b[64];
    if (ty != LUA_TNUMBER) sc_fail(v, "expected a number (rad/s about z, in 2D), got %s", sc_got(v->L, -1, b, sizeof b));
    out[0] = out[1] = 0;
    out[2] = sc_num_top(v);
    field_close(v, old);
    return 1;
}

static void check_rotation_2d(vctx *v, const double q[4]) {
    if (v->s->def.dim == 2 && (fabs(q[1]) > 1e-9 || fabs(q[2]) > 1e-9))
        sc_fail(v, "in 2D a rotation must be about z (use axis_angle = {0, 0, 1, degrees})");
}

/* rotation = {w,x,y,z} | axis_angle = {ax, ay, az, degrees} in table t; identity if neither; in 2D
 * about z only if plane_only. */
static int rotation_fields(vctx *v, int t, double q[4], int plane_only) {
    int has_q = sc_get(v, t, "rotation") != LUA_TNIL;
    lua_pop(v->L, 1);
    int has_aa = sc_get(v, t, "axis_angle") != LUA_TNIL;
    lua_pop(v->L, 1);
    sc_quat_identity(q);
    if (has_q && has_aa) {
        size_t old = sc_push_key(v, "axis_angle");
        sc_fail(v, "give rotation or axis_angle, not both");
        sc_pop_key(v, old);
    }
    if (has_q) {
        size_t old = sc_push_key(v, "rotation");
        sc_get(v, t, "rotation");
        sc_vec_top(v, 4, "{w, x, y, z} (a unit quaternion)", q);
        lua_pop(v->L, 1);
        double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (!(fabs(n - 1) < 1e-3)) {
            char nb[32];
            sc_fail(v,
                  "must be a unit quaternion {w, x, y, z}, |q| = %s (for an axis and an angle use "
                  "axis_angle = {ax, ay, az, degrees})",
                  sc_fmt_num(nb, n));
        }
        for (int k = 0; k < 4; k++) q[k] /= n;
        if (plane_only) check_rotation_2d(v, q);
        sc_pop_key(v, old);
    } else if (has_aa) {
        size_t old = sc_push_key(v, "axis_angle");
        double aa[4];
        sc_get(v, t, "axis_angle");
        sc_vec_top(v, 4, "{ax, ay, az, degrees}", aa);
        lua_pop(v->L, 1);
        if (!sc_quat_axis_angle(aa[0], aa[1], aa[2], aa[3], q)) sc_fail(v, "the axis must be non-zero");
        if (plane_only) check_rotation_2d(v, q);
        sc_pop_key(v, old);
    }
    return has_q || has_aa;
}

int sc_rotation_fields(vctx *v, int t, double q[4]) { return rotation_fields(v, t, q, 1); }
int sc_rotation_fields_any(vctx *v, int t, double q[4]) { return rotation_fields(v, t, q, 0); }

/* Checks that t[key] is a table and pushes it (returns 0 and pushes nothing if absent). */
int sc_table_field(vctx *v, int t, const char *key) {
    char b[64];
    int ty = sc_get(v, t, key);
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        return 0;
    }
    if (ty != LUA_TTABLE) {
        size_t old = sc_push_key(v, key);
        sc_fail(v, "expected a table, got %s", sc_got(v->L, -1, b, sizeof b));
        sc_pop_key(v, old);
    }
    return 1;
}

void sc_require_table_top(vctx *v) {
    char b[64];
    if (lua_type(v->L, -1) != LUA_TTABLE) sc_fail(v, "expected a table, got %s", sc_got(v->L, -1, b, sizeof b));
}

/* "KEY: required WHAT" when !present. */
void sc_require(vctx *v, int present, const char *key, const char *what) {
    if (present) return;
    sc_push_key(v, key);
    sc_fail(v, "required%s%s", what[0] ? " " : "", what);
}

int sc_parse_list(vctx *v, int top, const char *key, const char *example, size_t size, void **items, int *count,
                  sc_item_parser parse, void *ctx) {
    lua_State *L = v->L;
    if (!sc_table_field(v, top, key)) return 0;
    size_t old = sc_push_key(v, key);
    int lt = lua_gettop(L);
    int n = sc_list_len(v, lt, example);
    char *arr = calloc((size_t)n + 1, size);
    if (!arr) luaL_error(L, "out of memory");
    memcpy(items, &arr, sizeof arr); /* *items is a typed pointer (scene_object *, ...): stored bytewise */
    for (int i = 0; i < n; i++) {
        size_t o2 = sc_push_index(v, i + 1);
        lua_rawgeti(L, lt, i + 1);
        sc_require_table_top(v);
        (*count)++;
        parse(v, lua_gettop(L), i, arr + (size_t)i * size, ctx);
        lua_pop(L, 1);
        sc_pop_key(v, o2);
    }
    lua_pop(L, 1);
    sc_pop_key(v, old);
    return 1;
}

