/* Transfers (thesis 3.81-3.88, 3.109-3.113): P2G then G2P without forces conserves mass, linear
 * momentum and (APIC) angular momentum, in 2D and 3D, for both kernels. PIC and FLIP conserve mass
 * and linear momentum through the round trip (PIC loses angular momentum in G2P, by design). */
#include <string.h>

#include "test_util.h"
#include "world/world.h"

#if SM_DOUBLE
#define RTOL 1e-12
#else
#define RTOL 2e-5
#endif

static sm_world *make(int dim, sm_kernel kernel, sm_transfer transfer, unsigned long long seed) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = 0.05;
    def.kernel = kernel;
    def.transfer = transfer;
    for (int a = 0; a < 3; a++) def.gravity[a] = 0;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "%s\n", err);
        return NULL;
    }
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    /* Random particles in the middle of the domain with random velocities and affine B. */
    size_t n = dim == 2 ? 400 : 1500;
    double *x = malloc(n * 3 * sizeof(double)), *v = malloc(n * 3 * sizeof(double));
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            x[3 * i + a] = a < dim ? sm_test_uniform(&seed, 0.3, 0.7) : 0;
            v[3 * i + a] = a < dim ? sm_test_uniform(&seed, -1, 1) : 0;
        }
    CHECK(sm_world_add_particles(w, n, x, v, mat, 8) == SM_OK);
    /* Different masses per particle: scale via direct access (test hook). */
    for (size_t i = 0; i < n; i++) {
        w->p.vol0[i] *= (sm_real)sm_test_uniform(&seed, 0.5, 2.0); /* mass = density vol0 */
        if (transfer == SM_TRANSFER_APIC)
            for (int k = 0; k < dim * dim; k++) w->p.B[i * dim * dim + k] = (sm_real)sm_test_uniform(&seed, -0.01, 0.01);
    }
    free(x);
    free(v);
    return w;
}

int main(void) {
    const char *tn[] = {"APIC", "PIC", "FLIP"};
    for (int dim = 2; dim <= 3; dim++)
        for (int kern = 0; kern < 2; kern++)
            for (int tr = 0; tr < 3; tr++) {
                sm_world *w = make(dim, (sm_kernel)kern, (sm_transfer)tr, 7 + (unsigned long long)(dim * 10 + kern * 3 + tr));
                CHECK(w != NULL);
                if (!w) continue;
                sm_transfer_totals t;
                sm_world_debug_transfer_roundtrip(w, &t);
                double pscale = 0, lscale = 0;
                for (int a = 0; a < 3; a++) {
                    pscale += fabs(t.mom[0][a]);
                    lscale += fabs(t.ang[0][a]);
                }
                /* scale for momentum: total mass times typical speed */
                pscale = fmax(pscale, t.mass[0] * 0.1);
                lscale = fmax(lscale, t.mass[0] * 0.1 * 0.5);
                CHECK_REL(t.mass[1], t.mass[0], RTOL, 0);
                CHECK_REL(t.mass[2], t.mass[0], RTOL, 0);
                double worst_p = 0, worst_l = 0;
                for (int a = 0; a < 3; a++) {
                    CHECK_NEAR(t.mom[1][a], t.mom[0][a], RTOL * pscale);
                    CHECK_NEAR(t.mom[2][a], t.mom[0][a], RTOL * pscale);
                    worst_p = fmax(worst_p, fabs(t.mom[2][a] - t.mom[0][a]) / pscale);
                    if (tr != SM_TRANSFER_PIC && tr != SM_TRANSFER_FLIP) {
                        /* P2G conserves angular momentum for APIC (B term included) */
                        CHECK_NEAR(t.ang[1][a], t.ang[0][a], RTOL * lscale);
                        CHECK_NEAR(t.ang[2][a], t.ang[0][a], RTOL * lscale);
                        worst_l = fmax(worst_l, fabs(t.ang[2][a] - t.ang[0][a]) / lscale);
                    } else {
                        /* PIC/FLIP P2G still conserves it (no B); G2P need not. */
                        CHECK_NEAR(t.ang[1][a], t.ang[0][a], RTOL * lscale);
                    }
                }
                printf("%dD %s %s: mass rel %.2e, momentum rel %.2e, angular rel %.2e\n", dim,
                       kern ? "cubic" : "quadratic", tn[tr], fabs(t.mass[2] - t.mass[0]) / t.mass[0], worst_p, worst_l);
                sm_world_destroy(w);
            }
    return sm_test_summary("test_transfer");
}
