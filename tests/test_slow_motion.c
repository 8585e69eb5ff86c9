/* Slow motion is not lost to the rounding of positions (issue 12, item 4: "float positions drop
 * slow motion").
 *
 * G2P moves a particle by dt sum_i w_ip v-bar_i (3.116). At x = 0.7 m, v = 5e-4 m/s and
 * dt = 3.4e-5 s a step moves it by 1.7e-8 m, a quarter of a float's spacing at 0.7 (5.96e-8 m):
 * with float positions the particles did not move at all over 1,001 steps while F^E took the full
 * velocity gradient. Positions are double in both builds now (particles/particles.h).
 *
 * A block of sand at x ~ 0.7 m translating at that speed (no gravity, nothing touching it), 1,001
 * steps. A uniform velocity is reproduced by the grid, so every particle's displacement must be
 * the time integral of its own velocity, sum over steps of dt v_p (to 1e-4 of it), and at least
 * 0.95 v t. Not exactly v t: in float, F^E = I + O(1e-7) is a stress of order E 1e-7 = 0.04 Pa,
 * which over 34 ms changes a 5e-4 m/s velocity by up to a few percent (measured: 1.1 % in 3D,
 * 4e-5 in 2D cubic, 1e-6 in 2D quadratic) -- the sand's own elasticity, not lost motion.
 * 2D and 3D, quadratic and cubic kernels. */
#include <math.h>
#include <string.h>

#include "test_util.h"
#include "sandmpm/sandmpm.h"

#define STEPS 1001
#define DT 3.4e-5
#define SPEED 5e-4

static void slow_block(int dim, sm_kernel kernel) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = 0.02;
    def.kernel = kernel;
    def.threads = 1; /* results do not depend on it; one thread keeps 4,004 tiny steps cheap */
    for (int a = 0; a < 3; a++) def.gravity[a] = 0;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "world: %s\n", err);
        CHECK(0);
        return;
    }
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    /* 4^d particles, spacing dx/2, around (0.7, 0.7, 0.7); velocity along (1, 0.5, -0.25) scaled
     * so that the x component is SPEED. */
    const double dir[3] = {1.0, 0.5, dim == 3 ? -0.25 : 0.0};
    enum { MAXN = 64 };
    double x[MAXN * 3], v[MAXN * 3], x0[MAXN * 3], vdt[MAXN * 3] = {0};
    size_t n = 0;
    for (int k = 0; k < (dim == 3 ? 4 : 1); k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++) {
                const int ijk[3] = {i, j, k};
                for (int a = 0; a < 3; a++) {
                    x[3 * n + a] = a < dim ? 0.7 + 0.01 * (ijk[a] - 1.5) + 0.0013 * a : 0.0;
                    v[3 * n + a] = SPEED * dir[a];
                }
                n++;
            }
    CHECK(sm_world_add_particles(w, n, x, v, mat, 8) == SM_OK);
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    for (size_t p = 0; p < n; p++)
        for (int a = 0; a < dim; a++) x0[pv.id[p] * 3 + a] = pv.x[p * dim + a];
    for (int s = 0; s < STEPS; s++) {
        if (sm_world_step(w, DT) != SM_OK) {
            fprintf(stderr, "step %d: %s\n", s, sm_world_errmsg(w));
            CHECK(0);
            break;
        }
        sm_world_particles(w, &pv);
        for (size_t p = 0; p < pv.n; p++)
            for (int a = 0; a < dim; a++) vdt[pv.id[p] * 3 + a] += DT * (double)pv.v[p * dim + a];
    }
    sm_world_particles(w, &pv);
    CHECK(pv.n == n);
    const double t = STEPS * DT;
    double worst = 0, least = INFINITY;
    for (size_t p = 0; p < pv.n; p++) {
        const uint32_t id = pv.id[p];
        for (int a = 0; a < dim; a++) {
            const double moved = pv.x[p * dim + a] - x0[id * 3 + a];
            worst = fmax(worst, fabs(moved - vdt[id * 3 + a]) / (SPEED * t));
        }
        least = fmin(least, (pv.x[p * dim] - x0[id * 3]) / (SPEED * t));
    }
    printf("%dD %s: particle 0 moved %.6e m along x (v t = %.6e); worst |x - x0 - sum dt v| / (v t) %.2e, "
           "least x displacement / (v t) %.4f\n",
           dim, kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic", pv.x[0] - x0[pv.id[0] * 3], SPEED * t, worst,
           least);
    CHECK(worst < 1e-4);
    CHECK(least > 0.95);
    sm_world_destroy(w);
}

int main(void) {
    slow_block(2, SM_KERNEL_QUADRATIC);
    slow_block(2, SM_KERNEL_CUBIC);
    slow_block(3, SM_KERNEL_QUADRATIC);
    slow_block(3, SM_KERNEL_CUBIC);
    return sm_test_summary("test_slow_motion");
}
