/* The plasticity stage flushes subnormal numbers to zero on every thread and gives the caller's
 * floating-point mode back (core/fpmode.h):
 *  - a 3D sand block dropped on the ground, stepped with the caller's default mode, and the same
 *    world stepped by a caller that flushes subnormals itself (x86: MXCSR FTZ | DAZ) on 2 threads,
 *    have the same state hash (in the float build the fixed Jacobi sweeps do reach subnormal
 *    numbers here: without the stage's flush the two hashes differ);
 *  - after every step the caller's mode is the one it had before. */
#include "test_util.h"
#include "sandmpm/sandmpm.h"

#if defined(__SSE2__)
#include <xmmintrin.h>
#define CSR_MODE_BITS 0xffc0u /* rounding, flush and mask bits; not the sticky exception flags */
static unsigned csr_mode(void) { return _mm_getcsr() & CSR_MODE_BITS; }
static void set_flush(int on) {
    const unsigned c = _mm_getcsr();
    _mm_setcsr(on ? (c | 0x8040u) : (c & ~0x8040u));
}
#else
static unsigned csr_mode(void) { return 0; }
static void set_flush(int on) { (void)on; }
#endif

static sm_world *build(int threads) {
    sm_world_def def = sm_world_def_default();
    def.dim = 3;
    def.dx = 0.04;
    def.threads = threads;
    const double c[3] = {0.5, 0.45, 0.5}, h[3] = {0.12, 0.2, 0.12};
    return sm_test_sand_box(&def, 0.2, c, h);
}

/* Steps w `steps` times, checking after each that the caller's mode is unchanged. */
static void run(sm_world *w, int steps) {
    const unsigned mode = csr_mode();
    int kept = 1;
    for (int s = 0; s < steps; s++) {
        CHECK(sm_world_step(w, sm_world_next_dt(w, 1.0)) == SM_OK);
        kept &= csr_mode() == mode;
    }
    CHECK(kept);
}

int main(void) {
    const int steps = 60;
    sm_world *a = build(1), *b = build(2);
    if (!a || !b) return sm_test_summary("test_fpmode");
    set_flush(0);
    run(a, steps);
    set_flush(1);
    run(b, steps);
    set_flush(0);
    const uint64_t ha = sm_world_state_hash(a), hb = sm_world_state_hash(b);
    sm_particles_view pv;
    sm_world_particles(a, &pv);
    printf("%zu particles, %d steps: caller's default mode %016llx, caller flushing %016llx\n", pv.n, steps,
           (unsigned long long)ha, (unsigned long long)hb);
    CHECK(ha == hb);
    sm_world_destroy(a);
    sm_world_destroy(b);
    return sm_test_summary("test_fpmode");
}
