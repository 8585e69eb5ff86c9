/* Scaling of a distributed run (issue 19, docs/scaling.md): a 3D (or 2D) sand block collapsing
 * on the ground, on however many ranks mpirun starts, a fixed dt; rank 0 prints one CSV row.
 *   mpirun -np R mpi_scaling DIM strong|weak|implicit PARTICLES STEPS THREADS [OVERLAP]
 * strong: PARTICLES in total; weak: PARTICLES per rank; implicit: strong scaling of the implicit
 * integrator (Newton-GMRES, dt 1e-3 instead of 2e-5; its grid halo counts in the bytes and
 * messages); OVERLAP 0 turns off the overlap of the explicit step's exchange with the binning and
 * P2G of each rank's inner blocks (sm_world_set_dist_overlap; default 1). Columns: dim, mode, ranks, threads per
 * rank, particles, steps, seconds (the slowest rank), particle-steps/s, per step: ghosts sent,
 * particles migrating, bytes and messages (summed over the ranks), the largest rank's particles
 * over the mean, re-cuts; then seconds per stage (the slowest rank's), sm_stage_name order; then the
 * slowest rank's seconds blocked on the exchange's messages (sm_dist_stats.exchange_wait_s), the
 * overlap setting and the particles scattered while the messages travelled, per step (summed over
 * the ranks). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sandmpm/sandmpm_mpi.h"

static sm_world *build(int dim, double particles, int threads, int implicit) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    if (implicit) def.integrator = SM_INTEGRATOR_IMPLICIT;
    def.dx = dim == 3 ? 0.01 : 0.002;
    def.threads = threads;
    def.max_particles = 0;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "%s\n", err);
        return NULL;
    }
    sm_material_def m = sm_material_def_sand();
    int sand = -1;
    sm_world_add_material(w, &m, &sand);
    const double ppc = dim == 3 ? 8 : 4;
    const double side = def.dx * pow(particles / ppc, 1.0 / dim); /* a cube (square) of that many */
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = 0.5;
    box.center[1] = 0.04 + side / 2;
    box.center[2] = 0.5;
    for (int a = 0; a < 3; a++) box.half_extent[a] = fmin(side / 2, 0.45);
    sm_seed_def sd = sm_seed_def_default();
    sd.material = sand;
    sd.ppc = ppc;
    if (sm_world_seed_shape(w, &box, &sd, NULL) != SM_OK) {
        fprintf(stderr, "%s\n", sm_world_errmsg(w));
        sm_world_destroy(w);
        return NULL;
    }
    return w;
}

int main(int argc, char **argv) {
    MPI_Init(&argc, &argv);
    int rank, ranks;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    if (argc == 2 && !strcmp(argv[1], "--stage-names")) { /* the CSV header's stage columns */
        for (int s = 0; s < SM_STAGE_COUNT; s++) printf(",%s_s", sm_stage_name((sm_stage)s));
        MPI_Finalize();
        return 0;
    }
    if ((argc != 6 && argc != 7) || (strcmp(argv[2], "strong") && strcmp(argv[2], "weak") && strcmp(argv[2], "implicit"))) {
        if (rank == 0) fprintf(stderr, "usage: mpirun -np R mpi_scaling DIM strong|weak|implicit PARTICLES STEPS THREADS [OVERLAP]\n");
        MPI_Finalize();
        return 2;
    }
    const int dim = atoi(argv[1]), steps = atoi(argv[4]), threads = atoi(argv[5]);
    const int weak = !strcmp(argv[2], "weak"), implicit = !strcmp(argv[2], "implicit");
    const double n = atof(argv[3]) * (weak ? ranks : 1);
    sm_world *w = build(dim, n, threads, implicit);
    const int overlap = argc == 7 ? atoi(argv[6]) : 1;
    if (!w || sm_world_distribute(w, MPI_COMM_WORLD) != SM_OK || sm_world_set_dist_overlap(w, overlap) != SM_OK)
        MPI_Abort(MPI_COMM_WORLD, 1);
    const double dt = implicit ? 1e-3 : 2e-5;
    for (int s = 0; s < (implicit ? 1 : 5); s++) sm_world_step(w, dt); /* warm-up: caches, first re-cut */
    sm_diagnostics d0, d1;
    sm_world_diagnostics(w, &d0);
    double sums[5] = {0, 0, 0, 0, 0}, imbalance = 0, wait = 0;
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    for (int s = 0; s < steps; s++) {
        if (sm_world_step(w, dt) != SM_OK) MPI_Abort(MPI_COMM_WORLD, 1);
        sm_dist_stats ds;
        sm_world_dist_stats(w, &ds);
        sums[0] += (double)ds.ghosts_sent;
        sums[1] += (double)ds.migrated_sent;
        sums[2] += (double)(ds.bytes_sent + ds.halo_bytes_sent);
        sums[3] += (double)(ds.messages_sent + ds.halo_messages_sent);
        sums[4] += (double)ds.early_particles;
        imbalance += ds.mean_particles > 0 ? (double)ds.max_particles / ds.mean_particles : 1;
        wait += ds.exchange_wait_s;
    }
    const double mine = MPI_Wtime() - t0;
    sm_world_diagnostics(w, &d1);
    double secs = 0, all[5], stage[SM_STAGE_COUNT], stage_max[SM_STAGE_COUNT];
    MPI_Reduce(&mine, &secs, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    MPI_Reduce(sums, all, 5, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
    for (int s = 0; s < SM_STAGE_COUNT; s++) stage[s] = d1.stage_seconds[s] - d0.stage_seconds[s];
    MPI_Reduce(stage, stage_max, SM_STAGE_COUNT, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    double wait_max = 0;
    MPI_Reduce(&wait, &wait_max, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    sm_dist_stats ds;
    sm_world_dist_stats(w, &ds);
    double total = (double)ds.particles, total_all = 0;
    MPI_Reduce(&total, &total_all, 1, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
    if (rank == 0) {
        printf("%d,%s,%d,%d,%.0f,%d,%.4f,%.4g,%.1f,%.2f,%.0f,%.2f,%.3f,%llu", dim, argv[2], ranks, threads,
               total_all, steps, secs, total_all * steps / secs, all[0] / steps, all[1] / steps, all[2] / steps,
               all[3] / steps, imbalance / steps, (unsigned long long)ds.rebalances);
        for (int s = 0; s < SM_STAGE_COUNT; s++) printf(",%.4f", stage_max[s]);
        printf(",%.4f,%d,%.0f\n", wait_max, overlap, all[4] / steps);
    }
    sm_world_destroy(w);
    MPI_Finalize();
    return 0;
}
