/* The scene's items: shapes, materials, objects, colliders and emitters. Types, required keys and
 * the scene format's own rules are checked here; the library's numeric limits come from
 * sm_material_def_check and sm_collider_def_check (shapes too), reported at the scene's key. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>

#include "app/scene/scene_internal.h"

static const char *const shape_types[] = {"box", "sphere", "cylinder", "halfspace", "mesh"};
static const char *const keys_box[] = {"type", "center", "half_extent", "size", "rotation", "axis_angle", "inside_out"};
static const char *const keys_sphere[] = {"type", "center", "radius", "inside_out"};
static const char *const keys_cyl[] = {"type", "center", "radius", "half_height", "height", "rotation", "axis_angle",
                                       "inside_out"};
static const char *const keys_half[] = {"type", "point", "center", "normal", "inside_out"};
/* The library's limits on a shape (sm_collider_def_check on a one-shape collider), reported at the
 * shape's keys; as_size / as_height: the scene gave the full size / height. */
static void check_shape_limits(vctx *v, const sm_shape *s, int as_size, int as_height) {
    sm_collider_def c = sm_collider_def_default();
    c.shapes[0] = *s;
    c.shape_count = 1;
    char msg[256], buf[320];
    if (sm_collider_def_check(&c, v->s->def.dim, msg, sizeof msg) == SM_OK) return;
    const char *m = strncmp(msg, "shapes[0].", 10) ? msg : msg + 10;
    if (as_size && !strncmp(m, "half_extent: ", 13)) {
        snprintf(buf, sizeof buf, "size: %s (half_extent = size / 2)", m + 13);
        m = buf;
    } else if (as_height && !strncmp(m, "half_height: ", 13)) {
        snprintf(buf, sizeof buf, "height: %s (half_height = height / 2)", m + 13);
        m = buf;
    }
    static const char *const map[] = {"half_extent", "half_extent", "size", "size", "radius", "radius",
                                      "half_height", "half_height", "height", "height", "normal", "normal",
                                      "rotation", "rotation", NULL};
    sc_fail_library(v, m, map);
}

/* box: center, half_extent | size, rotation | axis_angle; returns whether size was given. */
static int parse_box(vctx *v, int t, sm_shape *s) {
    sc_check_keys(v, t, keys_box, SC_NKEYS(keys_box), "a box");
    sc_require(v, sc_vec_field(v, t, "center", s->center), "center", "for a box");
    double he[3] = {0, 0, 0}, sz[3] = {0, 0, 0};
    int h1 = sc_vec_field(v, t, "half_extent", he), h2 = sc_vec_field(v, t, "size", sz);
    if (h1 && h2) sc_fail(v, "give half_extent or size, not both");
    if (!h1 && !h2) sc_fail(v, "a box needs half_extent (half sizes) or size (full sizes)");
    for (int a = 0; a < v->s->def.dim; a++) s->half_extent[a] = h1 ? he[a] : 0.5 * sz[a];
    sc_rotation_fields(v, t, s->rotation);
    return h2;
}

/* cylinder: center, radius, half_height | height, rotation | axis_angle; returns whether height
 * was given. */
static int parse_cylinder(vctx *v, int t, sm_shape *s) {
    int has;
    sc_check_keys(v, t, keys_cyl, SC_NKEYS(keys_cyl), "a cylinder");
    sc_require(v, sc_vec_field(v, t, "center", s->center), "center", "for a cylinder");
    s->radius = sc_num_field(v, t, "radius", 0, &has, SC_NOLIM);
    sc_require(v, has, "radius", "for a cylinder");
    int h1, h2;
    double hh = sc_num_field(v, t, "half_height", 0, &h1, SC_NOLIM), h = sc_num_field(v, t, "height", 0, &h2, SC_NOLIM);
    if (h1 && h2) sc_fail(v, "give half_height or height, not both");
    if (!h1 && !h2) sc_fail(v, "a cylinder needs half_height or height (along its axis, local y)");
    s->half_height = h1 ? hh : 0.5 * h;
    sc_rotation_fields(v, t, s->rotation);
    return h2;
}

/* halfspace: point | center, normal. */
static void parse_halfspace(vctx *v, int t, sm_shape *s) {
    sc_check_keys(v, t, keys_half, SC_NKEYS(keys_half), "a halfspace");
    int h1 = sc_vec_field(v, t, "point", s->center);
    double c[3];
    int h2 = sc_vec_field(v, t, "center", c);
    if (h1 && h2) sc_fail(v, "give point or center, not both");
    if (!h1 && !h2) sc_fail(v, "a halfspace needs point (a point on its plane)");
    if (h2) memcpy(s->center, c, sizeof c);
    sc_require(v, sc_vec_field(v, t, "normal", s->normal), "normal", "for a halfspace (pointing out of the solid)");
}

/* The table on top of the stack (path already pushed) as a shape. */
static void parse_shape(vctx *v, sm_shape *out) {
    lua_State *L = v->L;
    sc_require_table_top(v);
    int t = lua_gettop(L);
    int ty = sc_get(v, t, "type");
    lua_pop(L, 1);
    sc_require(v, ty != LUA_TNIL, "type", "(\"box\", \"sphere\", \"cylinder\", \"halfspace\" or \"mesh\")");
    int kind = sc_enum_field(v, t, "type", shape_types, 5, 0);
    static const sm_shape_kind kinds[] = {SM_SHAPE_BOX, SM_SHAPE_SPHERE, SM_SHAPE_CYLINDER, SM_SHAPE_HALFSPACE,
                                          SM_SHAPE_MESH};
    sm_shape s = sm_shape_default(kinds[kind]);
    int has, as_size = 0, as_height = 0;
    switch (s.kind) {
    case SM_SHAPE_BOX: as_size = parse_box(v, t, &s); break;
    case SM_SHAPE_SPHERE:
        sc_check_keys(v, t, keys_sphere, SC_NKEYS(keys_sphere), "a sphere");
        sc_require(v, sc_vec_field(v, t, "center", s.center), "center", "for a sphere");
        s.radius = sc_num_field(v, t, "radius", 0, &has, SC_NOLIM);
        sc_require(v, has, "radius", "for a sphere");
        break;
    case SM_SHAPE_CYLINDER: as_height = parse_cylinder(v, t, &s); break;
    case SM_SHAPE_HALFSPACE: parse_halfspace(v, t, &s); break;
    case SM_SHAPE_MESH: sc_parse_mesh_shape(v, t, &s); break; /* its field comes after validation */
    }
    s.inside_out = sc_bool_field(v, t, "inside_out", 0);
    if (s.kind != SM_SHAPE_MESH) check_shape_limits(v, &s, as_size, as_height);
    *out = s;
}

/* t[key] as a shape; returns whether present. */
static int shape_field(vctx *v, int t, const char *key, sm_shape *out) {
    if (sc_get(v, t, key) == LUA_TNIL) {
        lua_pop(v->L, 1);
        return 0;
    }
    size_t old = sc_push_key(v, key);
    parse_shape(v, out);
    sc_pop_key(v, old);
    lua_pop(v->L, 1);
    return 1;
}

static const char *const mat_models[] = {"sand", "elastic"};
static const char *const keys_mat[] = {"model", "density", "E", "nu", "friction_angle", "hardening", "cone_fit",
                                       "repose_angle"};
static const char *const cone_fits[] = {"triaxial_compression", "plane_strain", "inscribed", "simple_shear"};

/* An angle in (0, pi/2] degrees is a sand that hardly holds together, and exactly what a value in
 * radians looks like: say so (a warning; such sand is allowed). */
static void warn_radians(vctx *v, const char *key, double degrees) {
    if (!(degrees > 0 && degrees <= 1.5708)) return;
    char a[32];
    size_t old = sc_push_key(v, key);
    const char *num = sc_fmt_num(a, degrees);
    sc_warn(v, "%s looks like radians (%s rad = %.1f degrees); angles are in degrees", num, num,
            degrees * 180 / 3.14159265358979323846);
    sc_pop_key(v, old);
}

/* Material keys cone_fit (sm_cone_fit, by name) and repose_angle: the angle theta of steady flow,
 * tan(theta) = mu_eff, turned into the friction angle of that fit in the scene's dimension
 * (sm_friction_angle_for_effective_friction; docs/validation.md). Returns the friction angle, or
 * -1 without repose_angle. */
static double parse_cone_fit(vctx *v, int t, sm_material_def *m) {
    m->cone_fit = (sm_cone_fit)sc_enum_field(v, t, "cone_fit", cone_fits, 4, 0);
    int has;
    double theta = sc_num_field(v, t, "repose_angle", 0, &has, 0.0, 1, 90.0, 0);
    if (!has) return -1;
    warn_radians(v, "repose_angle", theta);
    double phi = sm_friction_angle_for_effective_friction(tan(theta * 3.14159265358979323846 / 180), m->cone_fit,
                                                          v->s->def.dim);
    char a[32];
    size_t old = sc_push_key(v, "repose_angle");
    if (!(phi >= 0 && phi < 90))
        sc_fail(v, "%s degrees is beyond cone_fit \"%s\" in %dD (no friction angle below 90 gives it)",
                sc_fmt_num(a, theta), cone_fits[m->cone_fit], v->s->def.dim);
    sc_pop_key(v, old);
    return phi;
}

/* The library's limits on a material (sm_material_def_check), reported at the scene's key. */
static void check_material_limits(vctx *v, const sm_material_def *m) {
    char msg[256];
    if (sm_material_def_check(m, msg, sizeof msg) == SM_OK) return;
    static const char *const map[] = {"density", "density", "E", "E", "nu", "nu", "friction_angle", "friction_angle",
                                      "hardening", "hardening", "h0", "hardening.1", "h1", "hardening.2",
                                      "h2", "hardening.3", "h3", "hardening.4", NULL};
    sc_fail_library(v, msg, map);
}

/* materials.NAME (table at t). Types and the format's rules here; the limits are
 * sm_material_def_check's (density, E and nu checked first, with the model's default angles). */
static void parse_material(vctx *v, int t, sm_material_def *out) {
    sc_check_keys(v, t, keys_mat, SC_NKEYS(keys_mat), "a material");
    int model = sc_enum_field(v, t, "model", mat_models, 2, 0);
    sm_material_def m = model == 0 ? sm_material_def_sand() : sm_material_def_elastic();
    m.density = sc_num_field(v, t, "density", m.density, NULL, SC_NOLIM);
    m.youngs_modulus = sc_num_field(v, t, "E", m.youngs_modulus, NULL, SC_NOLIM);
    m.poisson_ratio = sc_num_field(v, t, "nu", m.poisson_ratio, NULL, SC_NOLIM);
    check_material_limits(v, &m);
    int has_fa, has_h = sc_get(v, t, "hardening") != LUA_TNIL;
    lua_pop(v->L, 1);
    double fa = sc_num_field(v, t, "friction_angle", 0, &has_fa, SC_NOLIM);
    if (has_fa) warn_radians(v, "friction_angle", fa);
    double fa_repose = parse_cone_fit(v, t, &m);
    if (fa_repose >= 0) {
        if (has_fa || model == 1)
            sc_fail(v, "repose_angle: %s", has_fa ? "give friction_angle or repose_angle, not both" : "only sand has one");
        fa = fa_repose, has_fa = 1;
    }
    if (model == 1) {
        if (has_fa || has_h)
            sc_fail(v, "an elastic material has no %s (only sand does)", has_fa ? "friction_angle" : "hardening");
    } else {
        if (has_fa && has_h) sc_fail(v, "give friction_angle or hardening, not both");
        if (!has_fa && !has_h)
            sc_fail(v, "sand needs friction_angle = degrees, repose_angle = degrees or hardening = {h0, h1, h2, h3} (e.g. {35, 9, 0.2, 10})");
        if (has_fa) {
            m.hardening = 0;
            m.friction_angle = fa;
        } else {
            size_t old = sc_push_key(v, "hardening");
            double h[4];
            sc_get(v, t, "hardening");
            sc_vec_top(v, 4, "{h0, h1, h2, h3} (degrees, degrees, -, degrees)", h);
            lua_pop(v->L, 1);
            sc_pop_key(v, old);
            m.hardening = 1;
            m.h0 = h[0];
            m.h1 = h[1];
            m.h2 = h[2];
            m.h3 = h[3];
        }
    }
    check_material_limits(v, &m);
    *out = m;
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(const char *const *)a, *(const char *const *)b); }

void sc_parse_materials(vctx *v, int top) {
    sm_scene *s = v->s;
    lua_State *L = v->L;
    if (!sc_table_field(v, top, "materials")) return;
    int t = lua_gettop(L);
    size_t old = sc_push_key(v, "materials");
    int n = 0;
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        if (lua_type(L, -1) != LUA_TSTRING)
            sc_fail(v, "expected named materials, materials = { sand = { ... } }, found a %s key", luaL_typename(L, -1));
        n++;
    }
    if (n > 65535) sc_fail(v, "too many materials");
    s->mat_names = calloc((size_t)n + 1, sizeof *s->mat_names);
    s->mats = calloc((size_t)n + 1, sizeof *s->mats);
    if (!s->mat_names || !s->mats) luaL_error(L, "out of memory");
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        if (!(s->mat_names[s->nmat] = sc_dup_str(lua_tostring(L, -1)))) luaL_error(L, "out of memory");
        s->nmat++;
    }
    qsort(s->mat_names, (size_t)s->nmat, sizeof *s->mat_names, cmp_str);
    for (int i = 0; i < s->nmat; i++) {
        size_t o2 = sc_push_key(v, s->mat_names[i]);
        sc_get(v, t, s->mat_names[i]);
        sc_require_table_top(v);
        parse_material(v, lua_gettop(L), &s->mats[i]);
        lua_pop(L, 1);
        sc_pop_key(v, o2);
    }
    sc_pop_key(v, old);
    lua_pop(L, 1);
}

/* t.material -> id (key optional when the scene has exactly one material). */
static int material_field(vctx *v, int t) {
    sm_scene *s = v->s;
    char b[64];
    int ty = sc_get(v, t, "material");
    size_t old = sc_push_key(v, "material");
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        if (s->nmat == 1) {
            sc_pop_key(v, old);
            return 0;
        }
        if (s->nmat == 0) sc_fail(v, "required, and the scene defines no materials (materials = { sand = { ... } })");
        sc_fail(v, "required (the scene has %d materials)", s->nmat);
    }
    if (ty != LUA_TSTRING) sc_fail(v, "expected a material name, got %s", sc_got(v->L, -1, b, sizeof b));
    const char *name = lua_tostring(v->L, -1);
    for (int i = 0; i < s->nmat; i++)
        if (!strcmp(name, s->mat_names[i])) {
            lua_pop(v->L, 1);
            sc_pop_key(v, old);
            return i;
        }
    const char *sug = sc_closest(name, (const char *const *)s->mat_names, s->nmat);
    if (sug) sc_fail(v, "unknown material \"%s\" (did you mean \"%s\"?)", name, sug);
    if (s->nmat == 0) sc_fail(v, "unknown material \"%s\": the scene defines no materials", name);
    sc_fail(v, "unknown material \"%s\" (the scene defines %d: %s%s)", name, s->nmat, s->mat_names[0],
          s->nmat > 1 ? ", ..." : "");
}

static const char *const sampling_names[] = {"jittered", "poisson"};
static const char *const keys_obj[] = {"shape", "material", "velocity", "angular_velocity",
                                       "ppc",   "sampling", "clip",     "seed"};

void sc_parse_object(vctx *v, int t, int i, void *item, void *ctx) {
    scene_object *o = item;
    const sc_list_defaults *dflt = ctx;
    sc_check_keys(v, t, keys_obj, SC_NKEYS(keys_obj), "an object");
    sc_require(v, shape_field(v, t, "shape", &o->shape), "shape", "");
    o->has_clip = shape_field(v, t, "clip", &o->clip);
    o->seed = sm_seed_def_default();
    o->seed.material = material_field(v, t);
    sc_vec_field(v, t, "velocity", o->seed.velocity);
    sc_angvel_field(v, t, "angular_velocity", o->seed.angular_velocity);
    o->seed.ppc = sc_num_field(v, t, "ppc", dflt->ppc, NULL, 0.0, 0, 4096.0, 1);
    o->seed.method = sc_enum_field(v, t, "sampling", sampling_names, 2, 0) ? SM_SEED_POISSON : SM_SEED_JITTERED;
    o->seed.seed = (uint64_t)sc_int_field(v, t, "seed", dflt->seed + i, NULL, 0, INT64_MAX);
    o->seed.clip = NULL; /* set at build: points into the scene's array */
}

const char *const sc_mode_names[3] = {"sticky", "slip", "separate"};
static const char *const keys_col[] = {"shape", "shapes", "inside_out", "mode", "friction", "position", "rotation",
                                       "axis_angle", "velocity", "angular_velocity", "keyframes", "motion"};
static const char *const keys_kf[] = {"t", "position", "rotation", "axis_angle"};

/* shape = {...} | shapes = { {...}, ... } (1..SM_MAX_COLLIDER_SHAPES) into d. */
static void parse_collider_shapes(vctx *v, int t, sm_collider_def *d) {
    lua_State *L = v->L;
    int has_shape = sc_get(v, t, "shape") != LUA_TNIL;
    lua_pop(L, 1);
    int has_shapes = sc_get(v, t, "shapes") != LUA_TNIL;
    lua_pop(L, 1);
    if (has_shape && has_shapes) sc_fail(v, "give shape or shapes, not both");
    if (!has_shape && !has_shapes) sc_fail(v, "a collider needs shape = {...} or shapes = { {...}, ... }");
    if (has_shape) {
        shape_field(v, t, "shape", &d->shapes[0]);
        d->shape_count = 1;
        return;
    }
    sc_table_field(v, t, "shapes");
    size_t old = sc_push_key(v, "shapes");
    int st = lua_gettop(L);
    int n = sc_list_len(v, st, "of shapes { {type = ...}, ... }");
    if (n < 1 || n > SM_MAX_COLLIDER_SHAPES) sc_fail(v, "need 1 to %d shapes, got %d", SM_MAX_COLLIDER_SHAPES, n);
    for (int i = 0; i < n; i++) {
        size_t o2 = sc_push_index(v, i + 1);
        lua_rawgeti(L, st, i + 1);
        parse_shape(v, &d->shapes[i]);
        lua_pop(L, 1);
        sc_pop_key(v, o2);
    }
    d->shape_count = n;
    lua_pop(L, 1);
    sc_pop_key(v, old);
}

/* One keyframe (a list item: item points into the collider's array, so item - 1 is the previous). */
static void parse_keyframe(vctx *v, int ft, int i, void *item, void *ctx) {
    (void)ctx;
    keyframe *k = item;
    sc_check_keys(v, ft, keys_kf, SC_NKEYS(keys_kf), "a keyframe");
    int has;
    k->t = sc_num_field(v, ft, "t", 0, &has, SC_NOLIM);
    sc_require(v, has, "t", "(the keyframe's time, s)");
    if (i > 0 && !(k->t > k[-1].t)) {
        char a[32], b[32];
        sc_push_key(v, "t");
        sc_fail(v, "keyframe times must increase, got %s after %s", sc_fmt_num(a, k->t), sc_fmt_num(b, k[-1].t));
    }
    sc_require(v, sc_vec_field(v, ft, "position", k->pos), "position", "");
    sc_rotation_fields(v, ft, k->rot);
}

/* motion = function(t): referenced from the registry and evaluated once at t = 0, so that its
 * errors show up at load time. */
static void parse_motion_function(vctx *v, int t, scene_collider *c) {
    lua_State *L = v->L;
    char b[64];
    size_t old = sc_push_key(v, "motion");
    sc_get(v, t, "motion");
    if (lua_type(L, -1) != LUA_TFUNCTION)
        sc_fail(v, "expected a function(t) returning position[, rotation], got %s", sc_got(L, -1, b, sizeof b));
    lua_Debug ar;
    lua_pushvalue(L, -1);
    if (lua_getinfo(L, ">S", &ar) && ar.linedefined > 0) c->fn_line = ar.linedefined;
    c->fn_ref = luaL_ref(L, LUA_REGISTRYINDEX);
    c->motion = MOTION_FUNCTION;
    lua_pushcfunction(L, sc_motion_call);
    lua_pushlightuserdata(L, c);
    lua_pushnumber(L, 0.0);
    int st = lua_pcall(L, 2, 0, 0);
    if (st != LUA_OK) {
        char msg[1024], out[1400];
        if (st == LUA_ERRMEM) lua_error(L); /* rethrow as is */
        sc_pop_error(L, st, msg, sizeof msg);
        sc_motion_error_text(v->s, c, 0.0, msg, out, sizeof out);
        lua_pushstring(L, out);
        lua_error(L);
    }
    c->last = c->tmp;
    sc_pop_key(v, old);
}

/* position/rotation/velocity/angular_velocity | keyframes | motion: at most one kind. */
static void parse_collider_motion(vctx *v, int t, scene_collider *c) {
    lua_State *L = v->L;
    sm_collider_def *d = &c->def;
    int has_pos = sc_vec_field(v, t, "position", d->pose.position);
    int has_rot = sc_rotation_fields(v, t, d->pose.rotation);
    int has_vel = sc_vec_field(v, t, "velocity", d->velocity);
    int has_av = sc_angvel_field(v, t, "angular_velocity", d->angular_velocity);
    int has_kf = sc_get(v, t, "keyframes") != LUA_TNIL;
    lua_pop(L, 1);
    int has_fn = sc_get(v, t, "motion") != LUA_TNIL;
    lua_pop(L, 1);
    if ((has_vel || has_av) + has_kf + has_fn > 1)
        sc_fail(v, "give at most one kind of motion: velocity/angular_velocity, keyframes or motion");
    if ((has_kf || has_fn) && (has_pos || has_rot)) {
        sc_push_key(v, has_pos ? "position" : "rotation");
        sc_fail(v, "not allowed with %s (they give the whole pose)", has_kf ? "keyframes" : "a motion function");
    }
    c->motion = MOTION_RIGID;
    if (has_kf) {
        sc_parse_list(v, t, "keyframes", "of keyframes { {t = 0, position = {...}}, ... }", sizeof *c->kf,
                      (void **)&c->kf, &c->nkf, parse_keyframe, NULL);
        if (c->nkf < 1) {
            sc_push_key(v, "keyframes");
            sc_fail(v, "need at least one keyframe");
        }
        c->motion = MOTION_KEYFRAMES;
    } else if (has_fn) {
        parse_motion_function(v, t, c);
    }
}

void sc_parse_collider(vctx *v, int t, int i, void *item, void *ctx) {
    (void)ctx;
    scene_collider *c = item;
    c->index = i + 1;
    c->scene = v->s;
    c->fn_ref = LUA_NOREF;
    lua_State *L = v->L;
    sm_collider_def *d = &c->def;
    sc_check_keys(v, t, keys_col, SC_NKEYS(keys_col), "a collider");
    *d = sm_collider_def_default();
    parse_collider_shapes(v, t, d);
    d->inside_out = sc_bool_field(v, t, "inside_out", 0);
    int ty = sc_get(v, t, "mode");
    lua_pop(L, 1);
    if (ty == LUA_TNIL) {
        sc_push_key(v, "mode");
        sc_fail(v, "required: \"sticky\", \"slip\" or \"separate\"");
    }
    static const sm_collide_mode modes[] = {SM_COLLIDE_STICKY, SM_COLLIDE_SLIP, SM_COLLIDE_SEPARATE};
    d->mode = modes[sc_enum_field(v, t, "mode", sc_mode_names, 3, 0)];
    d->friction = sc_num_field(v, t, "friction", 0, NULL, SC_NOLIM);
    char msg[256];
    sm_collider_def chk = *d; /* mesh shapes have no field yet: checked as a unit sphere in their place */
    for (int k = 0; k < chk.shape_count; k++)
        if (chk.shapes[k].kind == SM_SHAPE_MESH) {
            chk.shapes[k] = sm_shape_default(SM_SHAPE_SPHERE);
            chk.shapes[k].radius = 1;
        }
    if (sm_collider_def_check(&chk, v->s->def.dim, msg, sizeof msg) != SM_OK) {
        static const char *const map[] = {"friction", "friction", "shapes", "shapes", "mode", "mode", NULL};
        sc_fail_library(v, strncmp(msg, "collider ", 9) ? msg : msg + 9, map);
    }
    parse_collider_motion(v, t, c);
}

static const char *const keys_emit[] = {"shape", "material", "velocity", "rate", "start", "stop", "ppc", "seed"};

void sc_parse_emitter(vctx *v, int t, int i, void *item, void *ctx) {
    sm_emitter_def *e = item;
    const sc_list_defaults *dflt = ctx;
    sc_check_keys(v, t, keys_emit, SC_NKEYS(keys_emit), "an emitter");
    *e = sm_emitter_def_default();
    sc_require(v, shape_field(v, t, "shape", &e->shape), "shape", "");
    if (e->shape.kind == SM_SHAPE_HALFSPACE || e->shape.inside_out) {
        sc_push_key(v, "shape");
        sc_fail(v, "an emitter's shape must be a sphere, box, cylinder or closed mesh (not a halfspace, not inside_out)");
    }
    e->material = material_field(v, t);
    sc_vec_field(v, t, "velocity", e->velocity);
    int has;
    e->rate = sc_num_field(v, t, "rate", 0, &has, SC_GT0);
    sc_require(v, has, "rate", "(mass flow, kg/s; kg/(m s) in 2D)");
    e->start = sc_num_field(v, t, "start", 0, NULL, SC_NOLIM);
    int has_stop;
    double stop = sc_num_field(v, t, "stop", INFINITY, &has_stop, SC_NOLIM);
    if (has_stop && !(stop > e->start)) {
        char a[32], b[32];
        sc_push_key(v, "stop");
        sc_fail(v, "must be > start (%s), got %s", sc_fmt_num(a, e->start), sc_fmt_num(b, stop));
    }
    e->stop = stop;
    e->ppc = sc_num_field(v, t, "ppc", dflt->ppc, NULL, 0.0, 0, 4096.0, 1);
    e->seed = (uint64_t)sc_int_field(v, t, "seed", dflt->seed + i, NULL, 0, INT64_MAX);
}
