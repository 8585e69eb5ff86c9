/* Tests of src/material: Hencky StVK energy and its derivatives, Drucker–Prager PROJECT
 * (Algorithm 2), hardening (3.79)-(3.80), and the floor policy for inverted F. d = 2 and 3,
 * double and float builds (tolerances scale with SM_EPS where rounding dominates). */
#include <float.h>
#include <math.h>
#include <string.h>

#include "material/material.h"
#include "math/svd.h"
#include "test_util.h"

static unsigned long long rng = 0x5EED1234ULL;
static double U_(double lo, double hi) { return sm_test_uniform(&rng, lo, hi); }

/* Unit roundoff of sm_real as a double. */
static const double u = (double)SM_EPS;

/* Material used throughout: the thesis's sand, Table 4.2: E = 3.537e5 Pa, nu = 0.3. */
static double g_mu, g_lambda;

/* Worst errors, reported at the end. */
static double worst_dpsi_ratio, worst_dpsi_rel, worst_piola_ratio, worst_piola_rel;
static double worst_yield_rel, worst_trace, worst_parallel, worst_idem;

static double dmax(double a, double b) { return a > b ? a : b; }
static int is_finite_r(sm_real x) { return isfinite((double)x); }

/* Reference (double) psi from double singular values, no clamping (inputs > 0). */
static double ref_psi(int d, const double *s, double mu, double lambda) {
    double tr = 0, sq = 0;
    for (int i = 0; i < d; i++) {
        double e = log(s[i]);
        tr += e;
        sq += e * e;
    }
    return mu * sq + 0.5 * lambda * tr * tr;
}

/* ---------------------------------------------------------------------------------------- */

static void test_lame(void) {
    double mu, lambda;
    sm_lame(3.537e5, 0.3, &mu, &lambda);
    CHECK_REL(mu, 3.537e5 / 2.6, 1e-15, 0);
    CHECK_REL(lambda, 3.537e5 * 0.3 / (1.3 * 0.4), 1e-15, 0);
    sm_lame(1.0, 0.0, &mu, &lambda);
    CHECK(mu == 0.5 && lambda == 0.0);
    sm_lame(2.0, -0.5, &mu, &lambda); /* auxetic: lambda < 0, bulk still positive */
    CHECK_REL(mu, 2.0, 1e-15, 0);
    CHECK_REL(lambda, 2.0 * -0.5 / (0.5 * 2.0), 1e-15, 0);
}

/* psi(I) = 0, psi >= 0 (also for lambda < 0), tau = 2 mu ln s + lambda tr ln s = s * dpsi,
 * and the yield function equals ||dev tau|| + alpha tr tau. */
static void test_psi_tau(int d) {
    const double nus[3] = {0.3, -0.4, 0.45};
    sm_real one[3] = {1, 1, 1};
    for (int k = 0; k < 3; k++) {
        double mud, lad;
        sm_lame(3.537e5, nus[k], &mud, &lad);
        sm_real mu = (sm_real)mud, la = (sm_real)lad;
        CHECK(sm_hencky_psi(d, one, mu, la) == 0);
        sm_real g[3], t[3];
        sm_hencky_dpsi(d, one, mu, la, g);
        sm_hencky_tau(d, one, mu, la, t);
        for (int i = 0; i < d; i++) CHECK(g[i] == 0 && t[i] == 0);
        for (int n = 0; n < 500; n++) {
            sm_real s[3];
            double sd[3];
            for (int i = 0; i < d; i++) {
                s[i] = (sm_real)exp(U_(-1.5, 1.5));
                sd[i] = (double)s[i];
            }
            double psi = (double)sm_hencky_psi(d, s, mu, la);
            double ref = ref_psi(d, sd, (double)mu, (double)la);
            CHECK(psi >= 0);
            /* abs error: a few roundings of each term */
            double tr = 0, ln[3], sum_abs = 0;
            for (int i = 0; i < d; i++) {
                ln[i] = log(sd[i]);
                tr += ln[i];
                sum_abs += fabs(ln[i]);
            }
            double scale = (double)mu * sum_abs * sum_abs + fabs((double)la) * sum_abs * sum_abs;
            CHECK_NEAR(psi, ref, 16 * u * scale + DBL_MIN);
            sm_hencky_tau(d, s, mu, la, t);
            sm_hencky_dpsi(d, s, mu, la, g);
            double dev[3], trt = 0;
            for (int i = 0; i < d; i++) {
                double tref = 2 * (double)mu * ln[i] + (double)la * tr;
                double tscale = 2 * (double)mu * fabs(ln[i]) + fabs((double)la) * sum_abs;
                CHECK_NEAR(t[i], tref, 8 * u * tscale + DBL_MIN);
                CHECK_NEAR((double)g[i] * sd[i], tref, 8 * u * tscale + DBL_MIN);
                trt += (double)t[i];
            }
            double ndt = 0, nde = 0;
            for (int i = 0; i < d; i++) {
                dev[i] = (double)t[i] - trt / d;
                ndt += dev[i] * dev[i];
                double de = ln[i] - tr / d;
                nde += de * de;
            }
            double alpha = sm_dp_alpha(30 * SM_PI / 180);
            double y = (double)sm_dp_yield(d, s, (sm_real)alpha, mu, la);
            double yref = 2 * (double)mu * sqrt(nde) + alpha * (d * (double)la + 2 * (double)mu) * tr;
            double yt = sqrt(ndt) + alpha * trt;
            double yscale = (2 * (double)mu + d * fabs((double)la)) * sum_abs;
            CHECK_NEAR(y, yref, 16 * u * yscale + DBL_MIN);
            CHECK_NEAR(y, yt, 16 * u * yscale + DBL_MIN);
        }
    }
}

/* x +- h' in sm_real with h' ~ h chosen so that both are exact and x is exactly their midpoint
 * (otherwise the central difference is centred off x by up to an ulp, an O(u f'') error that
 * dominates in float). Returns the full step 2h'. */
static double sym_step(sm_real x, double h, sm_real *xp, sm_real *xn) {
    *xp = (sm_real)((double)x + h);
    double hh = (double)*xp - (double)x; /* exact: a multiple of ulp(x) */
    *xn = (sm_real)((double)x - hh);
    CHECK((double)x - (double)*xn == hh && hh > 0);
    return 2 * hh;
}

/* ENERGY_DERIVATIVE against central differences of psi along each sigma_i.
 * Truncation error of the central difference: h^2/6 max|f'''| on [s-h, s+h], with
 * f(x) = psi(.., x, ..), f'(x) = (a ln x + b)/x, a = 2 mu + lambda, b = lambda R (R = sum of the
 * other logs), hence f'''(x) = (2 a ln x + 2 b - 3 a)/x^3, bounded by
 * (2|a| max|ln x| + 2|b| + 3|a|)/(s-h)^3. Rounding: psi carries ~8u of its term magnitude P,
 * amplified by 1/(2h); dpsi itself carries ~8u of its terms. tol = truncation + rounding. */
static void fd_dpsi_one(int d, const sm_real *s, sm_real mu, sm_real la) {
    sm_real g[3];
    sm_hencky_dpsi(d, s, mu, la, g);
    double a = 2 * (double)mu + (double)la;
    double sum_abs = 0;
    for (int j = 0; j < d; j++) sum_abs += fabs(log((double)s[j]));
    for (int i = 0; i < d; i++) {
        /* step: minimises h^2/6 M3 + 8u 2P/(2h)  ->  h = cbrt(24 u P / M3) */
        double R0 = 0;
        for (int j = 0; j < d; j++)
            if (j != i) R0 += log((double)s[j]);
        double si = (double)s[i];
        double M3s = (2 * fabs(a) * fabs(log(si)) + 2 * fabs((double)la * R0) + 3 * fabs(a)) / (si * si * si);
        double P0 = ((double)mu + fabs((double)la)) * (sum_abs * sum_abs + u);
        double h = cbrt(24 * u * P0 / M3s);
        h = SM_MIN(h, 0.05 * si);
        sm_real sp[3], sn[3];
        memcpy(sp, s, sizeof sp);
        memcpy(sn, s, sizeof sn);
        double step = sym_step(s[i], h, &sp[i], &sn[i]);
        double fp = (double)sm_hencky_psi(d, sp, mu, la), fn = (double)sm_hencky_psi(d, sn, mu, la);
        double fd = (fp - fn) / step;
        double R = 0, sum_abs_p = 0, sum_abs_n = 0;
        for (int j = 0; j < d; j++) {
            if (j != i) R += log((double)s[j]);
            sum_abs_p += fabs(log((double)sp[j]));
            sum_abs_n += fabs(log((double)sn[j]));
        }
        double b = (double)la * R;
        double lo = (double)sn[i], hi = (double)sp[i];
        double maxln = dmax(fabs(log(lo)), fabs(log(hi)));
        double m3 = (2 * fabs(a) * maxln + 2 * fabs(b) + 3 * fabs(a)) / (lo * lo * lo);
        double trunc = 1.5 * (step / 2) * (step / 2) / 6 * m3;
        double Pp = ((double)mu + fabs((double)la)) * sum_abs_p * sum_abs_p;
        double Pn = ((double)mu + fabs((double)la)) * sum_abs_n * sum_abs_n;
        double round = 8 * u * (Pp + Pn) / step;
        double lsi = fabs(log((double)s[i]));
        double gscale = (2 * (double)mu * lsi + fabs((double)la) * (sum_abs_p + sum_abs_n)) / (double)s[i];
        double tol = trunc + round + 8 * u * gscale + DBL_MIN;
        double err = fabs(fd - (double)g[i]);
        CHECK_NEAR(fd, g[i], tol);
        worst_dpsi_ratio = dmax(worst_dpsi_ratio, err / tol);
        /* reported relative to the modulus 2 mu + d|lambda| (g itself may be a cancellation) */
        worst_dpsi_rel = dmax(worst_dpsi_rel, err / (2 * (double)mu + d * fabs((double)la)));
    }
}

static void test_dpsi_fd(int d) {
    sm_real mu = (sm_real)g_mu, la = (sm_real)g_lambda;
    for (int n = 0; n < 2000; n++) {
        sm_real s[3];
        for (int i = 0; i < d; i++) s[i] = (sm_real)U_(0.5, 2.0);
        fd_dpsi_one(d, s, mu, la);
    }
    for (int n = 0; n < 1000; n++) { /* near the rest state */
        sm_real s[3];
        for (int i = 0; i < d; i++) s[i] = (sm_real)(1 + U_(-1e-3, 1e-3));
        fd_dpsi_one(d, s, mu, la);
    }
    /* and with lambda < 0 / nearly incompressible */
    const double nus[2] = {-0.4, 0.45};
    for (int k = 0; k < 2; k++) {
        double mud, lad;
        sm_lame(3.537e5, nus[k], &mud, &lad);
        for (int n = 0; n < 500; n++) {
            sm_real s[3];
            for (int i = 0; i < d; i++) s[i] = (sm_real)U_(0.5, 2.0);
            fd_dpsi_one(d, s, (sm_real)mud, (sm_real)lad);
        }
    }
}

/* The Kirchhoff stress P F^T (what the force computation uses) equals U diag(tau) U^T. */
static void check_kirchhoff(int d, const sm_real *F, const sm_real *Uu, const sm_real *s, const sm_real *P,
                            sm_real mu, sm_real la) {
    sm_real t[3];
    sm_hencky_tau(d, s, mu, la, t);
    double pmax = 0;
    for (int i = 0; i < d * d; i++) pmax = dmax(pmax, fabs((double)P[i]));
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            double pft = 0, utu = 0;
            for (int k = 0; k < d; k++) {
                pft += (double)P[i * d + k] * (double)F[j * d + k];
                utu += (double)Uu[i * d + k] * (double)t[k] * (double)Uu[j * d + k];
            }
            CHECK_NEAR(pft, utu, 64 * u * pmax * (1 + fabs((double)s[0])) * d);
        }
}

/* psi(F) = psi(sigma(F)); P(F) = U diag(dpsi) V^T must be its gradient w.r.t. every entry of F.
 * Central differences with step h; tolerance = truncation h^2/6 * M3 + rounding.
 * M3 bounds the third derivative of psi along an entry of F: every third derivative of
 * psi(F) is a sum of terms (2 mu + d|lambda|) * O(1) / sigma_min^3 (the principal bound above plus
 * the rotational terms of the SVD, which have the same scaling); we take 6 (2 mu + d|lambda|)
 * (1 + max|ln s|) / (smin - 2h)^3 (measured: the true error stays below ~1/4 of this).
 * Rounding: the SVD gives singular values to ~c u ||F|| (c = 8 taken), psi moves by |dpsi| times
 * that at each of the two points, amplified by 1/(2h). */
static void test_piola_fd(int d) {
    sm_real mu = (sm_real)g_mu, la = (sm_real)g_lambda;
    /* h a power of two near cbrt(u) and F on a 2^-20 grid: F +- h exact, centred on F */
    double h = ldexp(1.0, (int)lround(log2(cbrt(u))));
    double K = 2 * (double)mu + d * fabs((double)la);
    for (int n = 0; n < 400; n++) {
        sm_real F[9], Uu[9], V[9], s[3], P[9];
        for (int i = 0; i < d; i++)
            for (int j = 0; j < d; j++)
                F[i * d + j] =
                    (sm_real)(ldexp(round(ldexp(U_(-0.25, 0.25), 20)), -20) + (i == j ? 1.0 : 0.0));
        if (d == 2)
            sm_svd2(F, Uu, s, V);
        else
            sm_svd3(F, Uu, s, V);
        if (!((double)s[d - 1] > 0.3)) continue; /* near identity: keep well away from the floor */
        sm_hencky_piola(d, Uu, s, V, mu, la, P);
        double smin = (double)s[d - 1], maxln = 0, gmax = 0, psi0 = (double)sm_hencky_psi(d, s, mu, la);
        sm_real g[3];
        sm_hencky_dpsi(d, s, mu, la, g);
        for (int i = 0; i < d; i++) {
            maxln = dmax(maxln, fabs(log((double)s[i])));
            gmax = dmax(gmax, fabs((double)g[i]));
        }
        double fnorm = 0;
        for (int i = 0; i < d * d; i++) fnorm += (double)F[i] * (double)F[i];
        fnorm = sqrt(fnorm);
        for (int e = 0; e < d * d; e++) {
            sm_real Fp[9], Fn[9], sp[3], sn[3], tU[9], tV[9];
            memcpy(Fp, F, sizeof Fp);
            memcpy(Fn, F, sizeof Fn);
            double step = sym_step(F[e], h, &Fp[e], &Fn[e]);
            if (d == 2) {
                sm_svd2(Fp, tU, sp, tV);
                sm_svd2(Fn, tU, sn, tV);
            } else {
                sm_svd3(Fp, tU, sp, tV);
                sm_svd3(Fn, tU, sn, tV);
            }
            double fd = ((double)sm_hencky_psi(d, sp, mu, la) - (double)sm_hencky_psi(d, sn, mu, la)) / step;
            double sl = smin - step;
            double m3 = 6 * K * (1 + maxln) / (sl * sl * sl);
            double trunc = (step / 2) * (step / 2) / 6 * m3;
            double round = (2 * 8 * u * fnorm * gmax * d + 16 * u * (psi0 + K * step * step)) / step;
            double tol = trunc + round + 32 * u * gmax * d;
            double err = fabs(fd - (double)P[e]);
            CHECK_NEAR(fd, P[e], tol);
            worst_piola_ratio = dmax(worst_piola_ratio, err / tol);
            worst_piola_rel = dmax(worst_piola_rel, err / K);
        }
        check_kirchhoff(d, F, Uu, s, P, mu, la);
        /* P = U diag(dpsi) V^T also via sm_material_udvt, and aliasing is allowed */
        sm_real Q[9];
        memcpy(Q, Uu, sizeof Q);
        sm_material_udvt(d, Q, g, V, Q);
        for (int i = 0; i < d * d; i++) CHECK(Q[i] == P[i]);
        /* at F = R (a pure rotation) the stress vanishes */
        sm_real one[3] = {1, 1, 1};
        sm_hencky_piola(d, Uu, one, V, mu, la, P);
        for (int i = 0; i < d * d; i++) CHECK(P[i] == 0);
    }
}

/* ---------------------------------------------------------------------------------------- */
/* PROJECT */

/* A random trace-free unit vector in R^d. */
static void rand_dev_dir(int d, double *n) {
    double m = 0, nn = 0;
    for (int i = 0; i < d; i++) {
        n[i] = U_(-1, 1);
        m += n[i];
    }
    for (int i = 0; i < d; i++) {
        n[i] -= m / d;
        nn += n[i] * n[i];
    }
    nn = sqrt(nn);
    if (nn < 1e-3) { /* regenerate a fixed direction */
        for (int i = 0; i < d; i++) n[i] = 0;
        n[0] = 1;
        n[1] = -1;
        nn = sqrt(2.0);
    }
    for (int i = 0; i < d; i++) n[i] /= nn;
}

/* Sigma = exp(m I + r n) rounded to sm_real. */
static void make_sigma(int d, double m, double r, const double *n, sm_real *s) {
    for (int i = 0; i < d; i++) s[i] = (sm_real)exp(m + r * n[i]);
}

/* Hencky strain (double) of sm_real singular values: ln, trace, deviator, ||dev||, ||eps||. */
typedef struct {
    double e[3], dev[3], tr, ndev, neps, sum_abs;
} strain_t;
static strain_t strain_of(int d, const sm_real *s) {
    strain_t t;
    memset(&t, 0, sizeof t);
    for (int i = 0; i < d; i++) {
        t.e[i] = log((double)s[i]);
        t.tr += t.e[i];
        t.neps += t.e[i] * t.e[i];
        t.sum_abs += fabs(t.e[i]);
    }
    for (int i = 0; i < d; i++) {
        t.dev[i] = t.e[i] - t.tr / d;
        t.ndev += t.dev[i] * t.dev[i];
    }
    t.ndev = sqrt(t.ndev);
    t.neps = sqrt(t.neps);
    return t;
}

static void test_project(int d) {
    sm_real mu = (sm_real)g_mu, la = (sm_real)g_lambda;
    double K = (d * (double)la + 2 * (double)mu) / (2 * (double)mu);
    const double phis[3] = {20, 30, 35};
    for (int k = 0; k < 3; k++) {
        sm_real alpha = (sm_real)sm_dp_alpha(phis[k] * SM_PI / 180);
        double al = (double)alpha;
        for (int n = 0; n < 1000; n++) {
            double dir[3];
            rand_dev_dir(d, dir);
            sm_real s[3], out[3], dq = -1;
            int c;

            /* case I: compressed, deviator within 90% of the cone radius */
            double m = U_(-0.3, -0.01);
            double rmax = -K * d * m * al;
            make_sigma(d, m, U_(0.01, 0.9) * rmax, dir, s);
            {
                c = sm_dp_project(d, s, alpha, mu, la, out, &dq);
                CHECK(c == 1);
                CHECK(dq == 0);
                for (int i = 0; i < d; i++) CHECK(out[i] == s[i]);
                CHECK(sm_dp_yield(d, s, alpha, mu, la) <= 0);
                /* in place */
                sm_real s2[3];
                memcpy(s2, s, sizeof s2);
                c = sm_dp_project(d, s2, alpha, mu, la, s2, &dq);
                CHECK(c == 1);
                for (int i = 0; i < d; i++) CHECK(s2[i] == s[i]);
            }

            /* case II, tension: tr eps > 0, any deviator */
            make_sigma(d, U_(1e-3, 0.3), U_(0.0, 1.0), dir, s);
            strain_t t = strain_of(d, s);
            CHECK(t.tr > 0);
            c = sm_dp_project(d, s, alpha, mu, la, out, &dq);
            CHECK(c == 2);
            for (int i = 0; i < d; i++) CHECK(out[i] == 1);
            CHECK_NEAR(dq, t.neps, 8 * u * t.neps);

            /* pure hydrostatic compression (zero deviator): on the cone's axis, inside: case I,
             * unchanged (not the tip: issue 12) */
            sm_real h = (sm_real)U_(0.3, 0.999);
            for (int i = 0; i < d; i++) s[i] = h;
            c = sm_dp_project(d, s, alpha, mu, la, out, &dq);
            CHECK(c == 1 && dq == 0);
            for (int i = 0; i < d; i++) CHECK(out[i] == h);

            /* case III: compressed, deviator outside the cone */
            m = U_(-0.3, -1e-3);
            rmax = -K * d * m * al;
            make_sigma(d, m, 1.05 * rmax + U_(1e-3, 1.0), dir, s);
            t = strain_of(d, s);
            CHECK(sm_dp_yield(d, s, alpha, mu, la) > 0);
            c = sm_dp_project(d, s, alpha, mu, la, out, &dq);
            CHECK(c == 3);
            double dgamma = t.ndev + K * t.tr * al; /* (3.76) from the trial state */
            CHECK(dq >= 0);
            CHECK_NEAR(dq, dgamma, 64 * u * (dgamma + t.sum_abs * (1 + K * al)));
            strain_t o = strain_of(d, out);
            double yabs = fabs((double)sm_dp_yield(d, out, alpha, mu, la));
            double yrel = yabs / (2 * (double)mu * t.ndev);
            /* Rounding: the result's logs carry ~u (1 + |eps|) each, which moves y by
             * ~u (2 mu + d alpha (d lambda + 2 mu)) (1 + sum|eps|); relative to 2 mu ||dev eps||
             * with a factor 16. Double must also meet the 1e-10 of the contract. */
            double ytol = 16 * u * (1 + d * al * K) * (1 + t.sum_abs) / t.ndev;
            if (SM_DOUBLE) ytol = SM_MIN(ytol, 1e-10);
            CHECK(yrel <= ytol);
            worst_yield_rel = dmax(worst_yield_rel, yrel);
            /* trace preserved */
            double trerr = fabs(o.tr - t.tr);
            CHECK(trerr <= 16 * u * (1 + t.sum_abs));
            worst_trace = dmax(worst_trace, trerr);
            /* deviator parallel to the trial deviator, same direction, shortened by dgamma */
            double dot = 0, perp = 0;
            for (int i = 0; i < d; i++) dot += o.dev[i] * t.dev[i] / t.ndev;
            for (int i = 0; i < d; i++) {
                double p = o.dev[i] - dot * t.dev[i] / t.ndev;
                perp += p * p;
            }
            perp = sqrt(perp);
            CHECK(dot > 0);
            CHECK(perp <= 16 * u * (1 + t.sum_abs));
            worst_parallel = dmax(worst_parallel, perp);
            CHECK_NEAR(o.ndev, t.ndev - dgamma, 32 * u * (1 + t.sum_abs));
            /* idempotent: projecting the result is case I, or case III landing in place */
            sm_real out2[3], dq2 = -1;
            c = sm_dp_project(d, out, alpha, mu, la, out2, &dq2);
            CHECK(c == 1 || c == 3);
            double moved = 0;
            for (int i = 0; i < d; i++) moved = dmax(moved, fabs(log((double)out2[i]) - o.e[i]));
            CHECK(moved <= 16 * u * (1 + t.sum_abs));
            CHECK((double)dq2 <= ytol * t.ndev);
            worst_idem = dmax(worst_idem, dmax(moved, (double)dq2));
        }
    }

    /* alpha = 0 (phi_F = 0, fluid-like): case III lands on the hydrostatic axis, trace kept */
    {
        double dir[3];
        rand_dev_dir(d, dir);
        sm_real s[3], out[3], dq;
        make_sigma(d, -0.1, 0.3, dir, s);
        strain_t t = strain_of(d, s);
        int c = sm_dp_project(d, s, 0, mu, la, out, &dq);
        CHECK(c == 3);
        strain_t o = strain_of(d, out);
        CHECK(o.ndev <= 8 * u);
        CHECK_NEAR(o.tr, t.tr, 16 * u * (1 + t.sum_abs));
        CHECK_REL(dq, t.ndev, 16 * u, 0);
    }

    /* the rest state: inside (on the apex, tr = 0), unchanged, nothing to harden */
    {
        sm_real one[3] = {1, 1, 1}, out[3], dq = -1;
        int c = sm_dp_project(d, one, (sm_real)sm_dp_alpha(0.5), mu, la, out, &dq);
        CHECK(c == 1 && dq == 0);
        for (int i = 0; i < d; i++) CHECK(out[i] == 1);
    }

    /* No jump on the hydrostatic axis (issue 12: Sigma = 0.99 I went to the tip, dq = 0.0174,
     * while 0.99 I plus a 1e-9 deviator stayed). Under compression the exactly hydrostatic state,
     * one perturbed by 64 ulps and one by a 1e-4 deviator all stay where they are (case I, dq = 0),
     * for alpha > 0 (for alpha = 0 the exactly hydrostatic one); in tension (1.001 I) the tip takes over with dq = ||eps||, which
     * goes to 0 as the state approaches the apex (no jump there either). */
    {
        const double alphas[3] = {0, sm_dp_alpha(0.2), sm_dp_alpha(0.6)};
        const double perturb[3] = {0, 64 * u, 1e-4};
        for (int ia = 0; ia < 3; ia++)
            for (int ip = 0; ip < 3; ip++) {
                if (ia == 0 && ip > 0) continue; /* alpha = 0: the cone is the axis, any deviator is case III */
                sm_real s[3], out[3], dq = -1;
                for (int i = 0; i < d; i++) s[i] = (sm_real)0.99;
                s[d - 1] = (sm_real)(0.99 * (1 + perturb[ip]));
                int c = sm_dp_project(d, s, (sm_real)alphas[ia], mu, la, out, &dq);
                CHECK(c == 1 && dq == 0);
                for (int i = 0; i < d; i++) CHECK(out[i] == s[i]);
            }
        const double stretch[2] = {1e-3, 1e-6};
        for (int k = 0; k < 2; k++) {
            sm_real s[3], out[3], dq = -1;
            for (int i = 0; i < d; i++) s[i] = (sm_real)(1 + stretch[k]);
            int c = sm_dp_project(d, s, (sm_real)sm_dp_alpha(0.5), mu, la, out, &dq);
            CHECK(c == 2);
            for (int i = 0; i < d; i++) CHECK(out[i] == 1);
            double dq_ref = sqrt((double)d) * log((double)s[0]);
            CHECK_NEAR(dq, dq_ref, 8 * u * dq_ref + 1e-30);
            CHECK(dq <= 2 * sqrt((double)d) * stretch[k]);
        }
    }
}

/* ---------------------------------------------------------------------------------------- */
/* Inverted / degenerate F: the floor policy (material.h) */

static void test_inverted(int d) {
    sm_real mu = (sm_real)g_mu, la = (sm_real)g_lambda;
    sm_real alpha = (sm_real)sm_dp_alpha(35 * SM_PI / 180);
    const double cases[8][3] = {{1.1, 0.9, -0.2}, {1.0, 1.0, 0.0}, {0.5, 0.5, -1e-30}, {1.2, -0.7, -3.0},
                                {0.0, 0.0, 0.0},  {1e-6, 1e-6, 1e-6}, {1e20, 1.0, -1e20}, {2.0, 2.0, -0.5}};
    for (int k = 0; k < 8; k++) {
        sm_real s[3], c[3], g[3], gc[3], t[3], out[3], dq = -1;
        for (int i = 0; i < d; i++) {
            s[i] = (sm_real)cases[k][i + (d == 2 ? 1 : 0)];
            c[i] = s[i] < SM_SIGMA_FLOOR ? SM_SIGMA_FLOOR : s[i];
        }
        sm_real psi = sm_hencky_psi(d, s, mu, la);
        CHECK(is_finite_r(psi) && psi >= 0);
        CHECK(psi == sm_hencky_psi(d, c, mu, la));
        sm_hencky_dpsi(d, s, mu, la, g);
        sm_hencky_dpsi(d, c, mu, la, gc);
        sm_hencky_tau(d, s, mu, la, t);
        for (int i = 0; i < d; i++) {
            CHECK(is_finite_r(g[i]) && is_finite_r(t[i]));
            CHECK(g[i] == gc[i]); /* stress held at its value at the floor */
            /* tau = s dpsi/ds with the signed s (P F^T) */
            CHECK_NEAR(t[i], (double)g[i] * (double)s[i], 8 * u * fabs((double)g[i] * (double)s[i]));
        }
        CHECK(is_finite_r(sm_dp_yield(d, s, alpha, mu, la)));
        int cs = sm_dp_project(d, s, alpha, mu, la, out, &dq);
        CHECK(cs >= 1 && cs <= 3);
        CHECK(is_finite_r(dq) && dq >= 0);
        for (int i = 0; i < d; i++) {
            if (cs == 1)
                CHECK(out[i] == s[i]); /* case I keeps the input, even inverted */
            else
                CHECK(is_finite_r(out[i]) && out[i] > 0);
        }
    }
    /* restoring: an inverted direction (others at rest) has compressive dpsi < 0, which pushes
     * sigma_d up (the energy decreases as sigma_d grows) */
    {
        sm_real s[3] = {1, 1, 1}, g[3];
        s[d - 1] = (sm_real)-0.3;
        sm_hencky_dpsi(d, s, mu, la, g);
        CHECK(g[d - 1] < 0);
        /* continuity at the floor */
        sm_real s2[3] = {1, 1, 1}, g2[3];
        s2[d - 1] = (sm_real)((double)SM_SIGMA_FLOOR * (1 + 1e-6));
        sm_hencky_dpsi(d, s2, mu, la, g2);
        CHECK_REL(g2[d - 1], g[d - 1], 1e-5, 0);
    }
    /* an inverted F through the signed SVD gives a finite P */
    for (int n = 0; n < 50; n++) {
        sm_real F[9], Uu[9], V[9], s[3], P[9];
        for (int i = 0; i < d; i++)
            for (int j = 0; j < d; j++) F[i * d + j] = (sm_real)((i == j ? 1.0 : 0.0) + U_(-0.25, 0.25));
        for (int j = 0; j < d; j++) F[j] = -F[j]; /* reflect row 0: det F < 0 */
        if (d == 2)
            sm_svd2(F, Uu, s, V);
        else
            sm_svd3(F, Uu, s, V);
        CHECK(s[d - 1] < 0);
        sm_hencky_piola(d, Uu, s, V, mu, la, P);
        for (int i = 0; i < d * d; i++) CHECK(is_finite_r(P[i]));
        check_kirchhoff(d, F, Uu, s, P, mu, la);
        sm_real out[3], dq;
        int cs = sm_dp_project(d, s, (sm_real)sm_dp_alpha(0.6), mu, la, out, &dq);
        for (int i = 0; i < d; i++) CHECK(is_finite_r(out[i]) && (cs == 1 ? out[i] == s[i] : out[i] > 0));
    }
    /* NaN is not hidden by the clamp */
    {
        sm_real s[3] = {1, 1, 1}, out[3], dq = 0;
        s[0] = (sm_real)NAN;
        CHECK(isnan((double)sm_hencky_psi(d, s, mu, la)));
        sm_dp_project(d, s, alpha, mu, la, out, &dq);
        CHECK(isnan((double)out[0]) || isnan((double)dq));
    }
}

/* ---------------------------------------------------------------------------------------- */

static void test_hardening_alpha(void) {
    const double deg = SM_PI / 180;
    double h0 = 35 * deg, h1 = 9 * deg, h2 = 0.2, h3 = 10 * deg;
    CHECK_NEAR(sm_hardening_phi(0, h0, h1, h2, h3) / deg, 25.0, 1e-12);
    double qs = 11.0 / 1.8; /* d phi/dq = 0 at q = 1/h2 + h3/h1 */
    double pmax = sm_hardening_phi(qs, h0, h1, h2, h3) / deg;
    CHECK_NEAR(pmax, 48.255867273954832, 1e-12); /* 35 + 45 e^{-11/9} */
    CHECK_NEAR(pmax, 48.26, 5e-3);
    for (int i = 1; i <= 50; i++) { /* it is the maximum */
        CHECK(sm_hardening_phi(qs + 0.1 * i, h0, h1, h2, h3) / deg < pmax);
        CHECK(sm_hardening_phi(qs - 0.1 * i, h0, h1, h2, h3) / deg < pmax);
    }
    double dq = 1e-5;
    double slope =
        (sm_hardening_phi(qs + dq, h0, h1, h2, h3) - sm_hardening_phi(qs - dq, h0, h1, h2, h3)) / (2 * dq);
    CHECK_NEAR(slope, 0, 1e-9);
    CHECK_NEAR(sm_hardening_phi(1, h0, h1, h2, h3) / deg, 35 + (9 - 10) * exp(-0.2), 1e-12);
    CHECK_NEAR(sm_hardening_phi(200, h0, h1, h2, h3) / deg, 35, 1e-12);
    CHECK_NEAR(sm_hardening_phi(1e6, h0, h1, h2, h3) / deg, 35, 1e-12);
    /* alpha(phi) = sqrt(2/3) 2 sin phi / (3 - sin phi); references to 30 digits (mpmath) */
    CHECK_NEAR(sm_dp_alpha(20 * deg), 0.210128212170296693, 1e-15);
    CHECK_NEAR(sm_dp_alpha(30 * deg), 0.326598632371090413, 1e-15);
    CHECK_NEAR(sm_dp_alpha(35 * deg), 0.386019330011002068, 1e-15);
    CHECK_NEAR(sm_dp_alpha(30 * deg), sqrt(2.0 / 3.0) * 2.0 / 5.0, 1e-15); /* sin 30 = 1/2 */
    CHECK(sm_dp_alpha(0) == 0);
}

int main(void) {
    double mu, lambda;
    sm_lame(3.537e5, 0.3, &mu, &lambda);
    g_mu = (double)(sm_real)mu;
    g_lambda = (double)(sm_real)lambda;

    test_lame();
    test_hardening_alpha();
    for (int d = 2; d <= 3; d++) {
        test_psi_tau(d);
        test_dpsi_fd(d);
        test_piola_fd(d);
        test_project(d);
        test_inverted(d);
    }
    printf("test_material (%s): worst dpsi FD err/tol %.3g (err/(2mu+d|lambda|) %.3g),\n"
           "  P(F) FD err/tol %.3g (%.3g), case III |y|/(2mu||dev eps_trial||) %.3g,\n"
           "  trace err %.3g, perp dev %.3g, idempotence %.3g\n",
           SM_DOUBLE ? "double" : "float", worst_dpsi_ratio, worst_dpsi_rel, worst_piola_ratio,
           worst_piola_rel, worst_yield_rel, worst_trace, worst_parallel, worst_idem);
    return sm_test_summary("test_material");
}
