/* The implicit grid solve (thesis §3.6.2.2, Algorithms 5, 6 and 8; stages 4-5 of the step with
 * integrator = implicit): after a P2G without forces, Newton's method with GMRES on the grid
 * velocities, plasticity inside the force; then collisions and friction as the explicit update
 * does. The equations are at the top of implicit_ops_dim.c (operators) and implicit_dim.c
 * (Newton, line search, GMRES).
 *
 * Seams: the operators read one struct, sm_implicit_sys (what the system is); the solver's
 * vectors are the workspace's named vectors. A preconditioner is one more operator on the same
 * struct and one more vector. */
#ifndef SM_INTEGRATE_IMPLICIT_SOLVER_H
#define SM_INTEGRATE_IMPLICIT_SOLVER_H

#include <float.h>

#include "collide/grid_collide.h"
#include "grid/bin.h"
#include "material/implicit.h"
#include "material/material_rt.h"
#include "math/xsum.h"

/* One rounding of sm_real. */
#if SM_DOUBLE
#define SM_REAL_EPSILON DBL_EPSILON
#else
#define SM_REAL_EPSILON FLT_EPSILON
#endif

/* Workspace of the implicit solve, grown as needed, never shrunk. Node vectors hold d values per
 * node of the live grid blocks, in grid node order (mass: one). Storage is reused between the
 * phases of a solve; what each holds when (every function names its arguments for the quantity
 * it is given; this is the one place that says which storage is passed):
 *
 *   storage  initial guess                Newton iteration                    finish (Alg. 5, l. 3-5)
 *   mass     node mass m_i (0 where none), the whole step
 *   vn       v^n, the whole step
 *   force    sum_p G_p grad w_ip at the velocities of the last force evaluation (at the finish: v-bar)
 *   z        explicit predictor, then     the iterate (collided)              v-bar = the solution
 *            the better guess
 *   y        the guesses' residuals       residual y(z); negated: GMRES rhs;  -
 *                                         line search: the trial's residual
 *                                         (the next iteration's if accepted)
 *   dz       guess v^n + dt g             Newton step (GMRES's solution)      GRID_COLLISIONS(v*)
 *   aux      -                            GMRES: TIMES_DIFF's P x             v*
 *   krylov   -                            GMRES: K+1 basis vectors;           -
 *                                         line search: z before the step
 *   contact  contacts of the last GRID_COLLISIONS (of z; at the finish, of v*)
 *   pp       per particle: Algorithm 8's precompute at the last evaluation with it (a Newton
 *            iterate; the line search's accepted trial)
 *   pinv     the preconditioner: per node the inverse of J's d x d diagonal block at the iterate
 *            (implicit_precond_dim.c); pz: GMRES's M^-1 v, then M^-1 of the combined basis
 *   partial  per-live-block partial sums (deterministic dot products) */
typedef struct sm_implicit_ws {
    size_t ncap;                 /* nodes the vectors hold */
    int kcap;                    /* Krylov vectors allocated */
    size_t pcap;                 /* particles pp and G hold */
    size_t partial_cap;          /* live blocks partial holds */
    sm_real *mass, *vn, *force, *z, *y, *dz, *aux, *krylov, *pz;
    sm_real *pinv;               /* d x d per node */
    sm_node_contact *contact;
    sm_implicit_particle *pp;
    double *partial;
} sm_implicit_ws;

/* Room for `nodes` nodes in `nblocks` live blocks, K + 1 Krylov vectors and np particles. */
sm_status sm_implicit_ws_reserve(sm_implicit_ws *ws, int dim, size_t nodes, size_t nblocks, size_t np, int K);
void sm_implicit_ws_free(sm_implicit_ws *ws);
size_t sm_implicit_ws_bytes(const sm_implicit_ws *ws, int dim);

/* Counters of the implicit solves (sm_diagnostics). */
typedef struct sm_implicit_stats {
    uint64_t newton_total, gmres_total, unconverged;
    uint64_t floor_stops;        /* solves that stopped at the precision's rounding floor above the tolerance */
    uint64_t rejected;           /* solves whose dt was refused because Newton did not converge */
    int last_iterations;         /* Newton steps of the last solve */
    int last_converged;          /* the last solve met the tolerance (or the rounding floor) */
    double last_norm;            /* its final residual norm sqrt(sum m |y|^2 / sum m), m/s */
    double last_residual;        /* the same over dt, m/s^2 */
    double hist[64];             /* residual (m/s^2) of each Newton step of the last solve */
} sm_implicit_stats;

/* A distributed solve's traffic (dist/halo.c; NULL on one rank). Every node vector is stored on
 * all of this rank's live blocks, but only the blocks it owns hold the solve's values (their
 * particles are all here: owned or ghosts); elsewhere the per-node operations leave whatever
 * they compute. So the operators that read neighbouring nodes (the particle gathers of
 * sm_imp_forces and TIMES_DIFF) first refresh their input's other blocks from their owners, the
 * inner products count owned blocks only (exact sums, added over the ranks). Every call is
 * collective: the ranks run the same iterations, as their inner products are the same bits. */
typedef struct sm_imp_ranks {
    void *ctx;
    const unsigned char *owned;            /* per live block: 1 where this rank owns it */
    void (*refresh)(void *ctx, sm_real *v); /* v (d per node) on the blocks owned elsewhere, from their owners */
    void (*sum)(void *ctx, sm_xsum *acc);   /* acc summed over the ranks, in place */
    int (*max_int)(void *ctx, int v);       /* the largest v over the ranks */
} sm_imp_ranks;

/* What the system reads: the particles at the step start, their binning, the live grid and the
 * colliders (the operators of implicit_ops_dim.c take this and vectors, nothing else). */
typedef struct sm_implicit_sys {
    const sm_step_ctx *c;
    size_t n;                    /* particles */
    const double *x;                     /* positions (double: particles.h) */
    const sm_real *F, *vol0, *alpha;     /* F^E at t^n, initial volumes, alpha */
    const uint16_t *mat;
    const sm_material_rt *mats;
    const sm_bins *bins;
    const sm_grid *grid;         /* live blocks: node positions */
    size_t nodes;                /* node vectors' length: live blocks * 4^d */
    sm_grid_colliders colliders;
    sm_implicit_ws *ws;          /* mass, vn, contacts, pp, force, partial */
    sm_real *cache;              /* the transfer caches (transfer.h: SM_CACHE_SIDE^d x SM_LANES values
                                    per thread), free during the solve: the particle passes' */
    const sm_imp_ranks *ranks;   /* NULL on one rank */
} sm_implicit_sys;

/* What a particle pass computes per particle (implicit_pass_dim.c). */
typedef enum sm_imp_pass {
    SM_IMP_PASS_FORCE,      /* G_p(z) */
    SM_IMP_PASS_PRECOMPUTE, /* G_p(z) and Algorithm 8's precompute at z (ws->pp) */
    SM_IMP_PASS_HESSIAN     /* apply_p(T_p) at the last precompute */
} sm_imp_pass;

/* The implicit stage: reads P2G's mass and momentum (P2G without force), writes v^n (FLIP
 * only), v-bar and v-tilde where the explicit grid update does. */
typedef struct sm_implicit_io {
    sm_implicit_sys sys;         /* c and nodes are filled by the solve */
    sm_grid_p2g in;
    sm_grid_vel out;
    double newton_tolerance;     /* def.newton_tolerance, m/s^2 */
    int newton_max_iterations, gmres_max_iterations;
    double gmres_tolerance;
    int precondition;            /* def.gmres_preconditioner: 1 block Jacobi, 0 none */
    double wave_speed;           /* the largest elastic wave speed of the materials, m/s (the initial guess) */
    int may_reject;              /* if Newton does not converge, return without finishing (stats->last_converged
                                    = 0): the caller retries with a smaller dt */
    sm_implicit_stats *stats;
} sm_implicit_io;

#ifdef SM_DIM
/* SM_ERR_NOMEM (workspace) or SM_ERR_NUMERICAL (the residual is not finite: stats->last_norm). */
sm_status SM_FN(sm_implicit_solve)(const sm_implicit_io *io, const sm_step_ctx *c);
/* Test hook: at random grid velocities z (scale vscale), the relative error of TIMES_DIFF
 * against the central difference of the unprojected residual with step h (no collider may touch
 * the nodes; P2G without force must have run). */
double SM_FN(sm_implicit_jvp_check)(const sm_implicit_io *io, const sm_step_ctx *c, uint64_t seed, double vscale,
                                    double h);

/* The operators (implicit_ops_dim.c). Vectors have s->nodes nodes. Those taking a non-const z
 * refresh its blocks owned by other ranks (sm_imp_ranks) before they read it. */
double SM_FN(sm_imp_dot)(const sm_implicit_sys *s, const sm_real *a, const sm_real *b);
/* The sum of ws->partial over the live blocks this rank owns, over all ranks: exact, so the same
 * bits whatever the order, thread count or rank count (math/xsum.h). */
double SM_FN(sm_imp_block_sum)(const sm_implicit_sys *s);
/* G_p at velocities z for every particle (and Algorithm 8's precompute if pre), then
 * ws->force = sum_p G_p grad w_ip. */
void SM_FN(sm_imp_forces)(const sm_implicit_sys *s, sm_real *z, int pre);
/* y = z - v^n - dt g + (dt/m) ws->force, nodes with mass (0 elsewhere). */
void SM_FN(sm_imp_residual)(const sm_implicit_sys *s, const sm_real *z, sm_real *y);
/* The contact projection P (sticky rows to zero, normals removed); prune: PRUNE_COLLISIONS. */
void SM_FN(sm_imp_project)(const sm_implicit_sys *s, sm_real *y, int prune);
/* vstar = v^n + FORCE_INCREMENT_VEL(z) = v^n + dt g - (dt/m) sum_p G_p(z) grad w. */
void SM_FN(sm_imp_force_increment)(const sm_implicit_sys *s, sm_real *z, sm_real *vstar);
/* The same from the forces the last sm_imp_forces left in ws->force (at its z). */
void SM_FN(sm_imp_vstar)(const sm_implicit_sys *s, sm_real *vstar);
/* NONLINEAR_FUNCTION at z (collided): y = the pruned residual; returns sum m |y|^2. With pre,
 * also Algorithm 8's precompute at z (ws->pp), as a Newton iteration at z needs. */
double SM_FN(sm_imp_residual_norm2)(const sm_implicit_sys *s, sm_real *z, sm_real *y, int pre);
/* TIMES_DIFF (Algorithm 6) at the last precompute: out = J x. px: scratch for P x. */
void SM_FN(sm_imp_times_diff)(const sm_implicit_sys *s, const sm_real *x, sm_real *out, sm_real *px);
/* GRID_COLLISIONS of z in place, recording ws->contact. */
void SM_FN(sm_imp_collide)(const sm_implicit_sys *s, sm_real *z);
/* sum m (|z|^2 + |v^n|^2 + |dt g|^2 + |dt f / m|^2) over nodes with mass (ws->force as the last
 * sm_imp_forces left it): the scale of the residual's terms, for its rounding floor. */
double SM_FN(sm_imp_term_scale2)(const sm_implicit_sys *s, const sm_real *z);

/* out = sum_p M_p grad w_ip with M_p of `kind` from T_p = sum_i in_i grad w_ip^T
 * (implicit_pass_dim.c; in must be refreshed across ranks). */
void SM_FN(sm_imp_particle_pass)(const sm_implicit_sys *s, sm_imp_pass kind, const sm_real *in, sm_real *out);

/* Per-particle work of a scatter: particle p's terms (block pb, origin bc) added into out. */
typedef void (*sm_imp_particle_scatter)(const sm_implicit_sys *s, const void *arg, size_t p, const sm_pblock *pb,
                                        const int bc[3], sm_real *out);
/* fn for every particle, colour by colour (no two threads reach a node at once; the same sum
 * order for any thread count), the blocks of a colour claimed from both ends of its list as in P2G
 * (core/team.h, sm_team_claim). */
void SM_FN(sm_imp_scatter_by_colour)(const sm_implicit_sys *s, sm_imp_particle_scatter fn, const void *arg,
                                     sm_real *out);

/* The block-Jacobi preconditioner (implicit_precond_dim.c): ws->pinv from the precompute at
 * the iterate (after sm_imp_forces with pre), and out = M^-1 x. */
void SM_FN(sm_imp_precond_build)(const sm_implicit_sys *s);
void SM_FN(sm_imp_precond_apply)(const sm_implicit_sys *s, const sm_real *x, sm_real *out);
#endif

#endif
