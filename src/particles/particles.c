/* Particle storage: every operation over all fields is generated from SM_PARTICLE_FIELDS
 * (particles.h). The per-particle loops (permute, pack) are written once with the dimension as a
 * parameter and instantiated for d = 2 and d = 3, so every copy has a constant size. */
#include <string.h>

#include "core/hash.h"
#include "particles/particles.h"

sm_particle_field sm_particle_field_info(int dim, int k) {
    const int d = dim;
    static const sm_particle_field none = {0};
    switch (k) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc)                                                 \
    case SM_PFIELD_##name: {                                                                       \
        const sm_particle_field f = {#name, #type, doc, sizeof(type), (count), (hashed)};          \
        return f;                                                                                  \
    }
        SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
    }
    (void)d;
    return none;
}

void *sm_particles_field_data(const sm_particles *p, int k) {
    switch (k) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc) \
    case SM_PFIELD_##name: return p->name;
        SM_PARTICLE_FIELDS(SM_X_, 0)
#undef SM_X_
    }
    return NULL;
}

size_t sm_particles_packed_size(int dim) {
    size_t b = 0;
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        const sm_particle_field f = sm_particle_field_info(dim, k);
        b += f.elem_size * (size_t)f.count;
    }
    return b;
}

static int grow(void **ptr, size_t bytes) {
    void *q = sm_realloc(*ptr, bytes);
    if (!q) return 0;
    *ptr = q;
    return 1;
}

sm_status sm_particles_reserve(sm_particles *p, int dim, size_t n) {
    if (n <= p->cap) return SM_OK;
    /* Exactly n when a large batch arrives (seeding); 25% headroom for trickles (emitters). */
    size_t cap = p->cap + p->cap / 4;
    if (cap < n) cap = n;
    if (cap < 1024) cap = 1024;
    const int d = dim;
    (void)d;
#define SM_X_(name, type, count, rest, hashed, p2g, doc) \
    if (!grow((void **)&p->name, sizeof(type) * (size_t)(count) * cap)) return SM_ERR_NOMEM;
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
    p->cap = cap;
    return SM_OK;
}

void sm_particles_free(sm_particles *p) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc) free(p->name);
    SM_PARTICLE_FIELDS(SM_X_, 0)
#undef SM_X_
    memset(p, 0, sizeof *p);
}

/* Rest value of entry k of a field with `count` values per particle. */
static inline int rest_value(int rest, int d, int count, int k) {
    (void)count;
    return rest == SM_REST_IDENTITY ? (k % (d + 1) == 0) : 0;
}

void sm_particles_init_rest(sm_particles *p, int dim, size_t first, size_t count_) {
    const int d = dim;
    for (size_t i = first; i < first + count_; i++) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc) \
    for (int k = 0; k < (count); k++) p->name[i * (size_t)(count) + (size_t)k] = (type)rest_value(rest, d, count, k);
        SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
    }
}

static inline __attribute__((always_inline)) void pack_d(const sm_particles *p, int d, size_t i, unsigned char *b) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc)                              \
    memcpy(b, p->name + i * (size_t)(count), sizeof(type) * (size_t)(count)); \
    b += sizeof(type) * (size_t)(count);
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
}

static inline __attribute__((always_inline)) void unpack_d(sm_particles *p, int d, size_t i, const unsigned char *b) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc)                              \
    memcpy(p->name + i * (size_t)(count), b, sizeof(type) * (size_t)(count)); \
    b += sizeof(type) * (size_t)(count);
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
}

/* Particle src to position dst, every field. */
static inline __attribute__((always_inline)) void move_d(sm_particles *p, int d, size_t dst, size_t src) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc) \
    memcpy(p->name + dst * (size_t)(count), p->name + src * (size_t)(count), sizeof(type) * (size_t)(count));
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
}

void sm_particles_move(sm_particles *p, int dim, size_t dst, size_t src) {
    if (dim == 2) move_d(p, 2, dst, src);
    else move_d(p, 3, dst, src);
}

static inline __attribute__((always_inline)) void pack_p2g_d(const sm_particles *p, int d, size_t i, unsigned char *b) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc)                               \
    if (p2g) {                                                                      \
        memcpy(b, p->name + i * (size_t)(count), sizeof(type) * (size_t)(count)); \
        b += sizeof(type) * (size_t)(count);                                       \
    }
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
}

static inline __attribute__((always_inline)) void unpack_p2g_d(sm_particles *p, int d, size_t i, const unsigned char *b) {
#define SM_X_(name, type, count, rest, hashed, p2g, doc)                               \
    if (p2g) {                                                                      \
        memcpy(p->name + i * (size_t)(count), b, sizeof(type) * (size_t)(count)); \
        b += sizeof(type) * (size_t)(count);                                       \
    }
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
}

size_t sm_particles_p2g_size(int dim) {
    size_t b = 0;
    const int d = dim;
    (void)d;
#define SM_X_(name, type, count, rest, hashed, p2g, doc) b += (p2g) ? sizeof(type) * (size_t)(count) : 0;
    SM_PARTICLE_FIELDS(SM_X_, d)
#undef SM_X_
    return b;
}

void sm_particles_pack_p2g(const sm_particles *p, int dim, size_t i, void *buf) {
    if (dim == 2) pack_p2g_d(p, 2, i, buf);
    else pack_p2g_d(p, 3, i, buf);
}

void sm_particles_unpack_p2g(sm_particles *p, int dim, size_t i, const void *buf) {
    if (dim == 2) unpack_p2g_d(p, 2, i, buf);
    else unpack_p2g_d(p, 3, i, buf);
}

void sm_particles_pack(const sm_particles *p, int dim, size_t i, void *buf) {
    if (dim == 2) pack_d(p, 2, i, buf);
    else pack_d(p, 3, i, buf);
}

void sm_particles_unpack(sm_particles *p, int dim, size_t i, const void *buf) {
    if (dim == 2) unpack_d(p, 2, i, buf);
    else unpack_d(p, 3, i, buf);
}

/* The largest packed particle (3D), for the reorder's saved particle. */
#define SM_PACKED_MAX (sizeof(double) * (2 * 3 + 2 * 9 + 6 + 3) + sizeof(uint16_t) + sizeof(uint32_t) + 64)

static inline __attribute__((always_inline)) void permute_d(sm_particles *p, int d, uint32_t *perm) {
    const size_t n = p->n;
    const uint32_t MARK = 0x80000000u;
    unsigned char saved[SM_PACKED_MAX];
    for (size_t i = 0; i < n; i++) {
        if (perm[i] & MARK) continue;
        if (perm[i] == i) {
            perm[i] |= MARK;
            continue;
        }
        /* Position j receives the particle at perm[j]; save position i's particle first. */
        pack_d(p, d, i, saved);
        size_t j = i;
        for (;;) {
            size_t src = perm[j];
            perm[j] |= MARK;
            if (src == i) break;
            move_d(p, d, j, src);
            j = src;
        }
        unpack_d(p, d, j, saved);
    }
    for (size_t i = 0; i < n; i++) perm[i] = (uint32_t)i;
}

void sm_particles_permute(sm_particles *p, int dim, uint32_t *perm) {
    SM_ASSERT(sm_particles_packed_size(dim) <= SM_PACKED_MAX);
    if (dim == 2) permute_d(p, 2, perm);
    else permute_d(p, 3, perm);
}

uint64_t sm_particles_hash(const sm_particles *p, int dim) {
    const size_t n = p->n;
    uint64_t h = SM_HASH_INIT;
    h = sm_hash64(&n, sizeof n, h);
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        const sm_particle_field f = sm_particle_field_info(dim, k);
        if (f.hashed) h = sm_hash64(sm_particles_field_data(p, k), n * (size_t)f.count * f.elem_size, h);
    }
    return h;
}

uint64_t sm_particles_hash_ordered(const sm_particles *p, int dim, const uint32_t *order) {
    const size_t n = p->n;
    uint64_t h = SM_HASH_INIT;
    h = sm_hash64(&n, sizeof n, h);
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        const sm_particle_field f = sm_particle_field_info(dim, k);
        if (!f.hashed) continue;
        const size_t bytes = (size_t)f.count * f.elem_size;
        const unsigned char *data = sm_particles_field_data(p, k);
        for (size_t i = 0; i < n; i++) h = sm_hash64(data + (size_t)order[i] * bytes, bytes, h);
    }
    return h;
}

static int cmp_u64(const void *a, const void *b) {
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

uint64_t sm_particles_hash_by_id(const sm_particles *p, int dim) {
    const size_t n = p->n;
    uint64_t *pairs = malloc((n ? n : 1) * sizeof *pairs);
    uint32_t *order = malloc((n ? n : 1) * sizeof *order);
    uint64_t h = 0;
    if (pairs && order) {
        for (size_t i = 0; i < n; i++) pairs[i] = ((uint64_t)p->id[i] << 32) | (uint64_t)i;
        qsort(pairs, n, sizeof *pairs, cmp_u64);
        for (size_t i = 0; i < n; i++) order[i] = (uint32_t)pairs[i];
        h = sm_particles_hash_ordered(p, dim, order);
    }
    free(pairs);
    free(order);
    return h;
}
