/* The storage reorder on two threads (particles.h, sm_particles_permute_pair).
 *
 * sm_particles_permute follows perm's cycles and moves every field of a particle at each step of
 * a cycle, alone: the binning's reorder is serial, and the other thread of a step waits for it
 * (3D, 30,000 particles on 2 threads: 1.9% of the samples, the same again idle on the other
 * core). Here each of two threads follows the same cycles for half of the fields (thread 0 x, v
 * and B; thread 1 F^E, tau and the rest: 72 and 78 bytes of a 3D float particle), marking what it
 * moved in a bitmap of its own. The threads write disjoint memory and only read perm, so the
 * result is the serial reorder's, byte for byte (tests/test_particles.c). */
#include <string.h>

#include "core/team.h"
#include "particles/particles.h"

/* The fields of group g: 0 the ones listed before F, 1 F and the ones after. */
#define IN_GROUP(name, g) ((SM_PFIELD_##name < SM_PFIELD_F) == ((g) == 0))

/* The largest group of one particle (3D, double): for the particle saved at a cycle's start. */
#define GROUP_MAX (sizeof(double) * (3 + 3 + 9 + 9 + 6 + 3) + sizeof(uint16_t) + sizeof(uint32_t))

static inline __attribute__((always_inline)) void group_save(const sm_particles *p, int d, int g, size_t i,
                                                            unsigned char *b) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc)                                  \
    if (IN_GROUP(name, g)) {                                                             \
        memcpy(b, p->name + i * (size_t)(count), sizeof(type) * (size_t)(count));         \
        b += sizeof(type) * (size_t)(count);                                             \
    }
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
}

static inline __attribute__((always_inline)) void group_restore(sm_particles *p, int d, int g, size_t i,
                                                               const unsigned char *b) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc)                                  \
    if (IN_GROUP(name, g)) {                                                             \
        memcpy(p->name + i * (size_t)(count), b, sizeof(type) * (size_t)(count));         \
        b += sizeof(type) * (size_t)(count);                                             \
    }
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
}

static inline __attribute__((always_inline)) void group_move(sm_particles *p, int d, int g, size_t dst, size_t src) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc) \
    if (IN_GROUP(name, g))                               \
        memcpy(p->name + dst * (size_t)(count), p->name + src * (size_t)(count), sizeof(type) * (size_t)(count));
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
}

/* Group g of every particle moved along perm's cycles (position j receives perm[j]); seen: n bits,
 * zero. */
static inline __attribute__((always_inline)) void permute_group(sm_particles *p, int d, int g, const uint32_t *perm,
                                                               uint64_t *seen) {
    unsigned char saved[GROUP_MAX];
    for (size_t i = 0; i < p->n; i++) {
        if ((seen[i >> 6] >> (i & 63)) & 1 || perm[i] == i) continue; /* moved, or in place */
        group_save(p, d, g, i, saved);
        size_t j = i;
        for (;;) {
            const size_t src = perm[j];
            seen[j >> 6] |= 1ull << (j & 63);
            if (src == i) break;
            group_move(p, d, g, j, src);
            j = src;
        }
        group_restore(p, d, g, j, saved);
    }
}

typedef struct permute_job {
    sm_particles *p;
    int dim;
    const uint32_t *perm;
    uint64_t *seen; /* two bitmaps of `words` words */
    size_t words;
} permute_job;

/* Thread t moves group t; in a run of one thread (no second thread to be had), both. */
static void permute_share(void *arg, int t, int T) {
    const permute_job *job = arg;
    for (int g = t; g < 2; g += T) {
        uint64_t *seen = job->seen + (size_t)g * job->words;
        memset(seen, 0, job->words * sizeof *seen);
        if (job->dim == 2) {
            if (g == 0) permute_group(job->p, 2, 0, job->perm, seen);
            else permute_group(job->p, 2, 1, job->perm, seen);
        } else {
            if (g == 0) permute_group(job->p, 3, 0, job->perm, seen);
            else permute_group(job->p, 3, 1, job->perm, seen);
        }
    }
}

int sm_particles_permute_pair(sm_particles *p, int dim, uint32_t *perm, void *scratch, size_t scratch_bytes) {
    const size_t words = (p->n + 63) / 64;
    if (2 * words * sizeof(uint64_t) > scratch_bytes || ((uintptr_t)scratch & 7) != 0) return 0;
    permute_job job = {p, dim, perm, scratch, words};
    sm_team_run(2, permute_share, &job);
    for (size_t i = 0; i < p->n; i++) perm[i] = (uint32_t)i;
    return 1;
}
