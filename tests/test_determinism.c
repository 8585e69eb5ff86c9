/* Determinism (DESIGN §4): the hash of all particle state after 50 steps of a collapsing sand
 * block with colliders is identical for 1, 2 and 3 threads (3 splits the blocks unevenly), and for
 * two runs with the same input;
 * the state does change over the 50 steps (10 implicit) (so the hash is not trivially constant). 2D and 3D,
 * both kernels, APIC and FLIP; and the implicit integrator (Newton-GMRES, its step-size rule,
 * with and without the block-Jacobi preconditioner), quadratic APIC. */
#include "test_util.h"
#include "sandmpm/sandmpm.h"

#include <string.h>

/* implicit: 0 explicit, 1 implicit, 2 implicit with the block-Jacobi preconditioner. */
static uint64_t run(int dim, int threads, sm_kernel kernel, sm_transfer tr, int implicit, uint64_t *h0) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? 0.01 : 0.04;
    def.kernel = kernel;
    def.transfer = tr;
    def.threads = threads;
    if (implicit) {
        def.integrator = SM_INTEGRATOR_IMPLICIT;
        def.max_dt = 2e-3; /* above the explicit limit: Newton works, the step-size rule acts */
        def.gmres_preconditioner = implicit == 2;
    }
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) return 0;
    sm_material_def m = sm_material_def_sand();
    int sand = -1;
    CHECK(sm_world_add_material(w, &m, &sand) == SM_OK);
    sm_material_def e = sm_material_def_elastic();
    int ball = -1;
    CHECK(sm_world_add_material(w, &e, &ball) == SM_OK);
    sm_collider_def g = sm_test_ground(0.1);
    g.mode = SM_COLLIDE_SLIP;
    g.friction = 0.4;
    CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
    sm_collider_def s = sm_collider_def_default();
    s.shape_count = 1;
    s.shapes[0] = sm_shape_default(SM_SHAPE_SPHERE);
    s.shapes[0].center[0] = 0.7;
    s.shapes[0].center[1] = 0.25;
    s.shapes[0].center[2] = 0.5;
    s.shapes[0].radius = 0.08;
    s.velocity[0] = -1.0;
    s.mode = SM_COLLIDE_SEPARATE;
    s.friction = 0.2;
    CHECK(sm_world_add_collider(w, &s, NULL) == SM_OK);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = 0.45;
    box.center[1] = 0.3;
    box.center[2] = 0.5;
    box.half_extent[0] = box.half_extent[1] = box.half_extent[2] = 0.15;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = sand;
    sd.ppc = dim == 2 ? 4 : 8;
    sm_world_seed_shape(w, &box, &sd, NULL);
    sm_shape sph = sm_shape_default(SM_SHAPE_SPHERE);
    sph.center[0] = 0.45;
    sph.center[1] = 0.6;
    sph.center[2] = 0.5;
    sph.radius = 0.07;
    sd.material = ball;
    sd.velocity[1] = -3;
    sd.method = SM_SEED_POISSON;
    sm_world_seed_shape(w, &sph, &sd, NULL);
    *h0 = sm_world_state_hash(w);
    for (int i = 0; i < (implicit ? 10 : 50); i++) /* a dt the implicit solve refuses is retried (at half of it) */
        for (int tries = 0; sm_world_step(w, sm_world_next_dt(w, 10.0)) != SM_OK; tries++)
            if (tries == 10 || !sm_world_step_refused(w)) {
                fprintf(stderr, "%s\n", sm_world_errmsg(w));
                CHECK(0);
                i = 50;
                break;
            }
    uint64_t h = sm_world_state_hash(w);
    sm_world_destroy(w);
    return h;
}

int main(void) {
    for (int dim = 2; dim <= 3; dim++)
        for (int implicit = 1; implicit <= 2; implicit++) {
            uint64_t s1, s2, s3;
            uint64_t h1 = run(dim, 1, SM_KERNEL_QUADRATIC, SM_TRANSFER_APIC, implicit, &s1);
            uint64_t h2 = run(dim, 2, SM_KERNEL_QUADRATIC, SM_TRANSFER_APIC, implicit, &s2);
            uint64_t h3 = run(dim, 3, SM_KERNEL_QUADRATIC, SM_TRANSFER_APIC, implicit, &s3);
            printf("%dD implicit%s: 1 thread %016llx, 2 threads %016llx, 3 threads %016llx\n", dim,
                   implicit == 2 ? " (block Jacobi)" : "", (unsigned long long)h1, (unsigned long long)h2,
                   (unsigned long long)h3);
            CHECK(h1 != 0);
            CHECK(h1 == h2);
            CHECK(h1 == h3);
            CHECK(h1 != s1);
        }
    for (int dim = 2; dim <= 3; dim++)
        for (int k = 0; k < 2; k++)
            for (int t = 0; t < 2; t++) {
                sm_transfer tr = t ? SM_TRANSFER_FLIP : SM_TRANSFER_APIC;
                uint64_t s1, s2, s3, s4;
                uint64_t h1 = run(dim, 1, (sm_kernel)k, tr, 0, &s1);
                uint64_t h2 = run(dim, 2, (sm_kernel)k, tr, 0, &s2);
                uint64_t h3 = run(dim, 2, (sm_kernel)k, tr, 0, &s3);
                uint64_t h4 = run(dim, 3, (sm_kernel)k, tr, 0, &s4);
                printf("%dD %s %s: 1 thread %016llx, 2 threads %016llx, again %016llx, 3 threads %016llx\n", dim,
                       k ? "cubic" : "quadratic", t ? "FLIP" : "APIC", (unsigned long long)h1, (unsigned long long)h2,
                       (unsigned long long)h3, (unsigned long long)h4);
                CHECK(h1 != 0);
                CHECK(h1 == h2);
                CHECK(h2 == h3);
                CHECK(h1 == h4);
                CHECK(s1 == s2);
                CHECK(h1 != s1);
            }
    return sm_test_summary("test_determinism");
}
