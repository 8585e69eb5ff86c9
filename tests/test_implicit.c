/* Tests of src/material/implicit: M = dY/dF against central differences of Y in each projection
 * case, for well separated, nearly equal and exactly repeated singular values, d = 2 and 3; the
 * PRECOMPUTE / HESSIAN_TIMES pair against differences of the force matrix; consistency checks.
 *
 * Finite differences: Richardson-extrapolated central differences along a random unit direction
 * E (Frobenius norm 1, F ~ 1):  R = (4 C(h/2) - C(h)) / 3,  C(h) = (Y(F + hE) - Y(F - hE)) / 2h.
 * Truncation error O((h/l)^4) with l the smallest length scale of the nonlinearity (|dev eps|
 * in case III, ~1 otherwise); rounding error ~ c u |Y| / (h |M E|) (c ~ 10-30: SVD + logs).
 * h = min(FD_H, FD_REL |s_min|, and in case III FD_REL l), l = ||dev ln s|| (fd_step).
 *   double: FD_H = 2e-4, FD_REL = 0.1: truncation <~ (h/l)^4 <~ 1e-8 (the O(h^2) term of a plain
 *           central difference, (h/l)^2/6 ~ 1e-5 .. 1e-8, is what Richardson removes), rounding
 *           ~ 30 u / h ~ 3e-11; tolerance 1e-6 (observed worst ~1e-9).
 *   float:  FD_H = 2e-2, FD_REL = 0.2: rounding 30 u |Y| / (h |ME|) ~ 1e-4 .. 1e-3 dominates
 *           (smaller h is worse); truncation (h/l)^4 <~ 2e-3; tolerance 5e-3 (observed ~1.4e-3).
 * The error is measured on the whole dY matrix, relative to its Frobenius norm. The direction
 * actually taken is recovered from the rounded F +- hE ((Fp - Fm)/2h, in double) and M is
 * applied to that direction. Points whose probes change projection case are skipped (counted). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "material/implicit.h"
#include "material/material.h"
#include "math/svd.h"
#include "test_util.h"

static unsigned long long rng = 0x1A9C1ULL;
static double U_(double lo, double hi) { return sm_test_uniform(&rng, lo, hi); }
static double dmax(double a, double b) { return a > b ? a : b; }

static const double u = (double)SM_EPS;

#if SM_DOUBLE
#define FD_H_DEF 2e-4
#define FD_REL_DEF 0.1
#define TOL_FD_DEF 1e-6
#else
#define FD_H_DEF 2e-2
#define FD_REL_DEF 0.2
#define TOL_FD_DEF 5e-3
#endif
#ifndef FD_H
#define FD_H FD_H_DEF
#endif
#ifndef TOL_FD
#define TOL_FD TOL_FD_DEF
#endif
#ifndef FD_REL
#define FD_REL FD_REL_DEF
#endif
/* Two evaluation orders of the same linear map (apply vs direct M): ~1000 u. */
#define TOL_SAME (1000 * u)

/* Worst relative FD errors: [case 0..3] for separated, near-repeated and exactly repeated
 * singular values; inverted F; apply() vs FD of the force matrix; apply vs direct M. */
enum { FAM_SEP, FAM_NEAR, FAM_EXACT, NFAM };
static double worst[4][NFAM];
static int tested[4][NFAM];
static double worst_inv, worst_apply, worst_direct, worst_sym;
static int skipped, fd_total;

static double g_mu, g_lambda, g_alpha;

static sm_implicit_material material(int plastic, double alpha) {
    sm_implicit_material m;
    m.mu = (sm_real)g_mu;
    m.lambda = (sm_real)g_lambda;
    m.alpha = (sm_real)alpha;
    m.plastic = plastic;
    return m;
}

/* ---- small double helpers --------------------------------------------------------------- */

static void rotation(int d, double *R) {
    if (d == 2) {
        double t = U_(-SM_PI, SM_PI);
        R[0] = cos(t), R[1] = -sin(t), R[2] = sin(t), R[3] = cos(t);
        return;
    }
    double q[4], n;
    do {
        n = 0;
        for (int i = 0; i < 4; i++) {
            q[i] = U_(-1, 1);
            n += q[i] * q[i];
        }
    } while (n < 0.05 || n > 1);
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

/* F = R1 diag(s) R2^T, rounded to sm_real. */
static void compose(int d, const double *s, sm_real *F) {
    double R1[9], R2[9];
    rotation(d, R1);
    rotation(d, R2);
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            double a = 0;
            for (int k = 0; k < d; k++) a += R1[i * d + k] * s[k] * R2[j * d + k];
            F[i * d + j] = (sm_real)a;
        }
}

static double fro(int d, const double *A) {
    double s = 0;
    for (int i = 0; i < d * d; i++) s += A[i] * A[i];
    return sqrt(s);
}

static void random_dir(int d, double *E) {
    for (int i = 0; i < d * d; i++) E[i] = U_(-1, 1);
    double n = fro(d, E);
    for (int i = 0; i < d * d; i++) E[i] /= n;
}

/* ---- FD of Y ------------------------------------------------------------------------------ */

/* Richardson central difference of Y at F along E: writes R and the effective direction Eeff.
 * Returns 0 if a probe is in another projection case than F (then R is not computed). */
static int fd_Y(int d, const sm_real *F, const double *E, const sm_implicit_material *mat,
                double h, int cas, double *R, double *Eeff) {
    double C[2][9], Ed[2][9];
    for (int l = 0; l < 2; l++) {
        double hl = l == 0 ? h : h / 2;
        sm_real Fp[9], Fm[9], Yp[9], Ym[9];
        for (int i = 0; i < d * d; i++) {
            Fp[i] = (sm_real)((double)F[i] + hl * E[i]);
            Fm[i] = (sm_real)((double)F[i] - hl * E[i]);
        }
        if (sm_implicit_Y(d, Fp, mat, Yp) != cas) return 0;
        if (sm_implicit_Y(d, Fm, mat, Ym) != cas) return 0;
        for (int i = 0; i < d * d; i++) {
            C[l][i] = ((double)Yp[i] - (double)Ym[i]) / (2 * hl);
            Ed[l][i] = ((double)Fp[i] - (double)Fm[i]) / (2 * hl);
        }
    }
    for (int i = 0; i < d * d; i++) {
        R[i] = (4 * C[1][i] - C[0][i]) / 3;
        Eeff[i] = (4 * Ed[1][i] - Ed[0][i]) / 3;
    }
    return 1;
}

/* FD step at F: FD_H, capped at FD_REL |s_min| (ln s varies on that scale) and in case III at
 * FD_REL ||dev ln s|| (the projection direction varies on that scale); see the top. */
static double fd_step(int d, const sm_real *F, int cas) {
    sm_real U[9], s[3], V[9];
    if (d == 2)
        sm_svd2(F, U, s, V);
    else
        sm_svd3(F, U, s, V);
    double h = fmin(FD_H, FD_REL * fabs((double)s[d - 1]));
    if (cas != 3) return h;
    double e[3], m = 0, n = 0;
    for (int i = 0; i < d; i++) {
        e[i] = log(fabs((double)s[i]));
        m += e[i] / d;
    }
    for (int i = 0; i < d; i++) n += (e[i] - m) * (e[i] - m);
    return fmin(h, FD_REL * sqrt(n));
}

/* ||a - b|| / ||b||, with 0 for a = b = 0. */
static double rel_err(int d, const double *a, const double *b) {
    double diff[9];
    for (int i = 0; i < d * d; i++) diff[i] = a[i] - b[i];
    double nb = fro(d, b), nd = fro(d, diff);
    if (nb == 0) return nd == 0 ? 0 : INFINITY;
    return nd / nb;
}

/* M applied to E by the library (sm_implicit_dY), in double. */
static void lib_dY(int d, const sm_real *F, const double *E, const sm_implicit_material *mat,
                   double *out) {
    sm_real Er[9] = {0}, dY[9];
    for (int i = 0; i < d * d; i++) Er[i] = (sm_real)E[i];
    sm_implicit_dY(d, F, Er, mat, dY);
    for (int i = 0; i < d * d; i++) out[i] = (double)dY[i];
}

/* Checks M[E] against FD for one F and a few random directions; expected case `cas`
 * (-1: whatever). Returns the worst error, -1 if skipped. */
static double check_point(int d, const sm_real *F, const sm_implicit_material *mat, int cas) {
    sm_real Y[9];
    int c0 = sm_implicit_Y(d, F, mat, Y);
    if (cas >= 0 && c0 != cas) fprintf(stderr, "d=%d expected case %d got %d\n", d, cas, c0);
    if (cas >= 0) CHECK(c0 == cas);
    double w = 0, Es[3][9];
    for (int r = 0; r < 3; r++) random_dir(d, Es[r]); /* fixed RNG use, skips or not */
    for (int r = 0; r < 3; r++) {
        double R[9], Eeff[9], M[9];
        const double *E = Es[r];
        fd_total++;
        if (!fd_Y(d, F, E, mat, fd_step(d, F, c0), c0, R, Eeff)) {
            skipped++;
            return -1;
        }
        lib_dY(d, F, Eeff, mat, M);
        double e = rel_err(d, M, R);
        if (c0 == 2) { /* Y = 0 around F: both exactly zero */
            CHECK(fro(d, M) == 0 && fro(d, R) == 0);
            e = fro(d, M) + fro(d, R);
        }
        if (!(e <= TOL_FD))
            fprintf(stderr, "d=%d case %d: FD rel error %.3g\n", d, c0, e);
        CHECK(e <= TOL_FD);
        w = dmax(w, e);
    }
    return w;
}

static void record(int cas, int fam, double e) {
    if (e < 0) return;
    worst[cas][fam] = dmax(worst[cas][fam], e);
    tested[cas][fam]++;
}

/* ---- generators --------------------------------------------------------------------------- */

/* Principal strains for a target case. A: strain amplitude (0.05 near identity, 0.4 for large
 * compression/shear). dir: unit deviatoric direction (NULL: random). */
static void gen_eps(int d, int cas, double A, double alpha, const double *dir, double *eps) {
    double c0 = (d * g_lambda + 2 * g_mu) / (2 * g_mu) * alpha;
    double m, n;
    switch (cas) {
    case 1: /* inside the cone: n < -c0 d m */
        m = -U_(0.2, 1) * A;
        n = U_(0.05, 0.7) * (-c0 * d * m);
        break;
    case 2: /* tension */
        m = U_(0.2, 1) * A;
        n = U_(0, 1) * A;
        break;
    case 3: /* beyond the cone: n > -c0 d m, and n >= 0.3 A */
        m = -U_(0.2, 1) * A;
        n = dmax(U_(1.3, 3) * (-c0 * d * m), U_(0.3, 1) * A);
        break;
    default: /* elastic: anything */
        m = U_(-1, 1) * A;
        n = U_(0, 1) * A;
        break;
    }
    double v[3];
    if (dir) {
        for (int i = 0; i < d; i++) v[i] = dir[i];
    } else {
        double mean = 0, nv = 0;
        for (int i = 0; i < d; i++) {
            v[i] = U_(-1, 1);
            mean += v[i] / d;
        }
        for (int i = 0; i < d; i++) {
            v[i] -= mean;
            nv += v[i] * v[i];
        }
        nv = sqrt(nv);
        for (int i = 0; i < d; i++) v[i] /= nv;
    }
    for (int i = 0; i < d; i++) eps[i] = m + n * v[i];
}

/* ---- tests ---------------------------------------------------------------------------------- */

/* Separated singular values: random rotations, targeted cases, two strain amplitudes, and raw
 * random F (near identity, compressed + sheared). */
static void test_separated(int d) {
    for (int cas = 0; cas <= 3; cas++) {
        sm_implicit_material mat = material(cas != 0, g_alpha);
        for (int amp = 0; amp < 2; amp++)
            for (int n = 0; n < 150; n++) {
                double eps[3], s[3];
                gen_eps(d, cas, amp ? 0.4 : 0.05, g_alpha, NULL, eps);
                for (int i = 0; i < d; i++) s[i] = exp(eps[i]);
                sm_real F[9];
                compose(d, s, F);
                record(cas, FAM_SEP, check_point(d, F, &mat, cas));
            }
    }
    /* alpha = 0: case III maps everything onto the hydrostatic axis (z_i all equal) */
    sm_implicit_material m0 = material(1, 0.0);
    for (int n = 0; n < 100; n++) {
        double eps[3], s[3];
        gen_eps(d, 3, 0.3, 0.0, NULL, eps);
        for (int i = 0; i < d; i++) s[i] = exp(eps[i]);
        sm_real F[9];
        compose(d, s, F);
        record(3, FAM_SEP, check_point(d, F, &m0, 3));
    }
    /* raw random F */
    for (int pl = 0; pl < 2; pl++) {
        sm_implicit_material mat = material(pl, g_alpha);
        for (int n = 0; n < 200; n++) {
            sm_real F[9];
            for (int i = 0; i < d; i++)
                for (int j = 0; j < d; j++) {
                    double x = (n & 1) ? U_(-0.3, 0.3) : U_(-0.05, 0.05); /* shear */
                    if (i == j) x += (n & 1) ? U_(0.6, 1.0) : 1.0;     /* compression */
                    F[i * d + j] = (sm_real)x;
                }
            sm_real Y[9];
            int cas = sm_implicit_Y(d, F, &mat, Y);
            record(cas, FAM_SEP, check_point(d, F, &mat, -1));
        }
    }
}

/* Nearly equal singular values s_j = s_i (1 + delta), delta = 1e-6 .. 1e-10 (in float these are
 * equal to rounding), with random rotations. */
static void test_near_repeated(int d) {
    const double deltas[4] = {1e-6, 1e-7, 1e-8, 1e-10};
    for (int cas = 0; cas <= 3; cas++) {
        if (d == 2 && cas == 3) continue; /* a 2-D near-repeated pair has a tiny deviator */
        sm_implicit_material mat = material(cas != 0, g_alpha);
        for (int k = 0; k < 4; k++)
            for (int n = 0; n < 40; n++) {
                double eps[3], s[3], dir[3];
                if (d == 3) {
                    double sg = (n & 1) ? 1 : -1; /* repeated pair is the larger or smaller */
                    dir[0] = sg / sqrt(6.0), dir[1] = sg / sqrt(6.0), dir[2] = -2 * sg / sqrt(6.0);
                    gen_eps(d, cas, (n & 2) ? 0.4 : 0.05, g_alpha, dir, eps);
                } else {
                    double m = cas == 2 ? U_(0.01, 0.3) : -U_(0.01, 0.3);
                    if (cas == 0) m = U_(-0.3, 0.3);
                    eps[0] = eps[1] = m;
                }
                for (int i = 0; i < d; i++) s[i] = exp(eps[i]);
                s[1] *= 1 + deltas[k];
                sm_real F[9], Y[9];
                compose(d, s, F);
                /* float: a 2-D pair equal to rounding is hydrostatic (case 1 under compression,
                 * case 2 in tension), which need not be the tiny deviator's case */
                int c = sm_implicit_Y(d, F, &mat, Y);
                if (SM_DOUBLE || d == 3) CHECK(c == cas);
                record(c, FAM_NEAR, check_point(d, F, &mat, -1));
            }
    }
    /* triple (3-D) near-repeated, elastic only (plastic: hydrostatic, or a tiny deviator) */
    if (d == 3) {
        sm_implicit_material mat = material(0, g_alpha);
        for (int n = 0; n < 40; n++) {
            double a = exp(U_(-0.3, 0.3));
            double s[3] = {a, a * (1 + deltas[n % 4]), a * (1 - deltas[(n + 1) % 4])};
            sm_real F[9];
            compose(d, s, F);
            record(0, FAM_NEAR, check_point(d, F, &mat, 0));
        }
    }
}

/* Exactly repeated singular values. (a) F = P diag(s) P' with signed permutations, so the SVD
 * returns exactly equal values; (b) Mhat from exactly equal s in sm_real, applied with random
 * rotations U, V and compared with FD of the library's Y at F = U diag(s) V^T. */
static void apply_uv(int d, const double *U, const double *V, const sm_implicit_mhat *mh,
                     const double *E, double *out) {
    sm_real T[9], A[9];
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            double s = 0;
            for (int k = 0; k < d; k++)
                for (int l = 0; l < d; l++) s += U[k * d + i] * E[k * d + l] * V[l * d + j];
            T[i * d + j] = (sm_real)s;
        }
    sm_implicit_mhat_apply(d, mh, T, A);
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            double s = 0;
            for (int k = 0; k < d; k++)
                for (int l = 0; l < d; l++) s += U[i * d + k] * (double)A[k * d + l] * V[j * d + l];
            out[i * d + j] = s;
        }
}

static void test_exact_repeated(int d) {
    int exact_svd = 0, tries_svd = 0;
    for (int cas = 0; cas <= 3; cas++) {
        /* 2-D: repeated => hydrostatic: tip in tension (case 2), inside the cone under compression
         * (case 1, not the tip: issue 12); never case 3 */
        if (d == 2 && cas == 3) continue;
        sm_implicit_material mat = material(cas != 0, g_alpha);
        for (int n = 0; n < 60; n++) {
            double eps[3], dir[3];
            if (d == 3) {
                double sg = (n & 1) ? 1 : -1;
                dir[0] = sg / sqrt(6.0), dir[1] = sg / sqrt(6.0), dir[2] = -2 * sg / sqrt(6.0);
                gen_eps(d, cas, (n & 2) ? 0.4 : 0.05, g_alpha, dir, eps);
            } else {
                eps[0] = eps[1] = cas == 2 ? U_(0.01, 0.3) : cas == 1 ? -U_(0.01, 0.3) : U_(-0.3, 0.3);
            }
            sm_real sr[3];
            for (int i = 0; i < d; i++) sr[i] = (sm_real)exp(eps[i]);
            if (d == 3) sr[1] = sr[0]; /* exactly equal pair */
            /* (a) signed permutation of a diagonal matrix, det > 0 */
            {
                int perm[3] = {0, 1, 2}, parity = 0;
                for (int i = d - 1; i > 0; i--) {
                    int j = (int)(sm_test_rng_next(&rng) % (unsigned)(i + 1));
                    int t = perm[i];
                    perm[i] = perm[j];
                    perm[j] = t;
                    parity ^= j != i;
                }
                sm_real F[9] = {0};
                for (int i = 0; i < d; i++) {
                    int neg = (int)(sm_test_rng_next(&rng) & 1);
                    parity ^= neg;
                    F[i * d + perm[i]] = neg ? -sr[i] : sr[i];
                }
                if (parity) /* det < 0: negate the first row */
                    for (int j = 0; j < d; j++) F[j] = -F[j];
                sm_real Uq[9], sv[3], Vq[9];
                if (d == 2)
                    sm_svd2(F, Uq, sv, Vq);
                else
                    sm_svd3(F, Uq, sv, Vq);
                CHECK(sv[d - 1] > 0);
                tries_svd++;
                int eq = 0;
                for (int i = 0; i + 1 < d; i++) eq |= sv[i] == sv[i + 1];
                exact_svd += eq;
                /* not exactly equal (the SVD may split them by an ulp): near-repeated */
                record(cas, eq ? FAM_EXACT : FAM_NEAR, check_point(d, F, &mat, cas));
            }
            /* (b) exact sigma, random rotations */
            {
                double Ud[9], Vd[9];
                rotation(d, Ud);
                rotation(d, Vd);
                sm_real y[3], F[9];
                sm_implicit_mhat mh;
                int c = sm_implicit_diag(d, sr, &mat, y, &mh);
                CHECK(c == cas);
                for (int i = 0; i < d; i++)
                    for (int j = 0; j < d; j++) {
                        double a = 0;
                        for (int k = 0; k < d; k++)
                            a += Ud[i * d + k] * (double)sr[k] * Vd[j * d + k];
                        F[i * d + j] = (sm_real)a;
                    }
                double E[9], R[9], Eeff[9], M[9];
                random_dir(d, E);
                fd_total++;
                sm_real Yt[9];
                int cf = sm_implicit_Y(d, F, &mat, Yt);
                if (cf != c || !fd_Y(d, F, E, &mat, fd_step(d, F, c), c, R, Eeff)) {
                    skipped++;
                    continue;
                }
                apply_uv(d, Ud, Vd, &mh, Eeff, M);
                double e = c == 2 ? fro(d, M) + fro(d, R) : rel_err(d, M, R);
                if (!(e <= TOL_FD)) fprintf(stderr, "exact repeated d=%d case %d: %.3g\n", d, c, e);
                CHECK(e <= TOL_FD);
                record(cas, FAM_EXACT, e);
            }
        }
    }
    /* triple repeated, elastic */
    sm_implicit_material mat = material(0, g_alpha);
    for (int n = 0; n < 30; n++) {
        sm_real a = (sm_real)exp(U_(-0.3, 0.3)), F[9] = {0};
        for (int i = 0; i < d; i++) F[i * d + i] = a;
        record(0, FAM_EXACT, check_point(d, F, &mat, 0));
    }
    printf("d=%d exactly repeated via SVD of permuted diagonals: %d of %d exact\n", d, exact_svd,
           tries_svd);
    CHECK(2 * exact_svd >= tries_svd); /* case (b) always has exactly equal values */
}

/* Inverted F (det < 0, last signed singular value negative, below the floor): Y is still smooth
 * where the |s_i| are distinct and s_i + s_d is not small, and M must match. */
static void test_inverted(int d) {
    for (int pl = 0; pl < 2; pl++) {
        sm_implicit_material mat = material(pl, g_alpha);
        for (int n = 0; n < 100; n++) {
            double s[3];
            s[0] = U_(1.0, 1.4);
            if (d == 3) s[1] = U_(0.8, 0.95);
            s[d - 1] = -U_(0.1, 0.5);
            sm_real F[9];
            compose(d, s, F);
            double e = check_point(d, F, &mat, -1);
            if (e >= 0) worst_inv = dmax(worst_inv, e);
        }
    }
}

/* Elastic M is the Hessian of psi: <B, M[A]> = <A, M[B]>. */
static void test_symmetry(int d) {
    sm_implicit_material mat = material(0, g_alpha);
    for (int n = 0; n < 200; n++) {
        double eps[3], s[3], A[9], B[9], MA[9], MB[9];
        gen_eps(d, 0, 0.3, g_alpha, NULL, eps);
        for (int i = 0; i < d; i++) s[i] = exp(eps[i]);
        sm_real F[9];
        compose(d, s, F);
        random_dir(d, A);
        random_dir(d, B);
        lib_dY(d, F, A, &mat, MA);
        lib_dY(d, F, B, &mat, MB);
        double ab = 0, ba = 0, sc = 0;
        for (int i = 0; i < d * d; i++) {
            ab += B[i] * MA[i];
            ba += A[i] * MB[i];
        }
        sc = fro(d, MA) + fro(d, MB);
        double e = fabs(ab - ba) / sc;
        worst_sym = dmax(worst_sym, e);
        CHECK(e <= 64 * u);
    }
}

/* PRECOMPUTE + HESSIAN_TIMES: apply(T1) = (1/dt) d/de G(T + e T1), G = V0 Y((I + dt T) Fn) Fn^T,
 * apply = direct M application, precompute's G = force_matrix's G bitwise. */
static void test_apply(int d) {
    for (int cas = 0; cas <= 3; cas++) {
        sm_implicit_material mat = material(cas != 0, g_alpha);
        for (int n = 0; n < 150; n++) {
            double eps[3], s[3];
            gen_eps(d, cas, (n & 1) ? 0.3 : 0.05, g_alpha, NULL, eps);
            for (int i = 0; i < d; i++) s[i] = exp(eps[i]);
            sm_real Fn[9], T[9], T1[9];
            compose(d, s, Fn);
            sm_real dt = (sm_real)U_(1e-3, 1e-2);
            sm_real V0 = (sm_real)U_(0.5e-3, 2e-3);
            double tsc = (n & 2) ? 0.01 : 3.0; /* |dt T| ~ 0 .. 0.03 */
            for (int i = 0; i < d * d; i++) {
                T[i] = (sm_real)U_(-tsc, tsc);
                T1[i] = (sm_real)U_(-1, 1);
            }
            sm_implicit_particle p;
            sm_real G1[9], G2[9];
            int c1 = sm_implicit_precompute(d, Fn, dt, T, V0, &mat, &p, G1);
            int c2 = sm_implicit_force_matrix(d, Fn, dt, T, V0, &mat, G2);
            CHECK(c1 == c2);
            CHECK(memcmp(G1, G2, sizeof(sm_real) * (size_t)(d * d)) == 0);

            /* apply */
            sm_real A[9], A2[9];
            sm_implicit_apply(d, &p, T1, A);
            memcpy(A2, T1, sizeof A2);
            sm_implicit_apply(d, &p, A2, A2); /* aliasing allowed */
            CHECK(memcmp(A, A2, sizeof(sm_real) * (size_t)(d * d)) == 0);

            /* direct: V0 M[T1 Fn] Fn^T with F computed as the library does */
            sm_real F[9], TF[9], dF[9], dY[9];
            for (int i = 0; i < d; i++)
                for (int j = 0; j < d; j++) {
                    sm_real a = 0, b = 0;
                    for (int k = 0; k < d; k++) {
                        a += T[i * d + k] * Fn[k * d + j];
                        b += T1[i * d + k] * Fn[k * d + j];
                    }
                    TF[i * d + j] = a;
                    dF[i * d + j] = b;
                }
            for (int i = 0; i < d * d; i++) F[i] = Fn[i] + dt * TF[i];
            int c3 = sm_implicit_dY(d, F, dF, &mat, dY);
            CHECK(c3 == c1);
            double Ad[9], Dd[9];
            for (int i = 0; i < d; i++)
                for (int j = 0; j < d; j++) {
                    double a = 0;
                    for (int k = 0; k < d; k++) a += (double)dY[i * d + k] * (double)Fn[j * d + k];
                    Dd[i * d + j] = (double)V0 * a;
                    Ad[i * d + j] = (double)A[i * d + j];
                }
            if (c1 == 2) {
                CHECK(fro(d, Ad) == 0 && fro(d, Dd) == 0);
            } else {
                double e = rel_err(d, Ad, Dd);
                worst_direct = dmax(worst_direct, e);
                CHECK(e <= TOL_SAME);
            }

            /* FD of the force matrix in e, scaled so that |dF| = dt |T1 Fn| h_e ~ FD_H */
            double nT1F = 0;
            for (int i = 0; i < d * d; i++) nT1F += (double)dF[i] * (double)dF[i];
            double he = fd_step(d, F, c1) / ((double)dt * sqrt(nT1F));
            double C[2][9], Te[2][9];
            int ok = 1;
            for (int l = 0; l < 2 && ok; l++) {
                double hl = l == 0 ? he : he / 2;
                sm_real Tp[9], Tm[9], Gp[9], Gm[9];
                for (int i = 0; i < d * d; i++) {
                    Tp[i] = (sm_real)((double)T[i] + hl * (double)T1[i]);
                    Tm[i] = (sm_real)((double)T[i] - hl * (double)T1[i]);
                }
                ok = sm_implicit_force_matrix(d, Fn, dt, Tp, V0, &mat, Gp) == c1 &&
                     sm_implicit_force_matrix(d, Fn, dt, Tm, V0, &mat, Gm) == c1;
                for (int i = 0; i < d * d; i++) {
                    C[l][i] = ((double)Gp[i] - (double)Gm[i]) / (2 * hl) / (double)dt;
                    Te[l][i] = ((double)Tp[i] - (double)Tm[i]) / (2 * hl);
                }
            }
            fd_total++;
            if (!ok) {
                skipped++;
                continue;
            }
            double R[9];
            sm_real T1e[9], Ae[9];
            for (int i = 0; i < d * d; i++) {
                R[i] = (4 * C[1][i] - C[0][i]) / 3;
                T1e[i] = (sm_real)((4 * Te[1][i] - Te[0][i]) / 3);
            }
            sm_implicit_apply(d, &p, T1e, Ae);
            double Aed[9];
            for (int i = 0; i < d * d; i++) Aed[i] = (double)Ae[i];
            double e = c1 == 2 ? fro(d, Aed) + fro(d, R) : rel_err(d, Aed, R);
            if (!(e <= TOL_FD)) fprintf(stderr, "apply d=%d case %d: %.3g\n", d, c1, e);
            CHECK(e <= TOL_FD);
            worst_apply = dmax(worst_apply, e);
        }
    }
}

/* Y agrees with the explicit path (PROJECT, then sm_hencky_piola); y = 0, Mhat = 0 in case 2. */
static void test_consistency(int d) {
    for (int pl = 0; pl < 2; pl++) {
        sm_implicit_material mat = material(pl, g_alpha);
        for (int n = 0; n < 200; n++) {
            double eps[3], s[3];
            gen_eps(d, pl ? 1 + n % 3 : 0, 0.3, g_alpha, NULL, eps);
            for (int i = 0; i < d; i++) s[i] = exp(eps[i]);
            sm_real F[9], Y[9], P[9], U[9], sv[3], V[9], z[3], dq;
            compose(d, s, F);
            int cas = sm_implicit_Y(d, F, &mat, Y);
            if (d == 2) sm_svd2(F, U, sv, V); else sm_svd3(F, U, sv, V);
            int c2 = 0;
            if (pl) c2 = sm_dp_project(d, sv, mat.alpha, mat.mu, mat.lambda, z, &dq);
            else memcpy(z, sv, sizeof z);
            CHECK(cas == c2);
            sm_hencky_piola(d, U, z, V, mat.mu, mat.lambda, P);
            CHECK(memcmp(P, Y, sizeof(sm_real) * (size_t)(d * d)) == 0);
            sm_real y[3];
            sm_implicit_mhat mh;
            sm_implicit_diag(d, sv, &mat, y, &mh);
            if (cas == 2) {
                int zero = 1;
                for (int i = 0; i < d; i++) zero &= y[i] == 0;
                for (int i = 0; i < 9; i++) zero &= mh.ybar[i] == 0;
                for (int k = 0; k < 3; k++) zero &= mh.a[k] == 0 && mh.b[k] == 0;
                CHECK(zero);
            }
            for (int i = 0; i < 9; i++) CHECK(isfinite((double)mh.ybar[i]));
        }
    }
    /* finite everywhere, also far below the floor and exactly at the inversion s_i + s_d = 0 */
    const sm_real bad[5][3] = {{1, 1, -1}, {1, 1e-6f, -1e-6f}, {2, 1e-5f, 1e-5f},
                               {1e-5f, 1e-5f, 1e-5f}, {3, 0.5f, 0}};
    for (int pl = 0; pl < 2; pl++) {
        sm_implicit_material mat = material(pl, g_alpha);
        for (int k = 0; k < 5; k++) {
            sm_real s[3] = {bad[k][0], bad[k][1], bad[k][2]}, y[3];
            if (d == 2) s[1] = s[2];
            sm_implicit_mhat mh;
            sm_implicit_diag(d, s, &mat, y, &mh);
            int fin = 1;
            for (int i = 0; i < 9; i++) fin &= isfinite((double)mh.ybar[i]);
            for (int i = 0; i < 3; i++)
                fin &= isfinite((double)mh.a[i]) && isfinite((double)mh.b[i]);
            CHECK(fin);
        }
    }
}

int main(void) {
    sm_lame(3.537e5, 0.3, &g_mu, &g_lambda); /* thesis sand, Table 4.2 */
    g_alpha = sm_dp_alpha(35 * SM_PI / 180);
    for (int d = 2; d <= 3; d++) {
        test_separated(d);
        test_near_repeated(d);
        test_exact_repeated(d);
        test_inverted(d);
        test_symmetry(d);
        test_apply(d);
        test_consistency(d);
    }
    const char *names[4] = {"elastic", "case I", "case II", "case III"};
    printf("FD step h = %g (Richardson), tolerance %g (%s)\n", (double)FD_H, (double)TOL_FD,
           SM_DOUBLE ? "double" : "float");
    printf("worst relative FD error of M[E]  separated        near-repeated    exactly repeated\n");
    for (int c = 0; c < 4; c++)
        printf("  %-9s                    %.2e (%4d)  %.2e (%4d)  %.2e (%4d)\n", names[c],
               worst[c][FAM_SEP], tested[c][FAM_SEP], worst[c][FAM_NEAR], tested[c][FAM_NEAR],
               worst[c][FAM_EXACT], tested[c][FAM_EXACT]);
    printf("  inverted F: %.2e   apply vs FD of force matrix: %.2e   apply vs direct M: %.2e\n",
           worst_inv, worst_apply, worst_direct);
    printf("  elastic symmetry: %.2e   skipped (probe changed case): %d of %d\n", worst_sym,
           skipped, fd_total);
    CHECK(skipped * 20 <= fd_total);
    for (int c = 0; c < 4; c++) CHECK(tested[c][FAM_SEP] > 0 && tested[c][FAM_NEAR] > 0);
    return sm_test_summary("test_implicit");
}
