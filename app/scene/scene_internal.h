/* Internals of the scene loader, shared by app/scene.c and the files under app/scene/ (not part of app/scene.h).
 *
 * Who does what (one job per file):
 *   app/scene.c               the public entry points: load (read, run, validate, estimate), the
 *                             getters, destroy
 *   app/scene/sandbox.c       the Lua state: allocator with its memory limit, the budget of work
 *                             (instruction hook, charges, wall clock) that pcall cannot catch, the
 *                             safe libraries
 *   app/scene/bounded.c       the library functions that can work long in one call, charged
 *   app/scene/pattern.c       string.find/match/gmatch/gsub with a matcher that counts its steps
 *   app/scene/params.c        the scene's globals: params, axis_angle, print
 *   app/scene/locate.c        the line of a key path in the source (for messages)
 *   app/scene/schema.c        the schema's typed fields with ranges, a table's allowed keys, the one
 *                             list parser
 *   app/scene/messages.c      the schema's messages: key paths, file:line, did-you-mean, the allowed
 *                             keys and values listed, library messages mapped onto scene keys
 *   app/scene/parse_scene.c   the top-level table: world definition, domain, lists, outputs, camera
 *   app/scene/parse_items.c   shapes, materials, objects, colliders, emitters
 *   app/scene/motion.c        quaternions, keyframes, motion functions (the library's sm_motion_fn)
 *   app/scene/estimate.c      checks after validation: objects/emitters against the domain, unused
 *                             --set keys, particle and memory estimates against available memory,
 *                             time steps against SCENE_MAX_STEPS
 *   app/scene/volume.c        exact volumes of shapes inside a box (sampling where exact is impractical)
 *   app/scene/meshes.c        mesh shapes: files loaded (app/io/mesh_load.c), fields built or read
 *                             from the cache, put into their shapes
 *   app/scene/build.c         sm_scene_build: the world from the validated scene
 *
 * Functions shared between these files start with sc_ (the application is one static library:
 * short generic names could collide with another file's). */
#ifndef SM_APP_SCENE_INTERNAL_H
#define SM_APP_SCENE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include <lua5.4/lua.h>

#include "app/scene.h"

#define SCENE_INSN_LIMIT 50000000LL /* Lua instructions for running the scene file */
#define MOTION_INSN_LIMIT 1000000LL /* per motion-function call */
#define SCENE_TIME_LIMIT 10.0       /* CPU s for running the scene file (and 10 x as much wall clock) */
#define MOTION_TIME_LIMIT 0.1       /* CPU s per motion-function call (and 10 x as much wall clock) */
#define SCENE_MEM_LIMIT ((size_t)256 << 20)
#define SCENE_MAX_FILE ((long)16 << 20)
#define SCENE_MAX_LIST 1000000
#define SCENE_MAX_STEPS 1e8         /* time steps a run may need (estimate.c) */
#define SCENE_MEMORY_SHARE 0.9      /* of the memory this process can still get */
#define SCENE_MAX_GRAVITY 1e4       /* m/s^2 (about 1000 g) */

enum { MOTION_RIGID = 0, MOTION_KEYFRAMES = 1, MOTION_FUNCTION = 2 };

typedef struct keyframe {
    double t, pos[3], rot[4];
} keyframe;

typedef struct scene_collider {
    sm_collider_def def;
    int motion;  /* MOTION_* */
    keyframe *kf;
    int nkf;
    int fn_ref;  /* registry reference of the motion function */
    int fn_line; /* where the motion function is defined (0 if unknown) */
    sm_pose last; /* last good pose of a motion function */
    sm_pose tmp;
    int index; /* 1-based, for messages */
    struct sm_scene *scene;
} scene_collider;

typedef struct scene_object {
    sm_shape shape, clip;
    int has_clip;
    sm_seed_def seed;
} scene_object;

/* A mesh shape as parsed (the field is made after validation, sc_build_meshes). */
typedef struct scene_mesh {
    char key[96];          /* where the shape is: "objects[1].shape", "colliders[2].shapes[3]", ... */
    char file[1024];       /* the file as written in the scene */
    double unit, scale[3], rotation[4], position[3];
    int sign;              /* -1: auto (winding if closed, else one-sided), else an sm_mesh_sign */
    double resolution;     /* field spacing = dx / resolution */
    double band;           /* band half width in dx */
    int solid;             /* an object's shape or clip: the mesh must be closed */
    sm_mesh_field *field;  /* one reference (NULL until built) */
    int cached;            /* 0: built, 1: read from the cache file, 2: an earlier shape's field */
    double seconds;        /* build or read time, s */
    size_t triangles;      /* elements of the loaded mesh */
    uint64_t hash;         /* of the loaded (placed, welded) geometry */
    int sign_used;         /* the sign rule of the field */
    double centre[3];      /* the bounding box centre the mesh was moved by */
    int frames;            /* animated: the number of frame files (file is a %d pattern); 0: static */
    int first;             /* animated: the first frame's number in the file names */
    double fps;            /* animated: frames per second */
} scene_mesh;

typedef struct scene_param {
    char *key, *value;
    int used;
} scene_param;

#define SC_MAX_WARN 16
#define SC_WARN_LEN 640

struct sm_scene {
    lua_State *L;
    size_t mem, mem_limit;
    int mem_hit;
    long long insn, insn_limit; /* work done and allowed in the current budget (sc_set_budget) */
    long long next_clock;       /* insn at which to look at the clocks again */
    double time_limit;          /* CPU seconds (and 10 x as many wall-clock seconds), see sandbox.c */
    double cpu_start, wall_start; /* when the budget began: thread CPU time, CLOCK_MONOTONIC */
    const char *budget_what;    /* "the scene file", "a motion-function call" */
    int tripped;                /* a limit ran out: every instruction raises trip_msg again */
    int hooks_on;               /* the allocator may charge and set the hook (off in lua_close) */
    int hook_every;             /* instructions between two hook calls now */
    char trip_msg[512];
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
    int nmesh, mesh_cap;
    scene_mesh *meshes;
    sm_world *world;
    int built;
    sm_scene_world_hook on_world; /* sm_scene_on_world */
    void *on_world_user;
    sm_scene_sum_hook sum;        /* sm_scene_on_sum */
    void *sum_user;
    char motion_err[1024];
    int nwarn;                           /* warnings given (more than SC_MAX_WARN are counted only) */
    char warn[SC_MAX_WARN][SC_WARN_LEN]; /* "PATH:LINE: key: what looks wrong" */
};

/* ---- small helpers (schema.c: strings; messages.c: the rest) ---- */
void sc_copy_str(char *dst, size_t n, const char *src);
char *sc_dup_str(const char *s);
const char *sc_fmt_num(char buf[32], double x);                 /* %g; NaN and infinities spelled out */
const char *sc_closest(const char *word, const char *const *cands, int n); /* a likely typo's fix, or NULL */
int sc_is_identifier(const char *s);
/* Records a warning (already located: "PATH:LINE: ..."); the program prints them. */
void sc_warn_msg(sm_scene *s, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
sm_status sc_fail_msg(char *err, size_t errlen, sm_status code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

/* ---- the Lua sandbox (sandbox.c) ---- */
sm_scene *sc_scene_of(lua_State *L);
lua_State *sc_sandbox_new(sm_scene *s);           /* NULL if out of memory */
int sc_sandbox_init(lua_State *L);                /* lua_CFunction: libraries, globals, params */
/* The limits in force (tests and the fuzz harness tests/fuzz/fuzz_scene.c may lower them); the defaults are the SCENE_ and MOTION_ constants. */
typedef struct sc_limits {
    long long scene_insn, motion_insn;
    double scene_time, motion_time;
    size_t mem;                   /* bytes of Lua memory (SCENE_MEM_LIMIT) */
} sc_limits;
extern sc_limits sc_scene_limits;
/* A new budget from now on: limit instructions (and charged work) and seconds (CPU time) for what. */
void sc_set_budget(sm_scene *s, long long limit, double seconds, const char *what);
/* Adds cost to the budget for the library function what (called by scene code); raises the
 * limit's error, which pcall cannot catch, when the budget or the clock runs out. */
void sc_charge(lua_State *L, const char *what, long long cost);
void sc_open_bounded(lua_State *L);       /* bounded.c: charged string and table functions */
void sc_open_patterns(lua_State *L);      /* pattern.c: string.find/match/gmatch/gsub */
void sc_open_scene_globals(lua_State *L); /* params.c: params, axis_angle, print */
void sc_pop_error(lua_State *L, int status, char *buf, size_t n); /* a failed pcall's message, popped */
int sc_has_position(const char *msg);             /* starts with Lua's "chunk:line:"? */

/* ---- validation context, messages (messages.c) and typed fields (schema.c); they run inside
 * lua_pcall and raise a Lua error carrying the finished message ("path:line: key.path: problem") ---- */
typedef struct vctx {
    sm_scene *s;
    lua_State *L;
    char path[512]; /* the key path of what is being read, e.g. colliders[2].shape.center */
    size_t plen;
} vctx;

size_t sc_push_key(vctx *v, const char *key); /* appends .key; returns the old length for sc_pop_key */
size_t sc_push_index(vctx *v, long long i);   /* appends [i] */
void sc_pop_key(vctx *v, size_t old);
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3), noreturn))
#endif
void sc_fail(vctx *v, const char *fmt, ...);
/* A warning at the current key (located as sc_fail's messages); the load goes on. */
void sc_warn(vctx *v, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* A library check's message "field: problem": the field is mapped to the scene's key through
 * map (pairs {library name, scene key}, ending with NULL; an unmapped field keeps the current
 * path) and the message raised with the path and line. */
#if defined(__GNUC__)
__attribute__((noreturn))
#endif
void sc_fail_library(vctx *v, const char *libmsg, const char *const *map);
const char *sc_got(lua_State *L, int idx, char *buf, size_t n); /* "string \"abc\"", "number", ... */
/* The key k of the table being checked is not in allowed: "unknown key" at k, with a suggestion
 * or the keys what takes. */
#if defined(__GNUC__)
__attribute__((noreturn))
#endif
void sc_fail_unknown_key(vctx *v, const char *k, const char *const *allowed, int n, const char *what);
/* The enum value on top is not one of names (or not a string): the names, with a suggestion. */
#if defined(__GNUC__)
__attribute__((noreturn))
#endif
void sc_fail_enum(vctx *v, const char *const *names, int n);

/* typed fields (schema.c) */
int sc_get(vctx *v, int t, const char *key);                    /* pushes t[key] (raw); its type */
void sc_check_keys(vctx *v, int t, const char *const *allowed, int n, const char *what);
int sc_list_len(vctx *v, int t, const char *example);
double sc_num_top(vctx *v);
void sc_range(vctx *v, double x, double lo, int lo_closed, double hi, int hi_closed);
double sc_num_field(vctx *v, int t, const char *key, double def, int *present, double lo, int lo_closed, double hi,
                    int hi_closed);
long long sc_int_field(vctx *v, int t, const char *key, long long def, int *present, long long lo, long long hi);
int sc_bool_field(vctx *v, int t, const char *key, int def);
int sc_enum_field(vctx *v, int t, const char *key, const char *const *names, int n, int def);
void sc_vec_top(vctx *v, int n, const char *label, double *out);
const char *sc_vec_label(int dim);
int sc_vec_field(vctx *v, int t, const char *key, double out[3]);
int sc_angvel_field(vctx *v, int t, const char *key, double out[3]);
int sc_rotation_fields(vctx *v, int t, double q[4]);
int sc_rotation_fields_any(vctx *v, int t, double q[4]); /* also out of the plane in 2D (a mesh's placement) */
int sc_table_field(vctx *v, int t, const char *key);
void sc_require_table_top(vctx *v);
void sc_require(vctx *v, int present, const char *key, const char *what);

/* The one list parser: if top[key] is present it must be a list of tables; allocates its items
 * (size bytes each, zeroed) into *items, and for each calls parse(v, table index, i (from 0),
 * item, ctx) with the path at key[i + 1]. *count counts the items handed to parse (so that
 * sm_scene_destroy frees what a failing item had allocated). Returns whether the key was there. */
typedef void (*sc_item_parser)(vctx *v, int t, int i, void *item, void *ctx);
int sc_parse_list(vctx *v, int top, const char *key, const char *example, size_t size, void **items, int *count,
                  sc_item_parser parse, void *ctx);

#define SC_NOLIM (-INFINITY), 0, INFINITY, 0
#define SC_GT0 0.0, 0, INFINITY, 0
#define SC_GE0 0.0, 1, INFINITY, 0
#define SC_NKEYS(a) ((int)(sizeof(a) / sizeof((a)[0])))

/* ---- scene tables (parse_scene.c, parse_items.c) ---- */
int sc_validate(lua_State *L); /* lua_CFunction: (scene table, scene pointer) -> the scene struct */
extern const char *const sc_mode_names[3];
typedef struct sc_list_defaults {
    double ppc;     /* the scene's ppc */
    long long seed; /* the scene's seed */
} sc_list_defaults;
void sc_parse_materials(vctx *v, int top);
void sc_parse_object(vctx *v, int t, int i, void *item, void *ctx);   /* item: scene_object, ctx: sc_list_defaults */
void sc_parse_collider(vctx *v, int t, int i, void *item, void *ctx); /* item: scene_collider */
void sc_parse_emitter(vctx *v, int t, int i, void *item, void *ctx);  /* item: sm_emitter_def, ctx: sc_list_defaults */

/* ---- mesh shapes (meshes.c) ---- */
/* The shape table on top of the stack (type = "mesh", path pushed) into s: a pending mesh (its
 * field comes from sc_build_meshes). */
void sc_parse_mesh_shape(vctx *v, int t, sm_shape *s);
/* Loads every pending mesh, builds its field (or reads it from <scene dir>/.sandmpm-cache/) and
 * puts it into its shape. Errors as scene errors at the shape's file key (SM_ERR_INVALID, also for
 * a file that cannot be read) or SM_ERR_NOMEM. */
sm_status sc_build_meshes(sm_scene *s, char *err, size_t errlen);
void sc_free_meshes(sm_scene *s);

/* ---- motion (motion.c) ---- */
int sc_quat_axis_angle(double ax, double ay, double az, double deg, double q[4]);
void sc_quat_identity(double q[4]);
int sc_motion_call(lua_State *L); /* lua_CFunction: (collider, t) -> checks the results into c->tmp */
void sc_motion_error_text(const sm_scene *s, const scene_collider *c, double t, const char *msg, char *out, size_t n);
void sc_scene_motion(void *user, double t, sm_pose *pose); /* the library's sm_motion_fn */

/* ---- after validation (estimate.c, volume.c, locate.c) ---- */
sm_status sc_finish_load(sm_scene *s, char *err, size_t errlen);
/* Bytes this process can still allocate (MemAvailable, the room under RLIMIT_AS and RLIMIT_DATA;
 * INFINITY if none is known), and in why what they are. */
double sc_available_bytes(char *why, size_t n);
/* Bounding box of a bounded shape (box, sphere, cylinder; not inside-out); 0 if unbounded. */
int sc_shape_bbox(const sm_shape *sh, int dim, double lo[3], double hi[3]);
/* |shape and clip (or NULL) and [lo, hi]| (an area in 2D); dx sets the sampling lattice where the
 * volume is not exact. */
double sc_volume_in_box(const sm_shape *shape, const sm_shape *clip, int dim, const double lo[3], const double hi[3],
                        double dx);
/* The line of a key path ("objects[2].shape.center") in the source, 0 if not found. */
int sc_locate(const char *src, size_t n, const char *path);
/* "path:line" of a key path of the scene (just the path if the line is not found), in buf. */
const char *sc_where(const sm_scene *s, const char *keys, char *buf, size_t n);

#endif
