/* Internal basics shared by every module: asserts, small helpers, scalar math by precision. */
#ifndef SM_CORE_COMMON_H
#define SM_CORE_COMMON_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "sandmpm/sandmpm.h"

/* Tier 1 (DESIGN §5): programmer misuse and broken invariants. On unless SM_NO_ASSERT. */
void sm_assert_fail(const char *expr, const char *file, int line);
#ifdef SM_NO_ASSERT
#define SM_ASSERT(x) ((void)0)
#else
#define SM_ASSERT(x) ((x) ? (void)0 : sm_assert_fail(#x, __FILE__, __LINE__))
#endif

#if SM_DOUBLE
#define SM_R(x) (x)
#define sm_sqrt sqrt
#define sm_log log
#define sm_exp exp
#define sm_fabs fabs
#define sm_sin sin
#define sm_cos cos
#define sm_log1p log1p
#define sm_expm1 expm1
#define sm_floor floor
#define SM_EPS 2.220446049250313e-16
#else
#define SM_R(x) ((float)(x))
#define sm_sqrt sqrtf
#define sm_log logf
#define sm_exp expf
#define sm_fabs fabsf
#define sm_sin sinf
#define sm_cos cosf
#define sm_log1p log1pf
#define sm_expm1 expm1f
#define sm_floor floorf
#define SM_EPS 1.1920929e-07f
#endif

/* Counted heap allocation (src/core/error.c); release with free(). */
void *sm_malloc(size_t n);
void *sm_calloc(size_t n, size_t size);
void *sm_realloc(void *p, size_t n);
/* align: a power of two; n is rounded up to a multiple of it. */
void *sm_aligned_alloc(size_t align, size_t n);

/* Distinct entries of a symmetric d x d matrix, stored xx, yy, zz, xy, xz, yz (3D) or xx, yy, xy
 * (2D). */
#define SM_NSYM(d) ((d) == 3 ? 6 : 3)

#define SM_MIN(a, b) ((a) < (b) ? (a) : (b))
#define SM_MAX(a, b) ((a) > (b) ? (a) : (b))
#define SM_PI 3.14159265358979323846

#endif
