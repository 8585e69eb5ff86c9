/* Seeding (DESIGN; issue "Seeding"): a shape filled at ppc particles per cell has about ppc per cell
 * (jittered: within 3% on a box; Poisson disk: within 5%, and no two samples closer than the disk
 * radius), every particle inside the shape and the domain, V0 = dx^d/ppc and mass = rho V0, the same
 * seed gives the same particles and another seed others; a clip shape keeps the intersection. */
#include <string.h>

#include "test_util.h"
#include "sandmpm/sandmpm.h"

static sm_world *world(int dim, double dx) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dx;
    sm_world *w = NULL;
    char err[256];
    sm_world_create(&def, &w, err, sizeof err);
    sm_material_def m = sm_material_def_sand();
    CHECK(sm_world_add_material(w, &m, NULL) == SM_OK);
    return w;
}

int main(void) {
    for (int dim = 2; dim <= 3; dim++) {
        const double dx = 0.02, L = 0.2;
        const double ppcs[3] = {dim == 2 ? 4 : 8, 5, dim == 2 ? 9 : 27};
        for (int k = 0; k < 3; k++) {
            for (int method = 0; method < 2; method++) {
                double ppc = ppcs[k];
                sm_world *w = world(dim, dx);
                sm_shape box = sm_shape_default(SM_SHAPE_BOX);
                for (int a = 0; a < 3; a++) {
                    box.center[a] = 0.5;
                    box.half_extent[a] = L / 2;
                }
                sm_seed_def sd = sm_seed_def_default();
                sd.ppc = ppc;
                sd.method = (sm_seed_method)method;
                size_t n = 0;
                CHECK(sm_world_seed_shape(w, &box, &sd, &n) == SM_OK);
                double cells = pow(L / dx, dim);
                double expect = ppc * cells;
                printf("%dD %s ppc %g: %zu particles, expected %.0f (%.1f%%)\n", dim, method ? "poisson" : "jittered", ppc,
                       n, expect, 100.0 * ((double)n - expect) / expect);
                CHECK_REL((double)n, expect, method ? 0.05 : 0.03, 0);
                sm_particles_view pv;
                sm_world_particles(w, &pv);
                CHECK(pv.n == n);
                double vol0 = pow(dx, dim) / ppc, worst_in = -1;
                for (size_t i = 0; i < pv.n; i++) {
                    CHECK_REL(pv.vol0[i], vol0, 1e-6, 0);
                    CHECK_REL(sm_world_particle_mass(w, i), 2200 * vol0, 1e-6, 0);
                    double x[3] = {0, 0, 0};
                    for (int a = 0; a < dim; a++) x[a] = pv.x[i * dim + a];
                    worst_in = fmax(worst_in, sm_shape_distance(&box, dim, x, NULL));
                }
                CHECK(worst_in < 0);
                if (method == 1 && pv.n < 6000) {
                    /* Poisson: minimum distance against the radius implied by the density constant. */
                    double dmin = 1e9;
                    for (size_t i = 0; i < pv.n; i++)
                        for (size_t j = i + 1; j < pv.n; j++) {
                            double d2 = 0;
                            for (int a = 0; a < dim; a++) {
                                double t = pv.x[i * dim + a] - pv.x[j * dim + a];
                                d2 += t * t;
                            }
                            dmin = fmin(dmin, d2);
                        }
                    dmin = sqrt(dmin);
                    double r = pow((dim == 2 ? 0.63 : 0.60) * pow(dx, dim) / ppc, 1.0 / dim);
                    printf("   min distance %.5f, disk radius %.5f\n", dmin, r);
                    CHECK(dmin >= r * (1 - 1e-6));
                }
                /* Same seed: same particles; other seed: others. */
                uint64_t h1 = sm_world_state_hash(w);
                sm_world_destroy(w);
                w = world(dim, dx);
                CHECK(sm_world_seed_shape(w, &box, &sd, NULL) == SM_OK);
                CHECK(sm_world_state_hash(w) == h1);
                sm_world_destroy(w);
                w = world(dim, dx);
                sd.seed = 99;
                CHECK(sm_world_seed_shape(w, &box, &sd, NULL) == SM_OK);
                CHECK(sm_world_state_hash(w) != h1);
                sm_world_destroy(w);
            }
        }
        /* Clip: a ball clipped by a half-space y < 0.5 keeps about half. */
        sm_world *w = world(dim, dx);
        sm_shape ball = sm_shape_default(SM_SHAPE_SPHERE);
        ball.center[0] = ball.center[1] = ball.center[2] = 0.5;
        ball.radius = 0.15;
        sm_shape half = sm_shape_default(SM_SHAPE_HALFSPACE);
        half.center[1] = 0.5;
        half.normal[1] = 1;
        sm_seed_def sd = sm_seed_def_default();
        size_t full = 0, clipped = 0;
        CHECK(sm_world_seed_shape(w, &ball, &sd, &full) == SM_OK);
        sd.clip = &half;
        sd.seed = 2;
        CHECK(sm_world_seed_shape(w, &ball, &sd, &clipped) == SM_OK);
        CHECK_REL((double)clipped, 0.5 * (double)full, 0.05, 0);
        sm_particles_view pv;
        sm_world_particles(w, &pv);
        for (size_t i = full; i < pv.n; i++) CHECK(pv.x[i * dim + 1] < 0.5);
        /* A shape sticking out of the domain: only the part inside (2 cells from the walls) is filled. */
        sm_shape big = sm_shape_default(SM_SHAPE_BOX);
        big.center[0] = 0.0;
        big.center[1] = big.center[2] = 0.5;
        big.half_extent[0] = big.half_extent[1] = big.half_extent[2] = 0.1;
        size_t part = 0;
        sd.clip = NULL;
        CHECK(sm_world_seed_shape(w, &big, &sd, &part) == SM_OK);
        sm_world_particles(w, &pv);
        double minx = 1;
        for (size_t i = full + clipped; i < pv.n; i++) minx = fmin(minx, pv.x[i * dim]);
        CHECK(minx >= 2 * dx);
        CHECK(part > 0);
        sm_world_destroy(w);
    }
    return sm_test_summary("test_seed");
}
