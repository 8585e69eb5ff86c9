/* sandmpm across MPI ranks (built when the library was configured with SM_MPI; config.h's
 * SM_HAVE_MPI is 1 then).
 *
 * A distributed run: every rank builds the same world (the same definition, materials,
 * colliders, emitters and particles, e.g. from the same scene) and calls sm_world_distribute
 * with the same communicator; from then on each rank holds the particles of its share of the
 * grid blocks, and sm_world_step / sm_world_advance are collective: every rank calls them with
 * the same arguments. The results are bitwise identical to a run on one rank (particle state
 * ordered by id: sm_world_id_hash) for any number of ranks and threads.
 *
 * Particles added later (sm_world_add_particles, seeding, emitters) are added on every rank, and
 * each rank keeps the ones in its blocks. sm_world_particles and sm_world_diagnostics report the
 * calling rank's particles. sm_world_save is collective: rank 0 writes one checkpoint of the whole
 * run (every particle, in id order), which resumes on any number of ranks (sm_world_load on each,
 * then sm_world_distribute) or on none. The implicit integrator runs across ranks too, with the
 * same bits (its inner products are exact sums: the same on any number of ranks). */
#ifndef SANDMPM_MPI_H
#define SANDMPM_MPI_H

#include <mpi.h>

#include "sandmpm/sandmpm.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Makes w one rank's part of a distributed run over comm (collective; the library duplicates
 * comm). The ranks' worlds must be identical (same particle state hash: SM_ERR_INVALID
 * otherwise). Cuts the grid blocks, in Morton order, into one contiguous range per rank with
 * about equal particle counts, and keeps the particles of this rank's range. */
SM_API sm_status sm_world_distribute(sm_world *w, MPI_Comm comm);

/** What the decomposition did: this rank and the number of ranks, this rank's particles, the
 * largest and the mean particle count over the ranks after the last step's migration, the
 * re-balancings, and this rank's traffic of the last step (ghost and migrating particles sent,
 * bytes and messages; with the implicit integrator also the grid node vectors sent to other
 * ranks: bytes, messages and refreshes of the last step). */
typedef struct sm_dist_stats {
    int rank, ranks;
    size_t particles;
    size_t max_particles;
    double mean_particles;
    uint64_t rebalances;
    size_t ghosts_sent, migrated_sent;
    size_t bytes_sent, messages_sent;
    size_t halo_bytes_sent, halo_messages_sent, halo_refreshes; /* implicit: grid node vectors to other ranks */
    double exchange_wait_s; /* the last exchange's time blocked on its messages (s): at most what overlapping
                               the exchange with interior work could hide */
} sm_dist_stats;

/** Fills *out (collective only at sm_world_distribute; here local). 0 if w is not distributed. */
SM_API int sm_world_dist_stats(const sm_world *w, sm_dist_stats *out);

#ifdef __cplusplus
}
#endif

#endif
