/* The explicit step's real stability limit in the elastic CFL number k = c dt / dx (issue 18 item 4;
 * docs/benchmarks.md "Time-step limit").
 *
 * The library bounds the explicit dt by elastic_cfl dx / c, c = sqrt((lambda + 2 mu) / rho) the
 * fastest material's P-wave speed (step.c, sm_world_next_dt). This program measures the k at which
 * the step stops being stable: each case runs with a fixed dt = k dx / c (sm_world_step, bypassing
 * the controller) for `seconds` of simulated time, and counts as unstable if a step fails (the CFL
 * check or the health checks), or the fastest particle exceeds V_BLOWUP (the set-ups cannot reach a
 * tenth of it: a block settling under gravity, a ball dropped 0.1 m), or the elastic energy exceeds
 * 100 times the largest it can reach under gravity. k is bisected between a stable and an
 * unstable value to K_TOL. Cases: 2D and 3D, quadratic and cubic kernels, 4 to 32 particles per
 * cell, sand (Drucker-Prager with hardening: plastic flow) and an elastic block, each on a sticky
 * ground; and an elastic ball dropped onto the ground (collision, separate mode).
 *
 *   elastic_limit [--quick] [--seconds S] [--threads N] [--dim 2|3] [--kernel quadratic|cubic]
 * prints one CSV row per case: dim,kernel,ppc,material,setup,k_stable,k_unstable,steps_at_k_stable. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sandmpm/sandmpm.h"

#define V_BLOWUP 20.0 /* m/s */
#define K_TOL 0.02

typedef struct limit_case {
    int dim, kernel, ppc, elastic, ball;
} limit_case;

static double wave_speed(const sm_material_def *m) {
    const double E = m->youngs_modulus, nu = m->poisson_ratio;
    const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
    return sqrt((lambda + 2 * mu) / m->density);
}

static sm_material_def case_material(const limit_case *lc) {
    sm_material_def m = lc->elastic ? sm_material_def_elastic() : sm_material_def_sand();
    m.density = 1500;
    m.youngs_modulus = 1e5;
    m.poisson_ratio = 0.3;
    return m;
}

/* A block 0.2 x 0.1 (x 0.2) m resting on a sticky ground, or a ball of radius 0.05 m 0.1 m above a
 * separating one; dx = 0.02 m (0.01 m for the ball). */
static sm_world *make_world(const limit_case *lc, int threads, double *dx_out) {
    sm_world_def def = sm_world_def_default();
    def.dim = lc->dim;
    def.dx = lc->ball ? 0.01 : 0.02;
    def.kernel = lc->kernel;
    def.threads = threads;
    def.max_dt = 1.0;
    for (int a = 0; a < 3; a++) def.domain_min[a] = 0, def.domain_max[a] = a < lc->dim ? 0.6 : 0;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "elastic_limit: %s\n", err);
        exit(1);
    }
    sm_material_def m = case_material(lc);
    int mat = -1;
    sm_world_add_material(w, &m, &mat);
    sm_collider_def g = sm_collider_def_default();
    g.shape_count = 1;
    g.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    g.shapes[0].center[1] = 0.1;
    g.shapes[0].normal[1] = 1;
    g.mode = lc->ball ? SM_COLLIDE_SEPARATE : SM_COLLIDE_STICKY;
    sm_world_add_collider(w, &g, NULL);
    sm_shape s = sm_shape_default(lc->ball ? SM_SHAPE_SPHERE : SM_SHAPE_BOX);
    for (int a = 0; a < lc->dim; a++) s.center[a] = 0.3;
    if (lc->ball) {
        s.center[1] = 0.1 + 0.1 + 0.05;
        s.radius = 0.05;
    } else {
        s.center[1] = 0.1 + 0.05;
        for (int a = 0; a < lc->dim; a++) s.half_extent[a] = a == 1 ? 0.05 : 0.1;
    }
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = lc->ppc;
    if (sm_world_seed_shape(w, &s, &sd, NULL) != SM_OK) {
        fprintf(stderr, "elastic_limit: seeding: %s\n", sm_world_errmsg(w));
        exit(1);
    }
    *dx_out = def.dx;
    return w;
}

/* 1 if the case runs stably for `seconds` at dt = k dx / c; *steps: the steps taken. */
static int stable_at(const limit_case *lc, double k, double seconds, int threads, long *steps) {
    double dx;
    sm_world *w = make_world(lc, threads, &dx);
    const sm_material_def m = case_material(lc);
    const double dt = k * dx / wave_speed(&m);
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    /* the largest elastic energy gravity can store: the weight M g over the block's own height
     * (or the ball's fall), times a hundred */
    const double e_cap = 100 * d.total_mass * 9.81 * 0.3;
    int ok = 1;
    *steps = 0;
    for (double t = 0; t < seconds && ok; t += dt, ++*steps) {
        if (sm_world_step(w, dt) != SM_OK) ok = 0;
        sm_world_diagnostics(w, &d);
        if (!(d.max_speed < V_BLOWUP) || !(d.elastic_energy < e_cap)) ok = 0;
    }
    sm_world_destroy(w);
    return ok;
}

static void run_case(const limit_case *lc, double seconds, int threads) {
    double lo = 0.25, hi = 4.0;
    long steps = 0, s;
    if (!stable_at(lc, lo, seconds, threads, &steps)) {
        printf("%d,%s,%d,%s,%s,unstable at %.2f\n", lc->dim, lc->kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic",
               lc->ppc, lc->elastic ? "elastic" : "sand", lc->ball ? "ball" : "block", lo);
        return;
    }
    while (stable_at(lc, hi, seconds, threads, &s) && hi < 64) lo = hi, steps = s, hi *= 2;
    while (hi - lo > K_TOL) {
        const double mid = 0.5 * (lo + hi);
        if (stable_at(lc, mid, seconds, threads, &s)) lo = mid, steps = s;
        else hi = mid;
    }
    printf("%d,%s,%d,%s,%s,%.3f,%.3f,%ld\n", lc->dim, lc->kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic", lc->ppc,
           lc->elastic ? "elastic" : "sand", lc->ball ? "ball" : "block", lo, hi, steps);
    fflush(stdout);
}

int main(int argc, char **argv) {
    double seconds = 1.0;
    int threads = 1, quick = 0, only_dim = 0, only_kernel = -1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--quick")) quick = 1;
        else if (!strcmp(argv[i], "--seconds") && i + 1 < argc) seconds = atof(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--dim") && i + 1 < argc) only_dim = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--kernel") && i + 1 < argc) only_kernel = !strcmp(argv[++i], "cubic");
        else {
            fprintf(stderr, "usage: elastic_limit [--quick] [--seconds S] [--threads N] [--dim 2|3] [--kernel quadratic|cubic]\n");
            return 2;
        }
    }
    printf("dim,kernel,ppc,material,setup,k_stable,k_unstable,steps_at_k_stable\n");
    static const int ppc2[] = {4, 9, 16, 32}, ppc3[] = {4, 8, 16, 32};
    for (int dim = 2; dim <= 3; dim++)
        for (int kern = 0; kern < 2; kern++)
            for (int p = 0; p < (quick ? 1 : 4) && (!only_dim || dim == only_dim) && (only_kernel < 0 || kern == only_kernel); p++)
                for (int el = 0; el < 2; el++) {
                    limit_case lc = {dim, kern ? SM_KERNEL_CUBIC : SM_KERNEL_QUADRATIC, dim == 2 ? ppc2[p] : ppc3[p], el, 0};
                    if (quick) lc.ppc = dim == 2 ? 4 : 8;
                    run_case(&lc, seconds, threads);
                }
    for (int dim = 2; dim <= 3; dim++)
        for (int kern = 0; kern < 2; kern++) {
            if ((only_dim && dim != only_dim) || (only_kernel >= 0 && kern != only_kernel)) continue;
            limit_case lc = {dim, kern ? SM_KERNEL_CUBIC : SM_KERNEL_QUADRATIC, dim == 2 ? 4 : 8, 1, 1};
            run_case(&lc, seconds, threads);
        }
    return 0;
}
