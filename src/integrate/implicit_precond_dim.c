/* The block-Jacobi preconditioner of the implicit solve's GMRES (implicit_solver.h), compiled
 * for SM_DIM = 2 and 3.
 *
 * The Newton operator of TIMES_DIFF (Algorithm 6, implicit_ops_dim.c) is
 *   (J x)_i = x_i + (dt^2 / m_i) sum_p apply_p(sum_j x_j grad w_jp^T) grad w_ip
 * (projected by P). apply_p is linear in its d x d argument: apply_p(T) = sum_{c,f} T_cf C_p^{cf}
 * with C_p^{cf} = apply_p(E_cf), E_cf the unit matrix. The node-diagonal d x d block of J is
 *   B_i[b][a] = delta_ab + (dt^2 / m_i) sum_p sum_{e,f} C_p^{af}[b][e] (grad w_ip)_e (grad w_ip)_f,
 * assembled once per Newton step from the precompute at the iterate (d^2 applies per particle,
 * about three GMRES iterations' work), scattered in P2G's colour schedule (the same summation
 * order for any thread count). The preconditioner is M^-1 x = S_i^-1 x_i per node, S_i the
 * symmetric part of B_i, where S_i is well posed (sm_imp_precond_build; else a scalar; nodes
 * without mass: 0), followed by the contact projection P: without it the Newton step gained
 * components J cannot see (into sticky and contact nodes), and the line search stalled. GMRES uses it on
 * the right, J M^-1 u = b, x = M^-1 u, so it minimises the same residual as without it and the
 * Newton step is the same to the GMRES tolerance (tests/test_implicit_world.c). */
#include "core/dim.h"

#include <string.h>

#include "core/team.h"
#include "integrate/implicit_solver.h"
#include "transfer/stencil_dim.h"

/* C[(a*D + f) * DD + b*D + e] = apply_p(E_af)[b][e]. */
static void particle_operator(const sm_implicit_particle *pp, sm_real *C) {
    for (int af = 0; af < DD; af++) {
        sm_real E[DD];
        for (int k = 0; k < DD; k++) E[k] = k == af ? 1 : 0;
        sm_implicit_apply(D, pp, E, C + af * DD);
    }
}

/* blk[b*D + a] += sum_{e,f} C^{af}[b][e] gw_e gw_f. */
static inline void add_block(const sm_real *C, const sm_real *gw, sm_real *blk) {
    for (int a = 0; a < D; a++) {
        sm_real col[3] = {0, 0, 0};
        for (int f = 0; f < D; f++) {
            const sm_real *Caf = C + (a * D + f) * DD;
            for (int b = 0; b < D; b++) {
                sm_real s = 0;
                for (int e = 0; e < D; e++) s += Caf[b * D + e] * gw[e];
                col[b] += s * gw[f];
            }
        }
        for (int b = 0; b < D; b++) blk[b * D + a] += col[b];
    }
}

/* Particle p's terms of the diagonal blocks into blocks (DD per node). */
static void scatter_particle_blocks(const sm_implicit_sys *s, const void *arg, size_t p, const sm_pblock *pb,
                                    const int bc[3], sm_real *blocks) {
    (void)arg;
    const int S = s->c->stencil;
    sm_real C[DD * DD];
    particle_operator(&s->ws->pp[p], C);
    weights W;
    kernel_weights(S, s->x + p * D, s->c, bc, &W);
    STENCIL_BEGIN(S, W, pb)
    (void)wgt;
    add_block(C, gw, blocks + ni * DD);
    STENCIL_END
}

/* Inverse of the d x d block A (double), or 0 if it is singular or not finite. */
static int invert(const double *A, double *inv) {
#if SM_DIM == 2
    const double det = A[0] * A[3] - A[1] * A[2];
    if (!(fabs(det) > 1e-12 * (fabs(A[0] * A[3]) + fabs(A[1] * A[2]))) || !isfinite(det)) return 0;
    inv[0] = A[3] / det;
    inv[1] = -A[1] / det;
    inv[2] = -A[2] / det;
    inv[3] = A[0] / det;
#else
    double c[9];
    c[0] = A[4] * A[8] - A[5] * A[7];
    c[1] = A[2] * A[7] - A[1] * A[8];
    c[2] = A[1] * A[5] - A[2] * A[4];
    c[3] = A[5] * A[6] - A[3] * A[8];
    c[4] = A[0] * A[8] - A[2] * A[6];
    c[5] = A[2] * A[3] - A[0] * A[5];
    c[6] = A[3] * A[7] - A[4] * A[6];
    c[7] = A[1] * A[6] - A[0] * A[7];
    c[8] = A[0] * A[4] - A[1] * A[3];
    const double det = A[0] * c[0] + A[1] * c[3] + A[2] * c[6];
    double scale = 0;
    for (int k = 0; k < 9; k++) scale = fmax(scale, fabs(A[k]));
    if (!(fabs(det) > 1e-12 * scale * scale * scale) || !isfinite(det)) return 0;
    for (int k = 0; k < 9; k++) inv[k] = c[k] / det;
#endif
    return 1;
}

/* Whether the symmetric d x d block S is positive definite with every pivot of its LDL^T at
 * least PIVOT_MIN (its eigenvalues are then not far below 1, so its inverse is not large). */
#define PIVOT_MIN 0.5
static int well_posed(const double *S) {
    double L[DD], piv[3];
    for (int i = 0; i < D; i++) {
        for (int j = 0; j <= i; j++) {
            double v = S[i * D + j];
            for (int k = 0; k < j; k++) v -= L[i * D + k] * L[j * D + k] * piv[k];
            if (i == j) {
                if (!(v >= PIVOT_MIN)) return 0;
                piv[i] = v;
                L[i * D + i] = 1;
            } else {
                L[i * D + j] = v / piv[j];
            }
        }
    }
    return 1;
}

/* Per node: S = the symmetric part of B = I + (dt^2/m) (the sums); M^-1 = S^-1 where S is well
 * posed, else the scalar 1 / max(1, tr B / d). Where the stiffness block is indefinite
 * (compressed, plastic) B^-1 itself can be huge along a direction J does not amplify, and
 * Newton's step with it diverged (an elastic block at 10x the explicit dt limit). */
typedef struct precond_job {
    const sm_implicit_sys *s;
    const sm_real *x;
    sm_real *out;
} precond_job;

static void invert_nodes(void *arg, long lo, long hi) {
    const precond_job *job = arg;
    sm_implicit_ws *ws = job->s->ws;
    const double dt2 = job->s->c->dt * job->s->c->dt;
    for (long l = lo; l < hi; l++) {
        sm_real *blk = ws->pinv + l * DD;
        const double m = (double)ws->mass[l];
        double S[DD], inv[DD], trace = 0;
        for (int b = 0; b < D; b++)
            for (int a = 0; a < D; a++) {
                const double sym = 0.5 * ((double)blk[b * D + a] + (double)blk[a * D + b]);
                S[b * D + a] = (a == b ? 1.0 : 0.0) + (m > 0 ? dt2 / m * sym : 0.0);
            }
        for (int a = 0; a < D; a++) trace += S[a * D + a];
        if (!well_posed(S) || !invert(S, inv)) {
            const double sc = 1.0 / fmax(1.0, trace / D);
            for (int k = 0; k < DD; k++) inv[k] = k % (D + 1) == 0 ? sc : 0.0;
        }
        for (int k = 0; k < DD; k++) blk[k] = m > 0 ? (sm_real)inv[k] : 0;
    }
}

void SM_FN(sm_imp_precond_build)(const sm_implicit_sys *s) {
    sm_implicit_ws *ws = s->ws;
    memset(ws->pinv, 0, s->nodes * DD * sizeof(sm_real));
    SM_FN(sm_imp_scatter_by_colour)(s, scatter_particle_blocks, NULL, ws->pinv);
    precond_job job = {s, NULL, NULL};
    sm_team_for(s->c->threads, (long)s->nodes, invert_nodes, &job);
}

static void apply_nodes(void *arg, long lo, long hi) {
    const precond_job *job = arg;
    const sm_implicit_ws *ws = job->s->ws;
    for (long l = lo; l < hi; l++) {
        const sm_real *inv = ws->pinv + l * DD;
        for (int b = 0; b < D; b++) {
            double acc = 0;
            for (int a = 0; a < D; a++) acc += (double)inv[b * D + a] * (double)job->x[l * D + a];
            job->out[l * D + b] = (sm_real)acc;
        }
    }
}

void SM_FN(sm_imp_precond_apply)(const sm_implicit_sys *s, const sm_real *x, sm_real *out) {
    precond_job job = {s, x, out};
    sm_team_for(s->c->threads, (long)s->nodes, apply_nodes, &job);
    SM_FN(sm_imp_project)(s, out, 0); /* keep the step in P's range: J does not see the rest, collisions would */
}
