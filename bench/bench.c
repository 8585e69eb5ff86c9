/* Benchmark: a block of sand collapsing under gravity onto a sticky ground (3D by default:
 * hardening 35/9/0.2/10, quadratic kernel, APIC, 8 particles per cell, explicit).
 * Prints particle-steps per second, in total and per stage, for each thread count asked.
 * Precision is the build's (sm_real); scripts/bench.sh runs the float and the double build.
 *
 *   sm_bench [--dim 2|3] [--particles N] [--steps S] [--warmup W] [--threads 1,2] [--csv]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "sandmpm/sandmpm.h"

static double now(void) {
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static sm_world *build(int dim, double target, int threads) {
    /* Block of side L with ppc = 8 at dx: n = (L/dx)^d * 8, L chosen so n ~ target. */
    const double ppc = dim == 3 ? 8 : 4;
    const double dx = dim == 3 ? 0.01 : 0.004;
    double cells = pow(target / ppc, 1.0 / dim);
    double L = cells * dx;
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dx;
    def.threads = threads;
    def.max_dt = 1e-3;
    for (int a = 0; a < dim; a++) {
        def.domain_min[a] = 0;
        def.domain_max[a] = (a == 1 ? 1.6 * L : 3.0 * L) + 8 * dx;
    }
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "sm_bench: %s\n", err);
        exit(2);
    }
    sm_material_def m = sm_material_def_sand();
    int mat = sm_world_add_material(w, &m);
    sm_collider_def g = sm_collider_def_default();
    g.shape_count = 1;
    g.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    g.shapes[0].center[1] = 3 * dx;
    g.shapes[0].normal[1] = 1;
    g.mode = SM_COLLIDE_STICKY;
    sm_world_add_collider(w, &g);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    for (int a = 0; a < dim; a++) {
        box.center[a] = a == 1 ? 3 * dx + 0.5 * L : 0.5 * def.domain_max[a];
        box.half_extent[a] = 0.5 * L;
    }
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = ppc;
    if (sm_world_seed_shape(w, &box, &sd, NULL) != SM_OK) {
        fprintf(stderr, "sm_bench: %s\n", sm_world_errmsg(w));
        exit(2);
    }
    return w;
}

int main(int argc, char **argv) {
    int dim = 3, steps = 40, warmup = 20, csv = 0;
    double target = 250000;
    const char *threads_arg = "1,2";
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--dim") && i + 1 < argc) dim = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--particles") && i + 1 < argc) target = atof(argv[++i]);
        else if (!strcmp(argv[i], "--steps") && i + 1 < argc) steps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--warmup") && i + 1 < argc) warmup = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads_arg = argv[++i];
        else if (!strcmp(argv[i], "--csv")) csv = 1;
        else {
            fprintf(stderr, "usage: sm_bench [--dim 2|3] [--particles N] [--steps S] [--warmup W] [--threads 1,2] [--csv]\n");
            return 2;
        }
    }
    if ((dim != 2 && dim != 3) || steps < 1 || warmup < 0 || !(target > 0)) {
        fprintf(stderr, "sm_bench: bad arguments\n");
        return 2;
    }
    const char *prec = sm_real_is_double() ? "double" : "float";
    if (csv) printf("dim,precision,threads,particles,particle_steps_per_s\n");
    char buf[64];
    snprintf(buf, sizeof buf, "%s", threads_arg);
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        int th = atoi(tok);
        sm_world *w = build(dim, target, th);
        /* Warm up into the collapse (sand in motion, plasticity active), then measure. */
        for (int s = 0; s < warmup; s++) sm_world_step(w, sm_world_next_dt(w, 1e9));
        sm_diagnostics d0, d1;
        sm_world_diagnostics(w, &d0);
        double t0 = now();
        for (int s = 0; s < steps; s++) {
            sm_status st = sm_world_step(w, sm_world_next_dt(w, 1e9));
            if (st != SM_OK) {
                fprintf(stderr, "sm_bench: %s\n", sm_world_errmsg(w));
                return 3;
            }
        }
        double t1 = now();
        sm_world_diagnostics(w, &d1);
        double ps = (double)d1.particles * steps / (t1 - t0);
        if (csv) {
            printf("%d,%s,%d,%zu,%.4g\n", dim, prec, th, d1.particles, ps);
        } else {
            printf("%dD %s, %d thread(s), %zu particles, %d steps: %.3g particle-steps/s (%.3f s)\n", dim, prec, th,
                   d1.particles, steps, ps, t1 - t0);
            for (int s = 0; s < SM_STAGE_COUNT; s++) {
                double sec = d1.stage_seconds[s] - d0.stage_seconds[s];
                printf("  %-11s %8.3f s  %10.3g particle-steps/s  %5.1f%%\n", sm_stage_name((sm_stage)s), sec,
                       sec > 0 ? (double)d1.particles * steps / sec : 0.0, 100.0 * sec / (t1 - t0));
            }
        }
        sm_world_destroy(w);
    }
    return 0;
}
