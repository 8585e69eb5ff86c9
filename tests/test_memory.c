/* Memory and allocation invariants of the explicit step (issue 6):
 *  - in a steady state (sand resting on the ground, after a few steps), a step allocates nothing;
 *  - a 3D block at 8 particles per cell costs at most 166 bytes per particle in float (304 in
 *    double), everything the world holds included (sparse grid, sort, caches); measured 164.7
 *    in float since positions are double in both builds (12 bytes more than float positions);
 *  - a large domain costs what its particles cost: the same sand in a 1000x larger domain
 *    volume holds the same memory. */
#include <stdio.h>
#include <string.h>

#include "sandmpm/sandmpm.h"
#include "test_util.h"

static sm_world *make(double domain, int threads) {
    sm_world_def def = sm_world_def_default();
    def.dim = 3;
    def.dx = 0.01;
    def.threads = threads;
    for (int a = 0; a < 3; a++) {
        def.domain_min[a] = 0;
        def.domain_max[a] = domain;
    }
    sm_world *w = NULL;
    char err[256];
    CHECK(sm_world_create(&def, &w, err, sizeof err) == SM_OK);
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    sm_collider_def g = sm_test_ground(0.05);
    g.mode = SM_COLLIDE_STICKY;
    CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    for (int a = 0; a < 3; a++) {
        box.center[a] = a == 1 ? 0.05 + 0.2 : 0.5;
        box.half_extent[a] = 0.2;
    }
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = 8;
    CHECK(sm_world_seed_shape(w, &box, &sd, NULL) == SM_OK);
    return w;
}

int main(void) {
    sm_world *w = make(1.0, 2);
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    const double n = (double)d.particles;
    for (int s = 0; s < 5; s++) CHECK(sm_world_step(w, 1e-4) == SM_OK);
    uint64_t a0 = sm_allocation_count();
    for (int s = 0; s < 30; s++) CHECK(sm_world_step(w, 1e-4) == SM_OK);
    uint64_t a1 = sm_allocation_count();
    printf("allocations in 30 steady steps: %llu (%.0f particles)\n", (unsigned long long)(a1 - a0), n);
    CHECK(a1 == a0);

    double bpp = (double)sm_world_memory_bytes(w) / n;
    /* float: 4 of them are the stable particle id (checkpoints), 12 the double positions */
    double limit = sizeof(sm_real) == 4 ? 166 : 304;
    printf("memory: %.1f bytes per particle (limit %.0f)\n", bpp, limit);
    CHECK(bpp <= limit);

    /* The same sand in a domain of 10 m per side (1000x the volume, 1e9 cells). */
    sm_world *big = make(10.0, 2);
    for (int s = 0; s < 3; s++) CHECK(sm_world_step(big, 1e-4) == SM_OK);
    double bpp_big = (double)sm_world_memory_bytes(big) / n;
    printf("memory in a 1000x larger domain: %.1f bytes per particle\n", bpp_big);
    CHECK(bpp_big <= bpp * 1.02);
    sm_world_destroy(big);
    sm_world_destroy(w);
    return sm_test_summary("test_memory");
}
