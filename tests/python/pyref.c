/* The C side of the Python binding's tests (tests/python/test_*.py): builds the same small worlds
 * as the tests do from Python, steps them with the C API, and prints what the tests compare
 * bitwise: state hashes, and a few diagnostics printed with %.17g (exact for doubles).
 *
 *   pyref column3        3D sand column, 20 adaptive steps: "step i hash"
 *   pyref frames2        2D column, 3 frames at 60 fps with sm_world_advance: "frame f hash"
 *   pyref kick           3D column, 5 steps, velocity of storage index 7 set to (0.5, 1, -0.25),
 *                        5 steps: "kicked hash" (right after the write), "after hash"
 *   pyref plate const    2D sand layer pushed by a plate at 0.5 m/s (constant velocity), advanced
 *   pyref plate motion   to 0.1 s; "const": the collider's velocity, "motion": a motion function
 *                        returning x0 + v t: "hash", "plate_x", "front_vx" (mean x velocity of the
 *                        particles within 2 dx in front of the plate face), "com_x"
 *
 * Linked against the shared library, the one Python loads. Exit status 0, or 1 on a library error
 * (printed to stderr). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sandmpm/sandmpm.h"

#define PLATE_X0 0.285
#define PLATE_Y0 0.2
#define PLATE_V 0.5
#define PLATE_HALF_W 0.01

static int fail(sm_world *w, sm_status st) {
    fprintf(stderr, "pyref: %s: %s\n", sm_status_string(st), w ? sm_world_errmsg(w) : "");
    sm_world_destroy(w);
    return 1;
}

static unsigned long long hash(const sm_world *w) { return (unsigned long long)sm_world_state_hash(w); }

/* Sand column on a sticky ground, as tests/python/scenes.py column(). */
static sm_world *column(int dim, double dx) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dx;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "pyref: %s\n", err);
        return NULL;
    }
    sm_material_def sand = sm_material_def_sand();
    int mat = -1;
    sm_collider_def ground = sm_collider_def_default();
    ground.shape_count = 1;
    ground.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    ground.shapes[0].center[1] = 0.1;
    ground.shapes[0].normal[1] = 1;
    sm_shape col = sm_shape_default(SM_SHAPE_CYLINDER);
    col.center[0] = col.center[2] = 0.5;
    col.center[1] = 0.25;
    col.radius = 0.1;
    col.half_height = 0.15;
    sm_seed_def seed = sm_seed_def_default();
    seed.ppc = 8;
    sm_status st = sm_world_add_material(w, &sand, &mat);
    seed.material = mat;
    if (st == SM_OK) st = sm_world_add_collider(w, &ground, NULL);
    if (st == SM_OK) st = sm_world_seed_shape(w, &col, &seed, NULL);
    if (st != SM_OK) {
        fail(w, st);
        return NULL;
    }
    return w;
}

static int steps(sm_world *w, int n, int print) {
    for (int i = 1; i <= n; i++) {
        sm_status st = sm_world_step(w, sm_world_next_dt(w, INFINITY));
        if (st != SM_OK) return fail(w, st);
        if (print) printf("step %d %016llx\n", i, hash(w));
    }
    return 0;
}

static int run_column3(void) {
    sm_world *w = column(3, 0.04);
    if (!w || steps(w, 20, 1)) return 1;
    sm_world_destroy(w);
    return 0;
}

static int run_frames2(void) {
    sm_world *w = column(2, 0.02);
    if (!w) return 1;
    for (int f = 1; f <= 3; f++) {
        sm_world_reset_step_stats(w);
        sm_status st = sm_world_advance(w, f / 60.0);
        if (st != SM_OK) return fail(w, st);
        printf("frame %d %016llx\n", f, hash(w));
    }
    sm_world_destroy(w);
    return 0;
}

static int run_kick(void) {
    sm_world *w = column(3, 0.04);
    if (!w || steps(w, 5, 0)) return 1;
    sm_real *v = sm_world_particle_velocities(w);
    v[7 * 3 + 0] = (sm_real)0.5;
    v[7 * 3 + 1] = (sm_real)1.0;
    v[7 * 3 + 2] = (sm_real)-0.25;
    printf("kicked %016llx\n", hash(w));
    if (steps(w, 5, 0)) return 1;
    printf("after %016llx\n", hash(w));
    sm_world_destroy(w);
    return 0;
}

static void plate_motion(void *user, double t, sm_pose *pose) {
    (void)user;
    memset(pose, 0, sizeof *pose);
    pose->position[0] = PLATE_X0 + PLATE_V * t;
    pose->position[1] = PLATE_Y0;
    pose->rotation[0] = 1;
}

/* A 2D sand layer on a sticky ground, pushed in +x by a sticky plate, as scenes.py plate(). */
static int run_plate(int scripted) {
    sm_world_def def = sm_world_def_default();
    def.dim = 2;
    def.dx = 0.01;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "pyref: %s\n", err);
        return 1;
    }
    sm_material_def sand = sm_material_def_sand();
    int mat = -1;
    sm_status st = sm_world_add_material(w, &sand, &mat);
    sm_collider_def ground = sm_collider_def_default();
    ground.shape_count = 1;
    ground.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    ground.shapes[0].center[1] = 0.1;
    ground.shapes[0].normal[1] = 1;
    if (st == SM_OK) st = sm_world_add_collider(w, &ground, NULL);
    sm_collider_def plate = sm_collider_def_default();
    plate.shape_count = 1;
    plate.shapes[0] = sm_shape_default(SM_SHAPE_BOX);
    plate.shapes[0].half_extent[0] = PLATE_HALF_W;
    plate.shapes[0].half_extent[1] = 0.1;
    plate.pose.position[0] = PLATE_X0;
    plate.pose.position[1] = PLATE_Y0;
    if (scripted) plate.motion = plate_motion;
    else plate.velocity[0] = PLATE_V;
    int plate_id = -1;
    if (st == SM_OK) st = sm_world_add_collider(w, &plate, &plate_id);
    sm_shape layer = sm_shape_default(SM_SHAPE_BOX);
    layer.center[0] = 0.5;
    layer.center[1] = 0.15;
    layer.half_extent[0] = 0.2;
    layer.half_extent[1] = 0.05;
    sm_seed_def seed = sm_seed_def_default();
    seed.material = mat;
    seed.ppc = 4;
    if (st == SM_OK) st = sm_world_seed_shape(w, &layer, &seed, NULL);
    if (st == SM_OK) st = sm_world_advance(w, 0.1);
    if (st != SM_OK) return fail(w, st);
    sm_pose pose;
    sm_world_collider_pose(w, plate_id, &pose);
    double face = pose.position[0] + PLATE_HALF_W, sum = 0;
    int count = 0;
    sm_particles_view p;
    sm_world_particles(w, &p);
    for (size_t i = 0; i < p.n; i++) {
        if (p.x[2 * i] > face && p.x[2 * i] < face + 2 * def.dx) {
            sum += p.v[2 * i];
            count++;
        }
    }
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    printf("hash %016llx\nplate_x %.17g\nfront_vx %.17g\nfront_n %d\ncom_x %.17g\n", hash(w), pose.position[0],
           count ? sum / count : 0.0, count, d.center_of_mass[0]);
    sm_world_destroy(w);
    return 0;
}

int main(int argc, char **argv) {
    const char *what = argc > 1 ? argv[1] : "";
    if (!strcmp(what, "column3")) return run_column3();
    if (!strcmp(what, "frames2")) return run_frames2();
    if (!strcmp(what, "kick")) return run_kick();
    if (!strcmp(what, "plate") && argc > 2) return run_plate(!strcmp(argv[2], "motion"));
    fprintf(stderr, "usage: pyref column3 | frames2 | kick | plate const|motion\n");
    return 2;
}
