/* Distributed runs (issue 19, sandmpm_mpi.h), run by CTest under mpirun on 1, 2, 3 and 4 ranks:
 *  - the explicit step on N ranks gives bitwise the particle state of one rank (sm_world_id_hash,
 *    particles in id order), computed here by rank 0 with 2 threads while the ranks run 1 thread
 *    each: 2D and 3D collapses of a sand block hit by a moving sphere, with a ball thrown across
 *    the domain and an emitter pouring sand on top, at the adaptive dt (a max over the ranks);
 *  - mass and momentum are conserved across migration: the ranks' particles add up to the seeded
 *    plus the emitted ones every frame, their masses to the seeded plus the emitted mass, and
 *    their momentum to the one-rank run's (within 1e-12 of the mass times 1 m/s: sum order);
 *  - the thrown ball's first particle crosses rank boundaries (its owner changes at least once on
 *    2 and 3 ranks, at least twice on 4); every rank holds particles at the start (the cuts balance them);
 *  - the state does change (the hash after the run differs from the start's);
 *  - a checkpoint written half way on N ranks (collective; rank 0 writes it) resumes on N - 1
 *    ranks (1 when N = 1) to the same final hash;
 *  - seeding by shares (sm_dist_seeding: a census build, then each rank builds its share only)
 *    leaves every rank the particles, order and fields of sm_world_distribute of the whole world,
 *    and 4 frames later the same state and traffic; misuse is refused;
 *  - the exchange overlapped with the binning and P2G of each rank's inner blocks (dist/overlap.c,
 *    on by default: the runs above; in 2D some particles are scattered that way), switched off,
 *    and made to redo every early scatter (the path of a particle arriving next to an inner
 *    block): the same final state; the recut's histogram sorted (its cuts ascend);
 *  - with the contact gate (contact_gap 0.35: the separating sphere and walls act only where
 *    material is near), the 2D explicit and implicit runs give the same bits on any number of
 *    ranks, and differ from the runs without it;
 *  - messages in pieces (dist/message.c; a rank's share can pass MPI's INT_MAX bytes): the 2D
 *    run sends every message, the checkpoint's gather included, in pieces of 997 bytes (prime: no
 *    piece boundary falls between particles), and rank 0's last message is several pieces. */
#include "test_util.h"
#include "sandmpm/sandmpm_mpi.h"
#include "dist/dist.h"

#include <stdlib.h>
#include <string.h>

#define FRAMES 12
#define FRAME_DT (1.0 / 120)

static int rank, ranks;
static sm_dist_seeding *seeding; /* build(): a census (seeding_census) or a share of it; NULL: neither */
static int seeding_census;
static sm_kernel kernel = SM_KERNEL_QUADRATIC; /* the explicit runs': the ghosts a particle needs depend on its support */
static double contact_gap = INFINITY; /* the contact gate (an OR over particles, ghosts included) */

static sm_world *build(int dim, int threads, size_t *ball_id, int implicit) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? (implicit ? 0.02 : 0.01) : 0.04;
    def.threads = threads;
    def.kernel = implicit ? SM_KERNEL_QUADRATIC : kernel;
    def.contact_gap = contact_gap;
    if (implicit) {
        def.integrator = SM_INTEGRATOR_IMPLICIT;
        def.gmres_preconditioner = dim == 3; /* both solver paths */
    }
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) return NULL;
    if (seeding) CHECK((seeding_census ? sm_world_seed_census(w, seeding) : sm_world_seed_share(w, seeding)) == SM_OK);
    sm_material_def m = sm_material_def_sand();
    int sand = -1, ball = -1;
    CHECK(sm_world_add_material(w, &m, &sand) == SM_OK);
    sm_material_def e = sm_material_def_elastic();
    CHECK(sm_world_add_material(w, &e, &ball) == SM_OK);
    sm_collider_def g = sm_test_ground(0.1);
    g.mode = SM_COLLIDE_SLIP;
    g.friction = 0.4;
    CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
    sm_collider_def s = sm_collider_def_default();
    s.shape_count = 1;
    s.shapes[0] = sm_shape_default(SM_SHAPE_SPHERE);
    s.shapes[0].center[0] = 0.75;
    s.shapes[0].center[1] = 0.22;
    s.shapes[0].center[2] = 0.5;
    s.shapes[0].radius = 0.08;
    s.velocity[0] = -1.5;
    s.mode = SM_COLLIDE_SEPARATE;
    s.friction = 0.2;
    CHECK(sm_world_add_collider(w, &s, NULL) == SM_OK);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = 0.45;
    box.center[1] = 0.28;
    box.center[2] = 0.5;
    box.half_extent[0] = box.half_extent[1] = box.half_extent[2] = 0.16;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = sand;
    sd.ppc = dim == 2 ? 4 : 8;
    CHECK(sm_world_seed_shape(w, &box, &sd, NULL) == SM_OK);
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    *ball_id = pv.n; /* ids are 0, 1, ... in order of insertion */
    sm_shape sph = sm_shape_default(SM_SHAPE_SPHERE);
    sph.center[0] = 0.12;
    sph.center[1] = 0.52;
    sph.center[2] = 0.5;
    sph.radius = 0.05;
    sd.material = ball;
    sd.velocity[0] = 7;
    sd.velocity[1] = -1;
    sd.method = SM_SEED_POISSON;
    CHECK(sm_world_seed_shape(w, &sph, &sd, NULL) == SM_OK);
    sm_emitter_def em = sm_emitter_def_default();
    em.shape = sm_shape_default(SM_SHAPE_SPHERE);
    em.shape.center[0] = 0.5;
    em.shape.center[1] = 0.85;
    em.shape.center[2] = 0.5;
    em.shape.radius = 0.04;
    em.material = sand;
    em.ppc = sd.ppc;
    em.velocity[1] = -2;
    em.rate = dim == 2 ? 20 : 200;
    em.stop = 1;
    CHECK(sm_world_add_emitter(w, &em, NULL) == SM_OK);
    return w;
}

static int memory_pread(void *user, uint64_t offset, void *data, size_t len) {
    const sm_test_membuf *b = user;
    if (offset > b->len || len > b->len - offset) return 1;
    memcpy(data, b->data + offset, len);
    return 0;
}

static int same_particles(const sm_world *a, const sm_world *b);

/* The checkpoint restored by shares (sm_world_restore_share) into a world built on every rank of
 * part with a census (none of its particles stored): a truncated stream is refused on every rank
 * and the world restored again from the whole one; it then holds what sm_world_load +
 * sm_world_distribute (loaded) left this rank. */
static sm_world *restore_by_shares(int dim, sm_test_membuf *ck, MPI_Comm part, const sm_world *loaded) {
    size_t ball_id = 0;
    CHECK(sm_dist_seeding_create(part, &seeding) == SM_OK);
    seeding_census = 1;
    sm_world *w = build(dim, 1, &ball_id, 0);
    sm_dist_seeding_destroy(seeding);
    seeding = NULL;
    seeding_census = 0;
    CHECK(w != NULL);
    if (!w) return NULL;
    sm_test_membuf cut = *ck;
    cut.len = ck->len / 2;
    CHECK(sm_world_restore_share(w, part, memory_pread, &cut, cut.len) == SM_ERR_INVALID); /* every rank */
    sm_dist_stats ds;
    CHECK(sm_world_dist_stats(w, &ds) == 0);
    CHECK(sm_world_restore_share(w, part, memory_pread, ck, ck->len) == SM_OK);
    CHECK(same_particles(w, loaded));
    CHECK(sm_world_restore_share(w, part, memory_pread, ck, ck->len) == SM_ERR_INVALID); /* distributed already */
    return w;
}

/* Resumes the checkpoint (rank 0's bytes) on ranks [0, M) and runs it to the end, loaded whole on
 * every rank then distributed, and restored by shares: the final id hash, the same on every rank
 * (0 on ranks past M) and for both ways. */
static uint64_t resume(int dim, sm_test_membuf *ck, int M) {
    unsigned long long len = ck->len;
    MPI_Bcast(&len, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
    if (rank != 0) {
        ck->data = malloc(len);
        ck->len = len;
    }
    MPI_Bcast(ck->data, (int)len, MPI_BYTE, 0, MPI_COMM_WORLD);
    MPI_Comm part;
    MPI_Comm_split(MPI_COMM_WORLD, rank < M ? 0 : MPI_UNDEFINED, rank, &part);
    uint64_t h = 0;
    if (part != MPI_COMM_NULL) {
        sm_world *w = NULL;
        char err[256];
        CHECK(sm_world_load(ck->data, ck->len, &w, err, sizeof err) == SM_OK);
        if (w) {
            CHECK(sm_world_distribute(w, part) == SM_OK);
            sm_world *s = restore_by_shares(dim, ck, part, w);
            for (int f = FRAMES / 2 + 1; f <= FRAMES; f++) {
                CHECK(sm_world_advance(w, f * FRAME_DT) == SM_OK);
                if (s) CHECK(sm_world_advance(s, f * FRAME_DT) == SM_OK);
            }
            h = sm_world_id_hash(w);
            if (s) CHECK(sm_world_id_hash(s) == h);
            sm_world_destroy(s);
            sm_world_destroy(w);
        }
        MPI_Comm_free(&part);
    }
    uint64_t all = 0;
    MPI_Allreduce(&h, &all, 1, MPI_UINT64_T, MPI_MAX, MPI_COMM_WORLD);
    return all;
}

/* This rank's particle count, mass and momentum (p[3], kg m/s), summed over the ranks (a world
 * not distributed: all = mine, pass comm_sum 0). */
static void totals(const sm_world *w, int comm_sum, double *count, double *mass, double p[3]) {
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    double mine[5] = {(double)pv.n, 0, 0, 0, 0}, all[5];
    for (size_t i = 0; i < pv.n; i++) {
        const double m = sm_world_particle_mass(w, i);
        mine[1] += m;
        for (int a = 0; a < pv.dim; a++) mine[2 + a] += m * (double)pv.v[i * (size_t)pv.dim + (size_t)a];
    }
    if (comm_sum) MPI_Allreduce(mine, all, 5, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    else memcpy(all, mine, sizeof all);
    *count = all[0];
    *mass = all[1];
    for (int a = 0; a < 3; a++) p[a] = all[2 + a];
}

/* The rank holding particle `id`, or -1. */
static int holder(const sm_world *w, size_t id) {
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    int mine = -1, all = -1;
    for (size_t i = 0; i < pv.n; i++)
        if (pv.id[i] == id) mine = rank;
    MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return all;
}


/* The ranks' id slices of w tile the id order, and their parts of the checkpoint stream, laid
 * over each other, are the bytes sm_world_save gathered on rank 0 (ck there), each byte written
 * by exactly one rank. */
typedef struct part_buf {
    unsigned char *data, *cover; /* the stream; 1 where this rank wrote */
    uint64_t len;
} part_buf;

static int part_write(void *user, uint64_t at, const void *data, size_t len) {
    part_buf *b = user;
    if (!b->data) return 0; /* the sizing pass */
    if (at + len > b->len) return 1;
    memcpy(b->data + at, data, len);
    for (size_t k = 0; k < len; k++) b->cover[at + k]++;
    return 0;
}

static void check_slices(const sm_world *w, const sm_test_membuf *ck) {
    sm_id_slice *s = NULL;
    CHECK(sm_world_id_slice(w, &s) == SM_OK);
    if (!s) return;
    sm_particles_view pv;
    sm_world_particles(sm_id_slice_world(s), &pv);
    uint64_t n = pv.n, first = sm_id_slice_first(s), total = 0;
    for (size_t i = 1; i < pv.n; i++) CHECK(pv.id[i - 1] < pv.id[i]);
    /* tiling: rank r's slice starts where rank r - 1's ends */
    uint64_t end = first + n, prev_end = 0;
    MPI_Sendrecv(&end, 1, MPI_UINT64_T, (rank + 1) % ranks, 5, &prev_end, 1, MPI_UINT64_T, (rank + ranks - 1) % ranks, 5,
                 MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    CHECK(first == (rank ? prev_end : 0));
    MPI_Allreduce(&n, &total, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
    CHECK(total == sm_id_slice_total(s));
    part_buf b = {NULL, NULL, 0};
    uint64_t len = 0;
    CHECK(sm_id_slice_save(s, part_write, &b, &len) == SM_OK);
    b.len = len;
    b.data = calloc(len, 1);
    b.cover = calloc(len, 1);
    unsigned char *all = malloc(len), *cover = malloc(len);
    CHECK(b.data && b.cover && all && cover);
    if (b.data && b.cover && all && cover) {
        uint64_t len2 = 0;
        CHECK(sm_id_slice_save(s, part_write, &b, &len2) == SM_OK && len2 == len);
        for (uint64_t at = 0; at < len; at += 1u << 30) { /* MPI counts are int */
            const int m = (int)(len - at < (1u << 30) ? len - at : (1u << 30));
            MPI_Allreduce(b.data + at, all + at, m, MPI_BYTE, MPI_BOR, MPI_COMM_WORLD);
            MPI_Allreduce(b.cover + at, cover + at, m, MPI_UNSIGNED_CHAR, MPI_SUM, MPI_COMM_WORLD);
        }
        int tiled = 1;
        for (uint64_t k = 0; k < len; k++) tiled &= cover[k] == 1;
        CHECK(tiled);
        if (rank == 0) {
            CHECK(len == ck->len);
            CHECK(len == ck->len && memcmp(all, ck->data, len) == 0);
            printf("%dD: the id slices' checkpoint parts (%llu bytes, rank 0's slice %llu of %llu particles) are the gathered "
                   "checkpoint's bytes\n",
                   w ? sm_world_get_def(w)->dim : 0, (unsigned long long)len, (unsigned long long)n,
                   (unsigned long long)total);
        }
    }
    free(b.data);
    free(b.cover);
    free(all);
    free(cover);
    sm_id_slice_destroy(s);
}

static uint64_t run(int dim) {
    size_t ball_id = 0;
    /* One rank, two threads: the reference. */
    uint64_t ref[1] = {0};
    double ref_p[FRAMES + 1][3]; /* the one-rank run's momentum after each frame */
    double ref_d[6] = {0};       /* its final diagnostics: particles, mass, kinetic energy, largest speed, com x, y */
    memset(ref_p, 0, sizeof ref_p);
    if (rank == 0) {
        sm_world *w = build(dim, 2, &ball_id, 0);
        CHECK(w != NULL);
        for (int f = 1; f <= FRAMES && w; f++) {
            CHECK(sm_world_advance(w, f * FRAME_DT) == SM_OK);
            double n, m;
            totals(w, 0, &n, &m, ref_p[f]);
        }
        ref[0] = sm_world_id_hash(w);
        sm_diagnostics dg;
        sm_world_diagnostics(w, &dg);
        const double r[6] = {(double)dg.particles, dg.total_mass, dg.kinetic_energy, dg.max_speed, dg.center_of_mass[0],
                             dg.center_of_mass[1]};
        memcpy(ref_d, r, sizeof r);
        sm_world_destroy(w);
    }
    MPI_Bcast(ref, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    MPI_Bcast(ref_d, 6, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    MPI_Bcast(ref_p, 3 * (FRAMES + 1), MPI_DOUBLE, 0, MPI_COMM_WORLD);

    sm_world *w = build(dim, 1, &ball_id, 0);
    CHECK(w != NULL);
    if (!w) return ref[0];
    const uint64_t h_start = sm_world_id_hash(w);
    double n0, m0, p0[3];
    totals(w, 1, &n0, &m0, p0); /* every rank holds every particle before sm_world_distribute */
    n0 /= ranks;
    m0 /= ranks;
    CHECK(sm_world_distribute(w, MPI_COMM_WORLD) == SM_OK);
    const size_t piece = dim == 2 ? 997 : 0; /* 0: the default, SM_DIST_PIECE */
    sm_dist_set_piece_bytes(w, piece);
    sm_particles_view pv;
    sm_world_particles(w, &pv);
    int empty = pv.n == 0, any_empty = 0;
    MPI_Allreduce(&empty, &any_empty, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    CHECK(!any_empty);
    int owner = holder(w, ball_id), changes = 0;
    double early = 0; /* particles scattered while the exchange's messages travelled, last step of each frame */
    CHECK(owner >= 0);
    sm_test_membuf ck = {NULL, 0, 0};
    for (int f = 1; f <= FRAMES; f++) {
        if (f == FRAMES / 2 + 1) {
            CHECK(sm_world_save(w, sm_test_mem_write, &ck) == SM_OK); /* collective */
            check_slices(w, &ck);
        }
        const sm_status st = sm_world_advance(w, f * FRAME_DT);
        CHECK(st == SM_OK);
        if (st != SM_OK) {
            fprintf(stderr, "rank %d: %s\n", rank, sm_world_errmsg(w));
            break;
        }
        double n, m, p[3];
        totals(w, 1, &n, &m, p);
        const double emitted = sm_world_emitted_mass(w, 0);
        CHECK(n > n0);
        CHECK_NEAR(m, m0 + emitted, (sm_real_is_double() ? 1e-12 : 1e-6) * (m0 + emitted)); /* particle masses in sm_real */
        /* Momentum across migration: the one-rank run's, to the rounding of the sums' order (the
         * state itself is bitwise the same: the hash below); 1 m/s of the mass as the scale. */
        for (int a = 0; a < dim; a++) CHECK_NEAR(p[a], ref_p[f][a], 1e-12 * m);
        const int now = holder(w, ball_id);
        CHECK(now >= 0);
        changes += now != owner;
        owner = now;
        sm_dist_stats fs;
        sm_world_dist_stats(w, &fs);
        early += (double)fs.early_particles; /* the frame's last step */
    }
    const uint64_t h = sm_world_id_hash(w);
    /* Diagnostics over the ranks (collective): the one-rank run's to the rounding of the sums'
     * order, counts and the largest speed exactly, the same bits on every rank. */
    sm_diagnostics dg;
    sm_world_diagnostics(w, &dg);
    CHECK(dg.particles == (size_t)ref_d[0]);
    CHECK_NEAR(dg.total_mass, ref_d[1], 1e-12 * ref_d[1]);
    CHECK_NEAR(dg.kinetic_energy, ref_d[2], 1e-12 * ref_d[2]);
    CHECK(dg.max_speed == ref_d[3]);
    CHECK_NEAR(dg.center_of_mass[0], ref_d[4], 1e-12);
    CHECK_NEAR(dg.center_of_mass[1], ref_d[5], 1e-12);
    double mine_d[2] = {dg.kinetic_energy, dg.center_of_mass[1]}, lo[2], hi[2];
    MPI_Allreduce(mine_d, lo, 2, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(mine_d, hi, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    CHECK(lo[0] == hi[0] && lo[1] == hi[1]);
    sm_dist_stats ds;
    CHECK(sm_world_dist_stats(w, &ds) == 1);
    CHECK(ds.ranks == ranks && ds.rank == rank);
    if (piece && ranks >= 2) CHECK(ds.bytes_sent > 3 * piece); /* rank 0 sent a message of several pieces */
    double early_all = 0;
    MPI_Allreduce(&early, &early_all, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    if (rank == 0)
        printf("%dD (%s kernel) on %d ranks: id hash %016llx (one rank, 2 threads: %016llx), the ball's owner changed %d times, "
               "rank 0: %zu particles, %zu ghosts and %zu migrating sent in the last step (%zu bytes, %zu messages), "
               "%llu cuts; %.0f particles scattered during the exchange (the frames' last steps, all ranks)\n",
               dim, kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic", ranks, (unsigned long long)h,
               (unsigned long long)ref[0], changes, ds.particles, ds.ghosts_sent,
               ds.migrated_sent, ds.bytes_sent, ds.messages_sent, (unsigned long long)ds.rebalances, early_all);
    /* The overlap ran (3D: the test's block is too small for inner blocks; one rank does not overlap). */
    if (dim == 2) CHECK((early_all > 0) == (ranks > 1));
    CHECK(h == ref[0]);
    CHECK(h != h_start);
    const int M = ranks > 1 ? ranks - 1 : 1;
    const uint64_t hr = resume(dim, &ck, M);
    free(ck.data);
    if (rank == 0)
        printf("%dD: the checkpoint of frame %d written on %d ranks, resumed on %d (whole and by shares): id hash %016llx\n", dim, FRAMES / 2,
               ranks, M, (unsigned long long)hr);
    CHECK(hr == ref[0]);
    if (ranks >= 2) CHECK(changes >= (ranks >= 4 ? 2 : 1)); /* several boundaries on 4 ranks */
    sm_world_destroy(w);
    return ref[0];
}

/* The exchange's overlap (dist/overlap.c) switched off (0), and forced to redo its early scatter
 * every step (2: the path taken when a particle arrives next to an inner block): the same final
 * state as the one-rank run `ref`; the public switch refuses what it should. */
static void run_overlap_modes(int dim, uint64_t ref) {
    for (int mode = 0; mode <= 2; mode += 2) {
        size_t ball_id = 0;
        sm_world *w = build(dim, 1, &ball_id, 0);
        CHECK(w != NULL);
        if (!w) return;
        CHECK(sm_world_set_dist_overlap(w, 1) == SM_ERR_INVALID); /* not distributed yet */
        CHECK(sm_world_distribute(w, MPI_COMM_WORLD) == SM_OK);
        CHECK(sm_world_set_dist_overlap(w, 2) == SM_ERR_INVALID);
        CHECK(sm_world_set_dist_overlap(w, mode ? 1 : 0) == SM_OK);
        sm_dist_set_overlap(w, mode);
        double early = 0;
        for (int f = 1; f <= FRAMES; f++) {
            CHECK(sm_world_advance(w, f * FRAME_DT) == SM_OK);
            sm_dist_stats ds;
            sm_world_dist_stats(w, &ds);
            early += (double)ds.early_particles;
        }
        const uint64_t h = sm_world_id_hash(w);
        sm_dist_stats ds;
        sm_world_dist_stats(w, &ds);
        double redone = (double)ds.overlap_redone, redone_all = 0;
        MPI_Allreduce(&redone, &redone_all, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
        if (rank == 0)
            printf("%dD on %d ranks, overlap mode %d: id hash %016llx (one rank: %016llx), early scatters redone %.0f times\n",
                   dim, ranks, mode, (unsigned long long)h, (unsigned long long)ref, redone_all);
        CHECK(h == ref);
        CHECK(early == 0); /* mode 0: none; mode 2: every early scatter redone (and not counted) */
        if (mode == 0) CHECK(redone_all == 0);
        else CHECK(redone_all > 0);
        sm_world_destroy(w);
    }
}

/* The particles of a and b the same (count, order, every field read here). */
static int same_particles(const sm_world *a, const sm_world *b) {
    sm_particles_view p, q;
    sm_world_particles(a, &p);
    sm_world_particles(b, &q);
    const size_t n = p.n, d = (size_t)p.dim, r = sizeof(sm_real);
    return n == q.n && !memcmp(p.id, q.id, n * sizeof *p.id) && !memcmp(p.x, q.x, n * d * sizeof *p.x) &&
           !memcmp(p.v, q.v, n * d * r) && !memcmp(p.F, q.F, n * d * d * r) && !memcmp(p.B, q.B, n * d * d * r) &&
           !memcmp(p.vol0, q.vol0, n * r) && !memcmp(p.q, q.q, n * r) && !memcmp(p.material, q.material, n * 2);
}

/* Seeding across ranks (sm_dist_seeding): a census build, then each rank builds only its share;
 * every rank then holds what sm_world_distribute of the whole world leaves it (the same particles
 * in the same order, fields and ids), and the run goes on with the same bits and traffic; misuse
 * is refused. */
static void run_seeded(int dim) {
    size_t ball_id = 0;
    sm_world *whole = build(dim, 1, &ball_id, 0);
    CHECK(whole != NULL);
    if (!whole) return;
    sm_particles_view pv;
    sm_world_particles(whole, &pv);
    const size_t total = pv.n;
    CHECK(sm_world_distribute(whole, MPI_COMM_WORLD) == SM_OK);
    CHECK(sm_dist_seeding_create(MPI_COMM_WORLD, &seeding) == SM_OK);
    seeding_census = 1;
    sm_world *census = build(dim, 1, &ball_id, 0);
    CHECK(census != NULL);
    sm_world_particles(census, &pv);
    CHECK(pv.n == 0); /* counted, not stored */
    CHECK(sm_world_seed_share(census, seeding) == SM_ERR_INVALID); /* a world with particles (ids given) */
    sm_world_destroy(census);
    seeding_census = 0;
    sm_world *share = build(dim, 1, &ball_id, 0); /* sm_world_seed_share: collective */
    CHECK(share != NULL);
    sm_world_particles(share, &pv);
    if (ranks > 1) CHECK(pv.n < total);
    CHECK(same_particles(whole, share)); /* before either steps */
    CHECK(sm_world_distribute_share(share, seeding) == SM_OK);
    sm_dist_seeding_destroy(seeding);
    seeding = NULL;
    CHECK(same_particles(whole, share));
    for (int f = 1; f <= 4; f++) {
        CHECK(sm_world_advance(whole, f * FRAME_DT) == SM_OK);
        CHECK(sm_world_advance(share, f * FRAME_DT) == SM_OK);
    }
    CHECK(same_particles(whole, share));
    const uint64_t hw = sm_world_id_hash(whole), hs = sm_world_id_hash(share);
    CHECK(hw == hs);
    sm_dist_stats a, b;
    sm_world_dist_stats(whole, &a);
    sm_world_dist_stats(share, &b);
    CHECK(a.bytes_sent == b.bytes_sent && a.rebalances == b.rebalances);
    if (rank == 0)
        printf("%dD seeded by shares on %d ranks: rank 0 built %zu of %zu particles; after 4 frames id hash %016llx "
               "(whole world distributed: %016llx)\n",
               dim, ranks, pv.n, total, (unsigned long long)hs, (unsigned long long)hw);
    /* Misuse: a share without a census; a world that did not join, handed to sm_world_distribute_share. */
    sm_dist_seeding *s2 = NULL;
    CHECK(sm_dist_seeding_create(MPI_COMM_WORLD, &s2) == SM_OK);
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    sm_world *plain = NULL;
    char err[256];
    CHECK(sm_world_create(&def, &plain, err, sizeof err) == SM_OK);
    CHECK(sm_world_seed_share(plain, s2) == SM_ERR_INVALID);
    CHECK(sm_world_distribute_share(plain, s2) == SM_ERR_INVALID); /* collective: every rank refuses */
    sm_dist_seeding_destroy(s2);
    sm_world_destroy(plain);
    sm_world_destroy(share);
    sm_world_destroy(whole);
}

/* The implicit integrator on N ranks: the one-rank bits (2 threads there, 1 per rank here), the
 * Newton and GMRES counts of rank 0 equal to the one-rank run's, and grid traffic between ranks. */
static void run_implicit(int dim, int frames) {
    size_t ball_id = 0;
    uint64_t ref[3] = {0, 0, 0};
    if (rank == 0) {
        sm_world *w = build(dim, 2, &ball_id, 1);
        CHECK(w != NULL);
        for (int f = 1; f <= frames && w; f++) CHECK(sm_world_advance(w, f * FRAME_DT) == SM_OK);
        sm_diagnostics dg;
        sm_world_diagnostics(w, &dg);
        ref[0] = sm_world_id_hash(w);
        ref[1] = dg.newton_iterations;
        ref[2] = dg.gmres_iterations;
        sm_world_destroy(w);
    }
    MPI_Bcast(ref, 3, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    sm_world *w = build(dim, 1, &ball_id, 1);
    CHECK(w != NULL);
    if (!w) return;
    CHECK(sm_world_distribute(w, MPI_COMM_WORLD) == SM_OK);
    size_t halo_bytes = 0;
    for (int f = 1; f <= frames; f++) {
        const sm_status st = sm_world_advance(w, f * FRAME_DT);
        CHECK(st == SM_OK);
        if (st != SM_OK) {
            fprintf(stderr, "rank %d: %s\n", rank, sm_world_errmsg(w));
            break;
        }
        sm_dist_stats ds;
        sm_world_dist_stats(w, &ds);
        halo_bytes += ds.halo_bytes_sent;
    }
    sm_diagnostics dg;
    sm_world_diagnostics(w, &dg);
    const uint64_t h = sm_world_id_hash(w);
    size_t all_halo = 0;
    MPI_Allreduce(&halo_bytes, &all_halo, 1, MPI_UNSIGNED_LONG, MPI_SUM, MPI_COMM_WORLD);
    if (rank == 0)
        printf("%dD implicit on %d ranks: id hash %016llx (one rank, 2 threads: %016llx), Newton %llu (%llu), GMRES %llu "
               "(%llu), grid halo %zu bytes sent by all ranks\n",
               dim, ranks, (unsigned long long)h, (unsigned long long)ref[0], (unsigned long long)dg.newton_iterations,
               (unsigned long long)ref[1], (unsigned long long)dg.gmres_iterations, (unsigned long long)ref[2], all_halo);
    CHECK(h == ref[0]);
    CHECK(dg.newton_iterations == ref[1] && dg.gmres_iterations == ref[2]);
    CHECK(dg.newton_iterations > 0);
    if (ranks >= 2) CHECK(all_halo > 0);
    sm_world_destroy(w);
}

int main(int argc, char **argv) {
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    const uint64_t ref2 = run(2);
    run_overlap_modes(2, ref2);
    run(3);
    kernel = SM_KERNEL_CUBIC; /* a stencil of 4: more of a block's particles reach the next block */
    run(2);
    kernel = SM_KERNEL_QUADRATIC;
    run_implicit(2, 3);
    run_implicit(3, 2);
    contact_gap = 0.35; /* the gate on the separating sphere and walls: the same bits on any number of ranks */
    const uint64_t gated = run(2);
    CHECK(gated != ref2); /* the gate acted */
    run_implicit(2, 3);
    contact_gap = INFINITY;
    run_seeded(2);
    run_seeded(3);
    int mine = sm_test_failures, all = 0;
    MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    MPI_Finalize();
    return all ? 1 : 0;
}
