/* Tests of the lane-parallel plasticity (src/material/plastic_batch.h) against the scalar path
 * (sm_svd + sm_dp_project + hardening + sm_hencky_tau), and of its log/exp/sin. Lanes are filled
 * with the packing helpers the library's plasticity stage uses.
 *
 * Tolerances (measured worst errors are printed; the bounds are ~4-10x those):
 *   log, exp, sin vs libm (double reference):  TOL_FN relative (float: 4 ulp, double: 8 eps)
 *   F:     |F_batch - F_scalar|_max <= TOL_F cond max(1, |F|_max)
 *   tau:   |tau_batch - tau_scalar|_max <= TOL_TAU cond max(2 mu + 3 lambda, |tau_scalar|_max) (the
 *          floor policy makes tau of an inverted F huge: then relative), TOL_TAU = 64 eps, cond = the
 *          condition number of tau(F) estimated from the singular values (see scalar_plastic):
 *          two correct SVDs legitimately differ by eps ||F|| in the small singular values and by
 *          eps / gap in the singular vectors.
 *   q:     |dq| <= TOL_Q cond max(1, q);  alpha: |dalpha| <= TOL_Q cond   (all TOL_* = 64 eps)
 * Particles whose return-mapping case is decided within rounding (|dgamma|, tr eps or |dev eps|
 * within 1e3 eps of 0, relatively) may legitimately take the other branch: if they differ they are
 * counted, not failed.
 * Lane independence: every particle run in two different lanes with different neighbours gives
 * identical bits. */
#include <float.h>
#include <string.h>

#include "material/material.h"
#include "material/plastic_batch.h"
#include "math/svd.h"
#include "test_util.h"

#if SM_DOUBLE
#define TOL_FN (8 * SM_EPS)
#define TOL_F (64 * SM_EPS)
#define TOL_TAU (64 * SM_EPS)
#define TOL_Q (64 * SM_EPS)
#else
#define TOL_FN (4 * SM_EPS)
#define TOL_F (64 * SM_EPS)
#define TOL_TAU (64 * SM_EPS)
#define TOL_Q (64 * SM_EPS)
#endif
#define L SM_PLASTIC_LANES
#define N_BATCH 2000

static unsigned long long rng = 0x1234abcd9876ULL;
static double urand(double lo, double hi) { return sm_test_uniform(&rng, lo, hi); }

typedef sm_plastic_params mat_t;

/* The scalar path (what the library computed per particle before the lanes). Returns the case
 * (1 if elastic). */
static int scalar_plastic(int D, const mat_t *m, sm_real *F, sm_real *alpha, sm_real *q, sm_real *T,
                          double *margin, double *cond) {
    sm_real U[9], V[9], s[3], tau[3];
    if (D == 3)
        sm_svd3(F, U, s, V);
    else
        sm_svd2(F, U, s, V);
    int kase = 1;
    sm_real s_in[3] = {s[0], s[1], D == 3 ? s[2] : 0};
    *margin = 1;
    if (m->plastic) {
        /* how close the decision is: recompute the quantities of sm_dp_project in double */
        double eps[3], tr = 0, nd = 0, emax = 0;
        for (int i = 0; i < D; i++) eps[i] = log(fmax((double)s[i], (double)SM_SIGMA_FLOOR)), tr += eps[i];
        for (int i = 0; i < D; i++) nd += (eps[i] - tr / D) * (eps[i] - tr / D), emax = fmax(emax, fabs(eps[i]));
        double kappa = (D * (double)m->lambda + 2 * (double)m->mu) / (2 * (double)m->mu) * tr * (double)*alpha;
        double dg = sqrt(nd) + kappa;
        *margin = fmin(fabs(tr) / (emax + 1e-300), fabs(dg) / (sqrt(nd) + fabs(kappa) + 1e-300));
        *margin = fmin(*margin, sqrt(nd) / (emax + 1e-300));
        sm_real dq = 0;
        kase = sm_dp_project(D, s, *alpha, m->mu, m->lambda, s, &dq);
        if (kase != 1) {
            for (int a = 0; a < D; a++)
                for (int e = 0; e < D; e++) {
                    sm_real acc = 0;
                    for (int k = 0; k < D; k++) acc += U[a * D + k] * s[k] * V[e * D + k];
                    F[a * D + e] = acc;
                }
            if (m->hardening && dq > 0) {
                *q += dq;
                double phi = sm_hardening_phi((double)*q, m->h0, m->h1, m->h2, m->h3);
                *alpha = (sm_real)sm_dp_alpha_fit(phi, m->fit, D);
            }
        }
    }
    sm_hencky_tau(D, s, m->mu, m->lambda, tau);
    /* Condition number of tau(F) (relative, in units of the relative perturbation of F): log near
     * the smallest singular value, and rotations of singular vectors between nearly equal |s_i|
     * with different tau_i (e.g. s_i = -s_j: the floor policy makes tau jump there). */
    {
        double fm = 0, tm = 2 * (double)m->mu + 3 * (double)m->lambda, smin = 1e300;
        for (int i = 0; i < D; i++) fm = fmax(fm, fabs((double)s[i])), tm = fmax(tm, fabs((double)tau[i]));
        for (int i = 0; i < D; i++) smin = fmin(smin, fmax(fabs((double)s[i]), (double)SM_SIGMA_FLOOR));
        *cond = 1 + fm / smin;
        double fm_in = 0, sm = 0, smin_in = 1e300;
        for (int i = 0; i < D; i++) fm_in = fmax(fm_in, fabs((double)s_in[i])), sm = fmax(sm, fabs((double)s[i]));
        for (int i = 0; i < D; i++) smin_in = fmin(smin_in, fmax(fabs((double)s_in[i]), (double)SM_SIGMA_FLOOR));
        *cond = fmax(*cond, 1 + fm_in / smin_in); /* the return mapping takes logs of the input */
        for (int i = 0; i < D; i++)
            for (int j = i + 1; j < D; j++) {
                double gap = fmax(fabs(fabs((double)s_in[i]) - fabs((double)s_in[j])) / fm_in, (double)SM_EPS);
                *cond = fmax(*cond, fabs((double)tau[i] - (double)tau[j]) / tm / gap);
                *cond = fmax(*cond, fabs((double)s[i] - (double)s[j]) / sm / gap); /* F = U diag(s') V^T */
            }
    }
    for (int a = 0; a < D; a++)
        for (int e = 0; e < D; e++) {
            sm_real acc = 0;
            for (int k = 0; k < D; k++) acc += U[a * D + k] * tau[k] * U[e * D + k];
            T[a * D + e] = acc;
        }
    return kase;
}

static void rand_rot(int D, double *R) {
    if (D == 2) {
        double a = urand(-SM_PI, SM_PI);
        R[0] = cos(a), R[1] = -sin(a), R[2] = sin(a), R[3] = cos(a);
        return;
    }
    double q[4], n2;
    do {
        n2 = 0;
        for (int i = 0; i < 4; i++) q[i] = urand(-1, 1), n2 += q[i] * q[i];
    } while (n2 > 1 || n2 < 1e-4);
    double s = 1 / sqrt(n2), w = q[0] * s, x = q[1] * s, y = q[2] * s, z = q[3] * s;
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

/* Categories of F: 0 near-rotation (1e-3), 1 mildly compressed/stretched (1e-2..5e-2), 2 strongly
 * (0.3..3), 3 hydrostatic compression, 4 inverted, 5 tiny singular value, 6 random entries. */
static void make_F(int D, int cat, sm_real *F) {
    double U[9], V[9], s[3];
    rand_rot(D, U);
    rand_rot(D, V);
    for (int i = 0; i < D; i++) {
        switch (cat) {
        case 0: s[i] = 1 + urand(-1e-3, 1e-3); break;
        case 1: s[i] = 1 + urand(-5e-2, 3e-2); break;
        case 2: s[i] = exp(urand(-1.2, 1.1)); break;
        case 3: s[i] = 0.97; break;
        case 4: s[i] = 1 + urand(-0.2, 0.1); break;
        case 5: s[i] = i == D - 1 ? urand(0, 2e-4) : 1 + urand(-0.1, 0.1); break;
        default: s[i] = 0; break;
        }
    }
    if (cat == 4) s[D - 1] = -s[D - 1];
    for (int i = 0; i < D; i++)
        for (int j = 0; j < D; j++) {
            double acc = 0;
            for (int k = 0; k < D; k++) acc += U[i * D + k] * s[k] * V[j * D + k];
            F[i * D + j] = (sm_real)(cat == 6 ? urand(-1.5, 1.5) : acc);
        }
}

static double ulp_err(double got, double ref) {
    double u = (double)SM_EPS * fmax(fabs(ref), (double)(SM_DOUBLE ? DBL_MIN : FLT_MIN));
    return fabs(got - ref) / u;
}

static void test_functions(void) {
    sm_real x[L], y[L];
    double wl = 0, we = 0, ws = 0;
    for (int it = 0; it < 20000; it++) {
        for (int l = 0; l < L; l++) x[l] = (sm_real)exp(urand(-30, 30));
        if (it == 0) x[0] = 1, x[1] = SM_SIGMA_FLOOR, x[2] = (sm_real)0.7071067811865476, x[3] = 2;
        sm_lanes_log(x, y);
        for (int l = 0; l < L; l++) {
            double ref = log((double)x[l]);
            double e = fabs((double)y[l] - ref) / fmax(fabs(ref), 1e-300) / SM_EPS;
            if (ref == 0) e = fabs((double)y[l]) / SM_EPS;
            /* relative error, but near x = 1 the absolute error relative to |x - 1| is what counts */
            e = fmin(e, fabs((double)y[l] - ref) / fmax(fabs((double)x[l] - 1), 1e-300) / SM_EPS);
            wl = fmax(wl, e);
        }
        for (int l = 0; l < L; l++) x[l] = (sm_real)urand(-60, 60);
        if (it == 0) x[0] = 0, x[1] = (sm_real)-1e-8, x[2] = (sm_real)0.5 * (sm_real)0.69314718, x[3] = 80;
        sm_lanes_exp(x, y);
        for (int l = 0; l < L; l++) we = fmax(we, ulp_err((double)y[l], exp((double)x[l])));
        for (int l = 0; l < L; l++) x[l] = (sm_real)urand(-8, 8);
        sm_lanes_sin(x, y);
        for (int l = 0; l < L; l++) {
            double ref = sin((double)x[l]);
            ws = fmax(ws, fabs((double)y[l] - ref) / fmax(fabs(ref), 0.01) / SM_EPS);
        }
    }
    printf("  lane log/exp/sin worst error: %.2f / %.2f / %.2f eps (tolerance %.0f eps)\n", wl, we, ws,
           TOL_FN / SM_EPS);
    CHECK(wl <= TOL_FN / SM_EPS);
    CHECK(we <= TOL_FN / SM_EPS);
    CHECK(ws <= TOL_FN / SM_EPS);
}

static void fill_lane(sm_plastic_lanes *b, int l, int D, const sm_real *F, sm_real alpha, sm_real q,
                      const mat_t *m) {
    sm_plastic_lanes_set_params(b, l, m);
    sm_plastic_lanes_load(b, D, l, F, alpha, q);
}

static void test_against_scalar(int D) {
    const double deg = SM_PI / 180;
    double mu, lambda;
    sm_lame(3.537e5, 0.3, &mu, &lambda);
    const sm_real h0 = (sm_real)(35 * deg), h1 = (sm_real)(9 * deg), h3 = (sm_real)(10 * deg);
    mat_t mats[6] = {
        {(sm_real)mu, (sm_real)lambda, h0, h1, (sm_real)0.2, h3, 1, 1, SM_CONE_TRIAXIAL_COMPRESSION},
        {(sm_real)mu, (sm_real)lambda, 0, 0, 0, 0, 1, 0, 0}, /* fixed friction angle */
        {(sm_real)mu, (sm_real)lambda, 0, 0, 0, 0, 0, 0, 0}, /* elastic */
        /* hardening with the other cone fits (sm_cone_fit) */
        {(sm_real)mu, (sm_real)lambda, h0, h1, (sm_real)0.2, h3, 1, 1, SM_CONE_PLANE_STRAIN},
        {(sm_real)mu, (sm_real)lambda, h0, h1, (sm_real)0.2, h3, 1, 1, SM_CONE_INSCRIBED},
        {(sm_real)mu, (sm_real)lambda, h0, h1, (sm_real)0.2, h3, 1, 1, SM_CONE_SIMPLE_SHEAR},
    };
    static sm_plastic_lanes b, b2;
    double wF = 0, wT = 0, wQ = 0, wA = 0;
    long n = 0, flips = 0, cases[4] = {0, 0, 0, 0}, bitdiff = 0;
    const int DD = D * D;
    for (int it = 0; it < N_BATCH; it++) {
        sm_real F[L][9], Fs[L][9], Ts[L][9], as[L], qs[L];
        double margin[L], cond[L];
        int mi[L], kase[L], cat[L];
        for (int l = 0; l < L; l++) {
            mi[l] = (int)(urand(0, 6));
            cat[l] = (int)urand(0, 7);
            make_F(D, cat[l], F[l]);
            as[l] = mats[mi[l]].plastic ? (sm_real)urand(0, 0.5) : 0;
            qs[l] = (sm_real)urand(0, 0.3);
            fill_lane(&b, l, D, F[l], as[l], qs[l], &mats[mi[l]]);
            memcpy(Fs[l], F[l], sizeof F[l]);
            kase[l] = scalar_plastic(D, &mats[mi[l]], Fs[l], &as[l], &qs[l], Ts[l], &margin[l], &cond[l]);
        }
        /* the same particles, rotated by one lane */
        for (int l = 0; l < L; l++) {
            int k = (l + 1) % L;
            fill_lane(&b2, k, D, F[l], b.alpha[l], b.q[l], &mats[mi[l]]);
        }
        if (D == 3)
            sm_plastic_lanes3(&b), sm_plastic_lanes3(&b2);
        else
            sm_plastic_lanes2(&b), sm_plastic_lanes2(&b2);
        for (int l = 0; l < L; l++) {
            int k = (l + 1) % L;
            int same = b.alpha[l] == b2.alpha[k] && b.q[l] == b2.q[k];
            for (int e = 0; e < DD; e++)
                same &= memcmp(&b.F[e][l], &b2.F[e][k], sizeof(sm_real)) == 0 &&
                        memcmp(&b.tau[e][l], &b2.tau[e][k], sizeof(sm_real)) == 0;
            bitdiff += !same;
            n++;
            cases[kase[l]]++;
            double fm = 1, dF = 0, dT = 0;
            for (int e = 0; e < DD; e++) fm = fmax(fm, fabs((double)Fs[l][e]));
            for (int e = 0; e < DD; e++) dF = fmax(dF, fabs((double)b.F[e][l] - (double)Fs[l][e]) / fm);
            double ts = 2 * (double)mats[mi[l]].mu + 3 * (double)mats[mi[l]].lambda;
            for (int e = 0; e < DD; e++) ts = fmax(ts, fabs((double)Ts[l][e])); /* huge when inverted */
            for (int e = 0; e < DD; e++) dT = fmax(dT, fabs((double)b.tau[e][l] - (double)Ts[l][e]) / ts);
            dT /= cond[l], dF /= cond[l];
            double dQ = fabs((double)b.q[l] - (double)qs[l]) / fmax(1, fabs((double)qs[l])) / cond[l];
            double dA = fabs((double)b.alpha[l] - (double)as[l]) / cond[l];
            int ok = dF <= TOL_F && dT <= TOL_TAU && dQ <= TOL_Q && dA <= TOL_Q;
            if (!ok && margin[l] < 1e3 * SM_EPS) { /* the case is decided by rounding: either is right */
                flips++;
                continue;
            }
            if (!ok)
                fprintf(stderr, "  D=%d cat %d lane %d mat %d case %d: dF %.3g dtau %.3g dq %.3g dalpha %.3g\n", D, cat[l], l,
                        mi[l], kase[l], dF, dT, dQ, dA);
            CHECK(dF <= TOL_F);
            CHECK(dT <= TOL_TAU);
            CHECK(dQ <= TOL_Q);
            CHECK(dA <= TOL_Q);
            wF = fmax(wF, dF), wT = fmax(wT, dT), wQ = fmax(wQ, dQ), wA = fmax(wA, dA);
        }
    }
    CHECK(bitdiff == 0);
    CHECK(cases[1] > n / 10 && cases[2] > n / 20 && cases[3] > n / 20);
    printf("  %dD: %ld particles (case 1/2/3: %ld/%ld/%ld, %ld differing at a case boundary), lane moves "
           "changing bits: %ld\n      worst |dF|/cond %.3g (tol %.2g), |dtau|/max(2mu+3lambda,|tau|)/cond %.3g (tol %.2g), |dq| %.3g, "
           "|dalpha| %.3g (/cond, tol %.2g)\n",
           D, n, cases[1], cases[2], cases[3], flips, bitdiff, wF, TOL_F, wT, TOL_TAU, wQ, wA, TOL_Q);
}

int main(void) {
    printf("sm_real = %s, lanes = %d\n", SM_DOUBLE ? "double" : "float", L);
    test_functions();
    test_against_scalar(3);
    test_against_scalar(2);
    return sm_test_summary("test_plastic_batch");
}
