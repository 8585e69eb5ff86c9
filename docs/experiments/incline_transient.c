/* EXPERIMENT (not built; docs/validation.md section 6, "the static creep is a release transient"):
 * tests/test_incline.c's 2D block (elastic, E 1e6, 0.2 x 0.1 m, released a quarter cell above a
 * plane tilted 30 degrees in the grid) on a Coulomb plane; prints the mean displacement along the
 * slope and the mean squared particle speed every 0.1 s.
 *   mpicc -O2 -std=c11 -fopenmp -I include -I build-rel -I build-rel/include \
 *         docs/experiments/incline_transient.c build-rel/libsandmpm.a -lm -o /tmp/incline_transient
 *   /tmp/incline_transient MU [ELASTIC_CFL]     env: SLIP=1 slip plane (else separating),
 *                                               PIC=1 or FLIP=ratio, NF=frames of 0.1 s (10)
 * (mpicc when the library was built with MPI; gcc otherwise.) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "sandmpm/sandmpm.h"
int main(int argc, char **argv) {
    const double mu = atof(argv[1]), TH = 30.0 * 3.14159265358979 / 180, cfl = argc > 2 ? atof(argv[2]) : 0.5;
    sm_world_def def = sm_world_def_default();
    def.dim = 2; def.dx = 0.01; def.threads = 1; def.elastic_cfl = cfl;
    if (getenv("PIC")) def.transfer = SM_TRANSFER_PIC;
    if (getenv("FLIP")) { def.transfer = SM_TRANSFER_FLIP; def.flip_ratio = atof(getenv("FLIP")); }
    def.domain_min[0] = 0; def.domain_max[0] = 2.0; def.domain_min[1] = 0; def.domain_max[1] = 1.3;
    sm_world *w = NULL; char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) { puts(err); return 1; }
    sm_material_def m = sm_material_def_elastic(); m.youngs_modulus = 1e6; int mat = -1;
    sm_world_add_material(w, &m, &mat);
    const double n[3] = {-sin(TH), cos(TH), 0}, tdown[3] = {-cos(TH), -sin(TH), 0}, p0[3] = {1.0, 0.6, 0.15};
    sm_collider_def c = sm_collider_def_default(); c.shape_count = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    for (int a = 0; a < 3; a++) { c.shapes[0].center[a] = p0[a]; c.shapes[0].normal[a] = n[a]; }
    c.mode = getenv("SLIP") ? SM_COLLIDE_SLIP : SM_COLLIDE_SEPARATE; c.friction = mu;
    sm_world_add_collider(w, &c, NULL);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    const double hx = 0.1, hy = 0.05, s_up = 0.6;
    for (int a = 0; a < 3; a++) box.center[a] = p0[a] - s_up * tdown[a] + (hy + 0.25 * def.dx) * n[a];
    box.half_extent[0] = hx; box.half_extent[1] = hy; box.half_extent[2] = 0.05;
    box.rotation[0] = cos(TH / 2); box.rotation[3] = sin(TH / 2);
    sm_seed_def sd = sm_seed_def_default(); sd.material = mat; sd.ppc = 4;
    sm_world_seed_shape(w, &box, &sd, NULL);
    double s0 = 0;
    const int nf = getenv("NF") ? atoi(getenv("NF")) : 10; for (int f = 0; f <= nf; f++) {
        if (f) sm_world_advance(w, f * 0.1);
        sm_particles_view pv; sm_world_particles(w, &pv);
        double s = 0, ke = 0;
        for (size_t i = 0; i < pv.n; i++) { s += pv.x[2*i] * tdown[0] + pv.x[2*i+1] * tdown[1]; ke += pv.v[2*i]*pv.v[2*i] + pv.v[2*i+1]*pv.v[2*i+1]; }
        s /= pv.n; if (!f) s0 = s;
        printf("t %.1f moved %.3f mm  mean v^2 %.3e\n", f * 0.1, (s - s0) * 1e3, ke / pv.n);
    }
    sm_world_destroy(w);
    return 0;
}
