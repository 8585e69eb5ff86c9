/* Free fall: with no contact, a block's centre of mass follows the integrator's own discrete
 * trajectory, v_{n+1} = v_n + g dt, y_{n+1} = y_n + dt v_{n+1} (symplectic Euler: grid velocity
 * updated first, positions moved with the new velocity, thesis 3.92 and 3.116), to 1e-9 relative
 * in double; and that trajectory differs from the exact g t^2/2 by g dt t/2 (first order in dt).
 * 2D and 3D, APIC, both kernels, a sand material (stress stays zero: no deformation). */
#include "test_util.h"
#include "sandmpm/sandmpm.h"

#if SM_DOUBLE
#define RTOL 1e-9
#define ULP_X 0.0
#else
/* In float, positions near 0.5 m carry an ulp of 6e-8 m and every step rounds x + dt v: the error
 * grows by up to about one ulp per step, so float gets an absolute allowance per step. */
#define RTOL 1e-4
#define ULP_X 6e-8
#endif

static void run(int dim, sm_kernel kernel) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = 0.05;
    def.kernel = kernel;
    def.max_dt = 2e-3;
    def.domain_min[1] = -2.0;
    def.domain_max[1] = 1.0;
    sm_world *w = NULL;
    char err[256];
    CHECK(sm_world_create(&def, &w, err, sizeof err) == SM_OK);
    if (!w) return;
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = 0.5;
    box.center[1] = 0.6;
    box.center[2] = 0.5;
    box.half_extent[0] = box.half_extent[1] = box.half_extent[2] = 0.12;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = dim == 2 ? 4 : 8;
    sd.velocity[0] = 0.3; /* drift sideways too */
    size_t added = 0;
    CHECK(sm_world_seed_shape(w, &box, &sd, &added) == SM_OK);
    CHECK(added > 50);
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    double y = d.center_of_mass[1], x = d.center_of_mass[0], vy = 0, vx = 0.3, t = 0;
    const double y0 = y, x0 = x, g = -9.81;
    double worst = 0;
    int steps = 0;
    const double dt = 1e-3; /* fixed, below the adaptive bound, so the discrete solution is closed-form */
    CHECK(sm_world_next_dt(w, 1.0) >= dt);
    for (int n = 0; n < 500; n++) {
        CHECK(sm_world_step(w, dt) == SM_OK);
        vy += g * dt;
        y += dt * vy;
        x += dt * vx;
        t += dt;
        steps++;
        sm_world_diagnostics(w, &d);
        double e = fabs(d.center_of_mass[1] - y) / fmax(fabs(y - y0), 1e-12);
        if (e > worst) worst = e;
        CHECK_NEAR(d.center_of_mass[1] - y0, y - y0, RTOL * fabs(y - y0) + ULP_X * (n + 1) + 1e-15);
        CHECK_NEAR(d.center_of_mass[0] - x0, x - x0, RTOL * fabs(x - x0) + ULP_X * (n + 1) + 1e-15);
        CHECK_REL(d.momentum[1], d.total_mass * vy, RTOL, d.total_mass * 0.1);
    }
    /* Discrete vs exact: y_disc - y_exact = g dt t / 2 for a constant dt (here max_dt). */
    double exact = y0 + 0.5 * g * t * t;
    double predicted = 0.5 * g * dt * t;
    CHECK_REL(y - exact, predicted, 1e-6, 1e-6);
    printf("%dD %s: %d steps, %zu particles, worst relative COM error %.2e; discrete - exact = %.4g (g dt t/2 = %.4g)\n",
           dim, kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic", steps, d.particles, worst, y - exact, predicted);
    sm_world_destroy(w);
}

int main(void) {
    for (int dim = 2; dim <= 3; dim++) {
        run(dim, SM_KERNEL_QUADRATIC);
        run(dim, SM_KERNEL_CUBIC);
    }
    return sm_test_summary("test_freefall");
}
