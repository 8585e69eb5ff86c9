/* Lua 5.4 scene files: load, validate, estimate, build a world.
 *
 * A scene file is a Lua chunk that returns a table (keys: dim, dx, ppc, domain, materials,
 * objects, colliders, emitters, outputs, camera, ...; see scenes/default.lua, docs/scene-format.md
 * and the comment at the top of app/scene.c for the whole format; the loader's files are under
 * app/scene/). It runs in a sandbox (app/scene/sandbox.c; docs/scene-format.md "Sandbox"): only
 * the base library (without dofile, loadfile, load), math, string (without dump, pack, unpack),
 * table and utf8; no io, os, package, debug, coroutine; at most 50 million Lua instructions and
 * 10 s of CPU time (100 s of wall clock) for the file, 1 million and 0.1 s (1 s) per
 * motion-function call, and 256 MB of Lua memory. Library functions that can work long in one call
 * (string.rep, the pattern functions, table.sort, ...) count their work against the instruction
 * limit, and a limit that runs out cannot be caught by pcall or xpcall. After validation the loader
 * refuses a scene whose estimated memory (from exact shape volumes) exceeds 90% of what the process
 * can still get (MemAvailable, RLIMIT_AS, RLIMIT_DATA), a run of more than 100 million time steps,
 * gravity above 1e4 m/s^2 and a camera whose up vector is parallel to its view. The global table
 * `params` holds params.quality ("preview", "paper" or "test") and every --set KEY=VALUE; the
 * global function axis_angle(ax, ay, az, degrees) returns the quaternion {w, x, y, z} of a
 * rotation, for motion functions.
 *
 * Errors are tier 2 (DESIGN §5): an sm_status (SM_ERR_INVALID bad input, SM_ERR_IO a scene file
 * that cannot be opened or read, SM_ERR_NOMEM out of memory) and a message that starts with the
 * scene path, and the line where it can be found:
 *   scenes/castle.lua:12: unexpected symbol near '}'
 *   scenes/castle.lua:40: colliders[2].frction: unknown key (did you mean "friction"?)
 *   scenes/castle.lua:7: materials.sand.E: must be > 0, got -5 */
#ifndef SM_APP_SCENE_H
#define SM_APP_SCENE_H

#include <stddef.h>

#include "sandmpm/sandmpm.h"

/* Owns the world, the lua_State (kept alive for motion functions) and the settings. */
typedef struct sm_scene sm_scene;

/* One --set KEY=VALUE. */
typedef struct sm_scene_param {
    const char *key;
    const char *value;
} sm_scene_param;

typedef struct sm_scene_settings {
    char name[128];                 /* file stem, e.g. "castle" ("scene" without a path) */
    double fps;                     /* frames per second (default 24) */
    int frames;                     /* frames after frame 0 (from `frames`, or ceil(end_time * fps)) */
    int checkpoint_every;           /* `checkpoint_every` (frames, 0: none), or -1 if not given */
    double end_time;                /* = frames / fps, s */
    int out_ply, out_vtk, out_csv;  /* the outputs table; defaults all 1 */
    int out_z_up;                   /* outputs.up = "z": frames written z-up, (x, y, z) -> (x, -z, y) */
    size_t estimated_particles;     /* particles the objects will seed (before seeding) */
    size_t estimated_emitted;       /* particles the emitters will add up to end_time */
    size_t estimated_bytes;         /* grid + (seeded + emitted) particles */
    int has_camera;                 /* 1 if the scene has a camera table */
    double eye[3], target[3], up[3];/* camera position, look-at point, up vector (default 0,1,0) */
    double fov;                     /* vertical field of view, degrees (default 40) */
} sm_scene_settings;

/* Loads and validates a scene (no world yet). source == NULL: reads the file at path; else source
 * is the Lua text and path only names it in messages (NULL: "scene"). quality: "preview" (NULL),
 * "paper" or "test". params: --set KEY=VALUE pairs, as params.KEY (a number if VALUE parses as
 * one, true/false as booleans, else the string); a key the scene never reads is an error.
 * threads: the world's step threads, 0 = the library chooses. Returns SM_OK and *out, or SM_ERR_INVALID
 * (bad input) / SM_ERR_IO (the file cannot be read) / SM_ERR_NOMEM with *out = NULL and a message
 * in err. */
sm_status sm_scene_load(const char *path, const char *source, const sm_scene_param *params, int nparams,
                        const char *quality, int threads, sm_scene **out, char *err, size_t errlen);

const sm_scene_settings *sm_scene_get_settings(const sm_scene *s);

/* Warnings: what looks like a mistake but is allowed ("PATH:LINE: key: ..."): an angle that looks
 * like radians (sm_scene_load), sand seeded inside a collider (sm_scene_build). Count = warnings
 * given so far; sm_scene_warning(s, i) is NULL for i beyond the first 16 (they are counted only). */
int sm_scene_warning_count(const sm_scene *s);
const char *sm_scene_warning(const sm_scene *s, int i);

/* The world definition the scene asks for (threads included). */
const sm_world_def *sm_scene_world_def(const sm_scene *s);

/* Materials in id order (the scene's material names sorted by strcmp; ids as in the PLY output). */
int sm_scene_material_count(const sm_scene *s);
const char *sm_scene_material_name(const sm_scene *s, int id); /* NULL if id is out of range */

/* Mesh shapes (type = "mesh"), in the order of the scene file: where, which file, its field. */
typedef struct sm_scene_mesh_info {
    const char *key;                  /* "colliders[1].shape", "objects[2].clip", ... */
    const char *file;                 /* as written in the scene */
    size_t triangles;                 /* elements of the loaded mesh (segments in 2D) */
    const sm_mesh_field_stats *field; /* the field's statistics */
    const char *sign;                 /* "winding" or "one_sided" (after sign = "auto") */
    const char *source;               /* "built", "cache" (read from the cache file) or "shared" (an earlier shape's) */
    double seconds;                   /* load and build (or read) time, s */
    int frames;                       /* animated: the number of frames (0: a static mesh) */
    double fps;                       /* animated: frames per second */
} sm_scene_mesh_info;

int sm_scene_mesh_count(const sm_scene *s);
/* 0 if i is out of range. */
int sm_scene_mesh(const sm_scene *s, int i, sm_scene_mesh_info *out);

/* Creates the world, materials, colliders, objects (seeded) and emitters. Returns SM_OK,
 * SM_ERR_INVALID (an object that seeds nothing, a library error, a motion function failing at
 * t = 0; message in err) or SM_ERR_NOMEM. Once only. */
sm_status sm_scene_build(sm_scene *s, char *err, size_t errlen);

/* Called by sm_scene_build on the new world before anything is added to it (e.g. to join a
 * distributed seeding: sandmpm_mpi.h's sm_world_seed_share); a status other than SM_OK fails the
 * build with the world's message. Set before sm_scene_build; NULL: none. */
typedef sm_status (*sm_scene_world_hook)(void *user, sm_world *w);
void sm_scene_on_world(sm_scene *s, sm_scene_world_hook hook, void *user);

/* Counts summed over the processes that build the scene together, each with its share of the
 * particles (an MPI run's ranks: sandmpm_mpi.h's sm_world_seed_share), so that the build's
 * warnings count every particle, not this process's: v[0 .. n) replaced by the sums.
 * sm_scene_build calls it (collective) once with n = 1 after seeding, also when the build failed
 * before (v[0]: whether this process failed), and once more with the counts if none did. NULL:
 * one process. */
typedef void (*sm_scene_sum_hook)(void *user, uint64_t *v, int n);
void sm_scene_on_sum(sm_scene *s, sm_scene_sum_hook hook, void *user);

/* The world (NULL before a successful sm_scene_build). Owned by the scene. */
sm_world *sm_scene_world(sm_scene *s);

/* NULL, or the first error of a collider's motion function (a Lua error, the instruction limit, a
 * bad return value), e.g. "scenes/rake.lua:14: boom (colliders[1].motion at t = 0.1042)". After
 * an error the collider keeps its last good pose; the caller should stop (exit code 2). */
const char *sm_scene_motion_error(const sm_scene *s);

/* Destroys the scene, its world and its Lua state. Accepts NULL. */
void sm_scene_destroy(sm_scene *s);

#endif
