/* The plasticity stage (plasticity.h), compiled for SM_DIM = 2 and 3.
 *
 * Algorithm 2 in batches of SM_PLASTIC_LANES consecutive particles (material/plastic_batch.h):
 *   F^E-hat = U diag(s) V^T;  s' = PROJECT(s, alpha);  F^E = U diag(s') V^T;
 *   q += dq, alpha = alpha(phi_F(q)) (3.78)-(3.80);   tau = U diag(2 mu ln s' + lambda tr ln s') U^T.
 * Every particle goes through the same lane-wise operations whatever its batch, so the result
 * does not depend on the thread count; every thread flushes subnormal numbers to zero
 * (core/fpmode.h), so it does not depend on whether the caller flushes them either. */
#include "core/dim.h"

#include "core/fpmode.h"
#include "core/team.h"
#include "material/plasticity.h"

#if D == 2
#define PLASTIC_LANES sm_plastic_lanes2
#else
#define PLASTIC_LANES sm_plastic_lanes3
#endif

typedef struct plastic_job {
    const sm_plasticity_io *io;
    sm_team_claims batches; /* core/team.h: the threads meet where the work does */
    atomic_int bad;
} plastic_job;

/* Batch k (particles first + k L ..); the lanes keep their material's parameters between batches
 * (lane_mat: the material whose parameters lane l holds, -1 padding). Returns 0 * every output,
 * summed: NaN iff one is not finite. */
static sm_real plastic_batch(const sm_plasticity_io *io, long k, sm_plastic_lanes *b, int *lane_mat) {
    enum { L = SM_PLASTIC_LANES };
    const size_t n = io->n, p0 = io->first + (size_t)k * L;
    const int cnt = (int)(n - p0 < (size_t)L ? n - p0 : (size_t)L);
    for (int l = 0; l < L; l++) {
        const size_t p = p0 + (size_t)l;
        const int mi = l < cnt ? (int)io->mat[p] : -1;
        if (mi != lane_mat[l]) {
            lane_mat[l] = mi;
            sm_plastic_lanes_set_params(b, l, mi >= 0 ? &io->mats[mi].law : NULL);
        }
        if (mi >= 0) sm_plastic_lanes_load(b, D, l, io->F + p * DD, io->alpha[p], io->q[p]);
        else sm_plastic_lanes_load(b, D, l, NULL, 0, 0);
    }
    PLASTIC_LANES(b);
    sm_real z = 0;
    for (int l = 0; l < cnt; l++) {
        const size_t p = p0 + (size_t)l;
        z += sm_plastic_lanes_store(b, D, l, io->F + p * DD, io->alpha + p, io->q + p, io->tau + p * SM_NSYM(D));
    }
    return z;
}

/* Thread t's batches, claimed from its end (sm_team_claim): every particle goes through the same
 * operations in any batch and on any thread. */
static void plastic_share(void *arg, int t, int T) {
    plastic_job *job = arg;
    sm_plastic_lanes b;
    int lane_mat[SM_PLASTIC_LANES];
    for (int l = 0; l < SM_PLASTIC_LANES; l++) lane_mat[l] = -2;
    sm_real z = 0;
    const sm_fpmode fp = sm_fpmode_flush_subnormals(); /* core/fpmode.h */
    sm_team_claimer claimer;
    sm_team_claimer_init(&claimer, &job->batches, t, T);
    long lo, hi;
    while (sm_team_claim(&claimer, 4, &lo, &hi))
        for (long k = lo; k < hi; k++) z += plastic_batch(job->io, k, &b, lane_mat);
    sm_fpmode_restore(fp);
    if (z != 0 || z != z) atomic_store_explicit(&job->bad, 1, memory_order_relaxed);
}

int SM_FN(sm_plasticity)(const sm_plasticity_io *io) {
    enum { L = SM_PLASTIC_LANES };
    const long nbatch = (long)((io->n - io->first + L - 1) / L);
    plastic_job job = {.io = io};
    sm_team_claims_init(&job.batches, nbatch);
    sm_team_run(io->threads, plastic_share, &job);
    return atomic_load(&job.bad);
}
