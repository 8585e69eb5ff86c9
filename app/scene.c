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
 *   fps = 24    frames = N | end_time = s (one of them, required)
 *   gravity = {0, -9.81, 0}   seed = whole number >= 0 (1)
 *   static_friction_sticks = bool   particle_projection = bool
 *   domain = { min = {..}, max = {..}, walls = "sticky" | "slip" | "separate", wall_friction = mu }
 *   materials = { NAME = { model = "sand" | "elastic" ("sand"), density, E, nu,
 *                          friction_angle = degrees | repose_angle = degrees | hardening = {h0, h1, h2, h3}
 *                          (sand: exactly one), cone_fit = "triaxial_compression" | "plane_strain" |
 *                          "inscribed" | "simple_shear" } }
 *   shape = { type = "box", center, half_extent | size, rotation | axis_angle }
 *         | { type = "sphere", center, radius }
 *         | { type = "cylinder", center, radius, half_height | height, rotation | axis_angle }
 *         | { type = "halfspace", point | center, normal }       each may have inside_out = true
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
 *   emitters = { { shape (required; a sphere, box or cylinder overlapping the domain), material,
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
 * Implementation: the file runs in a fresh lua_State with a counting allocator (memory limit) and
 * a count hook (instruction limit); the returned table is then validated by C code that runs
 * inside lua_pcall too, so a validation error is a Lua error carrying the finished message and
 * nothing is allocated outside the scene struct (which sm_scene_destroy frees). Keyframes are
 * evaluated in C; motion functions are called through lua_pcall from the library's sm_motion_fn. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>
#include <lua5.4/lualib.h>

#include "app/scene.h"

#define SCENE_INSN_LIMIT 50000000LL  /* Lua instructions for running the scene file */
#define MOTION_INSN_LIMIT 1000000LL  /* per motion-function call */
#define HOOK_STEP 1000               /* the count hook runs every HOOK_STEP instructions */
#define SCENE_MEM_LIMIT ((size_t)256 << 20)
#define SCENE_MAX_FILE ((long)16 << 20)
#define SCENE_MAX_LIST 1000000

enum { MOTION_RIGID = 0, MOTION_KEYFRAMES = 1, MOTION_FUNCTION = 2 };

typedef struct keyframe {
    double t, pos[3], rot[4];
} keyframe;

typedef struct scene_collider {
    sm_collider_def def;
    int motion;        /* MOTION_* */
    keyframe *kf;
    int nkf;
    int fn_ref;        /* registry reference of the motion function */
    int fn_line;       /* where the motion function is defined (0 if unknown) */
    sm_pose last;      /* last good pose of a motion function */
    sm_pose tmp;
    int index;         /* 1-based, for messages */
    struct sm_scene *scene;
} scene_collider;

typedef struct scene_object {
    sm_shape shape, clip;
    int has_clip;
    sm_seed_def seed;
} scene_object;

typedef struct scene_param {
    char *key, *value;
    int used;
} scene_param;

struct sm_scene {
    lua_State *L;
    size_t mem, mem_limit;
    int mem_hit;
    long long insn, insn_limit;
    char path[1024];
    char *source;
    size_t source_len;
    char quality[16];
    sm_scene_settings set;
    sm_world_def def;
    int nmat;
    char **mat_names;
    sm_material_def *mats;
    int nobj;
    scene_object *objs;
    int ncol;
    scene_collider *cols;
    int nemit;
    sm_emitter_def *emits;
    int nparams;
    scene_param *params;
    char **read_keys; /* params.KEY the scene read that --set did not give (for suggestions) */
    int nread, read_cap;
    sm_world *world;
    int built;
    char motion_err[1024];
};

/* ------------------------------------------------------------------------------------------ */
/* Small helpers                                                                                */

static void copy_str(char *dst, size_t n, const char *src) {
    if (!dst || n == 0) return;
    snprintf(dst, n, "%s", src ? src : "");
}

static char *dup_str(const char *s) {
    size_t n = strlen(s) + 1;
    char *p = malloc(n);
    if (p) memcpy(p, s, n);
    return p;
}

/* A number for a message: %g, with NaN and infinities spelled out. */
static const char *fmt_num(char buf[32], double x) {
    if (isnan(x)) return "NaN";
    if (isinf(x)) return x > 0 ? "inf" : "-inf";
    snprintf(buf, 32, "%g", x);
    return buf;
}

/* Optimal string alignment distance, case-insensitive (strings up to 63 characters). */
static int edit_distance(const char *a, const char *b) {
    size_t n = strlen(a), m = strlen(b);
    if (n > 63 || m > 63) return 1000;
    int d[64][64];
    for (size_t i = 0; i <= n; i++) d[i][0] = (int)i;
    for (size_t j = 0; j <= m; j++) d[0][j] = (int)j;
    for (size_t i = 1; i <= n; i++)
        for (size_t j = 1; j <= m; j++) {
            int ca = tolower((unsigned char)a[i - 1]), cb = tolower((unsigned char)b[j - 1]);
            int cost = ca != cb;
            int v = d[i - 1][j] + 1;
            if (d[i][j - 1] + 1 < v) v = d[i][j - 1] + 1;
            if (d[i - 1][j - 1] + cost < v) v = d[i - 1][j - 1] + cost;
            if (i > 1 && j > 1 && ca == tolower((unsigned char)b[j - 2]) && tolower((unsigned char)a[i - 2]) == cb &&
                d[i - 2][j - 2] + 1 < v)
                v = d[i - 2][j - 2] + 1;
            d[i][j] = v;
        }
    return d[n][m];
}

/* The candidate closest to word, or NULL if none is close enough to be a likely typo. */
static const char *closest(const char *word, const char *const *cands, int n) {
    size_t len = strlen(word);
    int limit = len <= 3 ? 1 : len <= 6 ? 2 : 3, best = 1000;
    const char *pick = NULL;
    for (int i = 0; i < n; i++) {
        int d = edit_distance(word, cands[i]);
        if (d < best) {
            best = d;
            pick = cands[i];
        }
    }
    return best <= limit ? pick : NULL;
}

static int is_ident_char(int c) { return isalnum((unsigned char)c) || c == '_'; }

static int is_identifier(const char *s) {
    if (!s[0] || isdigit((unsigned char)s[0])) return 0;
    for (; *s; s++)
        if (!is_ident_char(*s)) return 0;
    return 1;
}

/* The line of `key =` in the source if it occurs on exactly one line (outside comments), else 0.
 * Only a hint for messages: table fields carry no line numbers once the chunk has run. */
static int key_line(const char *src, const char *key) {
    if (!src || !key[0]) return 0;
    size_t kl = strlen(key);
    int line = 1, found = 0, nfound = 0, in_comment = 0;
    const char *p = src;
    for (;;) {
        const char *nl = strchr(p, '\n');
        const char *end = nl ? nl : p + strlen(p);
        const char *q = p;
        int hit = 0;
        while (q < end) {
            if (in_comment) {
                if (q + 1 < end && q[0] == ']' && q[1] == ']') {
                    in_comment = 0;
                    q += 2;
                } else {
                    q++;
                }
                continue;
            }
            if (q + 1 < end && q[0] == '-' && q[1] == '-') {
                if (q + 3 < end && q[2] == '[' && q[3] == '[') {
                    in_comment = 1;
                    q += 4;
                    continue;
                }
                break; /* line comment */
            }
            if ((size_t)(end - q) >= kl && memcmp(q, key, kl) == 0 && (q == p || !is_ident_char(q[-1])) &&
                (q + kl == end || !is_ident_char(q[kl]))) {
                const char *r = q + kl;
                while (r < end && (*r == ' ' || *r == '\t')) r++;
                if (r < end && *r == '=' && (r + 1 == end || r[1] != '=')) hit = 1;
            }
            q++;
        }
        if (hit) {
            nfound++;
            found = line;
        }
        if (!nl) break;
        p = nl + 1;
        line++;
    }
    return nfound == 1 ? found : 0;
}

/* Quaternion (w,x,y,z) of a rotation by deg degrees about an axis (normalised here). */
static int quat_axis_angle(double ax, double ay, double az, double deg, double q[4]) {
    double n = sqrt(ax * ax + ay * ay + az * az);
    if (!(n > 0) || !isfinite(n) || !isfinite(deg)) return 0;
    double h = 0.5 * deg * (3.14159265358979323846 / 180.0), s = sin(h) / n;
    q[0] = cos(h);
    q[1] = ax * s;
    q[2] = ay * s;
    q[3] = az * s;
    return 1;
}

static void quat_identity(double q[4]) {
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

/* ------------------------------------------------------------------------------------------ */
/* Lua state: memory limit, instruction limit, sandbox                                          */

static sm_scene *scene_of(lua_State *L) { return *(sm_scene **)lua_getextraspace(L); }

static void *scene_alloc(void *ud, void *ptr, size_t osize, size_t nsize) {
    sm_scene *s = ud;
    size_t old = ptr ? osize : 0;
    if (nsize == 0) {
        free(ptr);
        s->mem -= old;
        return NULL;
    }
    if (nsize > old && s->mem + (nsize - old) > s->mem_limit) {
        s->mem_hit = 1;
        return NULL;
    }
    void *q = realloc(ptr, nsize);
    if (!q) return nsize <= old ? ptr : NULL; /* Lua assumes shrinking never fails */
    s->mem = s->mem - old + nsize;
    return q;
}

static void insn_hook(lua_State *L, lua_Debug *ar) {
    (void)ar;
    sm_scene *s = scene_of(L);
    s->insn += HOOK_STEP;
    if (s->insn > s->insn_limit) {
        /* From now on every instruction fails, so a pcall in the script cannot swallow this. */
        lua_sethook(L, insn_hook, LUA_MASKCOUNT, 1);
        luaL_where(L, 0); /* in a hook, level 0 is the interrupted function */
        lua_pushfstring(L, "instruction limit exceeded (%d million Lua instructions): an endless loop?",
                        (int)(s->insn_limit / 1000000));
        lua_concat(L, 2);
        lua_error(L);
    }
}

static void set_budget(sm_scene *s, long long limit) {
    s->insn = 0;
    s->insn_limit = limit;
    lua_sethook(s->L, insn_hook, LUA_MASKCOUNT, HOOK_STEP);
}

static void mark_param_used(sm_scene *s, const char *key) {
    for (int i = 0; i < s->nparams; i++)
        if (!strcmp(s->params[i].key, key)) {
            s->params[i].used = 1;
            return;
        }
    for (int i = 0; i < s->nread; i++)
        if (!strcmp(s->read_keys[i], key)) return;
    if (s->nread == s->read_cap) {
        if (s->read_cap >= 4096) return;
        int cap = s->read_cap ? 2 * s->read_cap : 16;
        char **q = realloc(s->read_keys, (size_t)cap * sizeof *q);
        if (!q) return;
        s->read_keys = q;
        s->read_cap = cap;
    }
    if ((s->read_keys[s->nread] = dup_str(key)) != NULL) s->nread++;
}

/* params: an empty proxy whose metatable records which keys the scene reads. */
static int params_index(lua_State *L) {
    if (lua_type(L, 2) == LUA_TSTRING) mark_param_used(scene_of(L), lua_tostring(L, 2));
    lua_pushvalue(L, 2);
    lua_rawget(L, lua_upvalueindex(1));
    return 1;
}

static int params_newindex(lua_State *L) {
    lua_settop(L, 3);
    lua_pushvalue(L, 2);
    lua_pushvalue(L, 3);
    lua_rawset(L, lua_upvalueindex(1));
    return 0;
}

static int params_next(lua_State *L) {
    luaL_checktype(L, 1, LUA_TTABLE);
    lua_settop(L, 2);
    if (lua_next(L, 1)) return 2;
    lua_pushnil(L);
    return 1;
}

static int params_pairs(lua_State *L) {
    sm_scene *s = scene_of(L);
    for (int i = 0; i < s->nparams; i++) s->params[i].used = 1;
    lua_pushcfunction(L, params_next);
    lua_pushvalue(L, lua_upvalueindex(1));
    lua_pushnil(L);
    return 3;
}

static const char *const forbidden[] = {"io", "os", "package", "require", "debug", "dofile", "loadfile", "load",
                                        "loadstring", "coroutine", "module"};

static int globals_index(lua_State *L) {
    const char *k = lua_type(L, 2) == LUA_TSTRING ? lua_tostring(L, 2) : NULL;
    if (k)
        for (size_t i = 0; i < sizeof forbidden / sizeof forbidden[0]; i++)
            if (!strcmp(k, forbidden[i]))
                return luaL_error(L, "%s is not available in scene files (they run in a sandbox: math, string and "
                                     "table only, no files or OS access)", k);
    return 0;
}

/* setmetatable without __gc: Lua runs finalizers with hooks off, so the instruction limit could not
 * stop one (and an object is only finalized if its metatable had __gc when it was set). */
static int scene_setmetatable(lua_State *L) { /* lbaselib.c's, plus the __gc check */
    int t = lua_type(L, 2);
    luaL_checktype(L, 1, LUA_TTABLE);
    luaL_argexpected(L, t == LUA_TNIL || t == LUA_TTABLE, 2, "nil or table");
    if (t == LUA_TTABLE) {
        lua_pushliteral(L, "__gc");
        if (lua_rawget(L, 2) != LUA_TNIL) return luaL_error(L, "__gc metamethods are not allowed in scene files");
        lua_pop(L, 1);
    }
    if (luaL_getmetafield(L, 1, "__metatable") != LUA_TNIL) return luaL_error(L, "cannot change a protected metatable");
    lua_settop(L, 2);
    lua_setmetatable(L, 1);
    return 1;
}

static int forbidden_dump(lua_State *L) {
    return luaL_error(L, "string.dump is not available in scene files (they run in a sandbox)");
}

static int scene_print(lua_State *L) {
    int n = lua_gettop(L);
    for (int i = 1; i <= n; i++) {
        size_t len;
        const char *str = luaL_tolstring(L, i, &len);
        if (i > 1) fputc('\t', stderr);
        fwrite(str, 1, len, stderr);
        lua_pop(L, 1);
    }
    fputc('\n', stderr);
    return 0;
}

static int lua_axis_angle(lua_State *L) {
    double q[4];
    double ax = luaL_checknumber(L, 1), ay = luaL_checknumber(L, 2), az = luaL_checknumber(L, 3),
           deg = luaL_checknumber(L, 4);
    if (!quat_axis_angle(ax, ay, az, deg, q))
        return luaL_error(L, "axis_angle: need a finite non-zero axis and a finite angle");
    lua_createtable(L, 4, 0);
    for (int k = 0; k < 4; k++) {
        lua_pushnumber(L, q[k]);
        lua_rawseti(L, -2, k + 1);
    }
    return 1;
}

/* Runs protected: opens the allowed libraries and sets up the globals. */
static int scene_init(lua_State *L) {
    sm_scene *s = scene_of(L);
    luaL_requiref(L, LUA_GNAME, luaopen_base, 1);
    luaL_requiref(L, LUA_MATHLIBNAME, luaopen_math, 1);
    luaL_requiref(L, LUA_STRLIBNAME, luaopen_string, 1);
    luaL_requiref(L, LUA_TABLIBNAME, luaopen_table, 1);
    luaL_requiref(L, LUA_UTF8LIBNAME, luaopen_utf8, 1);
    lua_settop(L, 0);
    for (size_t i = 0; i < sizeof forbidden / sizeof forbidden[0]; i++) {
        lua_pushnil(L);
        lua_setglobal(L, forbidden[i]);
    }
    /* Lua 5.4 seeds math.random from the clock: make scenes that use it reproducible. */
    lua_getglobal(L, LUA_MATHLIBNAME);
    lua_getfield(L, -1, "randomseed");
    lua_pushinteger(L, 1);
    lua_call(L, 1, 0);
    lua_pop(L, 1);
    lua_getglobal(L, LUA_STRLIBNAME);
    lua_pushcfunction(L, forbidden_dump);
    lua_setfield(L, -2, "dump");
    lua_pop(L, 1);
    lua_pushcfunction(L, scene_print);
    lua_setglobal(L, "print");
    lua_pushcfunction(L, scene_setmetatable);
    lua_setglobal(L, "setmetatable");
    lua_pushcfunction(L, lua_axis_angle);
    lua_setglobal(L, "axis_angle");
    /* _G's metatable: clear messages for the removed libraries. */
    lua_pushglobaltable(L);
    lua_createtable(L, 0, 2);
    lua_pushcfunction(L, globals_index);
    lua_setfield(L, -2, "__index");
    lua_pushboolean(L, 0);
    lua_setfield(L, -2, "__metatable");
    lua_setmetatable(L, -2);
    lua_pop(L, 1);
    /* params */
    lua_newtable(L); /* storage */
    int storage = lua_gettop(L);
    lua_pushstring(L, s->quality);
    lua_setfield(L, storage, "quality");
    for (int i = 0; i < s->nparams; i++) {
        const char *v = s->params[i].value;
        if (!strcmp(v, "true")) lua_pushboolean(L, 1);
        else if (!strcmp(v, "false")) lua_pushboolean(L, 0);
        else if (lua_stringtonumber(L, v) == 0) lua_pushstring(L, v);
        lua_setfield(L, storage, s->params[i].key);
    }
    lua_newtable(L); /* proxy */
    lua_createtable(L, 0, 4);
    lua_pushvalue(L, storage);
    lua_pushcclosure(L, params_index, 1);
    lua_setfield(L, -2, "__index");
    lua_pushvalue(L, storage);
    lua_pushcclosure(L, params_newindex, 1);
    lua_setfield(L, -2, "__newindex");
    lua_pushvalue(L, storage);
    lua_pushcclosure(L, params_pairs, 1);
    lua_setfield(L, -2, "__pairs");
    lua_setmetatable(L, -2);
    lua_setglobal(L, "params");
    lua_settop(L, 0);
    return 0;
}

/* The message of a failed pcall (top of the stack), popped, into buf. */
static void pop_error(lua_State *L, int status, char *buf, size_t n) {
    sm_scene *s = scene_of(L);
    if (status == LUA_ERRMEM) {
        if (s->mem_hit) snprintf(buf, n, "memory limit exceeded (%zu MB of Lua memory)", s->mem_limit >> 20);
        else snprintf(buf, n, "out of memory");
    } else if (lua_type(L, -1) == LUA_TSTRING || lua_type(L, -1) == LUA_TNUMBER) {
        copy_str(buf, n, lua_tostring(L, -1));
    } else {
        snprintf(buf, n, "(error object is a %s value)", luaL_typename(L, -1));
    }
    lua_pop(L, 1);
}

/* Does msg already start with Lua's "chunk:line:" position? */
static int has_position(const char *msg) {
    const char *c = strchr(msg, ':');
    while (c) {
        const char *d = c + 1;
        if (isdigit((unsigned char)*d)) {
            while (isdigit((unsigned char)*d)) d++;
            if (*d == ':') return 1;
        }
        if (c - msg > 512) break;
        c = strchr(c + 1, ':');
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Validation: runs inside lua_pcall; vfail raises a Lua error with the finished message.       */

typedef struct vctx {
    sm_scene *s;
    lua_State *L;
    char path[512];
    size_t plen;
} vctx;

static size_t vpush(vctx *v, const char *key) {
    size_t old = v->plen;
    if (is_identifier(key)) snprintf(v->path + old, sizeof v->path - old, old ? ".%s" : "%s", key);
    else snprintf(v->path + old, sizeof v->path - old, "[\"%s\"]", key);
    v->plen = strlen(v->path);
    return old;
}

static size_t vpushi(vctx *v, long long i) {
    size_t old = v->plen;
    snprintf(v->path + old, sizeof v->path - old, "[%lld]", i);
    v->plen = strlen(v->path);
    return old;
}

static void vpop(vctx *v, size_t old) {
    v->plen = old;
    v->path[old] = 0;
}

/* The last named component of the current key path ("colliders[2].shapes[1].center[3]" -> "center"). */
static void last_name(const vctx *v, char *out, size_t n) {
    size_t e = v->plen;
    while (e > 0 && v->path[e - 1] == ']') { /* strip [..] suffixes */
        size_t b = e - 1;
        while (b > 0 && v->path[b] != '[') b--;
        if (b + 1 < e && v->path[b + 1] == '"') { /* ["name"] */
            size_t len = e - b - 4 < n - 1 ? e - b - 4 : n - 1;
            memcpy(out, v->path + b + 2, len);
            out[len] = 0;
            return;
        }
        e = b;
    }
    size_t b = e;
    while (b > 0 && v->path[b - 1] != '.' && v->path[b - 1] != ']') b--;
    size_t len = e - b < n - 1 ? e - b : n - 1;
    memcpy(out, v->path + b, len);
    out[len] = 0;
}

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3), noreturn))
#endif
static void vfail(vctx *v, const char *fmt, ...) {
    char msg[768], name[128], out[2400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    last_name(v, name, sizeof name);
    int line = key_line(v->s->source, name);
    char where[1100];
    if (line > 0) snprintf(where, sizeof where, "%s:%d", v->s->path, line);
    else snprintf(where, sizeof where, "%s", v->s->path);
    if (v->plen) snprintf(out, sizeof out, "%s: %s: %s", where, v->path, msg);
    else snprintf(out, sizeof out, "%s: %s", where, msg);
    lua_pushstring(v->L, out);
    lua_error(v->L);
    abort(); /* not reached */
}

/* Describes the value at idx for "got ...". */
static const char *got(lua_State *L, int idx, char *buf, size_t n) {
    if (lua_type(L, idx) == LUA_TSTRING) {
        const char *str = lua_tostring(L, idx);
        if (strlen(str) <= 40) snprintf(buf, n, "string \"%s\"", str);
        else snprintf(buf, n, "string");
        return buf;
    }
    return luaL_typename(L, idx);
}

/* Pushes t[key] (raw access: scene tables are plain data) and returns its type. */
static int vget(vctx *v, int t, const char *key) {
    lua_pushstring(v->L, key);
    return lua_rawget(v->L, t);
}

static void check_keys(vctx *v, int t, const char *const *allowed, int n, const char *what) {
    lua_State *L = v->L;
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        if (lua_type(L, -1) != LUA_TSTRING) {
            char kb[64];
            if (lua_isinteger(L, -1)) snprintf(kb, sizeof kb, "[%lld]", (long long)lua_tointeger(L, -1));
            else snprintf(kb, sizeof kb, "a %s key", luaL_typename(L, -1));
            vfail(v, "unexpected entry %s: %s has named keys (key = value), not a list", kb, what);
        }
        const char *k = lua_tostring(L, -1);
        int ok = 0;
        for (int i = 0; i < n && !ok; i++) ok = !strcmp(k, allowed[i]);
        if (ok) continue;
        vpush(v, k);
        if (v->plen == strlen(k) && !strcmp(k, "threads"))
            vfail(v, "not a scene key: the number of threads is a command-line option (--threads)");
        const char *sug = closest(k, allowed, n);
        if (sug) vfail(v, "unknown key (did you mean \"%s\"?)", sug);
        char list[512] = "";
        size_t len = 0;
        for (int i = 0; i < n && len < sizeof list - 64; i++)
            len += (size_t)snprintf(list + len, sizeof list - len, "%s%s", i ? ", " : "", allowed[i]);
        vfail(v, "unknown key (%s takes: %s)", what, list);
    }
}

/* The number of entries of the list at t, which must be a sequence 1..n. */
static int list_len(vctx *v, int t, const char *example) {
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
            vfail(v, "expected a list %s, found key %s", example,
                  lua_type(L, -1) == LUA_TSTRING ? (snprintf(buf, sizeof buf, "\"%s\"", lua_tostring(L, -1)), buf)
                                                 : luaL_typename(L, -1));
        }
        count++;
    }
    if (count != n) vfail(v, "expected a list %s without holes", example);
    if (n > SCENE_MAX_LIST) vfail(v, "too many entries (%llu)", (unsigned long long)n);
    return (int)n;
}

/* The value on top must be a finite number. */
static double vnum_top(vctx *v) {
    char b[64], nb[32];
    if (lua_type(v->L, -1) != LUA_TNUMBER) vfail(v, "expected a number, got %s", got(v->L, -1, b, sizeof b));
    double x = (double)lua_tonumber(v->L, -1);
    if (!isfinite(x)) vfail(v, "must be a finite number, got %s", fmt_num(nb, x));
    return x;
}

/* x in the interval (lo, hi), each end open or closed (an infinite end is no bound). */
static void vrange(vctx *v, double x, double lo, int lo_closed, double hi, int hi_closed) {
    char a[32], b[32], c[32];
    int ok_lo = isinf(lo) || (lo_closed ? x >= lo : x > lo);
    int ok_hi = isinf(hi) || (hi_closed ? x <= hi : x < hi);
    if (ok_lo && ok_hi) return;
    if (isinf(hi)) vfail(v, "must be %s %s, got %s", lo_closed ? ">=" : ">", fmt_num(a, lo), fmt_num(c, x));
    if (isinf(lo)) vfail(v, "must be %s %s, got %s", hi_closed ? "<=" : "<", fmt_num(b, hi), fmt_num(c, x));
    vfail(v, "must be in %c%s, %s%c, got %s", lo_closed ? '[' : '(', fmt_num(a, lo), fmt_num(b, hi),
          hi_closed ? ']' : ')', fmt_num(c, x));
}

#define NOLIM (-INFINITY), 0, INFINITY, 0
#define GT0 0.0, 0, INFINITY, 0
#define GE0 0.0, 1, INFINITY, 0

/* t[key] as a number in a range; def if absent (*present = 0). */
static double num_field(vctx *v, int t, const char *key, double def, int *present, double lo, int lo_closed, double hi,
                        int hi_closed) {
    int ty = vget(v, t, key);
    if (present) *present = ty != LUA_TNIL;
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        return def;
    }
    size_t old = vpush(v, key);
    double x = vnum_top(v);
    vrange(v, x, lo, lo_closed, hi, hi_closed);
    vpop(v, old);
    lua_pop(v->L, 1);
    return x;
}

static long long int_field(vctx *v, int t, const char *key, long long def, int *present, long long lo, long long hi) {
    char b[64];
    int ty = vget(v, t, key);
    if (present) *present = ty != LUA_TNIL;
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        return def;
    }
    size_t old = vpush(v, key);
    if (ty != LUA_TNUMBER) vfail(v, "expected a whole number, got %s", got(v->L, -1, b, sizeof b));
    int isint;
    lua_Integer i = lua_tointegerx(v->L, -1, &isint);
    if (!isint) {
        char nb[32];
        vfail(v, "expected a whole number, got %s", fmt_num(nb, (double)lua_tonumber(v->L, -1)));
    }
    if (i < lo || i > hi) vfail(v, "must be in %lld .. %lld, got %lld", lo, hi, (long long)i);
    vpop(v, old);
    lua_pop(v->L, 1);
    return (long long)i;
}

static int bool_field(vctx *v, int t, const char *key, int def) {
    char b[64];
    int ty = vget(v, t, key);
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        return def;
    }
    size_t old = vpush(v, key);
    if (ty != LUA_TBOOLEAN) vfail(v, "expected true or false, got %s", got(v->L, -1, b, sizeof b));
    int r = lua_toboolean(v->L, -1);
    vpop(v, old);
    lua_pop(v->L, 1);
    return r;
}

static int enum_field(vctx *v, int t, const char *key, const char *const *names, int n, int def) {
    char b[64], list[256] = "";
    int ty = vget(v, t, key);
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        return def;
    }
    size_t old = vpush(v, key);
    size_t len = 0;
    for (int i = 0; i < n; i++)
        len += (size_t)snprintf(list + len, sizeof list - len, "%s\"%s\"", i == 0 ? "" : i == n - 1 ? " or " : ", ",
                                names[i]);
    if (ty != LUA_TSTRING) vfail(v, "expected %s, got %s", list, got(v->L, -1, b, sizeof b));
    const char *str = lua_tostring(v->L, -1);
    for (int i = 0; i < n; i++)
        if (!strcmp(str, names[i])) {
            vpop(v, old);
            lua_pop(v->L, 1);
            return i;
        }
    vfail(v, "expected %s, got \"%s\"", list, str);
}

/* The value on top as a vector of exactly n finite numbers; label like "{x, y, z}". */
static void vec_top(vctx *v, int n, const char *label, double *out) {
    lua_State *L = v->L;
    char b[64];
    int t = lua_gettop(L);
    if (lua_type(L, t) != LUA_TTABLE) vfail(v, "expected %s, got %s", label, got(L, t, b, sizeof b));
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        int isnum;
        lua_Integer i = lua_tointegerx(L, -1, &isnum);
        if (lua_type(L, -1) != LUA_TNUMBER || !isnum || i < 1 || i > n) {
            if (lua_type(L, -1) == LUA_TSTRING)
                vfail(v, "expected %s (%d numbers), found key \"%s\"", label, n, lua_tostring(L, -1));
            vfail(v, "expected %s: %d numbers, got %llu", label, n, (unsigned long long)lua_rawlen(L, t));
        }
    }
    if (lua_rawlen(L, t) != (lua_Unsigned)n)
        vfail(v, "expected %s: %d numbers, got %llu", label, n, (unsigned long long)lua_rawlen(L, t));
    for (int i = 0; i < n; i++) {
        size_t old = vpushi(v, i + 1);
        lua_rawgeti(L, t, i + 1);
        out[i] = vnum_top(v);
        lua_pop(L, 1);
        vpop(v, old);
    }
}

static const char *vec_label(int dim) { return dim == 2 ? "{x, y}" : "{x, y, z}"; }

/* t[key] as a dim-vector (z = 0 in 2D); returns whether present (out untouched if absent). */
static int vec_field(vctx *v, int t, const char *key, double out[3]) {
    int dim = v->s->def.dim;
    if (vget(v, t, key) == LUA_TNIL) {
        lua_pop(v->L, 1);
        return 0;
    }
    size_t old = vpush(v, key);
    double tmp[3] = {0, 0, 0};
    vec_top(v, dim, vec_label(dim), tmp);
    memcpy(out, tmp, sizeof tmp);
    vpop(v, old);
    lua_pop(v->L, 1);
    return 1;
}

/* angular_velocity: a number (about z) in 2D, a 3-vector in 3D. */
static int angvel_field(vctx *v, int t, const char *key, double out[3]) {
    if (v->s->def.dim == 3) return vec_field(v, t, key, out);
    int ty = vget(v, t, key);
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        return 0;
    }
    size_t old = vpush(v, key);
    char b[64];
    if (ty != LUA_TNUMBER) vfail(v, "expected a number (rad/s about z, in 2D), got %s", got(v->L, -1, b, sizeof b));
    out[0] = out[1] = 0;
    out[2] = vnum_top(v);
    vpop(v, old);
    lua_pop(v->L, 1);
    return 1;
}

static void check_rotation_2d(vctx *v, const double q[4]) {
    if (v->s->def.dim == 2 && (fabs(q[1]) > 1e-9 || fabs(q[2]) > 1e-9))
        vfail(v, "in 2D a rotation must be about z (use axis_angle = {0, 0, 1, degrees})");
}

/* rotation = {w,x,y,z} | axis_angle = {ax, ay, az, degrees} in table t; identity if neither. */
static int rotation_fields(vctx *v, int t, double q[4]) {
    int has_q = vget(v, t, "rotation") != LUA_TNIL;
    lua_pop(v->L, 1);
    int has_aa = vget(v, t, "axis_angle") != LUA_TNIL;
    lua_pop(v->L, 1);
    quat_identity(q);
    if (has_q && has_aa) {
        size_t old = vpush(v, "axis_angle");
        vfail(v, "give rotation or axis_angle, not both");
        vpop(v, old);
    }
    if (has_q) {
        size_t old = vpush(v, "rotation");
        vget(v, t, "rotation");
        vec_top(v, 4, "{w, x, y, z} (a unit quaternion)", q);
        lua_pop(v->L, 1);
        double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (!(fabs(n - 1) < 1e-3)) {
            char nb[32];
            vfail(v,
                  "must be a unit quaternion {w, x, y, z}, |q| = %s (for an axis and an angle use "
                  "axis_angle = {ax, ay, az, degrees})",
                  fmt_num(nb, n));
        }
        for (int k = 0; k < 4; k++) q[k] /= n;
        check_rotation_2d(v, q);
        vpop(v, old);
    } else if (has_aa) {
        size_t old = vpush(v, "axis_angle");
        double aa[4];
        vget(v, t, "axis_angle");
        vec_top(v, 4, "{ax, ay, az, degrees}", aa);
        lua_pop(v->L, 1);
        if (!quat_axis_angle(aa[0], aa[1], aa[2], aa[3], q)) vfail(v, "the axis must be non-zero");
        check_rotation_2d(v, q);
        vpop(v, old);
    }
    return has_q || has_aa;
}

/* Checks that t[key] is a table and pushes it (returns 0 and pushes nothing if absent). */
static int table_field(vctx *v, int t, const char *key) {
    char b[64];
    int ty = vget(v, t, key);
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        return 0;
    }
    if (ty != LUA_TTABLE) {
        size_t old = vpush(v, key);
        vfail(v, "expected a table, got %s", got(v->L, -1, b, sizeof b));
        vpop(v, old);
    }
    return 1;
}

static void require_table_top(vctx *v) {
    char b[64];
    if (lua_type(v->L, -1) != LUA_TTABLE) vfail(v, "expected a table, got %s", got(v->L, -1, b, sizeof b));
}

/* ------------------------------------------------------------------------------------------ */
/* Shapes, materials, objects, colliders, emitters                                               */

static const char *const shape_types[] = {"box", "sphere", "cylinder", "halfspace"};
static const char *const keys_box[] = {"type", "center", "half_extent", "size", "rotation", "axis_angle", "inside_out"};
static const char *const keys_sphere[] = {"type", "center", "radius", "inside_out"};
static const char *const keys_cyl[] = {"type", "center", "radius", "half_height", "height", "rotation", "axis_angle",
                                       "inside_out"};
static const char *const keys_half[] = {"type", "point", "center", "normal", "inside_out"};
#define NKEYS(a) ((int)(sizeof(a) / sizeof((a)[0])))

/* "KEY: required WHAT" when !present. */
static void vrequire(vctx *v, int present, const char *key, const char *what) {
    if (present) return;
    vpush(v, key);
    vfail(v, "required%s%s", what[0] ? " " : "", what);
}

/* The table on top of the stack (path already pushed) as a shape. */
static void parse_shape(vctx *v, sm_shape *out) {
    lua_State *L = v->L;
    require_table_top(v);
    int t = lua_gettop(L);
    int ty = vget(v, t, "type");
    lua_pop(L, 1);
    vrequire(v, ty != LUA_TNIL, "type", "(\"box\", \"sphere\", \"cylinder\" or \"halfspace\")");
    int kind = enum_field(v, t, "type", shape_types, 4, 0);
    static const sm_shape_kind kinds[] = {SM_SHAPE_BOX, SM_SHAPE_SPHERE, SM_SHAPE_CYLINDER, SM_SHAPE_HALFSPACE};
    sm_shape s = sm_shape_default(kinds[kind]);
    int has;
    switch (s.kind) {
    case SM_SHAPE_BOX: {
        check_keys(v, t, keys_box, NKEYS(keys_box), "a box");
        vrequire(v, vec_field(v, t, "center", s.center), "center", "for a box");
        double he[3] = {0, 0, 0}, sz[3] = {0, 0, 0};
        int h1 = vec_field(v, t, "half_extent", he), h2 = vec_field(v, t, "size", sz);
        if (h1 && h2) vfail(v, "give half_extent or size, not both");
        if (!h1 && !h2) vfail(v, "a box needs half_extent (half sizes) or size (full sizes)");
        const char *which = h1 ? "half_extent" : "size";
        for (int a = 0; a < v->s->def.dim; a++) {
            double x = h1 ? he[a] : 0.5 * sz[a];
            size_t old = vpush(v, which);
            size_t old2 = vpushi(v, a + 1);
            vrange(v, h1 ? he[a] : sz[a], GT0);
            vpop(v, old2);
            vpop(v, old);
            s.half_extent[a] = x;
        }
        rotation_fields(v, t, s.rotation);
        break;
    }
    case SM_SHAPE_SPHERE:
        check_keys(v, t, keys_sphere, NKEYS(keys_sphere), "a sphere");
        vrequire(v, vec_field(v, t, "center", s.center), "center", "for a sphere");
        s.radius = num_field(v, t, "radius", 0, &has, GT0);
        vrequire(v, has, "radius", "for a sphere");
        break;
    case SM_SHAPE_CYLINDER: {
        check_keys(v, t, keys_cyl, NKEYS(keys_cyl), "a cylinder");
        vrequire(v, vec_field(v, t, "center", s.center), "center", "for a cylinder");
        s.radius = num_field(v, t, "radius", 0, &has, GT0);
        vrequire(v, has, "radius", "for a cylinder");
        int h1, h2;
        double hh = num_field(v, t, "half_height", 0, &h1, GT0), h = num_field(v, t, "height", 0, &h2, GT0);
        if (h1 && h2) vfail(v, "give half_height or height, not both");
        if (!h1 && !h2) vfail(v, "a cylinder needs half_height or height (along its axis, local y)");
        s.half_height = h1 ? hh : 0.5 * h;
        rotation_fields(v, t, s.rotation);
        break;
    }
    case SM_SHAPE_HALFSPACE: {
        check_keys(v, t, keys_half, NKEYS(keys_half), "a halfspace");
        int h1 = vec_field(v, t, "point", s.center);
        double c[3];
        int h2 = vec_field(v, t, "center", c);
        if (h1 && h2) vfail(v, "give point or center, not both");
        if (!h1 && !h2) vfail(v, "a halfspace needs point (a point on its plane)");
        if (h2) memcpy(s.center, c, sizeof c);
        vrequire(v, vec_field(v, t, "normal", s.normal), "normal", "for a halfspace (pointing out of the solid)");
        double nn = s.normal[0] * s.normal[0] + s.normal[1] * s.normal[1] + s.normal[2] * s.normal[2];
        if (!(nn > 0)) {
            size_t old = vpush(v, "normal");
            vfail(v, "must be non-zero");
            vpop(v, old);
        }
        break;
    }
    }
    s.inside_out = bool_field(v, t, "inside_out", 0);
    *out = s;
}

/* t[key] as a shape; returns whether present. */
static int shape_field(vctx *v, int t, const char *key, sm_shape *out) {
    if (vget(v, t, key) == LUA_TNIL) {
        lua_pop(v->L, 1);
        return 0;
    }
    size_t old = vpush(v, key);
    parse_shape(v, out);
    vpop(v, old);
    lua_pop(v->L, 1);
    return 1;
}

static const char *const mat_models[] = {"sand", "elastic"};
static const char *const keys_mat[] = {"model", "density", "E", "nu", "friction_angle", "hardening", "cone_fit",
                                       "repose_angle"};
static const char *const cone_fits[] = {"triaxial_compression", "plane_strain", "inscribed", "simple_shear"};

/* Material keys cone_fit (sm_cone_fit, by name) and repose_angle: the angle theta of steady flow,
 * tan(theta) = mu_eff, turned into the friction angle of that fit in the scene's dimension
 * (sm_friction_angle_for_effective_friction; docs/validation.md). Returns the friction angle, or
 * -1 without repose_angle. */
static double parse_cone_fit(vctx *v, int t, sm_material_def *m) {
    m->cone_fit = (sm_cone_fit)enum_field(v, t, "cone_fit", cone_fits, 4, 0);
    int has;
    double theta = num_field(v, t, "repose_angle", 0, &has, 0.0, 1, 90.0, 0);
    if (!has) return -1;
    double phi = sm_friction_angle_for_effective_friction(tan(theta * 3.14159265358979323846 / 180), m->cone_fit, v->s->def.dim);
    char a[32];
    size_t old = vpush(v, "repose_angle");
    if (!(phi >= 0 && phi < 90))
        vfail(v, "%s degrees is beyond cone_fit \"%s\" in %dD (no friction angle below 90 gives it)", fmt_num(a, theta),
              cone_fits[m->cone_fit], v->s->def.dim);
    vpop(v, old);
    return phi;
}

static void parse_material(vctx *v, int t, sm_material_def *out) {
    check_keys(v, t, keys_mat, NKEYS(keys_mat), "a material");
    int model = enum_field(v, t, "model", mat_models, 2, 0);
    sm_material_def m = model == 0 ? sm_material_def_sand() : sm_material_def_elastic();
    m.density = num_field(v, t, "density", m.density, NULL, GT0);
    m.youngs_modulus = num_field(v, t, "E", m.youngs_modulus, NULL, GT0);
    m.poisson_ratio = num_field(v, t, "nu", m.poisson_ratio, NULL, -1.0, 0, 0.5, 0);
    int has_fa, has_h = vget(v, t, "hardening") != LUA_TNIL;
    lua_pop(v->L, 1);
    double fa = num_field(v, t, "friction_angle", 0, &has_fa, 0.0, 1, 90.0, 0);
    double fa_repose = parse_cone_fit(v, t, &m);
    if (fa_repose >= 0) {
        if (has_fa || model == 1) vfail(v, "repose_angle: %s", has_fa ? "give friction_angle or repose_angle, not both" : "only sand has one");
        fa = fa_repose, has_fa = 1;
    }
    if (model == 1) {
        if (has_fa || has_h)
            vfail(v, "an elastic material has no %s (only sand does)", has_fa ? "friction_angle" : "hardening");
    } else {
        if (has_fa && has_h) vfail(v, "give friction_angle or hardening, not both");
        if (!has_fa && !has_h)
            vfail(v, "sand needs friction_angle = degrees, repose_angle = degrees or hardening = {h0, h1, h2, h3} (e.g. {35, 9, 0.2, 10})");
        if (has_fa) {
            m.hardening = 0;
            m.friction_angle = fa;
        } else {
            size_t old = vpush(v, "hardening");
            double h[4];
            vget(v, t, "hardening");
            vec_top(v, 4, "{h0, h1, h2, h3} (degrees, degrees, -, degrees)", h);
            lua_pop(v->L, 1);
            for (int i = 0; i < 4; i++) {
                size_t o2 = vpushi(v, i + 1);
                vrange(v, h[i], GE0);
                vpop(v, o2);
            }
            char a[32], b[32];
            if (!(h[0] < 90)) vfail(v, "h0 must be < 90 degrees, got %s", fmt_num(a, h[0]));
            if (!(h[0] > h[3]))
                vfail(v, "need h0 > h3 (the initial friction angle h0 - h3 must be positive), got h0 = %s, h3 = %s",
                      fmt_num(a, h[0]), fmt_num(b, h[3]));
            if (!(h[0] + h[1] < 360)) vfail(v, "h0 + h1 must be < 360");
            m.hardening = 1;
            m.h0 = h[0];
            m.h1 = h[1];
            m.h2 = h[2];
            m.h3 = h[3];
            vpop(v, old);
        }
    }
    *out = m;
}

static int cmp_str(const void *a, const void *b) { return strcmp(*(const char *const *)a, *(const char *const *)b); }

static void parse_materials(vctx *v, int top) {
    sm_scene *s = v->s;
    lua_State *L = v->L;
    if (!table_field(v, top, "materials")) return;
    int t = lua_gettop(L);
    size_t old = vpush(v, "materials");
    int n = 0;
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        if (lua_type(L, -1) != LUA_TSTRING)
            vfail(v, "expected named materials, materials = { sand = { ... } }, found a %s key", luaL_typename(L, -1));
        n++;
    }
    if (n > 65535) vfail(v, "too many materials");
    s->mat_names = calloc((size_t)n + 1, sizeof *s->mat_names);
    s->mats = calloc((size_t)n + 1, sizeof *s->mats);
    if (!s->mat_names || !s->mats) luaL_error(L, "out of memory");
    lua_pushnil(L);
    while (lua_next(L, t)) {
        lua_pop(L, 1);
        if (!(s->mat_names[s->nmat] = dup_str(lua_tostring(L, -1)))) luaL_error(L, "out of memory");
        s->nmat++;
    }
    qsort(s->mat_names, (size_t)s->nmat, sizeof *s->mat_names, cmp_str);
    for (int i = 0; i < s->nmat; i++) {
        size_t o2 = vpush(v, s->mat_names[i]);
        vget(v, t, s->mat_names[i]);
        require_table_top(v);
        parse_material(v, lua_gettop(L), &s->mats[i]);
        lua_pop(L, 1);
        vpop(v, o2);
    }
    vpop(v, old);
    lua_pop(L, 1);
}

/* t.material -> id (key optional when the scene has exactly one material). */
static int material_field(vctx *v, int t) {
    sm_scene *s = v->s;
    char b[64];
    int ty = vget(v, t, "material");
    size_t old = vpush(v, "material");
    if (ty == LUA_TNIL) {
        lua_pop(v->L, 1);
        if (s->nmat == 1) {
            vpop(v, old);
            return 0;
        }
        if (s->nmat == 0) vfail(v, "required, and the scene defines no materials (materials = { sand = { ... } })");
        vfail(v, "required (the scene has %d materials)", s->nmat);
    }
    if (ty != LUA_TSTRING) vfail(v, "expected a material name, got %s", got(v->L, -1, b, sizeof b));
    const char *name = lua_tostring(v->L, -1);
    for (int i = 0; i < s->nmat; i++)
        if (!strcmp(name, s->mat_names[i])) {
            lua_pop(v->L, 1);
            vpop(v, old);
            return i;
        }
    const char *sug = closest(name, (const char *const *)s->mat_names, s->nmat);
    if (sug) vfail(v, "unknown material \"%s\" (did you mean \"%s\"?)", name, sug);
    if (s->nmat == 0) vfail(v, "unknown material \"%s\": the scene defines no materials", name);
    vfail(v, "unknown material \"%s\" (the scene defines %d: %s%s)", name, s->nmat, s->mat_names[0],
          s->nmat > 1 ? ", ..." : "");
}

static const char *const sampling_names[] = {"jittered", "poisson"};
static const char *const keys_obj[] = {"shape", "material", "velocity", "angular_velocity",
                                       "ppc",   "sampling", "clip",     "seed"};

static void parse_object(vctx *v, int t, int i, scene_object *o, double scene_ppc, long long scene_seed) {
    check_keys(v, t, keys_obj, NKEYS(keys_obj), "an object");
    vrequire(v, shape_field(v, t, "shape", &o->shape), "shape", "");
    o->has_clip = shape_field(v, t, "clip", &o->clip);
    o->seed = sm_seed_def_default();
    o->seed.material = material_field(v, t);
    vec_field(v, t, "velocity", o->seed.velocity);
    angvel_field(v, t, "angular_velocity", o->seed.angular_velocity);
    o->seed.ppc = num_field(v, t, "ppc", scene_ppc, NULL, 0.0, 0, 4096.0, 1);
    o->seed.method = enum_field(v, t, "sampling", sampling_names, 2, 0) ? SM_SEED_POISSON : SM_SEED_JITTERED;
    o->seed.seed = (uint64_t)int_field(v, t, "seed", scene_seed + i, NULL, 0, INT64_MAX);
    o->seed.clip = NULL; /* set at build: points into the scene's array */
}

static const char *const mode_names[] = {"sticky", "slip", "separate"};
static const char *const keys_col[] = {"shape", "shapes", "inside_out", "mode", "friction", "position", "rotation",
                                       "axis_angle", "velocity", "angular_velocity", "keyframes", "motion"};
static const char *const keys_kf[] = {"t", "position", "rotation", "axis_angle"};

static int motion_call(lua_State *L);
static void motion_error_text(const sm_scene *s, const scene_collider *c, double t, const char *msg, char *out,
                              size_t n);

static void parse_collider(vctx *v, int t, scene_collider *c) {
    lua_State *L = v->L;
    sm_collider_def *d = &c->def;
    check_keys(v, t, keys_col, NKEYS(keys_col), "a collider");
    *d = sm_collider_def_default();
    int has_shape = vget(v, t, "shape") != LUA_TNIL;
    lua_pop(L, 1);
    int has_shapes = vget(v, t, "shapes") != LUA_TNIL;
    lua_pop(L, 1);
    if (has_shape && has_shapes) vfail(v, "give shape or shapes, not both");
    if (!has_shape && !has_shapes) vfail(v, "a collider needs shape = {...} or shapes = { {...}, ... }");
    if (has_shape) {
        shape_field(v, t, "shape", &d->shapes[0]);
        d->shape_count = 1;
    } else {
        table_field(v, t, "shapes");
        size_t old = vpush(v, "shapes");
        int st = lua_gettop(L);
        int n = list_len(v, st, "of shapes { {type = ...}, ... }");
        if (n < 1 || n > SM_MAX_COLLIDER_SHAPES) vfail(v, "need 1 to %d shapes, got %d", SM_MAX_COLLIDER_SHAPES, n);
        for (int i = 0; i < n; i++) {
            size_t o2 = vpushi(v, i + 1);
            lua_rawgeti(L, st, i + 1);
            parse_shape(v, &d->shapes[i]);
            lua_pop(L, 1);
            vpop(v, o2);
        }
        d->shape_count = n;
        lua_pop(L, 1);
        vpop(v, old);
    }
    d->inside_out = bool_field(v, t, "inside_out", 0);
    int ty = vget(v, t, "mode");
    lua_pop(L, 1);
    if (ty == LUA_TNIL) {
        size_t old = vpush(v, "mode");
        vfail(v, "required: \"sticky\", \"slip\" or \"separate\"");
        vpop(v, old);
    }
    static const sm_collide_mode modes[] = {SM_COLLIDE_STICKY, SM_COLLIDE_SLIP, SM_COLLIDE_SEPARATE};
    d->mode = modes[enum_field(v, t, "mode", mode_names, 3, 0)];
    d->friction = num_field(v, t, "friction", 0, NULL, GE0);
    /* motion */
    int has_pos = vec_field(v, t, "position", d->pose.position);
    int has_rot = rotation_fields(v, t, d->pose.rotation);
    int has_vel = vec_field(v, t, "velocity", d->velocity);
    int has_av = angvel_field(v, t, "angular_velocity", d->angular_velocity);
    int has_kf = vget(v, t, "keyframes") != LUA_TNIL;
    lua_pop(L, 1);
    int has_fn = vget(v, t, "motion") != LUA_TNIL;
    lua_pop(L, 1);
    if ((has_vel || has_av) + has_kf + has_fn > 1)
        vfail(v, "give at most one kind of motion: velocity/angular_velocity, keyframes or motion");
    if ((has_kf || has_fn) && (has_pos || has_rot)) {
        size_t old = vpush(v, has_pos ? "position" : "rotation");
        vfail(v, "not allowed with %s (they give the whole pose)", has_kf ? "keyframes" : "a motion function");
        vpop(v, old);
    }
    c->motion = MOTION_RIGID;
    if (has_kf) {
        table_field(v, t, "keyframes");
        size_t old = vpush(v, "keyframes");
        int kt = lua_gettop(L);
        int n = list_len(v, kt, "of keyframes { {t = 0, position = {...}}, ... }");
        if (n < 1) vfail(v, "need at least one keyframe");
        c->kf = calloc((size_t)n, sizeof *c->kf);
        if (!c->kf) luaL_error(L, "out of memory");
        c->nkf = n;
        for (int i = 0; i < n; i++) {
            size_t o2 = vpushi(v, i + 1);
            lua_rawgeti(L, kt, i + 1);
            require_table_top(v);
            int ft = lua_gettop(L);
            check_keys(v, ft, keys_kf, NKEYS(keys_kf), "a keyframe");
            int has;
            keyframe *k = &c->kf[i];
            k->t = num_field(v, ft, "t", 0, &has, NOLIM);
            vrequire(v, has, "t", "(the keyframe's time, s)");
            if (i > 0 && !(k->t > c->kf[i - 1].t)) {
                char a[32], b[32];
                size_t o3 = vpush(v, "t");
                vfail(v, "keyframe times must increase, got %s after %s", fmt_num(a, k->t), fmt_num(b, c->kf[i - 1].t));
                vpop(v, o3);
            }
            vrequire(v, vec_field(v, ft, "position", k->pos), "position", "");
            rotation_fields(v, ft, k->rot);
            lua_pop(L, 1);
            vpop(v, o2);
        }
        lua_pop(L, 1);
        vpop(v, old);
        c->motion = MOTION_KEYFRAMES;
    } else if (has_fn) {
        char b[64];
        size_t old = vpush(v, "motion");
        vget(v, t, "motion");
        if (lua_type(L, -1) != LUA_TFUNCTION)
            vfail(v, "expected a function(t) returning position[, rotation], got %s", got(L, -1, b, sizeof b));
        lua_Debug ar;
        lua_pushvalue(L, -1);
        if (lua_getinfo(L, ">S", &ar) && ar.linedefined > 0) c->fn_line = ar.linedefined;
        c->fn_ref = luaL_ref(L, LUA_REGISTRYINDEX);
        c->motion = MOTION_FUNCTION;
        /* Evaluate once at t = 0 so that errors show up at load time. */
        lua_pushcfunction(L, motion_call);
        lua_pushlightuserdata(L, c);
        lua_pushnumber(L, 0.0);
        int st = lua_pcall(L, 2, 0, 0);
        if (st != LUA_OK) {
            char msg[1024], out[1400];
            if (st == LUA_ERRMEM) lua_error(L); /* rethrow as is */
            pop_error(L, st, msg, sizeof msg);
            motion_error_text(v->s, c, 0.0, msg, out, sizeof out);
            lua_pushstring(L, out);
            lua_error(L);
        }
        c->last = c->tmp;
        vpop(v, old);
    }
}

static const char *const keys_emit[] = {"shape", "material", "velocity", "rate", "start", "stop", "ppc", "seed"};

static void parse_emitter(vctx *v, int t, int i, sm_emitter_def *e, double scene_ppc, long long scene_seed) {
    check_keys(v, t, keys_emit, NKEYS(keys_emit), "an emitter");
    *e = sm_emitter_def_default();
    vrequire(v, shape_field(v, t, "shape", &e->shape), "shape", "");
    if (e->shape.kind == SM_SHAPE_HALFSPACE || e->shape.inside_out) {
        size_t old = vpush(v, "shape");
        vfail(v, "an emitter's shape must be a sphere, box or cylinder (not a halfspace, not inside_out)");
        vpop(v, old);
    }
    e->material = material_field(v, t);
    vec_field(v, t, "velocity", e->velocity);
    int has;
    e->rate = num_field(v, t, "rate", 0, &has, GT0);
    vrequire(v, has, "rate", "(mass flow, kg/s; kg/(m s) in 2D)");
    e->start = num_field(v, t, "start", 0, NULL, NOLIM);
    int has_stop;
    double stop = num_field(v, t, "stop", INFINITY, &has_stop, NOLIM);
    if (has_stop && !(stop > e->start)) {
        char a[32], b[32];
        size_t old = vpush(v, "stop");
        vfail(v, "must be > start (%s), got %s", fmt_num(a, e->start), fmt_num(b, stop));
        vpop(v, old);
    }
    e->stop = stop;
    e->ppc = num_field(v, t, "ppc", scene_ppc, NULL, 0.0, 0, 4096.0, 1);
    e->seed = (uint64_t)int_field(v, t, "seed", scene_seed + i, NULL, 0, INT64_MAX);
}

/* If top[key] is present: pushes it, appends key to the path (old length in *old) and returns the
 * list's length; else -1. */
static int parse_list_header(vctx *v, int top, const char *key, const char *example, size_t *old) {
    if (!table_field(v, top, key)) return -1;
    *old = vpush(v, key);
    return list_len(v, lua_gettop(v->L), example);
}

static const char *const keys_top[] = {"dim", "dx", "ppc", "kernel", "transfer", "flip_ratio", "integrator", "cfl",
                                       "max_dt", "elastic_cfl", "newton_tolerance", "newton_max_iterations",
                                       "gmres_max_iterations", "gmres_tolerance", "fps", "frames", "end_time",
                                       "gravity", "seed", "domain",
                                       "static_friction_sticks", "particle_projection", "materials", "objects",
                                       "colliders", "emitters", "outputs", "camera"};
static const char *const keys_domain[] = {"min", "max", "walls", "wall_friction"};
static const char *const keys_out[] = {"ply", "vtk", "csv"};
static const char *const keys_cam[] = {"eye", "target", "up", "fov"};
static const char *const kernel_names[] = {"quadratic", "cubic"};
static const char *const transfer_names[] = {"apic", "pic", "flip"};
static const char *const integrator_names[] = {"explicit", "implicit"};

/* Validates the scene table (argument 1, the scene pointer is argument 2) into the scene struct. */
static int validate(lua_State *L) {
    vctx vc;
    memset(&vc, 0, sizeof vc);
    vc.s = lua_touserdata(L, 2);
    vc.L = L;
    vctx *v = &vc;
    sm_scene *s = v->s;
    char b[64];
    luaL_checkstack(L, 64, "scene validation"); /* the parser's nesting is bounded: well below this */
    if (lua_type(L, 1) != LUA_TTABLE)
        vfail(v, "the scene file must return a table (return { dim = 3, dx = ..., ... }), got %s",
              got(L, 1, b, sizeof b));
    lua_settop(L, 1);
    const int top = 1;
    check_keys(v, top, keys_top, NKEYS(keys_top), "a scene");

    sm_world_def *d = &s->def;
    d->dim = (int)int_field(v, top, "dim", 3, NULL, 2, 3);
    int has;
    d->dx = num_field(v, top, "dx", 0, &has, GT0);
    vrequire(v, has, "dx", "(the grid spacing, m)");
    double ppc = num_field(v, top, "ppc", d->dim == 3 ? 8 : 4, NULL, 0.0, 0, 4096.0, 1);
    d->kernel = enum_field(v, top, "kernel", kernel_names, 2, 0) ? SM_KERNEL_CUBIC : SM_KERNEL_QUADRATIC;
    static const sm_transfer transfers[] = {SM_TRANSFER_APIC, SM_TRANSFER_PIC, SM_TRANSFER_FLIP};
    d->transfer = transfers[enum_field(v, top, "transfer", transfer_names, 3, 0)];
    d->flip_ratio = num_field(v, top, "flip_ratio", d->flip_ratio, NULL, 0.0, 1, 1.0, 1);
    d->integrator =
        enum_field(v, top, "integrator", integrator_names, 2, 0) ? SM_INTEGRATOR_IMPLICIT : SM_INTEGRATOR_EXPLICIT;
    d->cfl = num_field(v, top, "cfl", d->cfl, NULL, 0.0, 0, 1.0, 1);
    d->max_dt = num_field(v, top, "max_dt", d->max_dt, NULL, GT0);
    d->elastic_cfl = num_field(v, top, "elastic_cfl", d->elastic_cfl, NULL, GE0);
    d->newton_tolerance = num_field(v, top, "newton_tolerance", d->newton_tolerance, NULL, GT0);
    d->newton_max_iterations = (int)int_field(v, top, "newton_max_iterations", d->newton_max_iterations, NULL, 1, 1000);
    d->gmres_max_iterations = (int)int_field(v, top, "gmres_max_iterations", d->gmres_max_iterations, NULL, 1, 200);
    d->gmres_tolerance = num_field(v, top, "gmres_tolerance", d->gmres_tolerance, NULL, 0.0, 0, 1.0, 0);
    s->set.fps = num_field(v, top, "fps", 24, NULL, 0.0, 0, 1e6, 1);
    int has_frames, has_end;
    long long frames = int_field(v, top, "frames", 0, &has_frames, 1, 1000000);
    double end = num_field(v, top, "end_time", 0, &has_end, GT0);
    if (has_frames && has_end) vfail(v, "give frames or end_time, not both");
    if (!has_frames && !has_end) vfail(v, "frames or end_time: one is required (frames = 48 or end_time = 2.0)");
    if (has_end) {
        double f = ceil(end * s->set.fps - 1e-9);
        if (f > 1000000) vfail(v, "end_time: %g s at %g fps is more than a million frames", end, s->set.fps);
        frames = f < 1 ? 1 : (long long)f;
    }
    s->set.frames = (int)frames;
    s->set.end_time = (double)frames / s->set.fps;
    vec_field(v, top, "gravity", d->gravity);
    if (d->dim == 2) d->gravity[2] = 0;
    long long seed = int_field(v, top, "seed", 1, NULL, 0, INT64_MAX / 2);
    d->static_friction_sticks = bool_field(v, top, "static_friction_sticks", d->static_friction_sticks);
    d->particle_projection = bool_field(v, top, "particle_projection", d->particle_projection);

    if (table_field(v, top, "domain")) {
        size_t old = vpush(v, "domain");
        int dt = lua_gettop(L);
        check_keys(v, dt, keys_domain, NKEYS(keys_domain), "domain");
        vec_field(v, dt, "min", d->domain_min);
        vec_field(v, dt, "max", d->domain_max);
        d->wall_mode = (sm_collide_mode)enum_field(v, dt, "walls", mode_names, 3, (int)d->wall_mode);
        d->wall_friction = num_field(v, dt, "wall_friction", d->wall_friction, NULL, GE0);
        lua_pop(L, 1);
        vpop(v, old);
    }
    if (d->dim == 2) d->domain_min[2] = d->domain_max[2] = 0;
    for (int a = 0; a < d->dim; a++)
        if (!(d->domain_max[a] > d->domain_min[a])) {
            char x[32], y[32];
            size_t old = vpush(v, "domain");
            vfail(v, "empty or inverted along %c: min %s, max %s (max must exceed min)", "xyz"[a],
                  fmt_num(x, d->domain_min[a]), fmt_num(y, d->domain_max[a]));
            vpop(v, old);
        }
    for (int a = 0; a < d->dim; a++) {
        /* as sm_world_create checks it, so that load (without a world) catches it too */
        double len = d->domain_max[a] - d->domain_min[a], cells = ceil(len / d->dx - 1e-9);
        if (cells < 6 || cells > SM_MAX_CELLS_PER_AXIS) {
            char x[32], y[32];
            size_t old = vpush(v, "domain");
            vfail(v, "%s cells along %c (length %s, dx %s): need 6 to %d", fmt_num(x, cells), "xyz"[a],
                  fmt_num(y, len), fmt_num(b, d->dx), SM_MAX_CELLS_PER_AXIS);
            vpop(v, old);
        }
    }

    parse_materials(v, top);

    size_t old;
    int n = parse_list_header(v, top, "objects", "of objects { {shape = ..., material = ...}, ... }", &old);
    if (n >= 0) {
        int lt = lua_gettop(L);
        s->objs = calloc((size_t)n + 1, sizeof *s->objs);
        if (!s->objs) luaL_error(L, "out of memory");
        for (int i = 0; i < n; i++) {
            size_t o2 = vpushi(v, i + 1);
            lua_rawgeti(L, lt, i + 1);
            require_table_top(v);
            parse_object(v, lua_gettop(L), i, &s->objs[i], ppc, seed);
            s->nobj++;
            lua_pop(L, 1);
            vpop(v, o2);
        }
        lua_pop(L, 1);
        vpop(v, old);
    }
    n = parse_list_header(v, top, "colliders", "of colliders { {shape = ..., mode = ...}, ... }", &old);
    if (n >= 0) {
        int lt = lua_gettop(L);
        s->cols = calloc((size_t)n + 1, sizeof *s->cols);
        if (!s->cols) luaL_error(L, "out of memory");
        for (int i = 0; i < n; i++) {
            scene_collider *c = &s->cols[i];
            c->index = i + 1;
            c->scene = s;
            c->fn_ref = LUA_NOREF;
            s->ncol++;
            size_t o2 = vpushi(v, i + 1);
            lua_rawgeti(L, lt, i + 1);
            require_table_top(v);
            parse_collider(v, lua_gettop(L), c);
            lua_pop(L, 1);
            vpop(v, o2);
        }
        lua_pop(L, 1);
        vpop(v, old);
    }
    n = parse_list_header(v, top, "emitters", "of emitters { {shape = ..., rate = ...}, ... }", &old);
    if (n >= 0) {
        int lt = lua_gettop(L);
        s->emits = calloc((size_t)n + 1, sizeof *s->emits);
        if (!s->emits) luaL_error(L, "out of memory");
        for (int i = 0; i < n; i++) {
            size_t o2 = vpushi(v, i + 1);
            lua_rawgeti(L, lt, i + 1);
            require_table_top(v);
            parse_emitter(v, lua_gettop(L), i, &s->emits[i], ppc, seed);
            s->nemit++;
            lua_pop(L, 1);
            vpop(v, o2);
        }
        lua_pop(L, 1);
        vpop(v, old);
    }

    s->set.out_ply = s->set.out_vtk = s->set.out_csv = 1;
    if (table_field(v, top, "outputs")) {
        size_t o2 = vpush(v, "outputs");
        int ot = lua_gettop(L);
        check_keys(v, ot, keys_out, NKEYS(keys_out), "outputs");
        s->set.out_ply = bool_field(v, ot, "ply", 1);
        s->set.out_vtk = bool_field(v, ot, "vtk", 1);
        s->set.out_csv = bool_field(v, ot, "csv", 1);
        lua_pop(L, 1);
        vpop(v, o2);
    }
    s->set.up[1] = 1;
    s->set.fov = 40;
    if (table_field(v, top, "camera")) {
        size_t o3 = vpush(v, "camera");
        int ct = lua_gettop(L);
        check_keys(v, ct, keys_cam, NKEYS(keys_cam), "camera");
        const char *names[3] = {"eye", "target", "up"};
        double *dst[3] = {s->set.eye, s->set.target, s->set.up};
        for (int k = 0; k < 3; k++) {
            if (vget(v, ct, names[k]) == LUA_TNIL) {
                lua_pop(L, 1);
                vrequire(v, k == 2, names[k], "");
                continue;
            }
            size_t o2 = vpush(v, names[k]);
            vec_top(v, 3, "{x, y, z}", dst[k]);
            lua_pop(L, 1);
            vpop(v, o2);
        }
        double dd = 0, uu = 0;
        for (int a = 0; a < 3; a++) {
            dd += (s->set.target[a] - s->set.eye[a]) * (s->set.target[a] - s->set.eye[a]);
            uu += s->set.up[a] * s->set.up[a];
        }
        if (!(dd > 0)) vfail(v, "eye and target must differ");
        if (!(uu > 0)) vfail(v, "up: must be non-zero");
        s->set.fov = num_field(v, ct, "fov", 40, NULL, 0.0, 0, 180.0, 0);
        s->set.has_camera = 1;
        lua_pop(L, 1);
        vpop(v, o3);
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Motion functions                                                                             */

static void motion_error_text(const sm_scene *s, const scene_collider *c, double t, const char *msg, char *out,
                              size_t n) {
    if (has_position(msg)) snprintf(out, n, "%.900s (colliders[%d].motion at t = %.6g)", msg, c->index, t);
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
                     ty == LUA_TNUMBER ? fmt_num(nb, x) : lua_typename(L, ty));
            return 0;
        }
        out[i] = x;
    }
    return 1;
}

/* Protected: (collider, t) -> calls the motion function, checks its results into c->tmp. */
static int motion_call(lua_State *L) {
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
    if (!read_vec_raw(L, 1, dim, p.position, "position", vec_label(dim), err, sizeof err))
        return luaL_error(L, "%s", err);
    if (lua_isnil(L, 2)) {
        quat_identity(p.rotation);
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
static void scene_motion(void *user, double t, sm_pose *pose) {
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
    set_budget(s, MOTION_INSN_LIMIT);
    int top = lua_gettop(L);
    lua_pushcfunction(L, motion_call);
    lua_pushlightuserdata(L, c);
    lua_pushnumber(L, t);
    int st = lua_pcall(L, 2, 0, 0);
    if (st == LUA_OK) {
        c->last = c->tmp;
    } else {
        char msg[1024];
        pop_error(L, st, msg, sizeof msg);
        motion_error_text(s, c, t, msg, s->motion_err, sizeof s->motion_err);
    }
    lua_settop(L, top);
    *pose = c->last;
}

/* ------------------------------------------------------------------------------------------ */
/* Load, build, destroy                                                                         */

static int read_file(sm_scene *s, const char *path, char *err, size_t errlen) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return 0;
    }
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        if (n + 1 >= cap) {
            if (cap >= (size_t)SCENE_MAX_FILE) {
                snprintf(err, errlen, "%s: file too large (more than %ld MB)", path, SCENE_MAX_FILE >> 20);
                free(buf);
                fclose(f);
                return 0;
            }
            char *q = realloc(buf, cap * 2);
            if (!q) break;
            buf = q;
            cap *= 2;
        }
        size_t r = fread(buf + n, 1, cap - 1 - n, f);
        n += r;
        if (r == 0) break;
    }
    if (!buf) {
        snprintf(err, errlen, "out of memory");
        fclose(f);
        return 0;
    }
    if (ferror(f)) {
        snprintf(err, errlen, "%s: cannot read: %s", path, strerror(errno));
        free(buf);
        fclose(f);
        return 0;
    }
    fclose(f);
    buf[n] = 0;
    s->source = buf;
    s->source_len = n;
    return 1;
}

static void set_name(sm_scene *s, const char *path) {
    const char *base = path ? strrchr(path, '/') : NULL;
    base = base ? base + 1 : (path ? path : "scene");
    copy_str(s->set.name, sizeof s->set.name, base);
    char *dot = strrchr(s->set.name, '.');
    if (dot && dot != s->set.name) *dot = 0;
    if (!s->set.name[0]) copy_str(s->set.name, sizeof s->set.name, "scene");
}

/* Bounding box of a bounded shape (box, sphere, cylinder; not inside-out); 0 if unbounded. */
static int shape_bbox(const sm_shape *sh, int dim, double lo[3], double hi[3]) {
    if (sh->inside_out || sh->kind == SM_SHAPE_HALFSPACE) return 0;
    double r[3] = {0, 0, 0};
    if (sh->kind == SM_SHAPE_SPHERE) {
        r[0] = r[1] = r[2] = sh->radius;
    } else {
        /* rotated extents: |R| h */
        double h[3];
        if (sh->kind == SM_SHAPE_BOX) memcpy(h, sh->half_extent, sizeof h);
        else h[0] = h[2] = sh->radius, h[1] = sh->half_height;
        const double *q = sh->rotation;
        double w = q[0], x = q[1], y = q[2], z = q[3];
        double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) r[a] += fabs(R[a][b]) * h[b];
    }
    for (int a = 0; a < 3; a++) {
        lo[a] = a < dim ? sh->center[a] - r[a] : 0;
        hi[a] = a < dim ? sh->center[a] + r[a] : 0;
    }
    return 1;
}

/* The usable region (domain rounded up to whole cells, less 2 dx on each side) where the library
 * seeds and emits. */
static void usable_region(const sm_world_def *d, double lo[3], double hi[3]) {
    for (int a = 0; a < 3; a++) lo[a] = hi[a] = 0;
    for (int a = 0; a < d->dim; a++) {
        double cells = ceil((d->domain_max[a] - d->domain_min[a]) / d->dx - 1e-9);
        lo[a] = d->domain_min[a] + 2 * d->dx;
        hi[a] = d->domain_min[a] + cells * d->dx - 2 * d->dx;
    }
}

static int fail_msg(char *err, size_t errlen, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
static int fail_msg(char *err, size_t errlen, int code, const char *fmt, ...) {
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return code;
}

/* Checks after validation: world definition, objects and emitters against the domain, params
 * used, estimates. */
static int finish_load(sm_scene *s, char *err, size_t errlen) {
    sm_world_def *d = &s->def;
    size_t grid = sm_world_def_grid_bytes(d);
    if (grid == 0) {
        /* Invalid definition: sm_world_create says why (it checks before allocating). */
        char msg[512] = "invalid world definition";
        sm_world *w = NULL;
        if (sm_world_create(d, &w, msg, sizeof msg) == SM_OK) {
            sm_world_destroy(w);
            copy_str(msg, sizeof msg, "invalid world definition");
        }
        return fail_msg(err, errlen, 2, "%s: %s", s->path, msg);
    }
    double lo[3], hi[3];
    usable_region(d, lo, hi);
    const int dim = d->dim;
    double cell = pow(d->dx, dim), est = 0;
    for (int i = 0; i < s->nobj; i++) {
        scene_object *o = &s->objs[i];
        double blo[3], bhi[3];
        if (shape_bbox(&o->shape, dim, blo, bhi)) {
            for (int a = 0; a < dim; a++)
                if (!(bhi[a] > lo[a] && blo[a] < hi[a]))
                    return fail_msg(err, errlen, 2,
                                    "%s: objects[%d].shape: outside the domain along %c (the shape spans %g .. %g; "
                                    "particles go in %g .. %g, 2 cells inside the domain)",
                                    s->path, i + 1, "xyz"[a], blo[a], bhi[a], lo[a], hi[a]);
        }
        /* Sample only where the shape (and its clip) can be: the library's estimate samples a 64^d
           lattice of the box it is given, so a small shape in a large domain needs a tight box. */
        double slo[3], shi[3];
        memcpy(slo, lo, sizeof slo);
        memcpy(shi, hi, sizeof shi);
        for (int k = 0; k < 1 + o->has_clip; k++)
            if (shape_bbox(k ? &o->clip : &o->shape, dim, blo, bhi))
                for (int a = 0; a < dim; a++) {
                    slo[a] = fmax(slo[a], blo[a]);
                    shi[a] = fmin(shi[a], bhi[a]);
                }
        double vol = sm_shape_volume_estimate(&o->shape, o->has_clip ? &o->clip : NULL, dim, slo, shi);
        est += vol / cell * o->seed.ppc;
    }
    double emitted = 0;
    for (int i = 0; i < s->nemit; i++) {
        sm_emitter_def *e = &s->emits[i];
        if (!(sm_shape_volume_estimate(&e->shape, NULL, dim, lo, hi) > 0))
            return fail_msg(err, errlen, 2,
                            "%s: emitters[%d].shape: outside the domain (particles are emitted only in the part of the "
                            "shape at least 2 cells inside the domain's walls)",
                            s->path, i + 1);
        double t = fmin(e->stop, s->set.end_time) - e->start;
        if (t > 0) emitted += e->rate * t / (s->mats[e->material].density * cell / e->ppc);
    }
    for (int i = 0; i < s->nparams; i++)
        if (!s->params[i].used) {
            const char *sug = closest(s->params[i].key, (const char *const *)s->read_keys, s->nread);
            char hint[200] = "";
            if (sug) snprintf(hint, sizeof hint, " (did you mean \"%s\"?)", sug);
            return fail_msg(err, errlen, 2, "%s: --set %s=%s: the scene does not use params.%s%s", s->path,
                            s->params[i].key, s->params[i].value, s->params[i].key, hint);
        }
    s->set.estimated_particles = (size_t)llround(est);
    s->set.estimated_emitted = (size_t)llround(emitted);
    double bytes = (double)grid + (est + emitted) * (double)sm_particle_bytes(dim);
    s->set.estimated_bytes = bytes > 1e18 ? (size_t)-1 : (size_t)bytes;
    return 0;
}

int sm_scene_load(const char *path, const char *source, const sm_scene_param *params, int nparams, const char *quality,
                  int threads, sm_scene **out, char *err, size_t errlen) {
    if (out) *out = NULL;
    if (err && errlen) err[0] = 0;
    if (!out) return fail_msg(err, errlen, 2, "sm_scene_load: out is NULL");
    const char *name = path ? path : "scene";
    if (!path && !source) return fail_msg(err, errlen, 2, "sm_scene_load: need a path or a source");
    if (!quality) quality = "preview";
    if (strcmp(quality, "preview") && strcmp(quality, "paper") && strcmp(quality, "test"))
        return fail_msg(err, errlen, 2, "quality: expected \"preview\", \"paper\" or \"test\", got \"%s\"", quality);
    if (threads < 0) return fail_msg(err, errlen, 2, "threads: must be >= 0, got %d", threads);
    if (nparams < 0 || (nparams > 0 && !params)) return fail_msg(err, errlen, 2, "sm_scene_load: bad params");
    for (int i = 0; i < nparams; i++) {
        const char *k = params[i].key;
        if (!k || !params[i].value) return fail_msg(err, errlen, 2, "--set: missing key or value");
        if (!is_identifier(k))
            return fail_msg(err, errlen, 2, "--set %s=%s: the key must be a name (letters, digits, _)", k,
                            params[i].value);
        if (!strcmp(k, "quality"))
            return fail_msg(err, errlen, 2, "--set quality=%s: params.quality comes from the quality option, not --set",
                            params[i].value);
    }

    sm_scene *s = calloc(1, sizeof *s);
    if (!s) return fail_msg(err, errlen, 5, "out of memory");
    copy_str(s->path, sizeof s->path, name);
    copy_str(s->quality, sizeof s->quality, quality);
    set_name(s, path);
    s->def = sm_world_def_default();
    s->def.threads = threads;
    s->mem_limit = SCENE_MEM_LIMIT;
    int rc = 0;
    if (nparams > 0) {
        s->params = calloc((size_t)nparams, sizeof *s->params);
        if (!s->params) {
            rc = fail_msg(err, errlen, 5, "out of memory");
            goto fail;
        }
        for (int i = 0; i < nparams; i++) {
            /* a repeated key: the last one wins */
            int j = 0;
            while (j < s->nparams && strcmp(s->params[j].key, params[i].key)) j++;
            char *v = dup_str(params[i].value);
            if (!v) {
                rc = fail_msg(err, errlen, 5, "out of memory");
                goto fail;
            }
            if (j < s->nparams) {
                free(s->params[j].value);
                s->params[j].value = v;
                continue;
            }
            s->params[j].value = v;
            if (!(s->params[j].key = dup_str(params[i].key))) {
                rc = fail_msg(err, errlen, 5, "out of memory");
                goto fail;
            }
            s->nparams++;
        }
    }
    if (source) {
        if (!(s->source = dup_str(source))) {
            rc = fail_msg(err, errlen, 5, "out of memory");
            goto fail;
        }
        s->source_len = strlen(source);
    } else if (!read_file(s, path, err, errlen)) {
        rc = 2;
        goto fail;
    }

    s->L = lua_newstate(scene_alloc, s);
    if (!s->L) {
        rc = fail_msg(err, errlen, 5, "out of memory (Lua state)");
        goto fail;
    }
    lua_State *L = s->L;
    *(sm_scene **)lua_getextraspace(L) = s;
    set_budget(s, SCENE_INSN_LIMIT);
    lua_pushcfunction(L, scene_init);
    int st = lua_pcall(L, 0, 0, 0);
    char msg[1024];
    if (st == LUA_OK) {
        char chunk[1100];
        snprintf(chunk, sizeof chunk, "@%s", name);
        st = luaL_loadbufferx(L, s->source, s->source_len, chunk, "t");
        if (st == LUA_OK) st = lua_pcall(L, 0, 1, 0);
        if (st == LUA_OK) {
            lua_pushcfunction(L, validate);
            lua_insert(L, -2);
            lua_pushlightuserdata(L, s);
            st = lua_pcall(L, 2, 0, 0);
        }
    }
    if (st != LUA_OK) {
        pop_error(L, st, msg, sizeof msg);
        int nomem = st == LUA_ERRMEM && !s->mem_hit;
        if (has_position(msg) || !strncmp(msg, name, strlen(name))) rc = fail_msg(err, errlen, 2, "%s", msg);
        else rc = fail_msg(err, errlen, 2, "%s: %s", name, msg);
        if (nomem) rc = 5;
        goto fail;
    }
    lua_settop(L, 0);
    lua_gc(L, LUA_GCCOLLECT);
    if ((rc = finish_load(s, err, errlen)) != 0) goto fail;
    *out = s;
    return 0;
fail:
    sm_scene_destroy(s);
    return rc ? rc : 2;
}

const sm_scene_settings *sm_scene_get_settings(const sm_scene *s) { return &s->set; }
const sm_world_def *sm_scene_world_def(const sm_scene *s) { return &s->def; }
int sm_scene_material_count(const sm_scene *s) { return s->nmat; }
const char *sm_scene_material_name(const sm_scene *s, int id) {
    return id >= 0 && id < s->nmat ? s->mat_names[id] : NULL;
}
sm_world *sm_scene_world(sm_scene *s) { return s ? s->world : NULL; }
const char *sm_scene_motion_error(const sm_scene *s) { return s && s->motion_err[0] ? s->motion_err : NULL; }

static int status_code(sm_status st) { return st == SM_ERR_NOMEM ? 5 : 2; }

int sm_scene_build(sm_scene *s, char *err, size_t errlen) {
    if (err && errlen) err[0] = 0;
    if (!s) return fail_msg(err, errlen, 2, "sm_scene_build: scene is NULL");
    if (s->built) return fail_msg(err, errlen, 2, "%s: the scene is already built", s->path);
    s->built = 1;
    char msg[512];
    sm_world *w = NULL;
    sm_status st = sm_world_create(&s->def, &w, msg, sizeof msg);
    if (st != SM_OK) return fail_msg(err, errlen, status_code(st), "%s: %s", s->path, msg);
    int rc = 0;
    for (int i = 0; i < s->nmat; i++)
        if ((st = sm_world_add_material(w, &s->mats[i], NULL)) != SM_OK) {
            rc = fail_msg(err, errlen, status_code(st), "%s: materials.%s: %s", s->path, s->mat_names[i], sm_world_errmsg(w));
            goto fail;
        }
    for (int i = 0; i < s->ncol; i++) {
        scene_collider *c = &s->cols[i];
        if (c->motion != MOTION_RIGID) {
            c->def.motion = scene_motion;
            c->def.motion_user = c;
        }
        if ((st = sm_world_add_collider(w, &c->def, NULL)) != SM_OK) {
            rc = fail_msg(err, errlen, status_code(st), "%s: colliders[%d]: %s", s->path, i + 1, sm_world_errmsg(w));
            goto fail;
        }
        if (s->motion_err[0]) {
            rc = fail_msg(err, errlen, 2, "%s", s->motion_err);
            goto fail;
        }
    }
    for (int i = 0; i < s->nobj; i++) {
        scene_object *o = &s->objs[i];
        sm_seed_def sd = o->seed;
        sd.clip = o->has_clip ? &o->clip : NULL;
        size_t added = 0;
        st = sm_world_seed_shape(w, &o->shape, &sd, &added);
        if (st != SM_OK) {
            rc = fail_msg(err, errlen, status_code(st), "%s: objects[%d]: %s", s->path, i + 1, sm_world_errmsg(w));
            goto fail;
        }
        if (added == 0) {
            rc = fail_msg(err, errlen, 2,
                          "%s: objects[%d]: no particles: no seeding point of the domain's usable region (2 cells "
                          "inside its walls) is inside the shape%s",
                          s->path, i + 1, o->has_clip ? " and its clip" : "");
            goto fail;
        }
    }
    for (int i = 0; i < s->nemit; i++)
        if ((st = sm_world_add_emitter(w, &s->emits[i], NULL)) != SM_OK) {
            rc = fail_msg(err, errlen, status_code(st), "%s: emitters[%d]: %s", s->path, i + 1, sm_world_errmsg(w));
            goto fail;
        }
    s->world = w;
    return 0;
fail:
    sm_world_destroy(w);
    return rc;
}

void sm_scene_destroy(sm_scene *s) {
    if (!s) return;
    sm_world_destroy(s->world);
    if (s->L) {
        set_budget(s, MOTION_INSN_LIMIT); /* finalizers (__gc) run in lua_close: keep them bounded */
        lua_close(s->L);
    }
    for (int i = 0; i < s->nmat; i++) free(s->mat_names[i]);
    free(s->mat_names);
    free(s->mats);
    free(s->objs);
    for (int i = 0; i < s->ncol; i++) free(s->cols[i].kf);
    free(s->cols);
    free(s->emits);
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
