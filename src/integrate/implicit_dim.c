/* The implicit solve (implicit_solver.h): Newton, line search and GMRES, compiled for
 * SM_DIM = 2 and 3. The operators (residual y, TIMES_DIFF J, FORCE_INCREMENT_VEL, the contact
 * projection P) are implicit_ops_dim.c's; the workspace's vectors are named in
 * implicit_solver.h.
 *
 * Thesis Algorithm 5 (COUPLED_SOLVE), with Algorithm 6 for J and Algorithm 8 for its
 * per-particle precompute:
 *   initial guess: the explicit predictor v^n + FORCE_INCREMENT_VEL(v^n), collided, where the
 *     explicit update is stable (c dt <= 0.9 dx, c the largest elastic wave speed); above that
 *     the better (smaller residual) of it and v^n + dt g, collided;
 *   Newton: y = y(z) pruned; stop when sqrt(sum m |y|^2 / sum m) < newton_tolerance dt (after at
 *     least one step), or when it is below the rounding floor 32 eps sqrt(sum m |terms|^2 / sum m)
 *     (eps of sm_real; the terms z, v^n, dt g, dt f / m of y: counted in floor_stops, so a float
 *     build does not iterate on rounding noise), or after newton_max_iterations (not converged: the
 *     step driver refuses the dt and retries at half of it); solve J dz = -y by GMRES (x0 = 0,
 *     mass-weighted inner product, modified Gram-Schmidt, Givens rotations, at most
 *     gmres_max_iterations, relative tolerance max(gmres_tolerance, 16 eps), right-preconditioned
 *     by block Jacobi if gmres_preconditioner: implicit_precond_dim.c); z = GRID_COLLISIONS(z + s dz)
 *     with s = 1, 1/2, ... (6 tries) until the residual norm decreases;
 *   finish (lines 3-5): v-bar = z, v* = v^n + FORCE_INCREMENT_VEL(v-bar),
 *     dv = GRID_COLLISIONS(v*) - v*, v-tilde = FRICTION(v-bar, dv) (collide/grid_collide.h). */
#include "core/dim.h"

#include <string.h>

#include "integrate/implicit_solver.h"

/* The workspace's mass and v^n from P2G's mass and momentum (v^n also into the grid for FLIP);
 * returns the total mass (of every rank's blocks). */
static double load_grid(const sm_implicit_io *io, const sm_implicit_sys *s) {
    sm_implicit_ws *ws = s->ws;
    for (size_t t = 0; t < s->grid->nactive; t++) {
        double msum = 0;
        for (size_t l = t * BN; l < (t + 1) * BN; l++) {
            sm_real m = io->in.mass[l];
            ws->mass[l] = m > 0 ? m : 0;
            msum += (double)ws->mass[l];
            for (int a = 0; a < D; a++) {
                sm_real vn = m > 0 ? io->in.momentum[l * D + a] / m : 0;
                if (io->out.vn) io->out.vn[l * D + a] = vn;
                ws->vn[l * D + a] = vn;
            }
        }
        ws->partial[t] = msum;
    }
    return SM_FN(sm_imp_block_sum)(s);
}

/* Up to this Courant number of the elastic wave, c dt / dx, the explicit update is stable (0.92
 * and more: docs/benchmarks.md, "Time-step limit"), and so is its predictor. */
#define PREDICTOR_COURANT_MAX 0.9

/* ws->z = the initial guess (collided). COUPLED_SOLVE starts from the explicit predictor
 * v^n + FORCE_INCREMENT_VEL(v^n), and so do we where the explicit update is stable. Above that
 * the predictor can itself be unstable (its residual measured 1e8 m/s^2 on an elastic block at
 * 10x the limit, and Newton never recovered), so there we start from whichever of it and
 * v^n + dt g has the smaller residual (two more force evaluations; docs/benchmarks.md,
 * "Implicit, third look", has what else was tried). */
static void initial_guess(const sm_implicit_io *io, const sm_implicit_sys *s) {
    sm_implicit_ws *ws = s->ws;
    const sm_real dt = (sm_real)s->c->dt;
    sm_real *guess = ws->dz, *residual = ws->y;
    SM_FN(sm_imp_force_increment)(s, ws->vn, ws->z);
    SM_FN(sm_imp_collide)(s, ws->z);
    if (io->wave_speed * s->c->dt <= PREDICTOR_COURANT_MAX * s->c->pos_dx) return;
    const double r_explicit = SM_FN(sm_imp_residual_norm2)(s, ws->z, residual, 0);
    for (size_t l = 0; l < s->nodes; l++)
        for (int a = 0; a < D; a++) guess[l * D + a] = ws->mass[l] > 0 ? ws->vn[l * D + a] + dt * s->c->gravity[a] : 0;
    SM_FN(sm_imp_collide)(s, guess);
    if (SM_FN(sm_imp_residual_norm2)(s, guess, residual, 0) < r_explicit) memcpy(ws->z, guess, s->nodes * D * sizeof(sm_real));
    SM_FN(sm_imp_collide)(s, ws->z);
}

/* The smallest relative residual GMRES is asked for: below a few roundings of sm_real the
 * Arnoldi estimate keeps falling while the true residual does not. */
#define GMRES_RTOL_FLOOR (16 * SM_REAL_EPSILON)

/* GMRES on J x = b, x0 = 0, mass-weighted inner product, basis in ws->krylov (K + 1 vectors),
 * right-preconditioned by M^-1 (ws->pinv) if precond: J M^-1 u = b, x = M^-1 u, the same residual
 * minimised over another subspace. Returns the iterations. Overwrites ws->pz. */
static int gmres(const sm_implicit_sys *s, const sm_real *b, sm_real *x, int K, double rtol, int precond) {
    sm_implicit_ws *ws = s->ws;
    const size_t N = s->nodes * D;
    sm_real *V = ws->krylov, *px = ws->aux, *pz = ws->pz;
    if (rtol < GMRES_RTOL_FLOOR) rtol = GMRES_RTOL_FLOOR;
    double H[201][200], cs[200], sn[200], gvec[201];
    double beta = sqrt(SM_FN(sm_imp_dot)(s, b, b));
    if (!(beta > 0)) {
        memset(x, 0, N * sizeof(sm_real));
        return 0;
    }
    for (size_t k = 0; k < N; k++) V[k] = (sm_real)((double)b[k] / beta);
    memset(gvec, 0, sizeof gvec);
    gvec[0] = beta;
    int j = 0;
    for (; j < K; j++) {
        sm_real *vj = V + (size_t)j * N, *wv = V + (size_t)(j + 1) * N;
        if (precond) {
            SM_FN(sm_imp_precond_apply)(s, vj, pz);
            SM_FN(sm_imp_times_diff)(s, pz, wv, px);
        } else {
            SM_FN(sm_imp_times_diff)(s, vj, wv, px);
        }
        for (int i = 0; i <= j; i++) { /* modified Gram-Schmidt */
            const sm_real *vi = V + (size_t)i * N;
            double h = SM_FN(sm_imp_dot)(s, wv, vi);
            H[i][j] = h;
            for (size_t k = 0; k < N; k++) wv[k] = (sm_real)((double)wv[k] - h * (double)vi[k]);
        }
        double hn = sqrt(SM_FN(sm_imp_dot)(s, wv, wv));
        H[j + 1][j] = hn;
        for (int i = 0; i < j; i++) { /* apply earlier Givens rotations */
            double t = cs[i] * H[i][j] + sn[i] * H[i + 1][j];
            H[i + 1][j] = -sn[i] * H[i][j] + cs[i] * H[i + 1][j];
            H[i][j] = t;
        }
        double r = hypot(H[j][j], H[j + 1][j]);
        cs[j] = r > 0 ? H[j][j] / r : 1;
        sn[j] = r > 0 ? H[j + 1][j] / r : 0;
        H[j][j] = r;
        H[j + 1][j] = 0;
        gvec[j + 1] = -sn[j] * gvec[j];
        gvec[j] = cs[j] * gvec[j];
        if (hn > 0)
            for (size_t k = 0; k < N; k++) wv[k] = (sm_real)((double)wv[k] / hn);
        if (fabs(gvec[j + 1]) <= rtol * beta || !(hn > 0)) {
            j++;
            break;
        }
    }
    double yv[200];
    for (int i = j - 1; i >= 0; i--) { /* back substitution */
        double sum = gvec[i];
        for (int k = i + 1; k < j; k++) sum -= H[i][k] * yv[k];
        yv[i] = H[i][i] != 0 ? sum / H[i][i] : 0;
    }
    sm_real *u = precond ? pz : x;
    memset(u, 0, N * sizeof(sm_real));
    for (int i = 0; i < j; i++) {
        const sm_real *vi = V + (size_t)i * N;
        for (size_t k = 0; k < N; k++) u[k] += (sm_real)(yv[i] * (double)vi[k]);
    }
    if (precond) SM_FN(sm_imp_precond_apply)(s, u, x);
    return j;
}

/* z = GRID_COLLISIONS(z0 + step dz), step = 1, 1/2, ... until the residual norm falls below
 * a_norm (or tol); the sixth try is taken as it is. z0 is kept in the first Krylov vector (the
 * basis is not needed any more). Each trial's residual is evaluated as a Newton iteration
 * would (with the precompute, into ws->y, free once GMRES has read its right-hand side), so an
 * accepted trial's is the next iteration's: returns its residual norm (m/s) then, -1 if the sixth
 * try was taken without an evaluation. */
static double line_search(const sm_implicit_sys *s, double a_norm, double tol, double mnorm) {
    sm_implicit_ws *ws = s->ws;
    const size_t N = s->nodes * D;
    sm_real *z0 = ws->krylov;
    memcpy(z0, ws->z, N * sizeof(sm_real));
    double step = 1;
    for (int ls = 0; ls < 6; ls++) {
        for (size_t k = 0; k < N; k++) ws->z[k] = z0[k] + (sm_real)step * ws->dz[k];
        SM_FN(sm_imp_collide)(s, ws->z);
        if (ls == 5) break;
        const double an = sqrt(SM_FN(sm_imp_residual_norm2)(s, ws->z, ws->y, 1) / mnorm);
        if (an < a_norm || an < tol) return an;
        step *= 0.5;
    }
    return -1;
}

/* The residual's rounding floor (m/s): a few roundings of sm_real of its terms' RMS. Newton
 * cannot get below it; a tolerance under it is met at the floor (counted in floor_stops). */
#define NEWTON_FLOOR_ROUNDINGS 32

/* Newton iterations from ws->z; returns the final residual norm (m/s) and whether it met the
 * tolerance (or the rounding floor) in *converged. */
static double newton(const sm_implicit_io *io, const sm_implicit_sys *s, double msum, int *converged) {
    sm_implicit_ws *ws = s->ws;
    sm_implicit_stats *st = io->stats;
    const double dt = s->c->dt, tol = io->newton_tolerance * dt, mnorm = msum > 0 ? msum : 1;
    const size_t N = s->nodes * D;
    sm_real *rhs = ws->y;
    int it = 0, at_floor = 0;
    double a_norm = INFINITY, searched = -1;
    for (;; it++) {
        /* NONLINEAR_FUNCTION at z (already collided), with the Algorithm 8 precompute, unless
         * the line search has just evaluated it (the same calls: the same bits). */
        a_norm = searched >= 0 ? searched : sqrt(SM_FN(sm_imp_residual_norm2)(s, ws->z, ws->y, 1) / mnorm);
        if (it < (int)(sizeof st->hist / sizeof st->hist[0])) st->hist[it] = a_norm / dt;
        if (it > 0 && !(a_norm < tol)) {
            const double floor = NEWTON_FLOOR_ROUNDINGS * SM_REAL_EPSILON * sqrt(SM_FN(sm_imp_term_scale2)(s, ws->z) / mnorm);
            at_floor = a_norm < floor;
        }
        if ((it > 0 && (a_norm < tol || at_floor)) || it >= io->newton_max_iterations) break;
        for (size_t k = 0; k < N; k++) rhs[k] = -ws->y[k]; /* solve J dz = -y */
        if (io->precondition) SM_FN(sm_imp_precond_build)(s);
        st->gmres_total += (uint64_t)gmres(s, rhs, ws->dz, io->gmres_max_iterations, io->gmres_tolerance, io->precondition);
        searched = line_search(s, a_norm, tol, mnorm);
    }
    st->newton_total += (uint64_t)it;
    st->last_iterations = it;
    st->last_norm = a_norm;
    st->last_residual = a_norm / dt;
    *converged = a_norm < tol || at_floor;
    if (at_floor) st->floor_stops++;
    return a_norm;
}

/* Algorithm 5, lines 3-5: v-bar = z; v* = v^n + FORCE_INCREMENT_VEL(v-bar);
 * dv = GRID_COLLISIONS(v*) - v*; v-tilde = FRICTION(v-bar, dv); into the grid. Newton's last
 * evaluation was at z, so ws->force holds the forces at v-bar. */
static void finish(const sm_implicit_io *io, const sm_implicit_sys *s) {
    sm_implicit_ws *ws = s->ws;
    sm_real *vstar = ws->aux, *vcollided = ws->dz;
    SM_FN(sm_imp_vstar)(s, vstar);
    memcpy(vcollided, vstar, s->nodes * D * sizeof(sm_real));
    SM_FN(sm_imp_collide)(s, vcollided); /* the contacts of this call drive FRICTION */
    SM_FN(sm_grid_friction_after_solve)(&s->colliders, s->grid, s->c, s->nodes, ws->contact, ws->z, vstar,
                                        vcollided, io->out.vbar, io->out.vtilde);
    /* Across ranks G2P reads blocks of other ranks too. z is right there (the force evaluation
     * above refreshed it), v-tilde is not: v* sums only the particles that reach this rank's
     * blocks (implicit_ops_dim.c's pblock_needed). Nor is v-bar where it took v-tilde's value at
     * a contact (static_friction_sticks). */
    if (s->ranks) {
        s->ranks->refresh(s->ranks->ctx, io->out.vtilde);
        if (s->colliders.static_sticks) s->ranks->refresh(s->ranks->ctx, io->out.vbar);
    }
}

static sm_implicit_sys system_of(const sm_implicit_io *io, const sm_step_ctx *c) {
    sm_implicit_sys s = io->sys;
    s.c = c;
    s.nodes = s.grid->nactive * (size_t)BN;
    return s;
}

sm_status SM_FN(sm_implicit_solve)(const sm_implicit_io *io, const sm_step_ctx *c) {
    const sm_implicit_sys s = system_of(io, c);
    int no_room = sm_implicit_ws_reserve(s.ws, D, s.nodes, s.grid->nactive, s.n, io->gmres_max_iterations) != SM_OK;
    if (s.ranks) no_room = s.ranks->max_int(s.ranks->ctx, no_room); /* every rank returns, or none */
    if (no_room) return SM_ERR_NOMEM;
    const double msum = load_grid(io, &s);
    initial_guess(io, &s);
    int converged = 0;
    const double a_norm = newton(io, &s, msum, &converged);
    if (!isfinite(a_norm)) return SM_ERR_NUMERICAL;
    io->stats->last_converged = converged;
    if (!converged && io->may_reject) {
        io->stats->rejected++;
        return SM_OK; /* the caller refuses the step: nothing outside the grid has changed */
    }
    if (!converged) io->stats->unconverged++;
    finish(io, &s);
    return SM_OK;
}

/* The finite-difference check: y(z +- h dz) by the residual without projection (no contacts),
 * J dz by TIMES_DIFF after the precompute at z. Vectors: z, dz as named; the two residuals and
 * the shifted z in the first three Krylov vectors; their difference in y. */
double SM_FN(sm_implicit_jvp_check)(const sm_implicit_io *io, const sm_step_ctx *c, uint64_t seed, double vs,
                                    double h) {
    const sm_implicit_sys s = system_of(io, c);
    sm_implicit_ws *ws = s.ws;
    const size_t nodes = s.nodes, N = nodes * D;
    if (sm_implicit_ws_reserve(ws, D, nodes, s.grid->nactive, s.n, 2) != SM_OK) return INFINITY;
    uint64_t st = seed;
    for (size_t l = 0; l < nodes; l++) {
        ws->mass[l] = io->in.mass[l] > 0 ? io->in.mass[l] : 0;
        for (int a = 0; a < D; a++) {
            st = st * 6364136223846793005ULL + 1442695040888963407ULL;
            double r1 = (double)(st >> 11) / 9007199254740992.0 - 0.5;
            st = st * 6364136223846793005ULL + 1442695040888963407ULL;
            double r2 = (double)(st >> 11) / 9007199254740992.0 - 0.5;
            ws->vn[l * D + a] = 0;
            ws->z[l * D + a] = ws->mass[l] > 0 ? (sm_real)(vs * r1) : 0;
            ws->dz[l * D + a] = ws->mass[l] > 0 ? (sm_real)(vs * r2) : 0;
        }
        ws->contact[l].sticky = -1;
        ws->contact[l].count = 0;
    }
    sm_real *z_shifted = ws->krylov, *y_plus = ws->krylov + N, *y_minus = ws->krylov + 2 * N;
    for (int sgn = 0; sgn < 2; sgn++) {
        for (size_t k = 0; k < N; k++) z_shifted[k] = ws->z[k] + (sm_real)((sgn ? -h : h)) * ws->dz[k];
        SM_FN(sm_imp_forces)(&s, z_shifted, 0);
        SM_FN(sm_imp_residual)(&s, z_shifted, sgn ? y_minus : y_plus);
    }
    sm_real *fd = y_plus, *jdz = y_minus, *diff = ws->y;
    for (size_t k = 0; k < N; k++) fd[k] = (sm_real)(((double)y_plus[k] - (double)y_minus[k]) / (2 * h));
    SM_FN(sm_imp_forces)(&s, ws->z, 1);
    SM_FN(sm_imp_times_diff)(&s, ws->dz, jdz, ws->aux);
    for (size_t k = 0; k < N; k++) diff[k] = jdz[k] - fd[k];
    const double num = SM_FN(sm_imp_dot)(&s, diff, diff);
    const double den = SM_FN(sm_imp_dot)(&s, fd, fd);
    return sqrt(num / den);
}
