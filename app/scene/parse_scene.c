/* The scene table's top level: the world definition (whose limits come from sm_world_def_check),
 * the domain, the lists of materials, objects, colliders and emitters, outputs and camera. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <lua5.4/lauxlib.h>
#include <lua5.4/lua.h>

#include "app/scene/scene_internal.h"

static const char *const keys_top[] = {"dim", "dx", "ppc", "kernel", "transfer", "flip_ratio", "integrator", "cfl",
                                       "max_dt", "elastic_cfl", "newton_tolerance", "newton_max_iterations",
                                       "gmres_max_iterations", "gmres_tolerance", "gmres_preconditioner", "fps", "frames", "end_time", "checkpoint_every",
                                       "gravity", "seed", "domain",
                                       "static_friction_sticks", "particle_projection", "contact_gap", "materials", "objects",
                                       "colliders", "emitters", "outputs", "camera"};
static const char *const keys_domain[] = {"min", "max", "walls", "wall_friction"};
static const char *const keys_out[] = {"ply", "vtk", "csv", "up"};
static const char *const up_names[] = {"y", "z"};
static const char *const keys_cam[] = {"eye", "target", "up", "fov"};
static const char *const kernel_names[] = {"quadratic", "cubic"};
static const char *const transfer_names[] = {"apic", "pic", "flip"};
static const char *const integrator_names[] = {"explicit", "implicit"};
static const char *const preconditioner_names[] = {"none", "block_jacobi"};

/* The library's limits on the world definition (sm_world_def_check), reported at the scene's key. */
static void check_world_def(vctx *v) {
    char msg[256];
    if (sm_world_def_check(&v->s->def, msg, sizeof msg) == SM_OK) return;
    static const char *const map[] = {"dim", "dim", "dx", "dx", "domain", "domain", "gravity", "gravity",
                                      "flip_ratio", "flip_ratio", "newton_tolerance", "newton_tolerance",
                                      "newton_max_iterations", "newton_max_iterations", "gmres_max_iterations",
                                      "gmres_max_iterations", "gmres_tolerance", "gmres_tolerance", "cfl", "cfl",
                                      "max_dt", "max_dt", "elastic_cfl", "elastic_cfl", "wall_mode", "domain.walls",
                                      "wall_friction", "domain.wall_friction", "contact_gap", "contact_gap", NULL};
    sc_fail_library(v, msg, map);
}

/* contact_gap = cells (> 0) | false (no contact gate: every node with mass meets every collider, as
 * the thesis; the default). */
static void parse_contact_gap(vctx *v, int top, sm_world_def *d) {
    const int ty = sc_get(v, top, "contact_gap");
    lua_pop(v->L, 1);
    if (ty == LUA_TBOOLEAN) {
        if (sc_bool_field(v, top, "contact_gap", 0)) {
            sc_push_key(v, "contact_gap");
            sc_fail(v, "expected a number of cells or false, got true");
        }
        d->contact_gap = INFINITY;
        return;
    }
    d->contact_gap = sc_num_field(v, top, "contact_gap", d->contact_gap, NULL, SC_GT0);
}

/* dim (checked at once: the vectors that follow have dim components), dx and the solver's
 * numbers into the world definition; returns the scene's ppc. */
static double parse_world_numbers(vctx *v, int top) {
    sm_world_def *d = &v->s->def;
    d->dim = (int)sc_int_field(v, top, "dim", 3, NULL, INT32_MIN, INT32_MAX);
    check_world_def(v);
    int has;
    d->dx = sc_num_field(v, top, "dx", 0, &has, SC_NOLIM);
    sc_require(v, has, "dx", "(the grid spacing, m)");
    double ppc = sc_num_field(v, top, "ppc", d->dim == 3 ? 8 : 4, NULL, 0.0, 0, 4096.0, 1);
    d->kernel = sc_enum_field(v, top, "kernel", kernel_names, 2, 0) ? SM_KERNEL_CUBIC : SM_KERNEL_QUADRATIC;
    static const sm_transfer transfers[] = {SM_TRANSFER_APIC, SM_TRANSFER_PIC, SM_TRANSFER_FLIP};
    d->transfer = transfers[sc_enum_field(v, top, "transfer", transfer_names, 3, 0)];
    d->flip_ratio = sc_num_field(v, top, "flip_ratio", d->flip_ratio, NULL, SC_NOLIM);
    d->integrator =
        sc_enum_field(v, top, "integrator", integrator_names, 2, 0) ? SM_INTEGRATOR_IMPLICIT : SM_INTEGRATOR_EXPLICIT;
    d->cfl = sc_num_field(v, top, "cfl", d->cfl, NULL, SC_NOLIM);
    d->max_dt = sc_num_field(v, top, "max_dt", d->max_dt, NULL, SC_NOLIM);
    d->elastic_cfl = sc_num_field(v, top, "elastic_cfl", d->elastic_cfl, NULL, SC_NOLIM);
    d->newton_tolerance = sc_num_field(v, top, "newton_tolerance", d->newton_tolerance, NULL, SC_NOLIM);
    d->newton_max_iterations =
        (int)sc_int_field(v, top, "newton_max_iterations", d->newton_max_iterations, NULL, INT32_MIN, INT32_MAX);
    d->gmres_max_iterations =
        (int)sc_int_field(v, top, "gmres_max_iterations", d->gmres_max_iterations, NULL, INT32_MIN, INT32_MAX);
    d->gmres_tolerance = sc_num_field(v, top, "gmres_tolerance", d->gmres_tolerance, NULL, SC_NOLIM);
    d->gmres_preconditioner = sc_enum_field(v, top, "gmres_preconditioner", preconditioner_names, 2, d->gmres_preconditioner);
    sc_vec_field(v, top, "gravity", d->gravity);
    if (d->dim == 2) d->gravity[2] = 0;
    double g = sqrt(d->gravity[0] * d->gravity[0] + d->gravity[1] * d->gravity[1] + d->gravity[2] * d->gravity[2]);
    if (g > SCENE_MAX_GRAVITY) {
        sc_push_key(v, "gravity");
        sc_fail(v, "|g| = %g m/s^2 is more than %g m/s^2 (about 1000 g): a typo?", g, SCENE_MAX_GRAVITY);
    }
    d->static_friction_sticks = sc_bool_field(v, top, "static_friction_sticks", d->static_friction_sticks);
    d->particle_projection = sc_bool_field(v, top, "particle_projection", d->particle_projection);
    parse_contact_gap(v, top, d);
    return ppc;
}

/* fps, frames | end_time, checkpoint_every. */
static void parse_time(vctx *v, int top) {
    sm_scene *s = v->s;
    s->set.fps = sc_num_field(v, top, "fps", 24, NULL, 0.0, 0, 1e6, 1);
    int has_frames, has_end;
    long long frames = sc_int_field(v, top, "frames", 0, &has_frames, 1, 1000000);
    double end = sc_num_field(v, top, "end_time", 0, &has_end, SC_GT0);
    if (has_frames && has_end) sc_fail(v, "give frames or end_time, not both");
    if (!has_frames && !has_end) sc_fail(v, "frames or end_time: one is required (frames = 48 or end_time = 2.0)");
    if (has_end) {
        double f = ceil(end * s->set.fps - 1e-9);
        if (f > 1000000) sc_fail(v, "end_time: %g s at %g fps is more than a million frames", end, s->set.fps);
        frames = f < 1 ? 1 : (long long)f;
    }
    s->set.frames = (int)frames;
    s->set.end_time = (double)frames / s->set.fps;
    int has_ckpt;
    long long every = sc_int_field(v, top, "checkpoint_every", 0, &has_ckpt, 0, 10000000);
    s->set.checkpoint_every = has_ckpt ? (int)every : -1;
}

static void parse_domain(vctx *v, int top) {
    sm_world_def *d = &v->s->def;
    if (sc_table_field(v, top, "domain")) {
        size_t old = sc_push_key(v, "domain");
        int dt = lua_gettop(v->L);
        sc_check_keys(v, dt, keys_domain, SC_NKEYS(keys_domain), "domain");
        sc_vec_field(v, dt, "min", d->domain_min);
        sc_vec_field(v, dt, "max", d->domain_max);
        d->wall_mode = (sm_collide_mode)sc_enum_field(v, dt, "walls", sc_mode_names, 3, (int)d->wall_mode);
        d->wall_friction = sc_num_field(v, dt, "wall_friction", d->wall_friction, NULL, SC_NOLIM);
        lua_pop(v->L, 1);
        sc_pop_key(v, old);
    }
    if (d->dim == 2) d->domain_min[2] = d->domain_max[2] = 0;
}

static void parse_outputs(vctx *v, int top) {
    sm_scene_settings *set = &v->s->set;
    set->out_ply = set->out_vtk = set->out_csv = 1;
    set->out_z_up = 0;
    if (!sc_table_field(v, top, "outputs")) return;
    size_t old = sc_push_key(v, "outputs");
    int ot = lua_gettop(v->L);
    sc_check_keys(v, ot, keys_out, SC_NKEYS(keys_out), "outputs");
    set->out_ply = sc_bool_field(v, ot, "ply", 1);
    set->out_vtk = sc_bool_field(v, ot, "vtk", 1);
    set->out_csv = sc_bool_field(v, ot, "csv", 1);
    set->out_z_up = sc_enum_field(v, ot, "up", up_names, 2, 0);
    lua_pop(v->L, 1);
    sc_pop_key(v, old);
}

static void parse_camera(vctx *v, int top) {
    lua_State *L = v->L;
    sm_scene_settings *set = &v->s->set;
    set->up[1] = 1;
    set->fov = 40;
    if (!sc_table_field(v, top, "camera")) return;
    size_t o3 = sc_push_key(v, "camera");
    int ct = lua_gettop(L);
    sc_check_keys(v, ct, keys_cam, SC_NKEYS(keys_cam), "camera");
    const char *names[3] = {"eye", "target", "up"};
    double *dst[3] = {set->eye, set->target, set->up};
    for (int k = 0; k < 3; k++) {
        if (sc_get(v, ct, names[k]) == LUA_TNIL) {
            lua_pop(L, 1);
            sc_require(v, k == 2, names[k], "");
            continue;
        }
        size_t o2 = sc_push_key(v, names[k]);
        sc_vec_top(v, 3, "{x, y, z}", dst[k]);
        lua_pop(L, 1);
        sc_pop_key(v, o2);
    }
    double dd = 0, uu = 0;
    for (int a = 0; a < 3; a++) {
        dd += (set->target[a] - set->eye[a]) * (set->target[a] - set->eye[a]);
        uu += set->up[a] * set->up[a];
    }
    if (!(dd > 0)) sc_fail(v, "eye and target must differ");
    size_t o_up = sc_push_key(v, "up");
    if (!(uu > 0)) sc_fail(v, "must be non-zero");
    double f[3], cr[3];
    for (int a = 0; a < 3; a++) f[a] = set->target[a] - set->eye[a];
    cr[0] = f[1] * set->up[2] - f[2] * set->up[1];
    cr[1] = f[2] * set->up[0] - f[0] * set->up[2];
    cr[2] = f[0] * set->up[1] - f[1] * set->up[0];
    if (!(sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]) > 1e-6 * sqrt(dd * uu)))
        sc_fail(v, "parallel to the view direction (target - eye = {%g, %g, %g}): the camera's roll is undefined; "
                   "give an up vector across the view",
                f[0], f[1], f[2]);
    sc_pop_key(v, o_up);
    set->fov = sc_num_field(v, ct, "fov", 40, NULL, 0.0, 0, 180.0, 0);
    set->has_camera = 1;
    lua_pop(L, 1);
    sc_pop_key(v, o3);
}

/* Validates the scene table (argument 1, the scene pointer is argument 2) into the scene struct. */
int sc_validate(lua_State *L) {
    vctx vc;
    memset(&vc, 0, sizeof vc);
    vc.s = lua_touserdata(L, 2);
    vc.L = L;
    vctx *v = &vc;
    sm_scene *s = v->s;
    char b[64];
    luaL_checkstack(L, 64, "scene validation"); /* the parser's nesting is bounded: well below this */
    if (lua_type(L, 1) != LUA_TTABLE)
        sc_fail(v, "the scene file must return a table (return { dim = 3, dx = ..., ... }), got %s",
                sc_got(L, 1, b, sizeof b));
    lua_settop(L, 1);
    const int top = 1;
    sc_check_keys(v, top, keys_top, SC_NKEYS(keys_top), "a scene");
    sc_list_defaults dflt;
    dflt.ppc = parse_world_numbers(v, top);
    parse_time(v, top);
    dflt.seed = sc_int_field(v, top, "seed", 1, NULL, 0, INT64_MAX / 2);
    parse_domain(v, top);
    check_world_def(v);
    sc_parse_materials(v, top);
    sc_parse_list(v, top, "objects", "of objects { {shape = ..., material = ...}, ... }", sizeof *s->objs,
                  (void **)&s->objs, &s->nobj, sc_parse_object, &dflt);
    sc_parse_list(v, top, "colliders", "of colliders { {shape = ..., mode = ...}, ... }", sizeof *s->cols,
                  (void **)&s->cols, &s->ncol, sc_parse_collider, &dflt);
    sc_parse_list(v, top, "emitters", "of emitters { {shape = ..., rate = ...}, ... }", sizeof *s->emits,
                  (void **)&s->emits, &s->nemit, sc_parse_emitter, &dflt);
    parse_outputs(v, top);
    parse_camera(v, top);
    return 0;
}
