/* EXPERIMENT (not built; docs/validation.md section 6, "the fit window"): sm_validate incline's
 * block (validation/analytic.c, incline_run, copied here with the start of the fit window as a
 * parameter) fitted over [T0, T1] instead of [0.05 s, 0.2 s], to see how much of the near-threshold
 * error is the block's release transient.
 *   mpicc -O2 -std=c11 -fopenmp -I include -I build-double -I build-double/include \
 *         docs/experiments/incline_window.c build-double/libsandmpm.a -lm -o /tmp/incline_window
 *   /tmp/incline_window DIM THETA MU TILTED T0 T1 [MAX_DT [OFFSET [EXTRA]]]  (TILTED 1: plane turned in the grid)
 * OFFSET (cells, aligned plane only): the plane y = 0.2 m + OFFSET dx instead of on the grid line
 * y = 0.2 m (docs/validation.md section 6, "where the plane lies in the grid"). EXTRA (m): the
 * block starts that much farther up a slope as much longer, as in validation/analytic.c (2.6 there).
 * With EXTRA 0 the aligned block's upper end (x = 2.0 m) lies inside the domain wall at 1.98 m.
 * (mpicc when the library was built with MPI; gcc otherwise.) Prints expected and fitted
 * acceleration along the slope and the error as sm_validate reports it. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "sandmpm/sandmpm.h"
static const double PI = 3.14159265358979323846, G = 9.81;
static int fail(const char *what, sm_world *w) {
    fprintf(stderr, "incline_window: %s: %s\n", what, w ? sm_world_errmsg(w) : "");
    exit(3);
}
/* validation/analytic.c's incline_run with the start of the fit window, t0, as a parameter. */
static double incline_run(int dim, double th_deg, double mu, int tilted, sm_collide_mode mode, double max_dt,
                          double t0, double t_end, double offset, double extra) {
    const double th = th_deg * PI / 180;
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? 0.01 : 0.02;
    def.max_dt = max_dt;
    def.domain_max[0] = 2.0 + (extra > 0 ? extra + 0.5 : 0);
    def.domain_max[1] = 1.3 + (tilted ? extra * sin(th) : 0);
    def.domain_max[2] = 0.3;
    /* tilted: plane through p0 with normal n, gravity -y; aligned: plane y = 0.2, gravity along
     * (-sin th, -cos th) in the grid: down the slope is -x */
    double n[3], tdown[3];
    if (tilted) {
        n[0] = -sin(th), n[1] = cos(th), n[2] = 0;
        tdown[0] = -cos(th), tdown[1] = -sin(th), tdown[2] = 0;
    } else {
        n[0] = 0, n[1] = 1, n[2] = 0;
        tdown[0] = -1, tdown[1] = 0, tdown[2] = 0;
        def.gravity[0] = -G * sin(th);
        def.gravity[1] = -G * cos(th);
    }
    const double p0[3] = {tilted ? 1.0 : 1.6, tilted ? 0.6 : 0.2 + offset * def.dx, 0.15};
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "sm_validate: %s\n", err);
        exit(2);
    }
    sm_material_def m = sm_material_def_elastic();
    m.youngs_modulus = 1e6;
    int mat = -1;
    if (sm_world_add_material(w, &m, &mat) != SM_OK) fail("material", w);
    sm_collider_def c = sm_collider_def_default();
    c.shape_count = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    for (int a = 0; a < 3; a++) c.shapes[0].center[a] = p0[a], c.shapes[0].normal[a] = n[a];
    c.mode = mode;
    c.friction = mu;
    if (sm_world_add_collider(w, &c, NULL) != SM_OK) fail("collider", w);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    const double hy = 0.05, up = 0.6 * (tilted ? 1 : 0.5) + extra;
    for (int a = 0; a < 3; a++) box.center[a] = p0[a] - up * tdown[a] + (hy + 0.25 * def.dx) * n[a];
    box.center[2] = 0.15;
    box.half_extent[0] = 0.1, box.half_extent[1] = hy, box.half_extent[2] = 0.05;
    if (tilted) box.rotation[0] = cos(th / 2), box.rotation[3] = sin(th / 2);
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = dim == 2 ? 4 : 8;
    if (sm_world_seed_shape(w, &box, &sd, NULL) != SM_OK) fail("seed", w);
    double St = 0, Sv = 0, Stt = 0, Stv = 0;
    int k = 0;
    sm_diagnostics d;
    for (int f = 1; f * 0.005 <= t_end + 1e-9; f++) {
        if (sm_world_advance(w, f * 0.005) != SM_OK) fail("advance", w);
        sm_world_diagnostics(w, &d);
        double t = sm_world_time(w), v = (d.momentum[0] * tdown[0] + d.momentum[1] * tdown[1]) / d.total_mass;
        if (t >= t0 - 1e-9) St += t, Sv += v, Stt += t * t, Stv += t * v, k++;
    }
    sm_world_destroy(w);
    return (k * Stv - St * Sv) / (k * Stt - St * St);
}


int main(int argc, char **argv) {
    if (argc < 7) {
        fprintf(stderr, "usage: incline_window DIM THETA MU TILTED T0 T1 [MAX_DT [OFFSET [EXTRA]]]\n");
        return 2;
    }
    const int dim = atoi(argv[1]), tilted = atoi(argv[4]);
    const double th = atof(argv[2]), mu = atof(argv[3]), t0 = atof(argv[5]), t1 = atof(argv[6]);
    const double dt = argc > 7 ? atof(argv[7]) : 2e-5, offset = argc > 8 ? atof(argv[8]) : 0,
                 extra = argc > 9 ? atof(argv[9]) : 0, r = th * PI / 180;
    const double expect = tan(r) > mu ? G * (sin(r) - mu * cos(r)) : 0;
    const double a = incline_run(dim, th, mu, tilted, SM_COLLIDE_SEPARATE, dt, t0, t1, offset, extra);
    printf("%d,%s,%g,%g,%g,%g,%g,%g,%.6f,%.6f,%.3g\n", dim, tilted ? "tilted" : "aligned", th, mu, dt, offset, t0, t1,
           expect, a,
           expect > 0 ? (a - expect) / expect : a / G);
    return 0;
}
