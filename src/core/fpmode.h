/* Subnormal numbers flushed to zero inside a stage (x86: MXCSR's FTZ and DAZ bits).
 *
 * The plasticity stage's fixed Jacobi sweeps (material/plastic_batch.c) square off-diagonal
 * entries that have already converged, down to subnormal numbers; on Intel cores every vector
 * operation with a subnormal input or result takes a microcode assist (~100+ cycles), which made
 * the 3D stage 5-8x slower there than on AMD cores (docs/benchmarks.md, 2026-12-03). With FTZ and
 * DAZ such values are zero: a change far below rounding of the results, the same on every thread,
 * and the stage's bits no longer depend on whether the caller flushes them. The caller's mode is
 * restored when the stage ends. On other processors this does nothing. */
#ifndef SM_CORE_FPMODE_H
#define SM_CORE_FPMODE_H

#if defined(__SSE2__)
#include <xmmintrin.h>
#define SM_MXCSR_FTZ_DAZ 0x8040u /* flush to zero (bit 15), denormals are zero (bit 6) */
#endif

typedef unsigned sm_fpmode;

/* Sets flush-to-zero for this thread; returns the mode to give back to sm_fpmode_restore. */
static inline sm_fpmode sm_fpmode_flush_subnormals(void) {
#if defined(__SSE2__)
    const unsigned old = _mm_getcsr();
    _mm_setcsr(old | SM_MXCSR_FTZ_DAZ);
    return old;
#else
    return 0;
#endif
}

static inline void sm_fpmode_restore(sm_fpmode old) {
#if defined(__SSE2__)
    _mm_setcsr(old);
#else
    (void)old;
#endif
}

#endif
