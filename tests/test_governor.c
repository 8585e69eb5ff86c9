/* The thread governor (src/integrate/governor.h) on simulated machines, and on a real world.
 *
 * A simulated machine gives each step a wall time per particle for 1 and for 2 threads; the
 * governor's choices are then a pure function of those times, so its behaviour can be asserted:
 *   - quiet machine (2 threads twice as fast): stays on 2 threads, total time within 2% of
 *     always-2 (probes of 1 thread end after one step);
 *   - loaded machine (a descheduled thread stalls every barrier: 2 threads 100x slower, as
 *     measured with a 64-particle block beside a load of 14): moves to 1 thread after its first
 *     window and stays; once its probes have backed off, time within 5% of always-1;
 *   - a load that comes and goes: the governor follows it both ways;
 *   - near-equal candidates (within the 5% hysteresis) do not make it flip back and forth;
 *   - a machine where 2 threads are usually faster but one step in four stalls for 150 steps'
 *     time (as measured beside one busy process: 73 ms against 0.45 ms per step): 1 thread, and
 *     its probes of 2 threads cost at most ~2% of the run (the probe budget);
 *   - one thread to choose from: always 1.
 * And a real world with def.threads = 0 gives the same state hash as with 1 and with 2 threads,
 * whatever the governor chose. */
#include <math.h>
#include <string.h>

#include "integrate/governor.h"
#include "sandmpm/sandmpm.h"
#include "test_util.h"

#define N 1000 /* particles per simulated step */

/* Runs `steps` simulated steps with per-particle times c1 (1 thread) and c2 (2 threads); returns
 * the total time and the steps run with 1 thread. */
static double simulate(sm_governor *g, long steps, double c1, double c2, long *one) {
    double total = 0;
    for (long s = 0; s < steps; s++) {
        const int t = sm_governor_threads(g);
        CHECK(t == 1 || t == 2);
        const double sec = (t == 1 ? c1 : c2) * N;
        if (t == 1) (*one)++;
        total += sec;
        sm_governor_record(g, sec, N);
    }
    return total;
}

/* Like simulate, but 2 threads take c2 per particle except every 4th step on 2 threads, which
 * stalls for `stall` seconds. */
static double simulate_stalls(sm_governor *g, long steps, double c1, double c2, double stall) {
    double total = 0;
    long twos = 0;
    for (long s = 0; s < steps; s++) {
        const int t = sm_governor_threads(g);
        double sec = (t == 1 ? c1 : c2) * N;
        if (t == 2 && twos++ % 4 == 3) sec += stall;
        total += sec;
        sm_governor_record(g, sec, N);
    }
    return total;
}

static void stalls(void) {
    sm_governor g;
    sm_governor_init(&g, 2);
    const long steps = 60000;
    const double t = simulate_stalls(&g, steps, 1.0, 0.9, 150.0 * N);
    printf("stalls: time %.4f x always-1, %llu switches\n", t / (steps * 1.0 * N), (unsigned long long)g.switches);
    CHECK(g.current == 1);
    CHECK(t <= 1.03 * steps * 1.0 * N);
}

static void quiet_and_loaded(void) {
    sm_governor g;
    long one = 0;
    sm_governor_init(&g, 2);
    double t = simulate(&g, 20000, 1.0, 0.5, &one);
    printf("quiet: %ld of 20000 steps on 1 thread, time %.4f x always-2, %llu switches\n", one, t / (20000 * 0.5 * N),
           (unsigned long long)g.switches);
    CHECK(t <= 1.02 * 20000 * 0.5 * N);
    CHECK(g.current == 2 && g.switches == 0);

    one = 0;
    sm_governor_init(&g, 2);
    t = simulate(&g, 20000, 1.0, 100.0, &one);
    printf("loaded: %ld of 20000 steps on 1 thread, time %.4f x always-1, %llu switches\n", one, t / (20000 * 1.0 * N),
           (unsigned long long)g.switches);
    CHECK(g.current == 1 && g.switches == 1);
    CHECK(one >= 20000 - 40); /* the warm-up, the first window and one-step probes on 2 threads */
    /* Once the probes have backed off: a probe (one 100x step) every 4096 steps. */
    const double t2 = simulate(&g, 40960, 1.0, 100.0, &one);
    printf("loaded, next 40960 steps: time %.4f x always-1\n", t2 / (40960 * 1.0 * N));
    CHECK(t2 <= 1.05 * 40960 * 1.0 * N);

    /* The load comes and goes: quiet, loaded, quiet, 20000 steps each. */
    one = 0;
    sm_governor_init(&g, 2);
    simulate(&g, 20000, 1.0, 0.5, &one);
    CHECK(g.current == 2);
    simulate(&g, 20000, 1.0, 100.0, &one);
    CHECK(g.current == 1);
    simulate(&g, 20000, 1.0, 0.5, &one);
    CHECK(g.current == 2);
    printf("load comes and goes: %llu switches\n", (unsigned long long)g.switches);
    CHECK(g.switches == 2);

    /* Near-equal: 1 thread 3% faster: inside the hysteresis, no flip-flop. */
    one = 0;
    sm_governor_init(&g, 2);
    simulate(&g, 20000, 0.97, 1.0, &one);
    CHECK(g.switches == 0);

    sm_governor_init(&g, 1);
    one = 0;
    simulate(&g, 100, 1.0, 1.0, &one);
    CHECK(one == 100);
}

/* A small 2D column, 200 steps, with the given def.threads: its state hash. */
static uint64_t column_hash(int threads, sm_diagnostics *diag) {
    sm_world_def def = sm_world_def_default();
    def.dim = 2;
    def.dx = 0.02;
    def.threads = threads;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "world: %s\n", err);
        CHECK(0);
        return 0;
    }
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = 0.3, box.center[1] = 0.25;
    box.half_extent[0] = 0.1, box.half_extent[1] = 0.2;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    CHECK(sm_world_seed_shape(w, &box, &sd, NULL) == SM_OK);
    for (int s = 0; s < 200; s++) CHECK(sm_world_step(w, 2e-4) == SM_OK);
    sm_world_diagnostics(w, diag);
    const uint64_t h = sm_world_state_hash(w);
    sm_world_destroy(w);
    return h;
}

int main(void) {
    quiet_and_loaded();
    stalls();
    sm_diagnostics d0, d1, d2;
    const uint64_t h0 = column_hash(0, &d0), h1 = column_hash(1, &d1), h2 = column_hash(2, &d2);
    printf("column: %zu particles, hash %016llx (threads 0: %d threads at the end, %llu switches)\n", d0.particles,
           (unsigned long long)h0, d0.threads, (unsigned long long)d0.thread_switches);
    CHECK(d0.particles > 100);
    CHECK(h0 == h1 && h0 == h2);
    CHECK(d1.threads == 1 && d2.threads == 2 && d1.thread_switches == 0);
    CHECK(d0.threads >= 1);
    return sm_test_summary("test_governor");
}
