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
    atomic_int bad;
} plastic_job;

/* Batches [lo, hi) of the stage on one thread. */
static void plastic_batches(void *arg, long lo, long hi) {
    plastic_job *job = arg;
    const sm_plasticity_io *io = job->io;
    const size_t n = io->n, first = io->first;
    const sm_material_rt *mats = io->mats;
    enum { L = SM_PLASTIC_LANES };
    sm_plastic_lanes b;
    int lane_mat[L]; /* material whose parameters lane l holds (-1: padding) */
    for (int l = 0; l < L; l++) lane_mat[l] = -2;
    sm_real z = 0; /* 0 * every output: NaN iff one is not finite */
    const sm_fpmode fp = sm_fpmode_flush_subnormals(); /* core/fpmode.h */
    for (long t = lo; t < hi; t++) {
        const size_t p0 = first + (size_t)t * L;
        const int cnt = (int)(n - p0 < (size_t)L ? n - p0 : (size_t)L);
        for (int l = 0; l < L; l++) {
            const size_t p = p0 + (size_t)l;
            const int mi = l < cnt ? (int)io->mat[p] : -1;
            if (mi != lane_mat[l]) { /* the lanes keep their parameters between batches */
                lane_mat[l] = mi;
                sm_plastic_lanes_set_params(&b, l, mi >= 0 ? &mats[mi].law : NULL);
            }
            if (mi >= 0) sm_plastic_lanes_load(&b, D, l, io->F + p * DD, io->alpha[p], io->q[p]);
            else sm_plastic_lanes_load(&b, D, l, NULL, 0, 0);
        }
        PLASTIC_LANES(&b);
        for (int l = 0; l < cnt; l++) {
            const size_t p = p0 + (size_t)l;
            z += sm_plastic_lanes_store(&b, D, l, io->F + p * DD, io->alpha + p, io->q + p, io->tau + p * SM_NSYM(D));
        }
    }
    sm_fpmode_restore(fp);
    if (z != 0 || z != z) atomic_store_explicit(&job->bad, 1, memory_order_relaxed);
}

int SM_FN(sm_plasticity)(const sm_plasticity_io *io) {
    enum { L = SM_PLASTIC_LANES };
    const long nbatch = (long)((io->n - io->first + L - 1) / L);
    plastic_job job = {io, 0};
    sm_team_for(io->threads, nbatch, plastic_batches, &job);
    return atomic_load(&job.bad);
}
