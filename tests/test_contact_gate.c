/* The contact gate (sm_world_def.contact_gap, collide/grid_collide.h): a separating collider acts
 * on a grid node only where material lies within contact_gap dx of it.
 *
 * 1. Approach, 2D and 3D: a weightless, unstressed block of particles on a lattice (2 per cell and
 *    axis) moves at 0.2 m/s towards a separating ground. With its lowest particles 0.75 dx above the
 *    ground, nodes of their stencil lie on the ground and meet it: without the gate (contact_gap
 *    infinite) they stop the block's bottom a step before it arrives; with the gate (0.35) nothing
 *    touches the block, and its momentum is that of free flight. With its lowest particles 0.25 dx
 *    above the ground, every node that meets the ground has material within the gap, and the gate
 *    changes nothing: the same state hash with and without it.
 * 2. The same with the implicit integrator, whose contact set follows the gate.
 * The gate is off by default (contact_gap infinite); what it does to the incline benchmark and to a
 * block resting on a plane is measured in docs/validation.md, section 6. */
#include "test_util.h"
#include "sandmpm/sandmpm.h"

static sm_world *make_world(int dim, double gap, const double gravity[3], int implicit) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = 0.02;
    def.contact_gap = gap;
    if (implicit) def.integrator = SM_INTEGRATOR_IMPLICIT;
    for (int a = 0; a < 3; a++) def.gravity[a] = gravity[a];
    def.domain_max[2] = dim == 3 ? 0.4 : 1;
    sm_world *w = NULL;
    char err[256];
    CHECK(sm_world_create(&def, &w, err, sizeof err) == SM_OK);
    return w;
}

static int add_ground(sm_world *w, double y, double mu) {
    sm_collider_def c = sm_collider_def_default();
    c.shape_count = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    c.shapes[0].center[1] = y;
    c.shapes[0].normal[1] = 1;
    c.mode = SM_COLLIDE_SEPARATE;
    c.friction = mu;
    return sm_world_add_collider(w, &c, NULL) == SM_OK;
}

/* Mean velocity along y after one step of a block whose lowest particles are `lift` dx above a
 * separating ground at a node row (y = 0.3); its state hash in *hash. */
static double approach(int dim, int implicit, double gap, double lift, uint64_t *hash) {
    const double zero[3] = {0, 0, 0}, dx = 0.02, ground = 0.3, v0 = -0.2;
    sm_world *w = make_world(dim, gap, zero, implicit);
    if (!w) return 0;
    sm_material_def m = sm_material_def_elastic();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    CHECK(add_ground(w, ground, 0.5));
    enum { NX = 12, NY = 8, NZ = 6 };
    static double x[NX * NY * NZ * 3], v[NX * NY * NZ * 3];
    size_t n = 0;
    for (int i = 0; i < NX; i++)
        for (int j = 0; j < NY; j++)
            for (int k = 0; k < (dim == 3 ? NZ : 1); k++, n++) {
                x[3 * n] = 0.4 + (0.25 + 0.5 * i) * dx;
                x[3 * n + 1] = ground + (lift + 0.5 * j) * dx;
                x[3 * n + 2] = dim == 3 ? 0.1 + (0.25 + 0.5 * k) * dx : 0;
                v[3 * n] = v[3 * n + 2] = 0;
                v[3 * n + 1] = v0;
            }
    CHECK(sm_world_add_particles(w, n, x, v, mat, dim == 3 ? 8 : 4) == SM_OK);
    CHECK(sm_world_step(w, 1e-3) == SM_OK);
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    *hash = sm_world_state_hash(w);
    sm_world_destroy(w);
    return d.momentum[1] / d.total_mass;
}

static void test_approach(int dim, int implicit) {
    const double v0 = -0.2;
    uint64_t h_gate, h_none;
    const double far_gate = approach(dim, implicit, 0.35, 0.75, &h_gate), far_none = approach(dim, implicit, INFINITY, 0.75, &h_none);
    printf("%s %dD: lowest particles 0.75 dx above the ground, mean velocity after a step: %.9f m/s with the gate, "
           "%.9f without (free flight %.1f)\n", implicit ? "implicit" : "explicit", dim, far_gate, far_none, v0);
    CHECK(fabs(far_gate - v0) < 1e-6 * fabs(v0));
    CHECK(fabs(far_none - v0) > 1e-3 * fabs(v0)); /* without the gate the ground reaches the block */
    const double near_gate = approach(dim, implicit, 0.35, 0.25, &h_gate), near_none = approach(dim, implicit, INFINITY, 0.25, &h_none);
    printf("%s %dD: 0.25 dx above: %.9f with the gate, %.9f without; state hashes %s\n", implicit ? "implicit" : "explicit", dim, near_gate, near_none,
           h_gate == h_none ? "equal" : "differ");
    CHECK(h_gate == h_none);
    CHECK(near_gate > v0 + 1e-3 * fabs(v0)); /* the contact acts */
}

int main(void) {
    for (int implicit = 0; implicit < 2; implicit++) {
        test_approach(2, implicit);
        test_approach(3, implicit);
    }
    return sm_test_summary("test_contact_gate");
}
