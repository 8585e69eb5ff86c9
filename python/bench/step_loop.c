/* The C side of python/bench/step_overhead.py: a step loop over the C API, timed.
 *
 *   step_loop SCENE STEPS WARMUP THREADS
 *     SCENE "block": a 3D sand block of about 100k particles (dx 0.02, ppc 8, box 0.5 x 0.4 x 0.5 m
 *     on a sticky ground at y = 0.1) collapsing; "empty": the same world without particles (what a
 *     step costs the caller besides the simulation itself).
 *   Prints "particles N", "seconds_per_step S" (wall time of STEPS steps after WARMUP, each step
 *   sm_world_step(w, sm_world_next_dt(w, INFINITY)), the loop Python's World.step() makes),
 *   "cpu_seconds_per_step" (the process's CPU time, less sensitive to other programs on the
 *   machine than wall time) and "hash H" (the state hash at the end, to check that both loops
 *   simulated the same thing).
 *
 * Not a test: a benchmark (docs/python.md, "Overhead"). Linked against the shared library, the
 * one Python loads. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "sandmpm/sandmpm.h"

static double seconds(clockid_t clock) {
    struct timespec ts;
    clock_gettime(clock, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The scene of step_overhead.py's build(). */
static sm_world *build(int with_particles, int threads) {
    sm_world_def def = sm_world_def_default();
    def.dx = 0.02;
    def.threads = threads;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "step_loop: %s\n", err);
        return NULL;
    }
    sm_collider_def ground = sm_collider_def_default();
    ground.shape_count = 1;
    ground.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    ground.shapes[0].center[1] = 0.1;
    ground.shapes[0].normal[1] = 1;
    sm_material_def sand = sm_material_def_sand();
    int mat = -1;
    sm_status st = sm_world_add_material(w, &sand, &mat);
    if (st == SM_OK) st = sm_world_add_collider(w, &ground, NULL);
    if (st == SM_OK && with_particles) {
        sm_shape block = sm_shape_default(SM_SHAPE_BOX);
        block.center[0] = block.center[2] = 0.5;
        block.center[1] = 0.3;
        block.half_extent[0] = block.half_extent[2] = 0.25;
        block.half_extent[1] = 0.2;
        sm_seed_def seed = sm_seed_def_default();
        seed.material = mat;
        seed.ppc = 8;
        st = sm_world_seed_shape(w, &block, &seed, NULL);
    }
    if (st != SM_OK) {
        fprintf(stderr, "step_loop: %s\n", sm_world_errmsg(w));
        sm_world_destroy(w);
        return NULL;
    }
    return w;
}

int main(int argc, char **argv) {
    if (argc != 5 || (strcmp(argv[1], "block") && strcmp(argv[1], "empty"))) {
        fprintf(stderr, "usage: step_loop block|empty STEPS WARMUP THREADS\n");
        return 2;
    }
    int steps = atoi(argv[2]), warmup = atoi(argv[3]);
    sm_world *w = build(!strcmp(argv[1], "block"), atoi(argv[4]));
    if (!w) return 1;
    sm_status st = SM_OK;
    for (int i = 0; i < warmup && st == SM_OK; i++) st = sm_world_step(w, sm_world_next_dt(w, INFINITY));
    double t0 = seconds(CLOCK_MONOTONIC), c0 = seconds(CLOCK_PROCESS_CPUTIME_ID);
    for (int i = 0; i < steps && st == SM_OK; i++) st = sm_world_step(w, sm_world_next_dt(w, INFINITY));
    double t1 = seconds(CLOCK_MONOTONIC), c1 = seconds(CLOCK_PROCESS_CPUTIME_ID);
    if (st != SM_OK) {
        fprintf(stderr, "step_loop: %s\n", sm_world_errmsg(w));
        sm_world_destroy(w);
        return 1;
    }
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    printf("particles %zu\nseconds_per_step %.9g\ncpu_seconds_per_step %.9g\nhash %016llx\n", d.particles,
           (t1 - t0) / steps, (c1 - c0) / steps, (unsigned long long)sm_world_state_hash(w));
    sm_world_destroy(w);
    return 0;
}
