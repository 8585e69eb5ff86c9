/* Minimal test harness: CHECK macros that count, print failures with file:line, and a summary.
 * Each test program returns non-zero if any check failed. */
#ifndef SM_TEST_UTIL_H
#define SM_TEST_UTIL_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sandmpm/sandmpm.h"

static int sm_test_checks = 0, sm_test_failures = 0;

#define CHECK(cond)                                                                          \
    do {                                                                                     \
        sm_test_checks++;                                                                    \
        if (!(cond)) {                                                                       \
            sm_test_failures++;                                                              \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);       \
        }                                                                                    \
    } while (0)

/* |a - b| <= tol, printing both on failure. */
#define CHECK_NEAR(a, b, tol)                                                                \
    do {                                                                                     \
        double sm_a_ = (double)(a), sm_b_ = (double)(b), sm_t_ = (double)(tol);              \
        sm_test_checks++;                                                                    \
        if (!(fabs(sm_a_ - sm_b_) <= sm_t_)) {                                               \
            sm_test_failures++;                                                              \
            fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.17g, %s = %.17g, |diff| = %.3g > %.3g\n", \
                    __FILE__, __LINE__, #a, sm_a_, #b, sm_b_, fabs(sm_a_ - sm_b_), sm_t_);   \
        }                                                                                    \
    } while (0)

/* |a - b| <= rtol * max(|a|, |b|, floor). */
#define CHECK_REL(a, b, rtol, floor_)                                                        \
    do {                                                                                     \
        double sm_a_ = (double)(a), sm_b_ = (double)(b);                                     \
        double sm_s_ = fmax(fmax(fabs(sm_a_), fabs(sm_b_)), (double)(floor_));               \
        sm_test_checks++;                                                                    \
        if (!(fabs(sm_a_ - sm_b_) <= (double)(rtol) * sm_s_)) {                              \
            sm_test_failures++;                                                              \
            fprintf(stderr, "%s:%d: CHECK_REL failed: %s = %.17g, %s = %.17g, rel = %.3g > %.3g\n", \
                    __FILE__, __LINE__, #a, sm_a_, #b, sm_b_, fabs(sm_a_ - sm_b_) / sm_s_,   \
                    (double)(rtol));                                                         \
        }                                                                                    \
    } while (0)

static inline int sm_test_summary(const char *name) {
    printf("%s: %d checks, %d failed\n", name, sm_test_checks, sm_test_failures);
    return sm_test_failures ? 1 : 0;
}

/* Deterministic RNG for tests (splitmix64). */
static inline unsigned long long sm_test_rng_next(unsigned long long *s) {
    unsigned long long z = (*s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}
/* Uniform in [lo, hi). */
static inline double sm_test_uniform(unsigned long long *s, double lo, double hi) {
    return lo + (hi - lo) * (double)(sm_test_rng_next(s) >> 11) * (1.0 / 9007199254740992.0);
}

/* A default collider holding one horizontal ground: the half-space y < y0 (mode, friction and
 * motion as sm_collider_def_default gives them). */
static inline sm_collider_def sm_test_ground(double y0) {
    sm_collider_def g = sm_collider_def_default();
    g.shape_count = 1;
    g.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    g.shapes[0].center[1] = y0;
    g.shapes[0].normal[1] = 1;
    return g;
}

/* A world of *def with one default sand material seeded in a box (centre c, half extents h; the
 * z entries only in 3D) resting above sm_test_ground(ground_y); the calls checked, NULL if the
 * world could not be created. */
static inline sm_world *sm_test_sand_box(const sm_world_def *def, double ground_y, const double c[3], const double h[3]) {
    sm_world *w = NULL;
    char err[256];
    CHECK(sm_world_create(def, &w, err, sizeof err) == SM_OK);
    if (!w) return NULL;
    sm_material_def m = sm_material_def_sand();
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    sm_collider_def g = sm_test_ground(ground_y);
    CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    for (int a = 0; a < def->dim; a++) box.center[a] = c[a], box.half_extent[a] = h[a];
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    CHECK(sm_world_seed_shape(w, &box, &sd, NULL) == SM_OK);
    return w;
}

/* A growing memory buffer for sm_world_save (sm_write_fn: 0 is success). */
typedef struct sm_test_membuf {
    unsigned char *data;
    size_t len, cap;
} sm_test_membuf;

static inline int sm_test_mem_write(void *user, const void *data, size_t len) {
    sm_test_membuf *m = user;
    if (m->len + len > m->cap) {
        size_t cap = m->cap ? m->cap : 65536;
        while (cap < m->len + len) cap *= 2;
        unsigned char *q = realloc(m->data, cap);
        if (!q) return 1;
        m->data = q;
        m->cap = cap;
    }
    memcpy(m->data + m->len, data, len);
    m->len += len;
    return 0;
}

#endif
