/* The distributed world (sandmpm_mpi.h): what the step driver and the particle API call. Built
 * with MPI (SM_HAVE_MPI); without it w->dist is always NULL and these are no-ops.
 *
 * The decomposition (dist.c): particle blocks (grid/bin.h) in Morton order of their block
 * coordinates, cut into one contiguous range per rank (cuts[r] <= morton < cuts[r + 1]) of about
 * equal particle counts; re-cut when the largest rank holds more than SM_DIST_IMBALANCE times the
 * mean.
 *
 * One exchange per step (exchange.c), before binning: each particle goes to the owner of its
 * block (migration, every field), and a copy to the owner of every block within one block of it
 * (ghosts). A rank then holds its particles, [0, owned), and every particle of the blocks next to
 * them, [owned, n). A grid block's P2G sums come from the particle blocks b - {0,1}^d, and G2P of
 * particle block b reads grid blocks b + {0,1}^d: with the ghosts, every grid block that an owned
 * particle reads is complete on its rank, summed in the same colour order as on one rank, with a
 * block's particles in ascending id (bin_dim.c). So the grid velocities an owned particle reads
 * are bitwise those of a one-rank run, and G2P and plasticity run on owned blocks only. At the
 * end of the step the ghosts are dropped. Grid blocks at the outer edge of the ghost layer are
 * incomplete; nothing reads them (the grid health check skips them).
 *
 * The exchange overlaps with interior work (overlap.c): while its messages travel, an explicit
 * step bins the particles this rank kept and scatters the blocks that no arrival can touch, then
 * bins the arrivals as a second batch and scatters the rest; every node still sums its
 * contributions in colour order. */
#ifndef SM_DIST_H
#define SM_DIST_H

#include "core/common.h"
#include "core/step_ctx.h"
#include "grid/bin.h"

struct sm_world;
struct sm_imp_ranks;
typedef struct sm_dist sm_dist;

/* The largest rank's particles over the mean that triggers a re-cut, and the fewest steps between
 * two re-cuts (a cut is only as fine as a block: when blocks are few, no cut reaches the
 * threshold, and re-cutting every step would only cost time). */
#define SM_DIST_IMBALANCE 1.10
#define SM_DIST_RECUT_STEPS 25
/* The largest piece of one MPI message, bytes: MPI counts are int (message.c). */
#define SM_DIST_PIECE ((size_t)1 << 30)

#if SM_HAVE_MPI
/* Migration, re-balancing and ghosts (collective), in two parts: _begin routes the particles and
 * posts the messages, leaving the storage with the particles this rank kept; *overlap says whether
 * the step may bin them and scatter its inner blocks before _finish (overlap.c); _finish waits
 * for the messages and appends the arrivals and the ghosts. */
sm_status sm_dist_exchange_begin(struct sm_world *w, int *overlap);
sm_status sm_dist_exchange_finish(struct sm_world *w);
/* Lets MPI move the exchange's messages (between the inner blocks' colours). */
void sm_dist_progress(struct sm_world *w);
/* After the kept particles' binning: marks the particle blocks whose P2G needs nothing the
 * messages bring (pb[].early) and returns them by colour, or NULL if there are none
 * (overlap.c); *side: the side arrays their scatter writes its mixed grid blocks to. */
const sm_block_lists *sm_dist_inner_blocks(struct sm_world *w, sm_grid_p2g *side);
/* After the arrivals' binning (sm_bin_more from `kept`): the blocks still to scatter, by colour;
 * before each colour's scatter, sm_dist_replay(w, colour). If an arrival joined an inner block
 * or its neighbours (a particle faster than a block per step, or test mode 2), the grid is
 * zeroed, the marks cleared and NULL returned: scatter all, replay nothing. */
const sm_block_lists *sm_dist_outer_blocks(struct sm_world *w, size_t kept);
/* Adds the side slots of the inner blocks of this colour into the grid. */
void sm_dist_replay(struct sm_world *w, int colour);
/* 1 (default) or 0: whether explicit steps overlap the exchange; 2: overlap and always redo
 * (tests the fallback). Results are the same bits in every mode. */
void sm_dist_set_overlap(struct sm_world *w, int mode);
/* The implicit solve's traffic for this step's live grid blocks (halo.c; collective, after the
 * binning): *out for sm_implicit_sys.ranks. */
sm_status sm_dist_halo_plan(struct sm_world *w, const struct sm_imp_ranks **out);
/* Drops the ghosts; reorders this rank's particles by block when they are scattered. */
void sm_dist_end_step(struct sm_world *w);
/* Keeps, of particles [first, n) (added on every rank alike), those in this rank's blocks. */
void sm_dist_adopt(struct sm_world *w, size_t first);
/* This rank's particles: [0, owned) of the storage. */
size_t sm_dist_owned(const struct sm_world *w);
/* The largest v over the ranks (collective). */
double sm_dist_max(const struct sm_world *w, double v);
/* The largest of an int over the ranks (collective). */
int sm_dist_max_int(const struct sm_world *w, int v);
/* v[0..n) summed over the ranks in rank order, the same bits on every rank (collective; n <= 32;
 * out of memory: MPI_Allreduce's order). */
void sm_dist_sum_n(const struct sm_world *w, double *v, int n);
/* v[0..n) replaced by their largest over the ranks (collective). */
void sm_dist_max_n(const struct sm_world *w, double *v, int n);
/* Whether grid block `key` is read by this rank's particles (complete). */
int sm_dist_block_complete(const struct sm_world *w, uint64_t key);
/* sm_world_id_hash of a distributed world (collective). */
uint64_t sm_dist_id_hash(const struct sm_world *w);
/* sm_world_save of a distributed world (collective; rank 0 writes a one-rank checkpoint of the
 * whole run, in id order, which any number of ranks can resume). */
sm_status sm_dist_save(const struct sm_world *w, sm_write_fn write, void *user);
void sm_dist_free(sm_dist *d);
/* Sets the piece size of w's messages (tests: small pieces exercise the splitting; 0 or more than
 * SM_DIST_PIECE restores SM_DIST_PIECE). */
void sm_dist_set_piece_bytes(struct sm_world *w, size_t bytes);
#else
static inline sm_status sm_dist_exchange_begin(struct sm_world *w, int *overlap) { (void)w; *overlap = 0; return SM_OK; }
static inline sm_status sm_dist_exchange_finish(struct sm_world *w) { (void)w; return SM_OK; }
static inline void sm_dist_progress(struct sm_world *w) { (void)w; }
static inline const sm_block_lists *sm_dist_inner_blocks(struct sm_world *w, sm_grid_p2g *side) {
    (void)w; (void)side;
    return NULL;
}
static inline void sm_dist_replay(struct sm_world *w, int colour) { (void)w; (void)colour; }
static inline const sm_block_lists *sm_dist_outer_blocks(struct sm_world *w, size_t kept) { (void)w; (void)kept; return NULL; }
static inline void sm_dist_set_overlap(struct sm_world *w, int mode) { (void)w; (void)mode; }
static inline sm_status sm_dist_halo_plan(struct sm_world *w, const struct sm_imp_ranks **out) {
    (void)w;
    *out = NULL;
    return SM_OK;
}
static inline void sm_dist_end_step(struct sm_world *w) { (void)w; }
static inline void sm_dist_adopt(struct sm_world *w, size_t first) { (void)w; (void)first; }
static inline size_t sm_dist_owned(const struct sm_world *w) { (void)w; return 0; }
static inline double sm_dist_max(const struct sm_world *w, double v) { (void)w; return v; }
static inline int sm_dist_max_int(const struct sm_world *w, int v) { (void)w; return v; }
static inline void sm_dist_sum_n(const struct sm_world *w, double *v, int n) { (void)w; (void)v; (void)n; }
static inline void sm_dist_max_n(const struct sm_world *w, double *v, int n) { (void)w; (void)v; (void)n; }
static inline int sm_dist_block_complete(const struct sm_world *w, uint64_t key) { (void)w; (void)key; return 1; }
static inline uint64_t sm_dist_id_hash(const struct sm_world *w) { (void)w; return 0; }
static inline sm_status sm_dist_save(const struct sm_world *w, sm_write_fn write, void *user) {
    (void)w; (void)write; (void)user;
    return SM_ERR_INVALID;
}
static inline void sm_dist_free(sm_dist *d) { (void)d; }
#endif

#endif
