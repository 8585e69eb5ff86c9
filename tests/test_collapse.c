/* Granular column collapse settles (thesis §4.1.1 setup, small): a sand column (hardening
 * 35/9/0.2/10) of height H on a sticky ground collapses; after 5 sqrt(H/g) the kinetic energy is
 * below 1% of its peak, and no particle is below the ground. 2D and 3D. */
#include "test_util.h"
#include "sandmpm/sandmpm.h"

static void run(int dim) {
    const double H = 0.2, W = 0.1, ground = 0.06;
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? 0.01 : 0.02;
    def.domain_max[0] = 0.8;
    def.domain_max[1] = 0.4;
    def.domain_max[2] = 0.8;
    sm_world *w = NULL;
    char err[256];
    CHECK(sm_world_create(&def, &w, err, sizeof err) == SM_OK);
    if (!w) return;
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    sm_collider_def c = sm_collider_def_default();
    c.shape_count = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    c.shapes[0].center[1] = ground;
    c.shapes[0].normal[1] = 1;
    c.mode = SM_COLLIDE_STICKY;
    CHECK(sm_world_add_collider(w, &c, NULL) == SM_OK);
    sm_shape col = sm_shape_default(dim == 2 ? SM_SHAPE_BOX : SM_SHAPE_CYLINDER);
    col.center[0] = 0.4;
    col.center[1] = ground + H / 2;
    col.center[2] = 0.4;
    col.half_extent[0] = W / 2;
    col.half_extent[1] = H / 2;
    col.half_extent[2] = W / 2;
    col.radius = W / 2;
    col.half_height = H / 2;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = dim == 2 ? 4 : 8;
    size_t added = 0;
    CHECK(sm_world_seed_shape(w, &col, &sd, &added) == SM_OK);
    const double T = 5 * sqrt(H / 9.81);
    double peak = 0, ke = 0, top0 = 0, top1 = 0, lowest = 1e9, spread0 = 0, spread1 = 0;
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    for (size_t i = 0; i < pv.n; i++) {
        top0 = fmax(top0, pv.x[i * dim + 1]);
        spread0 = fmax(spread0, fabs(pv.x[i * dim] - 0.4));
    }
    int frames = 0;
    for (int f = 1; f * 0.01 < T + 0.01; f++) {
        double t = fmin(f * 0.01, T);
        CHECK(sm_world_advance(w, t) == SM_OK);
        sm_diagnostics d;
        sm_world_diagnostics(w, &d);
        ke = d.kinetic_energy;
        peak = fmax(peak, ke);
        sm_world_particles(w, &pv);
        for (size_t i = 0; i < pv.n; i++) lowest = fmin(lowest, pv.x[i * dim + 1]);
        frames++;
    }
    sm_diagnostics dg;
    sm_world_diagnostics(w, &dg);
    for (size_t i = 0; i < pv.n; i++) {
        top1 = fmax(top1, pv.x[i * dim + 1]);
        spread1 = fmax(spread1, fabs(pv.x[i * dim] - 0.4));
    }
    printf("%dD: %zu particles, T = %.3f s, KE peak %.4g J, final %.3g J (%.3f%% of peak); top %.3f -> %.3f m, "
           "half-width %.3f -> %.3f m; lowest particle %.4f m (ground %.3f); %llu particle-steps projected out of "
           "the ground, %llu clamped\n",
           dim, added, T, peak, ke, 100 * ke / peak, top0, top1, spread0, spread1, lowest, ground,
           (unsigned long long)dg.projected_particles, (unsigned long long)dg.clamped_particles);
    CHECK(peak > 0);
    CHECK(ke < 0.01 * peak);
    /* Exactly on the surface is allowed (the projection puts particles there); 1e-6 m covers float. */
    CHECK(lowest >= ground - 1e-6);
    /* It did collapse: lower and wider than the column. */
    CHECK(top1 < top0 - 0.25 * H);
    CHECK(spread1 > spread0 + 0.5 * W);
    sm_world_destroy(w);
}

int main(void) {
    run(2);
    run(3);
    return sm_test_summary("test_collapse");
}
