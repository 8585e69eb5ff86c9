/* The cost of the contact gate (sm_world_def.contact_gap): the default scene's column (3D, r 0.1 m,
 * h 0.4 m, dx 0.015, 8 per cell, about 30k particles, 1.25 s) collapsing onto a *separating* ground
 * with mu 0.5 instead of the sticky one, so that the gate has work; prints the stage times.
 * ./gate_cost 0 (no gate) or ./gate_cost 0.35. Build from a build directory:
 *   mpicc -O2 -I ../include -I include ../docs/experiments/gate_cost.c libsandmpm.a -lm -fopenmp -o gate_cost
 * Behind docs/benchmarks.md, "The contact gate's cost". */
#include <stdio.h>
#include <stdlib.h>
#include <math.h>
#include "sandmpm/sandmpm.h"
int main(int argc, char **argv) {
    double gap = atof(argv[1]);
    sm_world_def def = sm_world_def_default();
    def.dim = 3; def.dx = 0.015; def.contact_gap = gap > 0 ? gap : INFINITY; def.max_dt = 1e-3;
    double lo[3] = {-0.6, -0.05, -0.6}, hi[3] = {0.6, 0.5, 0.6};
    for (int a = 0; a < 3; a++) def.domain_min[a] = lo[a], def.domain_max[a] = hi[a];
    sm_world *w; char err[256];
    if (sm_world_create(&def, &w, err, sizeof err)) { puts(err); return 1; }
    sm_material_def m = sm_material_def_sand(); int mat; sm_world_add_material(w, &m, &mat);
    sm_collider_def c = sm_collider_def_default(); c.shape_count = 1; c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    c.shapes[0].normal[1] = 1; c.mode = SM_COLLIDE_SEPARATE; c.friction = 0.5; sm_world_add_collider(w, &c, NULL);
    sm_shape cyl = sm_shape_default(SM_SHAPE_CYLINDER); cyl.center[1] = 0.2; cyl.radius = 0.1; cyl.half_height = 0.2;
    sm_seed_def sd = sm_seed_def_default(); sd.material = mat; sd.ppc = 8; sm_world_seed_shape(w, &cyl, &sd, NULL);
    for (int f = 1; f <= 30; f++) if (sm_world_advance(w, f / 24.0)) { puts(sm_world_errmsg(w)); return 1; }
    sm_diagnostics d; sm_world_diagnostics(w, &d);
    printf("gap %g steps %llu:", gap, (unsigned long long)d.steps);
    for (int s = 0; s < SM_STAGE_COUNT; s++) printf(" %s %.2f", sm_stage_name(s), d.stage_seconds[s]);
    printf("\n");
    return 0;
}
