/* Derivatives for implicit integration: Y(F) = dpsi/dF(Z(F)), M = dY/dF in diagonal space, and the
 * PRECOMPUTE / HESSIAN_TIMES pair of Algorithms 8 and 6 (Klár 2016, §3.6.2.2, Appendix A.5).
 *
 * Derivation (own; checked against central differences in tests/test_implicit.c)
 * ------------------------------------------------------------------------------
 * Notation: F = U Sigma V^T the signed SVD (U, V rotations, s_d < 0 when det F < 0),
 * Y(F) = U diag(y(s)) V^T with the diagonal map y = g(z(s)), z = PROJECT, g = dpsi/dsigma.
 * f = SM_SIGMA_FLOOR, o = (1, ..., 1).
 *
 * 1. Diagonal space (A.21-A.27). Put dF^ = U^T dF V and dY^ = U^T dY V. With dU = U Wu,
 *    dV = V Wv (Wu, Wv skew):  dF^ = Wu Sigma + dSigma - Sigma Wv,  and likewise
 *    dY^ = Wu diag(y) + diag(dy) - diag(y) Wv. Diagonal: dY^_ii = sum_j (dy_i/ds_j) dF^_jj.
 *    Off the diagonal, with a = (Wu)_ij, b = (Wv)_ij (i != j):
 *      dF^_ij = a s_j - b s_i,  dF^_ji = b s_j - a s_i
 *      dF^_ij + dF^_ji = (a - b)(s_j - s_i),   dF^_ij - dF^_ji = (a + b)(s_i + s_j)
 *    and the same for dY^ with y in place of s; eliminating a -+ b:
 *      dY^_ij + dY^_ji = D_ij (dF^_ij + dF^_ji),  D_ij = (y_i - y_j)/(s_i - s_j)
 *      dY^_ij - dY^_ji = S_ij (dF^_ij - dF^_ji),  S_ij = (y_i + y_j)/(s_i + s_j)
 *    so Mhat_ijij = (D + S)/2 and Mhat_ijji = (D - S)/2 (A.24, A.25). Nothing here needs s > 0,
 *    so it holds for the signed SVD. D is defined by continuity at s_i = s_j (computed below
 *    without a division by s_i - s_j), which also makes M independent of the non-unique U, V at
 *    repeated singular values.
 *
 * 2. The Jacobian ybar = dy/ds = Wbar Zbar (A.28).
 *    g_i(z) = (2 mu h_i + lambda K) / c_i with c = max(z, f), h = ln c, K = sum h  (floor policy):
 *      Wbar_ij = [ chi_j (2 mu delta_ij + lambda) / c_j
 *                  - delta_ij chi_i (2 mu h_i + lambda K) / c_i ] / c_i,
 *      chi_j = [z_j >= f]. This is (A.29) (extracted correctly) with the floor's zero slope.
 *    Zbar: not plastic and case I: z = s, Zbar = I. Case II: z = o, Zbar = 0, and y = g(o) = 0, so
 *    Mhat = 0 altogether. Case III: c = max(s, f), eps = ln c, k = tr eps, sd = eps - k/d o,
 *    n = ||sd||, n^ = sd/n, c0 = alpha (d lambda + 2 mu)/(2 mu), p = c0 k / n (<= 0),
 *    H = k/d o - p sd (p = -(1 - dgamma/n) of (3.75)), z = exp(H). Differentiating
 *    (dk = o.deps, dn = n^.deps, d sd = (I - o o^T/d) deps):
 *      dH = [ (1 + p)/d o o^T - c0 n^ o^T - p (I - n^ n^^T) ] deps,   deps = diag(w) ds,
 *      w_j = [s_j >= f] / c_j,   Zbar = diag(z) [ ... ] diag(w).
 *    (A.31) reads ((1 + 2p)/d o - (p/k) eps) w^T - p (I - n^ n^^T) Sigma^-1; since
 *    (p/k) eps = c0 n^ + (p/d) o the two agree. We use the form without 1/k: k = 0 (a pure
 *    deviator, mapped to z = o) is a regular point of case III.
 *
 * 3. D without cancellation (A.32-A.40). Write y through h' = ln max(z, f) (the logs g uses):
 *      y_i = e^{-h'_i} (2 mu h'_i + lambda K'),  K' = sum h',
 *    and split D_ij = G_ij R_ij at h' rather than at z as (A.32) does:
 *      G_ij = (y_i - y_j)/(h'_i - h'_j) = e^{-h'_j} [ 2 mu (1 + h'_i E) + lambda K' E ],
 *             E = expm1(-Delta)/Delta, Delta = h'_i - h'_j   (limit Delta = 0: E = -1),
 *      R_ij = (h'_i - h'_j)/(s_i - s_j):
 *        not plastic / case I (h' = ln max(s, f)):  R = C_f(s_i, s_j) L(c_i, c_j)
 *        case III (h_i - h_j = -p (eps_i - eps_j); h' = h unless z < f):
 *                                     R = C_lnf(h_i, h_j) (-p) L(c_i, c_j) C_f(s_i, s_j)
 *      with the divided differences of the clamp and of the logarithm
 *        C_f(a, b) = (max(a, f) - max(b, f))/(a - b)  (1 if both >= f, 0 if both < f, limit 1 or 0)
 *        L(x, y)   = (ln x - ln y)/(x - y) = log1p(r / y)/r, r = x - y >= 0 (y the smaller;
 *                    limit 1/y; for x > 1.5 y directly as (ln x - ln y)/r).
 *    E and L are smooth in their arguments, so rounding in Delta or r costs nothing (the
 *    thesis's "|w| < eps: 1" shortcut is unnecessary: log1p(w)/w and expm1(w)/w are accurate
 *    for tiny w; only w = 0 is special-cased). The thesis splits at z instead:
 *    (A.35) (y_i - y_j)/(z_i - z_j) and (A.38) (z_i - z_j)/(s_i - s_j) =
 *    (1 - dgamma/n) [(e^{H_i} - e^{H_j})/(H_i - H_j)] L(s_i, s_j); the exp/log divided
 *    differences through z cancel in our form.
 *    S needs no care while s_i + s_j > 0 (always >= f unless a singular value is below the
 *    floor). Below it (an inverted/degenerate F, where the floor policy already continues psi
 *    artificially) S is evaluated with s_i + s_j raised to f, so Mhat stays finite; M is then
 *    not the exact derivative (Y itself jumps where the signed SVD flips s_i + s_j through 0).
 *
 * 4. Algorithms 8 and 6. F = (I + dt T) F^n, so dF = dt T1 F^n for T -> T + e T1 and
 *      U^T dF V = dt U^T T1 Q,  Q = F^n V,    dY (F^n)^T = dt U [Mhat : (U^T T1 Q)] Q^T.
 *    HESSIAN_TIMES' A = V0 U (Mhat : (U^T T1 Q)) Q^T is therefore (1/dt) dG/de of the force
 *    matrix G = V0 Y(F) (F^n)^T; with f_i = -(dt/m_i) sum_p G_p grad w_ip the residual
 *    v - v^n - f has the derivative z + (dt^2/m_i) sum_p A_p grad w_ip (TIMES_DIFF line 9).
 *
 * Extraction problems in the thesis text (seed file): "\dot Y" in (A.26)/(A.27) stands for Y^;
 * (A.40) shows exp(w)/w where expm1(w)/w is meant; (A.38)'s first factor 1 - dgamma/||eps^||
 * is -p. (A.29)-(A.31) as extracted agree with the derivation above. */
#include "material/implicit.h"

#include "material/material.h"
#include "math/svd.h"

/* Pair k -> (i, j), i < j: 2-D (0,1); 3-D (0,1), (0,2), (1,2). */
static const int pair_i[3] = {0, 0, 1};
static const int pair_j[3] = {1, 2, 2};

static inline int npairs(int d) { return d == 2 ? 1 : 3; }

/* (max(a, lo) - max(b, lo)) / (a - b), the divided difference of the clamp (limit at a = b). */
static sm_real dd_clamp(sm_real a, sm_real b, sm_real lo) {
    int ia = a >= lo, ib = b >= lo;
    if (ia && ib) return 1;
    if (!ia && !ib) return 0;
    return ((ia ? a : lo) - (ib ? b : lo)) / (a - b); /* a != b: one is >= lo, the other not */
}

/* (ln x - ln y)/(x - y) for x, y > 0 (limit 1/y at x = y). */
static sm_real dd_log(sm_real x, sm_real y) {
    if (x < y) {
        sm_real t = x;
        x = y;
        y = t;
    }
    sm_real r = x - y; /* >= 0, exact when x <= 2 y (Sterbenz) */
    if (r == 0) return 1 / y;
    if (r <= SM_R(0.5) * y) return sm_log1p(r / y) / r;
    return (sm_log(x) - sm_log(y)) / r;
}

/* (g_i - g_j)/(hi - hj) for g(h) = e^{-h} (2 mu h + lambda K) (limit at hi = hj). */
static sm_real dd_g(sm_real hi, sm_real hj, sm_real K, sm_real mu, sm_real lambda) {
    sm_real delta = hi - hj;
    sm_real E = delta == 0 ? SM_R(-1.0) : sm_expm1(-delta) / delta;
    return sm_exp(-hj) * (2 * mu * (1 + hi * E) + lambda * K * E);
}

/* Stage 1 of Mhat (the projection's input): c = max(s, f), eps = ln c, w = [s >= f] / c; then
 * Zbar = dz/deps (d x d) and h = ln z (the exact exponent of case III, eps otherwise); *p_out is
 * case III's -scale (0 otherwise). */
static void projection_jacobian(int d, const sm_real *sigma, const sm_real *z, int cas, const sm_implicit_material *mat,
                                sm_real c[3], sm_real h[3], sm_real Zbar[9], sm_real *p_out) {
    const sm_real mu = mat->mu, lambda = mat->lambda, f = SM_SIGMA_FLOOR;
    sm_real eps[3], w[3], p = 0;
    for (int i = 0; i < d; i++) {
        int chi = sigma[i] >= f;
        c[i] = chi ? sigma[i] : f;
        eps[i] = sm_log(c[i]);
        w[i] = chi ? 1 / c[i] : 0;
    }
    if (cas == 3) {
        /* same expressions as sm_dp_project, so h is the exponent it used */
        sm_real tr = 0;
        for (int i = 0; i < d; i++) tr += eps[i];
        sm_real mean = tr / (sm_real)d, dev[3], ss = 0;
        for (int i = 0; i < d; i++) {
            dev[i] = eps[i] - mean;
            ss += dev[i] * dev[i];
        }
        sm_real ndev = sm_sqrt(ss);
        sm_real c0 = ((sm_real)d * lambda + 2 * mu) / (2 * mu) * mat->alpha;
        sm_real kappa = ((sm_real)d * lambda + 2 * mu) / (2 * mu) * tr * mat->alpha;
        sm_real scale = -kappa / ndev;
        p = -scale;
        sm_real nh[3];
        for (int i = 0; i < d; i++) {
            h[i] = mean + scale * dev[i];
            nh[i] = dev[i] / ndev;
        }
        const sm_real ad = (1 + p) / (sm_real)d;
        for (int i = 0; i < d; i++)
            for (int j = 0; j < d; j++) {
                sm_real id = i == j ? SM_R(1.0) : SM_R(0.0);
                sm_real e = ad - c0 * nh[i] - p * (id - nh[i] * nh[j]);
                Zbar[i * d + j] = z[i] * e * w[j];
            }
    } else {
        for (int i = 0; i < d; i++) {
            h[i] = eps[i];
            for (int j = 0; j < d; j++) Zbar[i * d + j] = i == j ? SM_R(1.0) : SM_R(0.0);
        }
    }
    *p_out = p;
}

/* Stage 2 of Mhat (the energy's input z): c2 = max(z, f), h2 = ln c2 (h where not clamped),
 * K2 = sum h2, chi2 = [z >= f]; ybar = Wbar Zbar with Wbar = dy/dz. */
static void energy_jacobian(int d, const sm_real *z, const sm_real *h, const sm_real Zbar[9], sm_real mu,
                            sm_real lambda, sm_real h2[3], int chi2[3], sm_real *K2_out, sm_real ybar[9]) {
    const sm_real f = SM_SIGMA_FLOOR;
    sm_real c2[3], K2 = 0;
    const sm_real lnf = sm_log(f);
    for (int i = 0; i < d; i++) {
        chi2[i] = z[i] >= f;
        c2[i] = chi2[i] ? z[i] : f;
        h2[i] = chi2[i] ? h[i] : lnf;
        K2 += h2[i];
    }
    sm_real Wbar[9];
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            sm_real e = chi2[j] ? ((i == j ? 2 * mu : 0) + lambda) / c2[j] : 0;
            if (i == j && chi2[i]) e -= (2 * mu * h2[i] + lambda * K2) / c2[i];
            Wbar[i * d + j] = e / c2[i];
        }
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            sm_real s = 0;
            for (int k = 0; k < d; k++) s += Wbar[i * d + k] * Zbar[k * d + j];
            ybar[i * d + j] = s;
        }
    *K2_out = K2;
}

int sm_implicit_diag(int d, const sm_real *sigma, const sm_implicit_material *mat, sm_real *y,
                     sm_implicit_mhat *mhat) {
    SM_ASSERT(d == 2 || d == 3);
    SM_ASSERT(mat != NULL && mat->mu > 0);
    const sm_real mu = mat->mu, lambda = mat->lambda, f = SM_SIGMA_FLOOR;
    sm_real z[3], dq;
    int cas;
    if (mat->plastic) {
        cas = sm_dp_project(d, sigma, mat->alpha, mu, lambda, z, &dq);
    } else {
        cas = 0;
        for (int i = 0; i < d; i++) z[i] = sigma[i];
    }
    sm_hencky_dpsi(d, z, mu, lambda, y);
    if (mhat == NULL) return cas;

    for (int i = 0; i < 9; i++) mhat->ybar[i] = 0;
    for (int k = 0; k < 3; k++) mhat->a[k] = mhat->b[k] = 0;
    if (cas == 2) return cas; /* y = 0 on an open set: M = 0 */

    sm_real c[3], h[3], Zbar[9], p, h2[3], K2;
    int chi2[3];
    projection_jacobian(d, sigma, z, cas, mat, c, h, Zbar, &p);
    energy_jacobian(d, z, h, Zbar, mu, lambda, h2, chi2, &K2, mhat->ybar);

    /* Off-diagonal pairs. */
    for (int k = 0; k < npairs(d); k++) {
        const int i = pair_i[k], j = pair_j[k];
        sm_real R = dd_clamp(sigma[i], sigma[j], f);
        if (R != 0) R *= dd_log(c[i], c[j]);
        if (cas == 3) {
            sm_real Ch;
            if (chi2[i] && chi2[j])
                Ch = 1;
            else if (!chi2[i] && !chi2[j])
                Ch = 0;
            else
                Ch = (h2[i] - h2[j]) / (h[i] - h[j]);
            R *= -p * Ch;
        }
        sm_real D = R == 0 ? 0 : dd_g(h2[i], h2[j], K2, mu, lambda) * R;
        sm_real den = sigma[i] + sigma[j];
        if (!(den >= f)) den = f; /* below the floor only; see the header comment */
        sm_real S = (y[i] + y[j]) / den;
        mhat->a[k] = SM_R(0.5) * (D + S);
        mhat->b[k] = SM_R(0.5) * (D - S);
    }
    return cas;
}

/* The loops below are written for any d and inlined where d is a constant (sm_implicit_apply),
 * which unrolls them: the same operations in the same order, so the same bits (no contraction:
 * -ffp-contract=off). */
#define SM_INLINE static inline __attribute__((always_inline))

SM_INLINE void mhat_apply(int d, const sm_implicit_mhat *mhat, const sm_real *T, sm_real *A) {
    for (int i = 0; i < d; i++) {
        sm_real s = 0;
        for (int j = 0; j < d; j++) s += mhat->ybar[i * d + j] * T[j * d + j];
        A[i * d + i] = s;
    }
    for (int k = 0; k < npairs(d); k++) {
        const int i = pair_i[k], j = pair_j[k];
        sm_real tij = T[i * d + j], tji = T[j * d + i];
        A[i * d + j] = mhat->a[k] * tij + mhat->b[k] * tji;
        A[j * d + i] = mhat->a[k] * tji + mhat->b[k] * tij;
    }
}

void sm_implicit_mhat_apply(int d, const sm_implicit_mhat *mhat, const sm_real *T, sm_real *A) {
    SM_ASSERT(d == 2 || d == 3);
    mhat_apply(d, mhat, T, A);
}

/* ---- small dense helpers (d x d row-major) ------------------------------------------------ */

static void svd_d(int d, const sm_real *F, sm_real *U, sm_real *s, sm_real *V) {
    if (d == 2)
        sm_svd2(F, U, s, V);
    else
        sm_svd3(F, U, s, V);
}

/* C = A B, C = A^T B, C = A B^T (C must not alias A or B). */
SM_INLINE void mat_mul(int d, const sm_real *A, const sm_real *B, sm_real *C) {
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            sm_real s = 0;
            for (int k = 0; k < d; k++) s += A[i * d + k] * B[k * d + j];
            C[i * d + j] = s;
        }
}
SM_INLINE void mat_tmul(int d, const sm_real *A, const sm_real *B, sm_real *C) {
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            sm_real s = 0;
            for (int k = 0; k < d; k++) s += A[k * d + i] * B[k * d + j];
            C[i * d + j] = s;
        }
}
SM_INLINE void mat_mult(int d, const sm_real *A, const sm_real *B, sm_real *C) {
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            sm_real s = 0;
            for (int k = 0; k < d; k++) s += A[i * d + k] * B[j * d + k];
            C[i * d + j] = s;
        }
}

/* out = U (Mhat : (U^T X W)) W^T. */
SM_INLINE void apply_full(int d, const sm_real *U, const sm_real *W, const sm_implicit_mhat *mhat,
                       const sm_real *X, sm_real *out) {
    /* zeroed: keeps -Wmaybe-uninitialized quiet when SM_ASSERT is compiled out */
    sm_real t1[9] = {0}, t2[9] = {0}, t3[9] = {0};
    mat_tmul(d, U, X, t1);
    mat_mul(d, t1, W, t2);
    mhat_apply(d, mhat, t2, t3);
    mat_mul(d, U, t3, t1);
    mat_mult(d, t1, W, out);
}

/* F = Fn + dt (T Fn). */
static void deformed(int d, const sm_real *Fn, sm_real dt, const sm_real *T, sm_real *F) {
    sm_real TF[9];
    mat_mul(d, T, Fn, TF);
    for (int i = 0; i < d * d; i++) F[i] = Fn[i] + dt * TF[i];
}

int sm_implicit_Y(int d, const sm_real *F, const sm_implicit_material *mat, sm_real *Y) {
    SM_ASSERT(d == 2 || d == 3);
    sm_real U[9], s[3], V[9], y[3];
    svd_d(d, F, U, s, V);
    int cas = sm_implicit_diag(d, s, mat, y, NULL);
    sm_material_udvt(d, U, y, V, Y);
    return cas;
}

int sm_implicit_dY(int d, const sm_real *F, const sm_real *dF, const sm_implicit_material *mat,
                   sm_real *dY) {
    SM_ASSERT(d == 2 || d == 3);
    sm_real U[9], s[3], V[9], y[3];
    sm_implicit_mhat mh;
    svd_d(d, F, U, s, V);
    int cas = sm_implicit_diag(d, s, mat, y, &mh);
    apply_full(d, U, V, &mh, dF, dY);
    return cas;
}

/* Shared by force_matrix and precompute so that both give the same bits. */
static int force_from_svd(int d, const sm_real *Fn, const sm_real *U, const sm_real *s,
                          const sm_real *V, sm_real V0, const sm_implicit_material *mat,
                          sm_real *G, sm_implicit_mhat *mh) {
    sm_real y[3], Y[9];
    int cas = sm_implicit_diag(d, s, mat, y, mh);
    if (G != NULL) {
        sm_material_udvt(d, U, y, V, Y);
        mat_mult(d, Y, Fn, G);
        for (int i = 0; i < d * d; i++) G[i] *= V0;
    }
    return cas;
}

int sm_implicit_force_matrix(int d, const sm_real *Fn, sm_real dt, const sm_real *T, sm_real V0,
                             const sm_implicit_material *mat, sm_real *G) {
    SM_ASSERT(d == 2 || d == 3);
    sm_real F[9], U[9], s[3], V[9];
    deformed(d, Fn, dt, T, F);
    svd_d(d, F, U, s, V);
    return force_from_svd(d, Fn, U, s, V, V0, mat, G, NULL);
}

int sm_implicit_precompute(int d, const sm_real *Fn, sm_real dt, const sm_real *T, sm_real V0,
                           const sm_implicit_material *mat, sm_implicit_particle *p, sm_real *G) {
    SM_ASSERT(d == 2 || d == 3);
    SM_ASSERT(p != NULL);
    sm_real F[9], s[3], V[9];
    for (int i = 0; i < 9; i++) p->U[i] = p->Q[i] = 0;
    deformed(d, Fn, dt, T, F);
    svd_d(d, F, p->U, s, V);
    int cas = force_from_svd(d, Fn, p->U, s, V, V0, mat, G, &p->M);
    mat_mul(d, Fn, V, p->Q);
    for (int i = 0; i < 9; i++) p->M.ybar[i] *= V0;
    for (int k = 0; k < 3; k++) {
        p->M.a[k] *= V0;
        p->M.b[k] *= V0;
    }
    return cas;
}

SM_INLINE void apply_particle(int d, const sm_implicit_particle *p, const sm_real *T1, sm_real *A) {
    sm_real t[9];
    for (int i = 0; i < d * d; i++) t[i] = T1[i];
    apply_full(d, p->U, p->Q, &p->M, t, A);
}

void sm_implicit_apply(int d, const sm_implicit_particle *p, const sm_real *T1, sm_real *A) {
    SM_ASSERT(d == 2 || d == 3);
    if (d == 2) apply_particle(2, p, T1, A);
    else apply_particle(3, p, T1, A);
}
