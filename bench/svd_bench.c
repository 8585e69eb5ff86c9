/* Micro-benchmark of the per-particle plasticity stage (precision of the build's sm_real).
 *
 *   svd_bench [--n N] [--reps R]
 *
 * 1. sm_svd3 / sm_svd2 on N matrices kept in L1/L2, called in a loop (throughput of independent
 *    calls, as in the particle loop): random entries in [-1, 1], and near-rotations
 *    F = R (I + 1e-3 noise), the typical elastic F of MPM. For sm_svd3 also the latency: each
 *    call's input then depends on the previous call's output.
 * 2. Plasticity, ns per particle: the scalar path (svd + sm_dp_project + hardening + sm_hencky_tau
 *    + the two matrix products, as the library computed it before the lanes) against
 *    sm_plastic_lanes3/2 (SM_PLASTIC_LANES particles per call, structure of arrays), packed and
 *    unpacked as the library's plasticity stage does (the helpers of material/plastic_batch.h).
 * Each figure is the best of 5 timed repetitions. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "material/material.h"
#include "material/plastic_batch.h"
#include "math/svd.h"

static double now(void) {
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static unsigned long long rng = 0x9e3779b97f4a7c15ULL;
static double urand(double lo, double hi) {
    unsigned long long z = (rng += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return lo + (hi - lo) * (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static void rand_rot3(double R[9]) {
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

/* F = R (I + noise) in d dimensions (d = 2: rotation by a random angle). */
static void near_rotation(int d, double noise, sm_real *F) {
    double R[9], E[9];
    if (d == 3) {
        rand_rot3(R);
    } else {
        double a = urand(-3.14159, 3.14159);
        R[0] = cos(a), R[1] = -sin(a), R[2] = sin(a), R[3] = cos(a);
    }
    for (int i = 0; i < d * d; i++) E[i] = (i % (d + 1) == 0 ? 1 : 0) + urand(-noise, noise);
    for (int i = 0; i < d; i++)
        for (int j = 0; j < d; j++) {
            double s = 0;
            for (int k = 0; k < d; k++) s += R[i * d + k] * E[k * d + j];
            F[i * d + j] = (sm_real)s;
        }
}

static volatile double sink;

/* ns per sm_svd call over the N matrices in F (d x d each). */
static double time_svd(int d, const sm_real *F, size_t n, int reps) {
    double best = 1e30;
    for (int r = 0; r < 5; r++) {
        double acc = 0;
        double t0 = now();
        for (int k = 0; k < reps; k++)
            for (size_t i = 0; i < n; i++) {
                sm_real U[9], V[9], s[3];
                if (d == 3)
                    sm_svd3(F + 9 * i, U, s, V);
                else
                    sm_svd2(F + 4 * i, U, s, V);
                acc += (double)(s[0] + U[0] + V[d * d - 1]);
            }
        double t = (now() - t0) / ((double)n * reps) * 1e9;
        sink = acc;
        if (t < best) best = t;
    }
    return best;
}

/* ns per sm_svd3 call when each call waits for the previous one (its input gets 0 * an output
 * added): the latency of one call, against the throughput figure of time_svd, where independent
 * calls overlap in the out-of-order core. */
static double time_svd3_latency(const sm_real *F, size_t n, int reps) {
    double best = 1e30;
    for (int r = 0; r < 5; r++) {
        sm_real dep = 0;
        double t0 = now();
        for (int k = 0; k < reps; k++)
            for (size_t i = 0; i < n; i++) {
                sm_real G[9], U[9], V[9], s[3];
                for (int j = 0; j < 9; j++) G[j] = F[9 * i + j] + dep;
                sm_svd3(G, U, s, V);
                dep = (s[2] + U[0] + V[8]) * (sm_real)0;
            }
        double t = (now() - t0) / ((double)n * reps) * 1e9;
        sink = (double)dep;
        if (t < best) best = t;
    }
    return best;
}

/* Material of the plasticity benchmark: the lanes' parameter struct (plastic_batch.h). */
typedef sm_plastic_params mat_t;

/* The scalar plasticity path. */
static void plastic_scalar(int D, const mat_t *m, sm_real *F, sm_real *alpha, sm_real *q, sm_real *T) {
    sm_real U[9], V[9], s[3], tau[3];
    if (D == 3)
        sm_svd3(F, U, s, V);
    else
        sm_svd2(F, U, s, V);
    if (m->plastic) {
        sm_real dq = 0;
        int kase = sm_dp_project(D, s, *alpha, m->mu, m->lambda, s, &dq);
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
                *alpha = (sm_real)sm_dp_alpha(phi);
            }
        }
    }
    sm_hencky_tau(D, s, m->mu, m->lambda, tau);
    for (int a = 0; a < D; a++)
        for (int e = 0; e < D; e++) {
            sm_real acc = 0;
            for (int k = 0; k < D; k++) acc += U[a * D + k] * tau[k] * U[e * D + k];
            T[a * D + e] = acc;
        }
}

/* Deformation gradients of a flowing sand pile: mostly near-rotations with 1e-3 strain, some
 * compressed and some stretched (so all three return-mapping cases occur). */
static void make_plastic_inputs(int D, size_t n, sm_real *F, sm_real *alpha, sm_real *q) {
    for (size_t i = 0; i < n; i++) {
        double u = urand(0, 1);
        near_rotation(D, u < 0.6 ? 1e-3 : 2e-2, F + i * D * D);
        if (u > 0.9)
            for (int k = 0; k < D * D; k++) F[i * D * D + k] *= (sm_real)1.01; /* tension */
        alpha[i] = (sm_real)0.2;
        q[i] = (sm_real)urand(0, 0.1);
    }
}

static double time_plastic_scalar(int D, const mat_t *m, const sm_real *F0, const sm_real *a0,
                                  const sm_real *q0, size_t n, int reps, sm_real *F, sm_real *alpha,
                                  sm_real *q, sm_real *T) {
    double best = 1e30;
    for (int r = 0; r < 5; r++) {
        double tt = 0;
        for (int k = 0; k < reps; k++) {
            memcpy(F, F0, n * D * D * sizeof *F);
            memcpy(alpha, a0, n * sizeof *alpha);
            memcpy(q, q0, n * sizeof *q);
            double t0 = now();
            for (size_t i = 0; i < n; i++) plastic_scalar(D, m, F + i * D * D, alpha + i, q + i, T + i * D * D);
            tt += now() - t0;
        }
        double t = tt / ((double)n * reps) * 1e9;
        if (t < best) best = t;
    }
    return best;
}

/* The batch path with gather/scatter from/to the array-of-structs particle arrays, as a caller
 * would do it. n must be a multiple of SM_PLASTIC_LANES here. */
static double time_plastic_batch(int D, const mat_t *m, const sm_real *F0, const sm_real *a0,
                                 const sm_real *q0, size_t n, int reps, sm_real *F, sm_real *alpha,
                                 sm_real *q, sm_real *T) {
    enum { L = SM_PLASTIC_LANES };
    static sm_plastic_lanes b;
    double best = 1e30;
    const int DD = D * D;
    sm_real z = 0; /* the lanes' finiteness sums: keeps the stores */
    for (int r = 0; r < 5; r++) {
        double tt = 0;
        for (int k = 0; k < reps; k++) {
            memcpy(F, F0, n * DD * sizeof *F);
            memcpy(alpha, a0, n * sizeof *alpha);
            memcpy(q, q0, n * sizeof *q);
            double t0 = now();
            for (size_t i0 = 0; i0 < n; i0 += L) {
                for (int l = 0; l < L; l++) {
                    size_t p = i0 + (size_t)l;
                    sm_plastic_lanes_set_params(&b, l, m);
                    sm_plastic_lanes_load(&b, D, l, F + p * DD, alpha[p], q[p]);
                }
                if (D == 3)
                    sm_plastic_lanes3(&b);
                else
                    sm_plastic_lanes2(&b);
                for (int l = 0; l < L; l++) {
                    size_t p = i0 + (size_t)l;
                    z += sm_plastic_lanes_store(&b, D, l, F + p * DD, alpha + p, q + p, T + p * SM_NSYM(D));
                }
            }
            tt += now() - t0;
        }
        double t = tt / ((double)n * reps) * 1e9;
        if (t < best) best = t;
    }
    sink = (double)z;
    return best;
}

int main(int argc, char **argv) {
    size_t n = 4096;
    int reps = 50;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (strcmp(argv[i], "--n") == 0) n = (size_t)atol(argv[i + 1]);
        else if (strcmp(argv[i], "--reps") == 0) reps = atoi(argv[i + 1]);
    }
    n = (n + SM_PLASTIC_LANES - 1) / SM_PLASTIC_LANES * SM_PLASTIC_LANES;
    sm_real *F = malloc(n * 9 * sizeof *F), *F0 = malloc(n * 9 * sizeof *F), *T = malloc(n * 9 * sizeof *T);
    sm_real *alpha = malloc(n * sizeof *alpha), *a0 = malloc(n * sizeof *a0);
    sm_real *q = malloc(n * sizeof *q), *q0 = malloc(n * sizeof *q0);
    if (!F || !F0 || !T || !alpha || !a0 || !q || !q0) return 1;

    printf("sm_real = %s, %zu matrices/particles, lanes = %d\n", SM_DOUBLE ? "double" : "float", n,
           SM_PLASTIC_LANES);
    for (int d = 3; d >= 2; d--) {
        for (size_t i = 0; i < n * d * d; i++) F[i] = (sm_real)urand(-1, 1);
        double tr = time_svd(d, F, n, reps), lr = d == 3 ? time_svd3_latency(F, n, reps) : 0;
        for (size_t i = 0; i < n; i++) near_rotation(d, 1e-3, F + i * d * d);
        double tn = time_svd(d, F, n, reps), ln = d == 3 ? time_svd3_latency(F, n, reps) : 0;
        printf("sm_svd%d: random %7.1f ns/call   near-rotation %7.1f ns/call\n", d, tr, tn);
        if (d == 3)
            printf("sm_svd3 latency (dependent calls): random %7.1f ns   near-rotation %7.1f ns\n", lr, ln);
    }

    double deg = SM_PI / 180.0;
    double E = 3.537e5, nu = 0.3, mu, lambda;
    sm_lame(E, nu, &mu, &lambda);
    mat_t mats[2] = {{(sm_real)mu, (sm_real)lambda, (sm_real)(35 * deg), (sm_real)(9 * deg), (sm_real)0.2,
                      (sm_real)(10 * deg), 1, 1, 0},
                     {(sm_real)mu, (sm_real)lambda, 0, 0, 0, 0, 0, 0, 0}};
    const char *names[2] = {"hardening sand", "elastic"};
    for (int d = 3; d >= 2; d--)
        for (int mi = 0; mi < 2; mi++) {
            make_plastic_inputs(d, n, F0, a0, q0);
            double ts = time_plastic_scalar(d, &mats[mi], F0, a0, q0, n, reps / 5 + 1, F, alpha, q, T);
            double tb = time_plastic_batch(d, &mats[mi], F0, a0, q0, n, reps / 5 + 1, F, alpha, q, T);
            printf("plasticity %dD %-15s scalar %7.1f ns/particle   batch %7.1f ns/particle  (x%.1f)\n",
                   d, names[mi], ts, tb, ts / tb);
        }
    free(F), free(F0), free(T), free(alpha), free(a0), free(q), free(q0);
    return 0;
}
