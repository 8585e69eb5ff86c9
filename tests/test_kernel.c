/* Kernels (thesis 3.18-3.21, 3.85-3.86): the 1D weights equal the thesis's spline formulas, form a
 * partition of unity, reproduce linear functions, their gradients sum to zero, and the APIC inertia
 * tensor D = sum w (x_i - x_p)(x_i - x_p)^T is dx^2/4 I (quadratic) or dx^2/3 I (cubic), in 2D and
 * 3D (tensor products). */
#include "test_util.h"
#include "transfer/kernel.h"

static double N_quadratic(double x) {
    x = fabs(x);
    if (x < 0.5) return 0.75 - x * x;
    if (x < 1.5) return 0.5 * (1.5 - x) * (1.5 - x);
    return 0;
}
static double N_cubic(double x) {
    x = fabs(x);
    if (x < 1) return 0.5 * x * x * x - x * x + 2.0 / 3.0;
    if (x < 2) return (2 - x) * (2 - x) * (2 - x) / 6.0;
    return 0;
}

int main(void) {
#if SM_DOUBLE
    const double tol = 1e-13;
#else
    const double tol = 2e-6;
#endif
    unsigned long long rng = 42;
    for (int S = 3; S <= 4; S++) {
        const double Dexp = S == 3 ? 0.25 : 1.0 / 3.0;
        double worst_pu = 0, worst_grad = 0, worst_D = 0;
        for (int t = 0; t < 20000; t++) {
            double Xd = sm_test_uniform(&rng, 3.0, 60.0);
            if (t < 8) Xd = 10.0 + 0.5 * t; /* exact node and half-node positions */
            sm_real X = (sm_real)Xd;
            sm_real w[4], dw[4];
            int base = sm_kernel_1d(S, X, w, dw);
            CHECK(base == sm_kernel_base(S, X));
            double sum = 0, sumd = 0, lin = 0, sec = 0;
            for (int k = 0; k < S; k++) {
                double r = (double)(base + k) - (double)X;
                double ref = S == 3 ? N_quadratic(r) : N_cubic(r);
                CHECK_NEAR(w[k], ref, tol);
                CHECK(w[k] >= 0);
                /* derivative against a central difference of the thesis formula */
                double h = 1e-6;
                double fd = S == 3 ? (N_quadratic(r - h) - N_quadratic(r + h)) / (2 * h)
                                   : (N_cubic(r - h) - N_cubic(r + h)) / (2 * h);
                CHECK_NEAR(dw[k], fd, 1e-6 + tol);
                sum += w[k];
                sumd += dw[k];
                lin += w[k] * r;
                sec += w[k] * r * r;
            }
            /* Nodes outside the stencil must have zero weight. */
            CHECK(((S == 3) ? N_quadratic((double)(base - 1) - (double)X) : N_cubic((double)(base - 1) - (double)X)) < 1e-12);
            CHECK(((S == 3) ? N_quadratic((double)(base + S) - (double)X) : N_cubic((double)(base + S) - (double)X)) < 1e-12);
            worst_pu = fmax(worst_pu, fabs(sum - 1));
            worst_grad = fmax(worst_grad, fabs(sumd));
            worst_D = fmax(worst_D, fabs(sec - Dexp));
            CHECK_NEAR(sum, 1.0, tol);
            CHECK_NEAR(sumd, 0.0, tol);
            CHECK_NEAR(lin, 0.0, tol * 4);
            CHECK_NEAR(sec, Dexp, tol * 8);
        }
        printf("%s: worst |sum w - 1| = %.2e, |sum dw| = %.2e, |D - %.4f| = %.2e (grid units)\n",
               S == 3 ? "quadratic" : "cubic", worst_pu, worst_grad, Dexp, worst_D);

        /* Tensor products in 2D and 3D: partition of unity, gradient sum, full D matrix. */
        for (int dim = 2; dim <= 3; dim++) {
            for (int t = 0; t < 500; t++) {
                sm_real w[3][4], dw[3][4];
                int base[3];
                double X[3];
                for (int a = 0; a < dim; a++) {
                    X[a] = sm_test_uniform(&rng, 3.0, 40.0);
                    base[a] = sm_kernel_1d(S, (sm_real)X[a], w[a], dw[a]);
                }
                double sum = 0, g[3] = {0, 0, 0}, Dm[3][3] = {{0}};
                int n2 = dim == 3 ? S : 1;
                for (int i = 0; i < S; i++)
                    for (int j = 0; j < S; j++)
                        for (int k = 0; k < n2; k++) {
                            int idx[3] = {i, j, k};
                            double wt = 1, r[3];
                            for (int a = 0; a < dim; a++) {
                                wt *= w[a][idx[a]];
                                r[a] = (double)(base[a] + idx[a]) - (double)(sm_real)X[a];
                            }
                            for (int a = 0; a < dim; a++) {
                                double ga = dw[a][idx[a]];
                                for (int b = 0; b < dim; b++)
                                    if (b != a) ga *= w[b][idx[b]];
                                g[a] += ga;
                            }
                            sum += wt;
                            for (int a = 0; a < dim; a++)
                                for (int b = 0; b < dim; b++) Dm[a][b] += wt * r[a] * r[b];
                        }
                CHECK_NEAR(sum, 1.0, tol * 4);
                for (int a = 0; a < dim; a++) {
                    CHECK_NEAR(g[a], 0.0, tol * 4);
                    for (int b = 0; b < dim; b++) CHECK_NEAR(Dm[a][b], a == b ? Dexp : 0.0, tol * 16);
                }
            }
        }
    }
    return sm_test_summary("test_kernel");
}
