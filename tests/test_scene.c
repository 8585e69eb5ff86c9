/* The Lua scene loader (app/scene.c): valid 2D and 3D scenes reach the world (definition fields,
 * materials through particle masses, colliders, particle counts within 10% of the estimate);
 * params and quality reach the scene; scenes/default.lua builds the same particles as the C
 * default scene; bad scenes fail with code 2 and a message naming the file, the key and the
 * problem; the sandbox refuses io/os/require/dofile/load/string.dump and stops endless loops;
 * keyframe and function motion reach the colliders; a failing motion function is reported. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "app/scene.h"
#include "sandmpm/sandmpm.h"
#include "test_util.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#ifndef SM_SOURCE_DIR
#define SM_SOURCE_DIR "."
#endif

static char err[2048];

static sm_scene *load_file(const char *rel, const sm_scene_param *p, int np, const char *quality) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", SM_SOURCE_DIR, rel);
    sm_scene *s = NULL;
    int rc = sm_scene_load(path, NULL, p, np, quality, 1, &s, err, sizeof err);
    if (rc != 0) fprintf(stderr, "load %s: rc %d: %s\n", rel, rc, err);
    CHECK(rc == 0 && s != NULL);
    return s;
}

static int build(sm_scene *s) {
    int rc = sm_scene_build(s, err, sizeof err);
    if (rc != 0) fprintf(stderr, "build: rc %d: %s\n", rc, err);
    CHECK(rc == 0);
    return rc == 0;
}

/* Mass of the first particle with material id mat (-1 if none). */
static double mass_of(const sm_world *w, int mat, size_t *count) {
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    double m = -1;
    *count = 0;
    for (size_t i = 0; i < pv.n; i++)
        if (pv.material[i] == mat) {
            if (m < 0) m = sm_world_particle_mass(w, i);
            (*count)++;
        }
    return m;
}

static void test_valid3d(void) {
    sm_scene *s = load_file("tests/scenes/valid3d.lua", NULL, 0, NULL);
    if (!s) return;
    const sm_scene_settings *st = sm_scene_get_settings(s);
    CHECK(!strcmp(st->name, "valid3d"));
    CHECK_NEAR(st->fps, 30, 0);
    CHECK(st->frames == 15);
    CHECK_NEAR(st->end_time, 0.5, 1e-12);
    CHECK(st->out_ply == 1 && st->out_vtk == 0 && st->out_csv == 1);
    CHECK(st->has_camera == 1);
    CHECK_NEAR(st->eye[0], 1, 0);
    CHECK_NEAR(st->target[1], 0.1, 0);
    CHECK_NEAR(st->up[1], 1, 0);
    CHECK_NEAR(st->fov, 35, 0);
    CHECK(st->estimated_bytes > st->estimated_particles * sm_particle_bytes(3));
    CHECK(sm_scene_material_count(s) == 2);
    CHECK(!strcmp(sm_scene_material_name(s, 0), "rubber")); /* sorted by name */
    CHECK(!strcmp(sm_scene_material_name(s, 1), "sand"));
    CHECK(sm_scene_material_name(s, 2) == NULL);
    CHECK(sm_scene_world(s) == NULL);
    if (!build(s)) {
        sm_scene_destroy(s);
        return;
    }
    sm_world *w = sm_scene_world(s);
    const sm_world_def *d = sm_world_get_def(w);
    CHECK(d->dim == 3);
    CHECK_NEAR(d->dx, 0.02, 0);
    CHECK(d->kernel == SM_KERNEL_CUBIC);
    CHECK(d->transfer == SM_TRANSFER_FLIP);
    CHECK_NEAR(d->flip_ratio, 0.9, 0);
    CHECK(d->integrator == SM_INTEGRATOR_EXPLICIT);
    CHECK_NEAR(d->cfl, 0.5, 0);
    CHECK_NEAR(d->max_dt, 5e-4, 0);
    CHECK_NEAR(d->elastic_cfl, 0.4, 0);
    CHECK_NEAR(d->gravity[1], -5, 0);
    CHECK_NEAR(d->domain_max[0], 0.6, 1e-9);
    CHECK_NEAR(d->domain_max[1], 0.5, 1e-9);
    CHECK(d->wall_mode == SM_COLLIDE_SLIP);
    CHECK_NEAR(d->wall_friction, 0.25, 0);
    CHECK(d->static_friction_sticks == 0 && d->particle_projection == 0);
    CHECK(d->threads == 1);
    /* materials through particle masses (m = rho dx^3 / ppc) and the friction angle */
    size_t nsand, nrub;
    double msand = mass_of(w, 1, &nsand), mrub = mass_of(w, 0, &nrub);
    CHECK_REL(msand, 2000 * 8e-6 / 8, 1e-6, 0);
    CHECK_REL(mrub, 1200 * 8e-6 / 4, 1e-6, 0);
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    size_t first_sand = 0;
    while (first_sand < pv.n && pv.material[first_sand] != 1) first_sand++;
    CHECK(first_sand < pv.n);
    if (first_sand < pv.n) {
        CHECK_NEAR(sm_world_particle_friction_angle(w, first_sand), 30, 1e-4);
        CHECK_NEAR(pv.v[3 * first_sand], 0.5, 1e-6); /* the box's initial velocity */
    }
    /* particle count against the estimate: box 0.2 x 0.1 x 0.16 at 8 ppc, sphere r 0.06 at 4 ppc */
    printf("3D: %zu particles (%zu sand, %zu rubber), estimate %zu, %zu bytes\n", pv.n, nsand, nrub,
           st->estimated_particles, st->estimated_bytes);
    CHECK_REL((double)pv.n, (double)st->estimated_particles, 0.10, 0);
    CHECK_REL((double)nsand, 0.0032 / 8e-6 * 8, 0.05, 0);
    CHECK_REL((double)nrub, 4.0 / 3.0 * M_PI * 0.06 * 0.06 * 0.06 / 8e-6 * 4, 0.10, 0);
    /* colliders: the ground (y < 0.04) and the moving cylinder+box at (0.45, 0.3, 0.1) */
    double x0[3] = {0.3, 0.0, 0.2}, x1[3] = {0.45, 0.3, 0.1};
    CHECK_NEAR(sm_world_collider_distance(w, 0, x0, NULL), -0.04, 1e-9);
    CHECK_NEAR(sm_world_collider_distance(w, 1, x1, NULL), -0.03, 1e-9);
    CHECK(isinf(sm_world_collider_distance(w, 2, x1, NULL)));
    CHECK(sm_world_advance(w, 0.02) == SM_OK);
    sm_pose pose;
    sm_world_collider_pose(w, 1, &pose);
    CHECK_NEAR(pose.position[1], 0.3 - 0.1 * 0.02, 1e-9);
    CHECK(sm_scene_motion_error(s) == NULL);
    /* once only */
    CHECK(sm_scene_build(s, err, sizeof err) == 2);
    sm_scene_destroy(s);
}

static void test_valid2d(void) {
    sm_scene *s = load_file("tests/scenes/valid2d.lua", NULL, 0, "paper");
    if (!s) return;
    const sm_scene_settings *st = sm_scene_get_settings(s);
    CHECK(st->frames == 3); /* ceil(0.1 * 24) */
    CHECK_NEAR(st->end_time, 3.0 / 24, 1e-12);
    CHECK(st->out_ply && st->out_vtk && st->out_csv && !st->has_camera);
    if (build(s)) {
        sm_world *w = sm_scene_world(s);
        const sm_world_def *d = sm_world_get_def(w);
        CHECK(d->dim == 2);
        CHECK_NEAR(d->gravity[1], -9.81, 0);
        size_t n;
        double m = mass_of(w, 0, &n);
        printf("2D: %zu particles, estimate %zu\n", n, st->estimated_particles);
        CHECK_REL(m, 2200 * 1e-4 / 4, 1e-6, 0);
        CHECK_REL((double)n, (double)st->estimated_particles, 0.10, 0);
        CHECK_REL((double)n, 0.4 * 0.1 / 1e-4 * 4, 0.05, 0);
        /* hardening 35/9/0.3/10: friction angle 25 degrees at q = 0 */
        CHECK_NEAR(sm_world_particle_friction_angle(w, 0), 25, 1e-4);
        double x[3] = {0.5, 0.0, 0};
        CHECK_NEAR(sm_world_collider_distance(w, 0, x, NULL), -0.03, 1e-9);
        CHECK(sm_world_advance(w, 0.01) == SM_OK);
        /* the spinning box: rotation 2 rad/s * t about z, position fixed */
        sm_pose p;
        sm_world_collider_pose(w, 1, &p);
        CHECK_NEAR(p.position[0], 0.8, 1e-12);
        CHECK_NEAR(p.position[1], 0.4, 1e-12);
        CHECK_NEAR(p.rotation[0], cos(0.01), 1e-9);
        CHECK_NEAR(p.rotation[3], sin(0.01), 1e-9);
    }
    sm_scene_destroy(s);
}

static double load_dx(const char *src, const sm_scene_param *p, int np, const char *quality) {
    sm_scene *s = NULL;
    int rc = sm_scene_load("inline.lua", src, p, np, quality, 0, &s, err, sizeof err);
    if (rc != 0) fprintf(stderr, "load_dx: %s\n", err);
    CHECK(rc == 0);
    double dx = rc == 0 ? sm_scene_world_def(s)->dx : -1;
    sm_scene_destroy(s);
    return dx;
}

static const char *scene_tail =
    "  frames = 1, domain = { min = {0, 0, 0}, max = {1, 1, 1} },\n"
    "  materials = { sand = { friction_angle = 30 } },\n"
    "  objects = { { shape = { type = \"sphere\", center = {0.5, 0.5, 0.5}, radius = 0.1 } } } }\n";

static void test_params_quality(void) {
    char src[2048];
    snprintf(src, sizeof src,
             "assert(params.flag == true and params.name == 'abc' and params.n == 3 and math.type(params.n) == 'integer')\n"
             "return { dx = params.dx or 0.1,\n%s",
             scene_tail);
    sm_scene_param p[] = {{"dx", "0.05"}, {"flag", "true"}, {"name", "abc"}, {"n", "3"}};
    CHECK_NEAR(load_dx(src, p, 4, NULL), 0.05, 0);
    snprintf(src, sizeof src, "return { dx = params.dx or 0.1,\n%s", scene_tail);
    CHECK_NEAR(load_dx(src, NULL, 0, NULL), 0.1, 0);
    /* a repeated key: the last wins */
    sm_scene_param p2[] = {{"dx", "0.05"}, {"dx", "0.125"}};
    CHECK_NEAR(load_dx(src, p2, 2, NULL), 0.125, 0);
    snprintf(src, sizeof src, "return { dx = ({preview = 0.1, paper = 0.05, test = 0.125})[params.quality],\n%s", scene_tail);
    CHECK_NEAR(load_dx(src, NULL, 0, NULL), 0.1, 0);
    CHECK_NEAR(load_dx(src, NULL, 0, "preview"), 0.1, 0);
    CHECK_NEAR(load_dx(src, NULL, 0, "paper"), 0.05, 0);
    CHECK_NEAR(load_dx(src, NULL, 0, "test"), 0.125, 0);
    sm_scene *s = NULL;
    CHECK(sm_scene_load("inline.lua", src, NULL, 0, "fast", 0, &s, err, sizeof err) == 2 && s == NULL);
    CHECK(strstr(err, "quality") != NULL);
    /* a --set the scene never reads is an error, with a suggestion from what it does read */
    sm_scene_param p3[] = {{"dxx", "0.05"}};
    snprintf(src, sizeof src, "return { dx = params.dx or 0.1,\n%s", scene_tail);
    CHECK(sm_scene_load("inline.lua", src, p3, 1, NULL, 0, &s, err, sizeof err) == 2);
    CHECK(strstr(err, "--set dxx=0.05: the scene does not use params.dxx (did you mean \"dx\"?)") != NULL);
    printf("unused --set: %s\n", err);
    sm_scene_param p4[] = {{"quality", "paper"}};
    CHECK(sm_scene_load("inline.lua", src, p4, 1, NULL, 0, &s, err, sizeof err) == 2);
    /* pairs(params) sees everything (and counts as reading it) */
    snprintf(src, sizeof src,
             "local n = 0 for k, v in pairs(params) do n = n + 1 end assert(n == 2)\n"
             "return { dx = 0.1,\n%s",
             scene_tail);
    sm_scene_param p5[] = {{"extra", "1"}};
    CHECK_NEAR(load_dx(src, p5, 1, NULL), 0.1, 0);
    /* math.random is reproducible (Lua 5.4 would seed it from the clock) */
    snprintf(src, sizeof src, "return { dx = 0.05 + 0.05 * math.random(),\n%s", scene_tail);
    double r1 = load_dx(src, NULL, 0, NULL), r2 = load_dx(src, NULL, 0, NULL);
    CHECK(r1 == r2 && r1 > 0.05 && r1 < 0.1);
}

/* scenes/default.lua gives the same particles as the C construction of cli/main.c's default. */
static void test_default(void) {
    sm_scene *s = load_file("scenes/default.lua", NULL, 0, NULL);
    if (!s) return;
    const sm_scene_settings *st = sm_scene_get_settings(s);
    CHECK(st->frames == 30 && st->fps == 24);
    CHECK_NEAR(sm_scene_world_def(s)->dx, 0.015, 0);
    if (build(s)) {
        sm_world_def def = sm_world_def_default();
        def.dim = 3;
        def.dx = 0.015;
        def.threads = 1;
        def.max_dt = 1e-3;
        def.domain_min[0] = def.domain_min[2] = -0.6;
        def.domain_max[0] = def.domain_max[2] = 0.6;
        def.domain_min[1] = -0.05;
        def.domain_max[1] = 0.5;
        sm_world *w = NULL;
        CHECK(sm_world_create(&def, &w, err, sizeof err) == SM_OK);
        sm_material_def sand = sm_material_def_sand();
        int mat = -1;
        CHECK(sm_world_add_material(w, &sand, &mat) == SM_OK);
        sm_shape col = sm_shape_default(SM_SHAPE_CYLINDER);
        col.center[1] = 0.2;
        col.radius = 0.1;
        col.half_height = 0.2;
        sm_seed_def sd = sm_seed_def_default();
        sd.material = mat;
        sd.ppc = 8;
        CHECK(sm_world_seed_shape(w, &col, &sd, NULL) == SM_OK);
        sm_world *ws = sm_scene_world(s);
        sm_diagnostics a, b;
        sm_world_diagnostics(w, &a);
        sm_world_diagnostics(ws, &b);
        printf("default scene: %zu particles (C: %zu), estimate %zu\n", b.particles, a.particles, st->estimated_particles);
        CHECK(a.particles == b.particles);
        CHECK(sm_world_state_hash(w) == sm_world_state_hash(ws));
        CHECK_REL((double)b.particles, (double)st->estimated_particles, 0.10, 0);
        const sm_world_def *d = sm_world_get_def(ws);
        CHECK(d->wall_mode == def.wall_mode && d->max_dt == def.max_dt && d->cfl == def.cfl);
        double x[3] = {0.3, -0.02, 0.3};
        CHECK_NEAR(sm_world_collider_distance(ws, 0, x, NULL), -0.02, 1e-12);
        sm_world_destroy(w);
    }
    sm_scene_destroy(s);
    s = load_file("scenes/default.lua", NULL, 0, "test");
    if (s) {
        CHECK(sm_scene_get_settings(s)->frames == 2);
        CHECK_NEAR(sm_scene_world_def(s)->dx, 0.04, 0);
    }
    sm_scene_destroy(s);
    s = load_file("scenes/default.lua", NULL, 0, "paper");
    if (s) {
        CHECK(sm_scene_get_settings(s)->frames == 30);
        CHECK_NEAR(sm_scene_world_def(s)->dx, 0.005, 0);
        printf("default scene at paper quality: estimate %zu particles, %.0f MB\n",
               sm_scene_get_settings(s)->estimated_particles, sm_scene_get_settings(s)->estimated_bytes / 1e6);
    }
    sm_scene_destroy(s);
}

typedef struct bad_case {
    const char *src;
    const char *want[3]; /* substrings the message must contain */
} bad_case;

#define OK3 "  fps = 24, frames = 1, domain = { min = {0, 0, 0}, max = {1, 1, 1} },\n"
#define MAT "  materials = { sand = { friction_angle = 30 } },\n"
#define OBJ "  objects = { { shape = { type = 'sphere', center = {0.5, 0.5, 0.5}, radius = 0.1 } } },\n"

static const bad_case bad[] = {
    {"return { dx = 0.02, }}\n", {"bad.lua:1: <eof> expected near '}'"}},
    {"return {\n  dx = 0.02\n  ppc = 4 }\n", {"bad.lua:3:", "'}' expected (to close '{' at line 1) near 'ppc'"}},
    {"return { dx = 'abc',\n" OK3 "}\n", {"bad.lua:1: dx: expected a number, got string \"abc\""}},
    {"return { dx = 0/0,\n" OK3 "}\n", {"bad.lua:1: dx: must be a finite number, got NaN"}},
    {"return { dx = 1/0,\n" OK3 "}\n", {"dx: must be a finite number, got inf"}},
    {"return { dx = -0.01,\n" OK3 "}\n", {"dx: must be > 0, got -0.01"}},
    {"return {\n" OK3 "}\n", {"bad.lua: dx: required"}},
    {"return { dx = 0.1, ppc = 8 }\n", {"bad.lua: frames or end_time: one is required"}},
    {"return { dx = 0.1, frames = 2, end_time = 1 }\n", {"give frames or end_time, not both"}},
    {"return { dx = 0.1, frames = 2.5 }\n", {"frames: expected a whole number, got 2.5"}},
    {"return { dx = 0.1, frames = 0 }\n", {"frames: must be in 1 .. 1000000, got 0"}},
    {"return { dx = 0.1, dim = 4,\n" OK3 "}\n", {"bad.lua:1: dim: must be 2 or 3, got 4"}},
    {"return { dx = 0.1, dxx = 3,\n" OK3 "}\n", {"bad.lua:1: dxx: unknown key (did you mean \"dx\"?)"}},
    {"return { dx = 0.1, threads = 3,\n" OK3 "}\n", {"threads: not a scene key", "--threads"}},
    {"return { dx = 0.1, gravity = {0, -9.81},\n" OK3 "}\n", {"gravity: expected {x, y, z}: 3 numbers, got 2"}},
    {"return { dx = 0.1, gravity = {0, '-9.81', 0},\n" OK3 "}\n", {"gravity[2]: expected a number, got string"}},
    {"return { dx = 0.1, gravity = {x = 0, y = -9.81, z = 0},\n" OK3 "}\n", {"gravity: expected {x, y, z} (3 numbers), found key"}},
    {"return { dx = 0.1, kernel = 'quadratik',\n" OK3 "}\n", {"kernel: expected \"quadratic\" or \"cubic\", got \"quadratik\""}},
    {"return { dx = 0.1, integrator = 'explicitt',\n" OK3 "}\n", {"integrator: expected \"explicit\" or \"implicit\", got \"explicitt\""}},
    {"return { dx = 0.1, gmres_max_iterations = 500,\n" OK3 "}\n", {"gmres_max_iterations: must be in 1..200, got 500"}},
    {"return { dx = 0.1, fps = 24, frames = 1, domain = { min = {0, 0, 0}, max = {1, 0, 1} } }\n",
     {"bad.lua:1: domain: max must exceed min along axis y (got 0 .. 0)"}},
    {"return { dx = 0.1, fps = 24, frames = 1, domain = { min = {0, 0, 0}, max = {1, -1, 1} } }\n", {"domain: max must exceed min along axis y (got 0 .. -1)"}},
    {"return { dx = 0.1, fps = 24, frames = 1, domain = { min = {0, 0, 0}, max = {0.3, 1, 1} } }\n", {"bad.lua:1: domain: at least 6 cells needed along axis x, got 3 (length 0.3, dx 0.1)"}},
    {"return { dx = 0.1, fps = 24, frames = 1, domain = { mn = {0, 0, 0} } }\n", {"domain.mn: unknown key (did you mean \"min\"?)"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { sand = { model = 'sand', E = -5, friction_angle = 30 } } }\n",
     {"bad.lua:3: materials.sand.E: must be > 0, got -5"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { sand = { nu = 0.5, friction_angle = 30 } } }\n", {"materials.sand.nu: must be in (-1, 0.5), got 0.5"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { sand = { } } }\n", {"materials.sand: sand needs friction_angle", "or hardening"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { sand = { friction_angle = 30, hardening = {35, 9, 0.2, 10} } } }\n", {"not both"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { sand = { hardening = {35, 9, 0.2} } } }\n", {"materials.sand.hardening: expected {h0, h1, h2, h3}"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { sand = { hardening = {10, 9, 0.2, 35} } } }\n", {"need h0 > h3"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { ball = { model = 'elastic', friction_angle = 30 } } }\n", {"an elastic material has no friction_angle"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { sand = { model = 'sandy', friction_angle = 30 } } }\n", {"materials.sand.model: expected \"sand\" or \"elastic\", got \"sandy\""}},
    {"return { dx = 0.1,\n" OK3 MAT "  objects = { { shape = { type = 'sphere', center = {0.5, 0.5, 0.5}, radius = 0.1 }, material = 'snad' } } }\n",
     {"bad.lua:4: objects[1].material: unknown material \"snad\" (did you mean \"sand\"?)"}},
    {"return { dx = 0.1,\n" OK3 "  materials = { a = { friction_angle = 30 }, b = { friction_angle = 20 } },\n" OBJ "}\n", {"objects[1].material: required (the scene has 2 materials)"}},
    {"return { dx = 0.1,\n" OK3 OBJ "}\n", {"objects[1].material: required, and the scene defines no materials"}},
    {"return { dx = 0.1,\n" OK3 MAT "  objects = { shape = { type = 'sphere' } } }\n", {"objects: expected a list of objects", "found key \"shape\""}},
    {"return { dx = 0.1,\n" OK3 MAT "  objects = { { shape = { type = 'cube', center = {0.5, 0.5, 0.5} } } } }\n",
     {"objects[1].shape.type: expected \"box\", \"sphere\", \"cylinder\" or \"halfspace\", got \"cube\""}},
    {"return { dx = 0.1,\n" OK3 MAT "  objects = { { shape = { type = 'sphere', center = {0.5, 0.5, 0.5}, radius = 0.1, half_extent = {1, 1, 1} } } } }\n",
     {"objects[1].shape.half_extent: unknown key (a sphere takes: type, center, radius, inside_out)"}},
    {"return { dx = 0.1,\n" OK3 MAT "  objects = { { shape = { type = 'box', center = {0.5, 0.5, 0.5}, size = {0.1, 0, 0.1} } } } }\n",
     {"bad.lua:4: objects[1].shape.size: must be > 0, got 0 (half_extent = size / 2)"}},
    {"return { dx = 0.1,\n" OK3 MAT "  objects = { { shape = { type = 'box', center = {0.5, 0.5, 0.5}, size = {0.1, 0.1, 0.1}, rotation = {1, 1, 0, 0} } } } }\n",
     {"objects[1].shape.rotation: must be a unit quaternion"}},
    {"return { dx = 0.1,\n" OK3 MAT "  objects = { { shape = { type = 'sphere', center = {5, 0.5, 0.5}, radius = 0.1 } } } }\n",
     {"bad.lua:4: objects[1].shape: outside the domain along x"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'halfspace', point = {0, 0, 0}, normal = {0, 1, 0} }, mode = 'sticky' },\n"
     "    { shape = { type = 'halfspace', point = {0, 0, 0}, normal = {0, 1, 0} }, mode = 'slip', frction = 0.3 } } }\n",
     {"bad.lua:6: colliders[2].frction: unknown key (did you mean \"friction\"?)"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'halfspace', point = {0, 0, 0}, normal = {0, 1, 0} }, mode = 'slipp' } } }\n",
     {"bad.lua:5: colliders[1].mode: expected \"sticky\", \"slip\" or \"separate\", got \"slipp\""}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'halfspace', point = {0, 0, 0}, normal = {0, 0, 0} }, mode = 'slip' } } }\n",
     {"bad.lua:5: colliders[1].shape.normal: must be a finite non-zero vector"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'halfspace', point = {0, 0, 0}, normal = {0, 1, 0} } } } }\n",
     {"colliders[1].mode: required"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'sphere', center = {0, 0, 0}, radius = 1 }, mode = 'slip', friction = -1 } } }\n",
     {"colliders[1].friction: must be >= 0, got -1"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'sphere', center = {0, 0, 0}, radius = 1 }, mode = 'slip', velocity = {1, 0, 0}, motion = function(t) return {0, 0, 0} end } } }\n",
     {"colliders[1]: give at most one kind of motion"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'sphere', center = {0, 0, 0}, radius = 1 }, mode = 'slip', keyframes = { {t = 1, position = {0, 0, 0}}, {t = 0.5, position = {0, 0, 0}} } } } }\n",
     {"colliders[1].keyframes[2].t: keyframe times must increase, got 0.5 after 1"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'sphere', center = {0, 0, 0}, radius = 1 }, mode = 'slip', motion = function(t) return 5 end } } }\n",
     {"bad.lua:5: colliders[1].motion at t = 0: returned position: expected {x, y, z}, got number"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'sphere', center = {0, 0, 0}, radius = 1 }, mode = 'slip', motion = function(t) error('nope') end } } }\n",
     {"bad.lua:5: nope (colliders[1].motion at t = 0)"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  colliders = { { shape = { type = 'sphere', center = {0, 0, 0}, radius = 1 }, mode = 'slip', shapes = {} } } }\n",
     {"colliders[1]: give shape or shapes, not both"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  emitters = { { shape = { type = 'sphere', center = {0.5, 0.8, 0.5}, radius = 0.05 } } } }\n",
     {"emitters[1].rate: required (mass flow"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  emitters = { { shape = { type = 'sphere', center = {0.5, 8, 0.5}, radius = 0.05 }, rate = 1 } } }\n",
     {"emitters[1].shape: outside the domain"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  camera = { eye = {1, 1, 1} } }\n", {"camera.target: required"}},
    {"return { dx = 0.1,\n" OK3 MAT OBJ "  outputs = { ply = 1 } }\n", {"outputs.ply: expected true or false, got number"}},
    /* runtime errors and the sandbox */
    {"local x = nil\nreturn { dx = x.y }\n", {"bad.lua:2: attempt to index a nil value (local 'x')"}},
    {"error('custom failure')\n", {"bad.lua:1: custom failure"}},
    {"error({})\n", {"bad.lua: (error object is a table value)"}},
    {"return 42\n", {"bad.lua: the scene file must return a table", "got number"}},
    {"local n = 0\nwhile true do n = n + 1 end\n", {"bad.lua:2: instruction limit exceeded"}},
    {"while true do pcall(function() while true do end end) end\n", {"instruction limit exceeded"}},
    {"do local x <close> = setmetatable({}, { __close = function() while true do end end }) end\n",
     {"bad.lua:1: instruction limit exceeded"}},
    {"local x <close> = setmetatable({}, { __close = function() while true do end end })\nwhile true do end\n",
     {"bad.lua:2: instruction limit exceeded"}}, /* the loop that ran out; the __close cannot replace it */
    {"local s = string.rep('x', 300000000)\n", {"bad.lua: memory limit exceeded"}},
    {"local t = {}\nfor i = 1, 1e9 do t[i] = string.rep('x', 1000) .. i end\n", {"bad.lua: memory limit exceeded"}},
    {"local f = io.open('/etc/passwd')\n", {"bad.lua:1: io is not available in scene files"}},
    {"os.execute('touch /tmp/sandmpm_pwned')\n", {"bad.lua:1: os is not available in scene files"}},
    {"local m = require('os')\n", {"bad.lua:1: require is not available in scene files"}},
    {"dofile('/etc/passwd')\n", {"bad.lua:1: dofile is not available in scene files"}},
    {"loadfile('/etc/passwd')\n", {"loadfile is not available"}},
    {"local f = load('return 1')\n", {"load is not available"}},
    {"local b = string.dump(function() end)\n", {"bad.lua:1: string.dump is not available"}},
    {"local b = ('x'):dump()\n", {"string.dump is not available"}},
    {"local x = debug.getinfo(1)\n", {"debug is not available"}},
    {"local x = package.loaded\n", {"package is not available"}},
    {"setmetatable(_G, nil)\n", {"bad.lua:1: cannot change a protected metatable"}},
    {"return { dim = 2, dx = 0.1, frames = 1, domain = { min = {0, 0}, max = {1, 1} },\n"
     "  colliders = { { shape = { type = 'box', center = {0.5, 0.5}, half_extent = {0.1, 0.1}, axis_angle = {1, 0, 0, 30} }, mode = 'slip' } } }\n",
     {"bad.lua:2: colliders[1].shape.axis_angle: in 2D a rotation must be about z"}},
    {"return { dim = 2, dx = 0.1, frames = 1, domain = { min = {0, 0}, max = {1, 1} },\n"
     "  colliders = { { shape = { type = 'sphere', center = {0.5, 0.5}, radius = 0.1 }, mode = 'slip', angular_velocity = {0, 0, 1} } } }\n",
     {"colliders[1].angular_velocity: expected a number (rad/s about z, in 2D), got table"}},
    {"return { dim = 2, dx = 0.1, frames = 1, domain = { min = {0, 0}, max = {1, 1, 1} } }\n", {"domain.max: expected {x, y}: 2 numbers, got 3"}},
    {"\x1bLua\x54\x00\x19\x93\r\n\x1a\n", {"bad.lua: attempt to load a binary chunk (mode is 't')"}},
};

static void test_bad(void) {
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        sm_scene *s = (sm_scene *)1;
        err[0] = 0;
        int rc = sm_scene_load("tests/bad.lua", bad[i].src, NULL, 0, NULL, 0, &s, err, sizeof err);
        int ok = rc == 2 && s == NULL;
        for (int k = 0; k < 3 && bad[i].want[k]; k++)
            if (!strstr(err, bad[i].want[k])) ok = 0;
        CHECK(ok);
        if (!ok) fprintf(stderr, "  bad case %zu: rc %d, message: %s\n", i, rc, err);
        else printf("  %s\n", err);
    }
    /* --set keys must be names */
    sm_scene *s = NULL;
    sm_scene_param kp[] = {{"a-b", "1"}};
    CHECK(sm_scene_load("bad.lua", "return {}", kp, 1, NULL, 0, &s, err, sizeof err) == 2 && s == NULL);
    CHECK(strstr(err, "--set a-b=1: the key must be a name") != NULL);
    /* an object that seeds nothing (its clip is elsewhere): load estimates 0, build refuses */
    CHECK(sm_scene_load("clip.lua",
                        "return { dx = 0.1,\n" OK3 MAT
                        "  objects = { { shape = { type = 'sphere', center = {0.5, 0.5, 0.5}, radius = 0.1 },\n"
                        "                clip = { type = 'box', center = {0.2, 0.2, 0.2}, size = {0.1, 0.1, 0.1} } } } }\n",
                        NULL, 0, NULL, 0, &s, err, sizeof err) == 0);
    if (s) {
        CHECK(sm_scene_get_settings(s)->estimated_particles == 0);
        CHECK(sm_scene_build(s, err, sizeof err) == 2);
        CHECK(strstr(err, "clip.lua: objects[1]: no particles") != NULL);
        printf("  %s\n", err);
        CHECK(sm_scene_world(s) == NULL);
    }
    sm_scene_destroy(s);
    s = NULL;
    /* finalizers run with hooks off (no instruction limit): refused; setmetatable works otherwise */
    CHECK(sm_scene_load("gc.lua", "local keep = setmetatable({}, { __gc = function() while true do end end })\n",
                        NULL, 0, NULL, 0, &s, err, sizeof err) == 2);
    CHECK(strstr(err, "gc.lua:1: __gc metamethods are not allowed") != NULL);
    CHECK(sm_scene_load("mt.lua",
                        "local mt = { __index = function(t, k) return 0.1 end }\n"
                        "local d = setmetatable({}, mt)\n"
                        "assert(getmetatable(d) == mt)\n"
                        "local mt2 = {} local e = setmetatable({}, mt2) mt2.__gc = function() while true do end end\n"
                        "return { dx = d.anything,\n" OK3 MAT OBJ "}\n",
                        NULL, 0, NULL, 0, &s, err, sizeof err) == 0);
    if (s) CHECK_NEAR(sm_scene_world_def(s)->dx, 0.1, 0);
    sm_scene_destroy(s);
    s = NULL;
    /* no such file */
    CHECK(sm_scene_load("/nonexistent/x.lua", NULL, NULL, 0, NULL, 0, &s, err, sizeof err) == SM_ERR_IO && s == NULL);
    CHECK(strstr(err, "/nonexistent/x.lua: cannot open") != NULL);
    /* a tiny error buffer is fine */
    char small[8];
    CHECK(sm_scene_load("bad.lua", "return nil", NULL, 0, NULL, 0, &s, small, sizeof small) == 2);
    CHECK(strlen(small) == 7);
    /* the endless loop does not take long: the count hook */
    sm_scene_destroy(NULL);
}

static void quat_about(double ax, double ay, double az, double deg, double q[4]) {
    double h = 0.5 * deg * M_PI / 180, n = sqrt(ax * ax + ay * ay + az * az);
    q[0] = cos(h);
    q[1] = sin(h) * ax / n;
    q[2] = sin(h) * ay / n;
    q[3] = sin(h) * az / n;
}

static void check_pose(const sm_pose *p, const double pos[3], const double rot[4]) {
    for (int a = 0; a < 3; a++) CHECK_NEAR(p->position[a], pos[a], 1e-9);
    double sgn = p->rotation[0] * rot[0] + p->rotation[1] * rot[1] + p->rotation[2] * rot[2] + p->rotation[3] * rot[3] < 0 ? -1 : 1;
    for (int k = 0; k < 4; k++) CHECK_NEAR(p->rotation[k], sgn * rot[k], 1e-9);
}

static void test_motion(void) {
    sm_scene *s = load_file("tests/scenes/motion.lua", NULL, 0, NULL);
    if (!s || !build(s)) {
        sm_scene_destroy(s);
        return;
    }
    sm_world *w = sm_scene_world(s);
    sm_pose p;
    double pos[3], rot[4];
    /* t = 0 */
    sm_world_collider_pose(w, 0, &p);
    pos[0] = 0.1, pos[1] = 0.4, pos[2] = 0.2;
    quat_about(0, 1, 0, 0, rot);
    check_pose(&p, pos, rot);
    const double T[] = {0.05, 0.125, 0.25, 0.35};
    for (int i = 0; i < 4; i++) {
        double t = T[i];
        CHECK(sm_world_advance(w, t) == SM_OK);
        CHECK_NEAR(sm_world_time(w), t, 1e-12);
        /* keyframes: x from 0.1 to 0.2 and 0 -> 90 degrees about y over [0, 0.2]; then y 0.4 -> 0.5 and back
           to identity over [0.2, 0.3]; clamped after */
        sm_world_collider_pose(w, 0, &p);
        if (t <= 0.2) {
            double u = t / 0.2;
            pos[0] = 0.1 + 0.1 * u, pos[1] = 0.4;
            quat_about(0, 1, 0, 90 * u, rot);
        } else {
            double u = fmin(1, (t - 0.2) / 0.1);
            pos[0] = 0.2, pos[1] = 0.4 + 0.1 * u;
            quat_about(0, 1, 0, 90 * (1 - u), rot);
        }
        pos[2] = 0.2;
        check_pose(&p, pos, rot);
        /* the Lua function */
        sm_world_collider_pose(w, 1, &p);
        pos[0] = 0.3 + 0.1 * t, pos[1] = 0.3 + 0.2 * t * t, pos[2] = 0.2;
        quat_about(0, 0, 1, 30 * t, rot);
        check_pose(&p, pos, rot);
        /* the collider is where the function says: its centre is 0.03 inside */
        CHECK_NEAR(sm_world_collider_distance(w, 1, pos, NULL), -0.03, 1e-9);
    }
    CHECK(sm_scene_motion_error(s) == NULL);
    sm_scene_destroy(s);

    /* a motion function that fails after t = 0.1 */
    sm_scene_param prm[] = {{"fail_after", "0.1"}};
    s = load_file("tests/scenes/motion.lua", prm, 1, NULL);
    if (!s || !build(s)) {
        sm_scene_destroy(s);
        return;
    }
    w = sm_scene_world(s);
    CHECK(sm_world_advance(w, 0.1) == SM_OK);
    CHECK(sm_scene_motion_error(s) == NULL);
    CHECK(sm_world_advance(w, 0.15) == SM_OK); /* the library goes on; the caller checks */
    const char *me = sm_scene_motion_error(s);
    CHECK(me != NULL);
    if (me) {
        printf("motion error: %s\n", me);
        CHECK(strstr(me, "tests/scenes/motion.lua:5: boom at t = ") != NULL);
        CHECK(strstr(me, "(colliders[2].motion at t = ") != NULL);
    }
    sm_world_collider_pose(w, 1, &p);
    CHECK(p.position[0] <= 0.3 + 0.1 * 0.1 + 1e-12); /* the last good pose (t <= 0.1) */
    CHECK(p.position[0] >= 0.3 + 0.1 * 0.09);
    CHECK(sm_world_advance(w, 0.2) == SM_OK);
    CHECK(sm_scene_motion_error(s) != NULL);
    sm_scene_destroy(s);

    /* an endless loop in a motion function: the per-call instruction limit */
    char src[2048];
    snprintf(src, sizeof src,
             "return { dx = 0.1,\n" OK3 MAT OBJ
             "  colliders = { { shape = { type = 'sphere', center = {0, 0, 0}, radius = 0.05 }, mode = 'slip',\n"
             "    motion = function(t) while t > 0.01 do end return {0.2, 0.2, 0.2} end } } }\n");
    s = NULL;
    CHECK(sm_scene_load("loop.lua", src, NULL, 0, NULL, 1, &s, err, sizeof err) == 0);
    if (s && build(s)) {
        CHECK(sm_world_advance(sm_scene_world(s), 0.05) == SM_OK);
        me = sm_scene_motion_error(s);
        CHECK(me && strstr(me, "loop.lua:6: instruction limit exceeded (1 million"));
        if (me) printf("motion error: %s\n", me);
    }
    sm_scene_destroy(s);
}

static void test_emitter(void) {
    const char *src = "return { dim = 2, dx = 0.02, fps = 10, end_time = 0.5,\n"
                      "  domain = { min = {0, 0}, max = {1, 1} },\n"
                      "  materials = { sand = { friction_angle = 30, density = 2000 } },\n"
                      "  emitters = { { shape = { type = 'box', center = {0.5, 0.8}, size = {0.1, 0.05} }, material = 'sand',\n"
                      "                 rate = 20, start = 0.1, stop = 0.3, velocity = {0, -1} } },\n"
                      "  colliders = { { shape = { type = 'halfspace', point = {0, 0.1}, normal = {0, 1} }, mode = 'sticky' } } }\n";
    sm_scene *s = NULL;
    int rc = sm_scene_load("emit.lua", src, NULL, 0, NULL, 1, &s, err, sizeof err);
    if (rc) fprintf(stderr, "%s\n", err);
    CHECK(rc == 0);
    if (!s) return;
    const sm_scene_settings *st = sm_scene_get_settings(s);
    CHECK(st->estimated_particles == 0);
    /* 20 kg/(m s) for 0.2 s, particle mass 2000 * 0.02^2 / 4 = 0.2 kg/m: 20 particles */
    CHECK(st->estimated_emitted == 20);
    if (build(s)) {
        sm_world *w = sm_scene_world(s);
        CHECK(sm_world_advance(w, 0.4) == SM_OK);
        sm_diagnostics d;
        sm_world_diagnostics(w, &d);
        CHECK_NEAR(sm_world_emitted_mass(w, 0), 4.0, 0.2 + 1e-9);
        printf("emitter: %zu particles, %.17g kg\n", d.particles, sm_world_emitted_mass(w, 0));
        CHECK(d.particles >= 19 && d.particles <= 20);
    }
    sm_scene_destroy(s);
}

int main(void) {
    test_valid3d();
    test_valid2d();
    test_params_quality();
    test_default();
    test_bad();
    test_motion();
    test_emitter();
    return sm_test_summary("test_scene");
}
