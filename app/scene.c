/* Lua 5.4 scene files; see scene.h.
 *
 * The format. A scene file returns a table; units are SI, vectors have `dim` components ({x, y}
 * in 2D, {x, y, z} in 3D), angles are degrees except angular velocities (rad/s, a number about z
 * in 2D). Every key is optional unless marked (required).
 *
 *   dim = 2 | 3 (3)                 dx = grid spacing, m (required)
 *   ppc = particles per cell (8 in 3D, 4 in 2D)
 *   kernel = "quadratic" | "cubic"  transfer = "apic" | "pic" | "flip"   flip_ratio = [0, 1]
 *   integrator = "explicit" | "implicit"   cfl = (0, 1]   max_dt = s   elastic_cfl = >= 0
 *   newton_tolerance = > 0   newton_max_iterations = 1..1000   gmres_max_iterations = 1..200
 *   gmres_tolerance = (0, 1)                (implicit only; defaults from sm_world_def_default)
 *   gmres_preconditioner = "none" | "block_jacobi"   (implicit only; default "none")
 *   fps = 24    frames = N | end_time = s (one of them, required)
 *   gravity = {0, -9.81, 0}   seed = whole number >= 0 (1)
 *   static_friction_sticks = bool   particle_projection = bool
 *   contact_gap = cells > 0 | false (the default: no contact gate)
 *   domain = { min = {..}, max = {..}, walls = "sticky" | "slip" | "separate", wall_friction = mu }
 *   materials = { NAME = { model = "sand" | "elastic" ("sand"), density, E, nu,
 *                          friction_angle = degrees | repose_angle = degrees | hardening = {h0, h1, h2, h3}
 *                          (sand: exactly one), cone_fit = "triaxial_compression" | "plane_strain" |
 *                          "inscribed" | "simple_shear" } }
 *   shape = { type = "box", center, half_extent | size, rotation | axis_angle }
 *         | { type = "sphere", center, radius }
 *         | { type = "cylinder", center, radius, half_height | height, rotation | axis_angle }
 *         | { type = "halfspace", point | center, normal }
 *         | { type = "mesh", file (required), unit, scale, rotation | axis_angle, position,
 *             sign = "auto" | "winding" | "one_sided", resolution, band }   (app/scene/meshes.c)
 *                                                                 each may have inside_out = true
 *     rotation = {w, x, y, z} (unit quaternion), axis_angle = {ax, ay, az, degrees}
 *   objects = { { shape (required), material (required unless there is one material), velocity,
 *                 angular_velocity, ppc, sampling = "jittered" | "poisson", clip = shape, seed }, ... }
 *   colliders = { { shape | shapes = {shape, ...} (1..16, union) (required), inside_out,
 *                   mode = "sticky" | "slip" | "separate" (required), friction = mu (0),
 *                   and at most one kind of motion:
 *                   position, rotation | axis_angle, velocity, angular_velocity (rigid, constant)
 *                 | keyframes = { {t, position (required), rotation | axis_angle}, ... } (t
 *                   increasing; position linear, rotation slerp, clamped outside)
 *                 | motion = function(t) return position, rotation_or_nil end }, ... }
 *   emitters = { { shape (required; a sphere, box, cylinder or closed mesh overlapping the domain), material,
 *                  velocity, rate = kg/s (required), start (0), stop (forever), ppc, seed }, ... }
 *   outputs = { ply = bool, vtk = bool, csv = bool }     (all true)
 *   camera = { eye (required), target (required), up = {0, 1, 0}, fov = 40 }   (3 components)
 *
 * Material ids are the material names in strcmp order. Objects and emitters without a seed get
 * the scene's seed + their index (from 0), so one object with the default seed 1 seeds exactly as
 * sm_seed_def_default() does. Globals: params (read-only in spirit; --set keys the scene never
 * reads are an error), axis_angle(ax, ay, az, degrees) -> {w, x, y, z}, print (to stderr).
 * math.random is seeded with 1 (reproducible); pairs() order is not reproducible across runs in
 * Lua 5.4 (randomised string hashing), so scenes should build lists with ipairs or numeric loops.
 * setmetatable refuses __gc (finalizers run with hooks off, out of the instruction limit's reach).
 *
 * Implementation: the work is split by job under app/scene/ (scene_internal.h says which file does
 * what). This file holds the public entry points: load reads the file, runs it in the sandbox,
 * validates the returned table into the scene struct and estimates what it will need; build (in
 * app/scene/build.c) creates the world; destroy frees everything. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>

#include "app/scene/scene_internal.h"

/* The file at path into s->source: SM_ERR_IO if it cannot be opened or read, SM_ERR_INVALID if it
 * is larger than SCENE_MAX_FILE. */
static sm_status read_file(sm_scene *s, const char *path, char *err, size_t errlen) {
    FILE *f = fopen(path, "rb");
    if (!f) return sc_fail_msg(err, errlen, SM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    sm_status st = SM_OK;
    while (buf) {
        if (n + 1 >= cap) {
            if (cap >= (size_t)SCENE_MAX_FILE) {
                st = sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s: file too large (more than %ld MB)", path,
                                 SCENE_MAX_FILE >> 20);
                break;
            }
            char *q = realloc(buf, cap * 2);
            if (!q) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = q;
            cap *= 2;
        }
        size_t r = fread(buf + n, 1, cap - 1 - n, f);
        n += r;
        if (r == 0) break;
    }
    if (st == SM_OK && !buf) st = sc_fail_msg(err, errlen, SM_ERR_NOMEM, "out of memory");
    if (st == SM_OK && ferror(f)) st = sc_fail_msg(err, errlen, SM_ERR_IO, "%s: cannot read: %s", path, strerror(errno));
    fclose(f);
    if (st != SM_OK) {
        free(buf);
        return st;
    }
    buf[n] = 0;
    s->source = buf;
    s->source_len = n;
    return SM_OK;
}

static void set_name(sm_scene *s, const char *path) {
    const char *base = path ? strrchr(path, '/') : NULL;
    base = base ? base + 1 : (path ? path : "scene");
    sc_copy_str(s->set.name, sizeof s->set.name, base);
    char *dot = strrchr(s->set.name, '.');
    if (dot && dot != s->set.name) *dot = 0;
    if (!s->set.name[0]) sc_copy_str(s->set.name, sizeof s->set.name, "scene");
}

/* The arguments of sm_scene_load that do not need the scene. */
static sm_status check_args(const char *path, const char *source, const sm_scene_param *params, int nparams,
                            const char *quality, int threads, char *err, size_t errlen) {
    if (!path && !source) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "sm_scene_load: need a path or a source");
    if (strcmp(quality, "preview") && strcmp(quality, "paper") && strcmp(quality, "test"))
        return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                           "quality: expected \"preview\", \"paper\" or \"test\", got \"%s\"", quality);
    if (threads < 0) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "threads: must be >= 0, got %d", threads);
    if (nparams < 0 || (nparams > 0 && !params)) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "sm_scene_load: bad params");
    for (int i = 0; i < nparams; i++) {
        const char *k = params[i].key;
        if (!k || !params[i].value) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "--set: missing key or value");
        if (!sc_is_identifier(k))
            return sc_fail_msg(err, errlen, SM_ERR_INVALID, "--set %s=%s: the key must be a name (letters, digits, _)",
                               k, params[i].value);
        if (!strcmp(k, "quality"))
            return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                               "--set quality=%s: params.quality comes from the quality option, not --set",
                               params[i].value);
    }
    return SM_OK;
}

/* The --set pairs into s->params (a repeated key: the last one wins). */
static sm_status copy_params(sm_scene *s, const sm_scene_param *params, int nparams, char *err, size_t errlen) {
    if (nparams == 0) return SM_OK;
    if (!(s->params = calloc((size_t)nparams, sizeof *s->params)))
        return sc_fail_msg(err, errlen, SM_ERR_NOMEM, "out of memory");
    for (int i = 0; i < nparams; i++) {
        int j = 0;
        while (j < s->nparams && strcmp(s->params[j].key, params[i].key)) j++;
        char *v = sc_dup_str(params[i].value);
        if (!v) return sc_fail_msg(err, errlen, SM_ERR_NOMEM, "out of memory");
        if (j < s->nparams) {
            free(s->params[j].value);
            s->params[j].value = v;
            continue;
        }
        s->params[j].value = v;
        if (!(s->params[j].key = sc_dup_str(params[i].key))) {
            free(v);
            s->params[j].value = NULL;
            return sc_fail_msg(err, errlen, SM_ERR_NOMEM, "out of memory");
        }
        s->nparams++;
    }
    return SM_OK;
}

/* Runs the scene file in a new sandbox and validates what it returns into s. */
static sm_status run_scene(sm_scene *s, const char *name, char *err, size_t errlen) {
    if (!(s->L = sc_sandbox_new(s))) return sc_fail_msg(err, errlen, SM_ERR_NOMEM, "out of memory (Lua state)");
    lua_State *L = s->L;
    sc_set_budget(s, sc_scene_limits.scene_insn, sc_scene_limits.scene_time, "the scene file");
    lua_pushcfunction(L, sc_sandbox_init);
    int st = lua_pcall(L, 0, 0, 0);
    if (st == LUA_OK) {
        char chunk[1100];
        snprintf(chunk, sizeof chunk, "@%s", name);
        st = luaL_loadbufferx(L, s->source, s->source_len, chunk, "t");
        if (st == LUA_OK) st = lua_pcall(L, 0, 1, 0);
        if (st == LUA_OK) {
            lua_pushcfunction(L, sc_validate);
            lua_insert(L, -2);
            lua_pushlightuserdata(L, s);
            st = lua_pcall(L, 2, 0, 0);
        }
    }
    if (st != LUA_OK) {
        char msg[1024];
        sc_pop_error(L, st, msg, sizeof msg);
        sm_status code = st == LUA_ERRMEM && !s->mem_hit ? SM_ERR_NOMEM : SM_ERR_INVALID;
        if (sc_has_position(msg) || !strncmp(msg, name, strlen(name))) return sc_fail_msg(err, errlen, code, "%s", msg);
        return sc_fail_msg(err, errlen, code, "%s: %s", name, msg);
    }
    lua_settop(L, 0);
    lua_gc(L, LUA_GCCOLLECT);
    return SM_OK;
}

sm_status sm_scene_load(const char *path, const char *source, const sm_scene_param *params, int nparams,
                        const char *quality, int threads, sm_scene **out, char *err, size_t errlen) {
    if (out) *out = NULL;
    if (err && errlen) err[0] = 0;
    if (!out) return sc_fail_msg(err, errlen, SM_ERR_INVALID, "sm_scene_load: out is NULL");
    const char *name = path ? path : "scene";
    if (!quality) quality = "preview";
    sm_status st = check_args(path, source, params, nparams, quality, threads, err, errlen);
    if (st != SM_OK) return st;
    sm_scene *s = calloc(1, sizeof *s);
    if (!s) return sc_fail_msg(err, errlen, SM_ERR_NOMEM, "out of memory");
    sc_copy_str(s->path, sizeof s->path, name);
    sc_copy_str(s->quality, sizeof s->quality, quality);
    set_name(s, path);
    s->def = sm_world_def_default();
    s->def.threads = threads;
    s->mem_limit = sc_scene_limits.mem;
    st = copy_params(s, params, nparams, err, errlen);
    if (st == SM_OK && source) {
        if ((s->source = sc_dup_str(source)) != NULL) s->source_len = strlen(source);
        else st = sc_fail_msg(err, errlen, SM_ERR_NOMEM, "out of memory");
    } else if (st == SM_OK) {
        st = read_file(s, path, err, errlen);
    }
    if (st == SM_OK) st = run_scene(s, name, err, errlen);
    if (st == SM_OK) st = sc_build_meshes(s, err, errlen);
    if (st == SM_OK) st = sc_finish_load(s, err, errlen);
    if (st != SM_OK) {
        sm_scene_destroy(s);
        return st;
    }
    *out = s;
    return SM_OK;
}

const sm_scene_settings *sm_scene_get_settings(const sm_scene *s) { return &s->set; }

int sm_scene_warning_count(const sm_scene *s) { return s ? s->nwarn : 0; }

const char *sm_scene_warning(const sm_scene *s, int i) {
    return s && i >= 0 && i < s->nwarn && i < SC_MAX_WARN ? s->warn[i] : NULL;
}
const sm_world_def *sm_scene_world_def(const sm_scene *s) { return &s->def; }
int sm_scene_material_count(const sm_scene *s) { return s->nmat; }
const char *sm_scene_material_name(const sm_scene *s, int id) {
    return id >= 0 && id < s->nmat ? s->mat_names[id] : NULL;
}
sm_world *sm_scene_world(sm_scene *s) { return s ? s->world : NULL; }
const char *sm_scene_motion_error(const sm_scene *s) { return s && s->motion_err[0] ? s->motion_err : NULL; }

void sm_scene_destroy(sm_scene *s) {
    if (!s) return;
    sm_world_destroy(s->world);
    if (s->L) {
        s->hooks_on = 0; /* no scene code runs here (no __gc) */
        lua_close(s->L);
    }
    for (int i = 0; i < s->nmat; i++) free(s->mat_names[i]);
    free(s->mat_names);
    free(s->mats);
    free(s->objs);
    for (int i = 0; i < s->ncol; i++) free(s->cols[i].kf);
    free(s->cols);
    free(s->emits);
    sc_free_meshes(s);
    for (int i = 0; i < s->nparams; i++) {
        free(s->params[i].key);
        free(s->params[i].value);
    }
    free(s->params);
    for (int i = 0; i < s->nread; i++) free(s->read_keys[i]);
    free(s->read_keys);
    free(s->source);
    free(s);
}
