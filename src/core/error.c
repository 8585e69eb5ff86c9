/* Tier-1 assertion failures (DESIGN §5): a broken invariant is a bug in the caller or in the
 * library; there is no sane way to continue, so abort (the one place the library stops). */
#include <stdio.h>
#include <stdlib.h>

#include "core/common.h"

void sm_assert_fail(const char *expr, const char *file, int line) {
    fprintf(stderr, "sandmpm: internal assertion failed: %s (%s:%d)\n", expr, file, line);
    abort();
}

/* Heap allocations go through these counters (sm_allocation_count, public API): the benchmark
 * and the tests check that a simulation in its steady state allocates nothing per step. */
#include <stdatomic.h>

static atomic_ullong sm_allocs;

void *sm_malloc(size_t n) {
    atomic_fetch_add_explicit(&sm_allocs, 1, memory_order_relaxed);
    return malloc(n);
}

void *sm_calloc(size_t n, size_t size) {
    atomic_fetch_add_explicit(&sm_allocs, 1, memory_order_relaxed);
    return calloc(n, size);
}

void *sm_realloc(void *p, size_t n) {
    atomic_fetch_add_explicit(&sm_allocs, 1, memory_order_relaxed);
    return realloc(p, n);
}

void *sm_aligned_alloc(size_t align, size_t n) {
    atomic_fetch_add_explicit(&sm_allocs, 1, memory_order_relaxed);
    size_t rounded = (n + align - 1) / align * align;
    return aligned_alloc(align, rounded ? rounded : align);
}

uint64_t sm_allocation_count(void) { return (uint64_t)atomic_load_explicit(&sm_allocs, memory_order_relaxed); }
