/* A 2D elastic block at rest on a grid-aligned separating plane, gravity tilted 30 degrees, mu 0.7
 * (> tan 30: it must hold), with and without the contact gate (sm_world_def.contact_gap): its centre
 * of mass and velocity down the slope every 0.1 s to 1.2 s. Behind docs/validation.md section 6's
 * "why the contact gate is off by default" (2026-12-07).
 *
 * Build (from a build directory of the program, made on the commit that added contact_gap):
 *   mpicc -O2 -I ../include -I ../tests -I include ../docs/experiments/resting_block_gate.c libsandmpm.a -lm -fopenmp -o rb
 * (plain gcc without MPI builds). Run: ./rb GAP MAX_DT DX METHOD [TRANSFER], GAP in cells (0: no gate),
 * METHOD 0 jittered, 1 Poisson seeding, TRANSFER 0 APIC (default), 1 PIC, 2 FLIP; e.g. ./rb 0.35 1e-3 0.01 0
 * (the elastic time step binds below max_dt 1e-3). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "sandmpm/sandmpm.h"

int main(int argc, char **argv) {
    if (argc < 5) {
        fprintf(stderr, "usage: rb GAP MAX_DT DX METHOD [TRANSFER]\n");
        return 2;
    }
    const double gap = atof(argv[1]), maxdt = atof(argv[2]), dx = atof(argv[3]);
    const int method = atoi(argv[4]);
    const double th = 30 * 3.14159265358979323846 / 180;
    sm_world_def def = sm_world_def_default();
    def.dim = 2;
    def.dx = dx;
    def.contact_gap = gap > 0 ? gap : INFINITY;
    def.max_dt = maxdt;
    if (argc > 5) def.transfer = (sm_transfer)atoi(argv[5]);
    def.gravity[0] = -9.81 * sin(th);
    def.gravity[1] = -9.81 * cos(th);
    sm_world *w;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err)) {
        puts(err);
        return 1;
    }
    sm_material_def m = sm_material_def_elastic();
    m.youngs_modulus = 1e6;
    int mat;
    sm_world_add_material(w, &m, &mat);
    sm_collider_def c = sm_collider_def_default();
    c.shape_count = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    c.shapes[0].center[1] = 0.2;
    c.shapes[0].normal[1] = 1;
    c.mode = SM_COLLIDE_SEPARATE;
    c.friction = 0.7;
    sm_world_add_collider(w, &c, NULL);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = 0.5;
    box.center[1] = 0.2 + 0.05 + 0.25 * dx;
    box.half_extent[0] = 0.1;
    box.half_extent[1] = 0.05;
    box.half_extent[2] = 1;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = 4;
    sd.method = method;
    sm_world_seed_shape(w, &box, &sd, NULL);
    sm_diagnostics d;
    for (int f = 1; f <= 12; f++) {
        if (sm_world_advance(w, f * 0.1) != SM_OK) {
            fprintf(stderr, "%s\n", sm_world_errmsg(w));
            return 1;
        }
        sm_world_diagnostics(w, &d);
        printf("t %.1f x %.5f y %.6f v %.5f steps %llu\n", f * 0.1, d.center_of_mass[0], d.center_of_mass[1],
               -d.momentum[0] / d.total_mass, (unsigned long long)d.steps);
    }
    sm_world_destroy(w);
    return 0;
}
