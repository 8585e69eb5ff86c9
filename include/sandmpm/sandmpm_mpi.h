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
 * same bits (its inner products are exact sums: the same on any number of ranks).
 *
 * A world too large for one rank's memory is built twice instead, with an sm_dist_seeding:
 * first a census (sm_world_seed_census on a new world, then its materials, colliders and
 * particles as usual: the particles are counted per grid block and none is stored; destroy it),
 * then the world itself (sm_world_seed_share on a new world, then the same build again: each rank
 * stores only the particles of its share) and sm_world_distribute_share. The ranks end as
 * sm_world_distribute of the whole world would leave them: the same particles, ids and cuts,
 * and the same results. */
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

/** Seeding across ranks (see above). Every call is made on every rank of comm, in the same order;
 * sm_world_seed_share and sm_world_distribute_share are collective. A seeding serves one census
 * and one share. The census and the share's worlds must have the same grid (dimension, dx, domain,
 * kernel) and no particles when they join; a failure is SM_ERR_INVALID (a misuse, or ranks whose
 * censuses or shares disagree) or SM_ERR_NOMEM, with the message in sm_world_errmsg. */
typedef struct sm_dist_seeding sm_dist_seeding;
SM_API sm_status sm_dist_seeding_create(MPI_Comm comm, sm_dist_seeding **out);
SM_API void sm_dist_seeding_destroy(sm_dist_seeding *s);
/** From now on w counts the particles added to it (seeding, sm_world_add_particles) and stores none. */
SM_API sm_status sm_world_seed_census(sm_world *w, sm_dist_seeding *s);
/** Cuts the blocks from the census (collective); from now on w stores only this rank's particles. */
SM_API sm_status sm_world_seed_share(sm_world *w, sm_dist_seeding *s);
/** Makes w, built since sm_world_seed_share, this rank's part of the run (collective; checks that
 * the ranks kept every particle of the census once). s may be destroyed afterwards. */
SM_API sm_status sm_world_distribute_share(sm_world *w, sm_dist_seeding *s);

/** Resumes a distributed run from a checkpoint (of len bytes, read at offsets through read: every
 *  rank reads the stream itself, e.g. the same file) without any rank holding every particle:
 *  w is the world built on every rank alike (as for sm_world_restore; built with a census,
 *  sm_world_seed_census, it stores none of the scene's particles, whose place the checkpoint's
 *  take), and each rank keeps only its share, with the cuts sm_world_distribute would compute from
 *  the whole restored world. The ranks end as sm_world_restore of the whole stream then
 *  sm_world_distribute would leave them (the same particles in the same order, the same cuts), so
 *  a checkpoint written on N ranks (or one process) resumes on M with the run's bits. Collective;
 *  the status is the same on every rank. A rank reads the positions twice and of the other fields
 *  only the pieces that hold its particles. On failure w is not distributed, and its state is the
 *  checkpoint's on the ranks whose read succeeded: restore it again (e.g. from an older one). */
SM_API sm_status sm_world_restore_share(sm_world *w, MPI_Comm comm, sm_pread_fn read, void *user, uint64_t len);

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
    double exchange_wait_s; /* the last exchange's time blocked on its messages (s), after the work overlapped
                               with them */
    size_t early_particles; /* the last step's particles scattered (P2G) while the exchange's messages
                               travelled: those of this rank's inner blocks (sm_world_set_dist_overlap) */
    uint64_t overlap_redone; /* steps whose early scatter was redone because an arriving particle joined an
                                inner block (one faster than a cell per step) */
} sm_dist_stats;

/** Fills *out (collective only at sm_world_distribute; here local). 0 if w is not distributed. */
SM_API int sm_world_dist_stats(const sm_world *w, sm_dist_stats *out);

/** Whether an explicit step overlaps its exchange of particles with work (1, the default): while
 * the messages travel, each rank bins the particles it kept and scatters (P2G) its inner blocks,
 * those that no arriving particle reaches, then the rest when the messages are in. 0: the
 * exchange first, then the step (as before). The results are the same bits either way; the
 * overlap pays where the network, not the processor, moves the bytes (docs/scaling.md). Local
 * (set it alike on every rank); SM_ERR_INVALID if w is not distributed or on is not 0 or 1. */
SM_API sm_status sm_world_set_dist_overlap(sm_world *w, int on);

/* ---- Id slices: the whole run in id order, one contiguous piece per rank ---------------------
 * For writing one file on several ranks (a frame, a checkpoint) without any rank holding the
 * whole run. sm_world_id_slice (collective for a distributed world) sends every particle, with
 * every field, to the rank whose slice of the id order holds it: rank r receives the particles at
 * positions first .. first + n - 1 of the whole run sorted by id (sm_id_slice_first, n the slice
 * world's particle count), about total / ranks of them. The slice's world is a copy of the run's
 * state at that moment (clock, statistics summed over the ranks, collider poses, emitter
 * counters) with those particles and no decomposition: read it (sm_world_particles and the other
 * const queries), never step it; it stays valid while the run's world lives, whatever steps the
 * run then takes. On one process the slice is the whole world in id order. SM_ERR_NOMEM (on
 * every rank) when some rank is out of memory. */
typedef struct sm_id_slice sm_id_slice;
SM_API sm_status sm_world_id_slice(const sm_world *w, sm_id_slice **out);
SM_API const sm_world *sm_id_slice_world(const sm_id_slice *s);
SM_API uint64_t sm_id_slice_first(const sm_id_slice *s);
SM_API uint64_t sm_id_slice_total(const sm_id_slice *s);
/* The run's communicator (MPI_COMM_SELF on one process). */
SM_API MPI_Comm sm_id_slice_comm(const sm_id_slice *s);
/* This rank's parts of the checkpoint stream of the whole run at the slice's moment (the bytes
 * sm_world_save gives): its particles' field data at their offsets, and on rank 0 every byte that
 * is not particle data. Not collective: each rank writes its parts, the ranks' parts tile the
 * stream. *bytes: the stream's length. SM_OK or SM_ERR_IO (write returned non-zero). */
SM_API sm_status sm_id_slice_save(const sm_id_slice *s, sm_pwrite_fn write, void *user, uint64_t *bytes);
SM_API void sm_id_slice_destroy(sm_id_slice *s);

#ifdef __cplusplus
}
#endif

#endif
