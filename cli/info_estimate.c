/* sandmpm info: what a run of the scene will cost, from a short timed probe of the built world
 * (issue 17 item 5; docs/outputs.md "What a run costs").
 *
 *   time    steps between T/dt_start (the speeds stay as they start) and T/dt_low + frames (one short step
 *           at each frame end),
 *           dt_low = min(dt_start, cfl dx / (v_start + sqrt(2 |g| H))), H the domain's extent
 *           along gravity (no grain falls farther than the domain is tall); seconds per
 *           particle-step measured over the probe's steps after its first, times the particles
 *           at the start (low) and at the end with emitters (high). Output writing is not in it.
 *   disk    per frame N (46 B PLY + 62 B VTK) plus their headers, for frames + 1 frames at the
 *           mean particle count, and the kept checkpoints (the stream of N particles each).
 *   memory  the probe's resident memory after its steps, plus what the run adds: the world's
 *           growth to the final particle count, the copy of the last frame's state that the
 *           checkpoints keep (one stream), and the frame writers' buffers (VTK: 62 B of arrays and
 *           8 B of id order per particle; PLY only: the 8 B order); or the probe's peak, if higher. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli/cli.h"

#define PLY_RECORD 46.0 /* app/io/ply_write.c */
#define PLY_HEADER 420.0
#define VTK_RECORD 62.0 /* app/io/vtk_write.c: 3+3 floats, 4 floats, ushort, uint, 2 int64 */
#define VTK_HEADER 1400.0
#define PROBE_SECONDS 1.0
#define PROBE_MAX_STEPS 50

static double now_seconds(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Resident memory now (/proc/self/statm), bytes; 0 if unknown. */
static double resident_bytes(void) {
    FILE *f = fopen("/proc/self/statm", "r");
    long size = 0, pages = 0;
    int ok = f && fscanf(f, "%ld %ld", &size, &pages) == 2;
    if (f) fclose(f);
    return ok ? (double)pages * (double)sysconf(_SC_PAGESIZE) : 0;
}

static int count_bytes(void *user, const void *data, size_t n) {
    (void)data;
    *(double *)user += (double)n;
    return 0;
}

/* One step as the run takes it: sm_world_advance over the next dt (a refused dt is covered in
 * smaller steps, as in the run). */
static sm_status probe_step(sm_world *w) {
    return sm_world_advance(w, sm_world_time(w) + sm_world_next_dt(w, INFINITY));
}

/* Steps until PROBE_SECONDS have passed (at least 3, at most PROBE_MAX_STEPS): the seconds and
 * particle-steps of all but the first (which allocates what the steps reuse). */
static sm_status probe_steps(sm_world *w, int *steps, double *seconds, double *particle_steps) {
    *steps = 0, *seconds = 0, *particle_steps = 0;
    double t0 = now_seconds(), t1 = t0;
    for (int k = 0; k < PROBE_MAX_STEPS && (k < 3 || now_seconds() - t0 < PROBE_SECONDS); k++) {
        sm_diagnostics d;
        sm_world_diagnostics(w, &d);
        sm_status st = probe_step(w);
        if (st != SM_OK) return st;
        double t = now_seconds();
        if (k > 0) *seconds += t - t1, *particle_steps += (double)d.particles;
        t1 = t;
        ++*steps;
    }
    return SM_OK;
}

/* The low dt: the fastest start plus a fall through the whole domain, against the CFL number. */
static double dt_low(sm_world *w, double dt_start, double v_start) {
    const sm_world_def *d = sm_world_get_def(w);
    double g = 0, h = 0;
    for (int a = 0; a < d->dim; a++) g += d->gravity[a] * d->gravity[a];
    g = sqrt(g);
    for (int a = 0; a < d->dim && g > 0; a++) h += fabs(d->gravity[a]) / g * (d->domain_max[a] - d->domain_min[a]);
    double v = v_start + sqrt(2 * g * h);
    return v > 0 ? fmin(dt_start, d->cfl * d->dx / v) : dt_start;
}

static void print_seconds(double s) {
    if (s < 120) printf("%.3g s", s);
    else if (s < 7200) printf("%.3g min", s / 60);
    else printf("%.3g h", s / 3600);
}

static void print_time(const sm_scene_settings *st, double dt0, double dtl, double n0, double nf, double cost) {
    const double T = st->end_time;
    const double lo = ceil(T / dt0), hi = ceil(T / dtl) + st->frames; /* + a short step per frame end */
    printf("run time     about ");
    print_seconds(lo * cost * n0);
    if (hi * cost * nf > 1.05 * lo * cost * n0) {
        printf(" to ");
        print_seconds(hi * cost * nf);
    }
    if (hi > lo) printf(": %.0f to %.0f steps (dt %.3g to %.3g s)", lo, hi, dt0, dtl);
    else printf(": %.0f steps (dt %.3g s)", lo, dt0);
    if (nf > n0) printf(", %.0f to %.0f particles", n0, nf);
    else printf(", %.0f particles", n0);
    printf("; output not included\n");
}

/* Frames and checkpoints on disk, at the mean particle count. */
static void print_disk(const sm_scene_settings *st, double n0, double nf, double stream) {
    const double ply = st->out_ply ? PLY_HEADER + PLY_RECORD * nf : 0, vtk = st->out_vtk ? VTK_HEADER + VTK_RECORD * nf : 0;
    const double mean = 0.5 * (n0 + nf), frames = st->frames + 1.0;
    const double per_mean = (st->out_ply ? PLY_HEADER + PLY_RECORD * mean : 0) + (st->out_vtk ? VTK_HEADER + VTK_RECORD * mean : 0);
    const int every = st->checkpoint_every >= 0 ? st->checkpoint_every : CLI_CHECKPOINT_EVERY;
    const int written = every > 0 ? st->frames / every : 0, kept = written < CLI_KEEP_CHECKPOINTS ? written : CLI_KEEP_CHECKPOINTS;
    const double ckpt = kept * (stream + 28);
    const double total = frames * per_mean + ckpt + (st->out_csv ? frames * 400.0 : 0);
    printf("disk         %.3g MB per frame (PLY %.3g, VTK %.3g), %d checkpoint%s of %.3g MB kept; %.3g GB for %d frames "
           "(%.0f bytes; renders not included)\n",
           (ply + vtk) / 1e6, ply / 1e6, vtk / 1e6, kept, kept == 1 ? "" : "s", (stream + 28) / 1e6, total / 1e9,
           st->frames + 1, total);
}

static void print_memory(const sm_scene_settings *st, sm_world *w, double n0, double nf, double stream) {
    const int dim = sm_world_get_def(w)->dim;
    const double world = (double)sm_world_memory_bytes(w), resident = resident_bytes(), peak = cli_peak_memory_bytes();
    const double per = n0 > 0 ? world / n0 : (double)sm_particle_bytes(dim);
    const double grow = (nf - n0) * per;
    const double every = st->checkpoint_every >= 0 ? st->checkpoint_every : CLI_CHECKPOINT_EVERY;
    const double last = every > 0 ? (n0 > 0 ? stream * nf / n0 : stream + nf * per) : 0;
    const double out = nf * (st->out_vtk ? VTK_RECORD + 8 : st->out_ply ? 8 : 0);
    const double run = fmax(peak, resident + grow + last + out);
    printf("memory       %.3g MB at the peak (world %.3g MB at the end, last frame's state %.3g, frame writer %.3g, "
           "the rest %.3g; the probe's peak %.3g MB)\n",
           run / 1e6, (world + grow) / 1e6, last / 1e6, out / 1e6, (resident - world) / 1e6, peak / 1e6);
}

sm_status cli_info_estimates(sm_scene *sc) {
    sm_world *w = sm_scene_world(sc);
    const sm_scene_settings *st = sm_scene_get_settings(sc);
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    const double n0 = (double)d.particles, nf = n0 + (double)st->estimated_emitted;
    const double dt0 = sm_world_next_dt(w, INFINITY), dtl = dt_low(w, dt0, d.max_speed);
    double stream = 0;
    sm_world_save(w, count_bytes, &stream);
    int steps;
    double seconds, particle_steps;
    sm_status s = probe_steps(w, &steps, &seconds, &particle_steps);
    if (s != SM_OK) {
        fprintf(stderr, "sandmpm info: the probe's step %d failed (%s): the run would fail too\n", steps + 1, sm_status_string(s));
        return s;
    }
    const double cost = particle_steps > 0 ? seconds / particle_steps : 0;
    sm_world_diagnostics(w, &d);
    printf("probe        %d steps in %.3g s (%.3g particle-steps/s after the first, %d thread%s)\n", steps, seconds,
           cost > 0 ? 1 / cost : 0, d.threads, d.threads == 1 ? "" : "s");
    const double stream_f = n0 > 0 ? stream * nf / n0 : stream + nf * (double)sm_particle_bytes(sm_world_get_def(w)->dim);
    if (cost > 0) print_time(st, dt0, dtl, n0, nf, cost);
    else printf("run time     not estimated: no particles at the start to time the steps with\n");
    print_disk(st, n0, nf, stream_f);
    print_memory(st, w, n0, nf, stream);
    return SM_OK;
}
