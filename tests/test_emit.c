/* Emitters: the emitted mass follows rate * (time active) to within one particle, nothing is
 * emitted outside [start, stop], total mass in the diagnostics matches, emission is deterministic
 * (same hash for 1 and 2 threads), and bad emitter definitions are refused with a message; a shape
 * is refused for "no volume inside the usable domain" exactly when sm_shape_volume_estimate over that
 * domain is 0 (the emitter's early-exit search visits the same lattice). */
#include <string.h>

#include "test_util.h"
#include "sandmpm/sandmpm.h"

static uint64_t run(int dim, int threads, double *emitted, double *mass, double *pmass, size_t *n_before) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? 0.01 : 0.02;
    def.threads = threads;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) return 0;
    sm_material_def m = sm_material_def_sand();
    m.hardening = 0;
    m.friction_angle = 30;
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    sm_collider_def g = sm_test_ground(0.1);
    CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
    sm_emitter_def e = sm_emitter_def_default();
    e.shape = sm_shape_default(SM_SHAPE_CYLINDER);
    e.shape.center[0] = e.shape.center[2] = 0.5;
    e.shape.center[1] = 0.7;
    e.shape.radius = 0.03;
    e.shape.half_height = 0.02;
    e.material = mat;
    e.ppc = dim == 2 ? 4 : 8;
    e.velocity[1] = -1.0;
    e.rate = dim == 2 ? 20.0 : 2.0;
    e.start = 0.1;
    e.stop = 0.3;
    int id = -1;
    CHECK(sm_world_add_emitter(w, &e, &id) == SM_OK);
    CHECK(id == 0);
    CHECK(sm_world_advance(w, 0.1) == SM_OK);
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    *n_before = d.particles;
    const uint64_t steps0 = d.steps, allocs0 = sm_allocation_count();
    CHECK(sm_world_advance(w, 0.2) == SM_OK); /* the emitting interval */
    sm_world_diagnostics(w, &d);
    /* Storage grows geometrically and the emission scratch is kept: far fewer allocations than
     * emitting steps (it was two per step). */
    const uint64_t esteps = d.steps - steps0, allocs = sm_allocation_count() - allocs0;
    CHECK(esteps >= 20);
    CHECK(allocs * 4 < esteps);
    if (!(allocs * 4 < esteps)) fprintf(stderr, "%llu allocations in %llu emitting steps\n", (unsigned long long)allocs, (unsigned long long)esteps);
    CHECK(sm_world_advance(w, 0.3) == SM_OK);
    sm_world_diagnostics(w, &d);
    *emitted = sm_world_emitted_mass(w, id);
    *mass = d.total_mass;
    *pmass = pow(def.dx, dim) / e.ppc * m.density;
    /* refused definitions */
    sm_emitter_def bad = e;
    bad.rate = -1;
    CHECK(sm_world_add_emitter(w, &bad, NULL) == SM_ERR_INVALID);
    CHECK(strstr(sm_world_errmsg(w), "rate") != NULL);
    bad = e;
    bad.shape.center[0] = 5;
    CHECK(sm_world_add_emitter(w, &bad, NULL) == SM_ERR_INVALID);
    CHECK(strstr(sm_world_errmsg(w), "shape") != NULL);
    bad = e;
    bad.stop = bad.start;
    CHECK(sm_world_add_emitter(w, &bad, NULL) == SM_ERR_INVALID);
    uint64_t h = sm_world_state_hash(w);
    sm_world_destroy(w);
    return h;
}

/* Small spheres, boxes and cylinders, some rotated, scattered over and around the domain: the emitter accepts one
 * exactly when the volume estimate over the usable domain (domain shrunk by 2 dx) is positive. */
static void volume_check(int dim) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = 0.05;
    sm_world *w = NULL;
    char err[256];
    CHECK(sm_world_create(&def, &w, err, sizeof err) == SM_OK);
    if (!w) return;
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, h = 1;
    for (int a = 0; a < dim; a++) {
        lo[a] = def.domain_min[a] + 2 * def.dx;
        hi[a] = def.domain_max[a] - 2 * def.dx;
        h = fmin(h, (hi[a] - lo[a]) / 64);
    }
    int accepted = 0, refused = 0, agree = 1;
    unsigned long long rng = 12345;
    for (int t = 0; t < 400; t++) {
        sm_emitter_def e = sm_emitter_def_default();
        e.material = mat;
        const sm_shape_kind kinds[3] = {SM_SHAPE_SPHERE, SM_SHAPE_BOX, SM_SHAPE_CYLINDER};
        e.shape = sm_shape_default(kinds[t % 3]);
        for (int a = 0; a < dim; a++) {
            const double u = sm_test_uniform(&rng, 0, 1);
            e.shape.center[a] = def.domain_min[a] + (u * 1.2 - 0.1) * (def.domain_max[a] - def.domain_min[a]);
            e.shape.half_extent[a] = (0.2 + 0.8 * u) * h;
        }
        e.shape.radius = 0.3 * h + (double)(t % 5) * 0.2 * h;
        e.shape.half_height = e.shape.radius * (1 + t % 4);
        if (t % 6 >= 3) { /* rotated about z by 0.3 rad (2D), about (1, 1, 1) / sqrt 3 (3D) */
            const double c = cos(0.15), sn = sin(0.15);
            e.shape.rotation[0] = c;
            for (int a = 1; a < 4; a++) e.shape.rotation[a] = dim == 2 ? (a == 3 ? sn : 0) : sn / sqrt(3.0);
        }
        const double vol = sm_shape_volume_estimate(&e.shape, NULL, dim, lo, hi);
        const sm_status st = sm_world_add_emitter(w, &e, NULL);
        if ((st == SM_OK) != (vol > 0)) agree = 0;
        if (st == SM_OK) accepted++;
        else refused++;
    }
    printf("%dD: %d small shapes accepted, %d refused, acceptance %s the volume estimate\n", dim, accepted,
           refused, agree ? "agrees with" : "DISAGREES with");
    CHECK(agree);
    CHECK(accepted > 40 && refused > 40);
    sm_world_destroy(w);
}

int main(void) {
    for (int dim = 2; dim <= 3; dim++) {
        double em, mass, pm, em2, mass2, pm2;
        size_t nb, nb2;
        uint64_t h1 = run(dim, 1, &em, &mass, &pm, &nb);
        uint64_t h2 = run(dim, 2, &em2, &mass2, &pm2, &nb2);
        double rate = dim == 2 ? 20.0 : 2.0, expect = rate * 0.2;
        printf("%dD: emitted %.6f kg (expected %.6f, particle mass %.3g), world mass %.6f, %zu particles before start\n",
               dim, em, expect, pm, mass, nb);
        CHECK(nb == 0);
        CHECK(em <= expect + 1e-12);
        CHECK(em > expect - pm - 1e-12);
        CHECK_REL(mass, em, 1e-6, 0);
        CHECK(h1 == h2);
        CHECK(h1 != 0);
    }
    volume_check(2);
    volume_check(3);
    return sm_test_summary("test_emit");
}
