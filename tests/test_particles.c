/* Particle storage (src/particles/particles.h): the field list drives every whole-particle
 * operation. Checks, in 2D and 3D:
 *  - the descriptor table: names, sizes and counts per field; their sum is the packed size; the
 *    data pointers are the struct's arrays; the hashed fields are exactly x, v, B, F, q, alpha;
 *  - reserve keeps the contents; new particles start at rest (F = I, everything else 0);
 *  - pack then unpack copies every byte of every field (to another index, through a buffer);
 *  - permute moves particle perm[j] to j for a random permutation (every field), perm becomes the
 *    identity; so does the reorder on two threads (permute_pair), which refuses too small a
 *    scratch;
 *  - the state hash sees the hashed fields and only those. */
#include <string.h>

#include "core/hash.h"
#include "particles/particles.h"
#include "test_util.h"

static uint64_t rng = 12345;
static uint64_t next(void) { return rng = sm_mix64(rng); }

/* Fills every value of particles [0, n) with distinct bytes (via the descriptor table). */
static void fill(sm_particles *p, int dim) {
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        sm_particle_field f = sm_particle_field_info(dim, k);
        unsigned char *b = sm_particles_field_data(p, k);
        size_t bytes = p->n * (size_t)f.count * f.elem_size;
        for (size_t i = 0; i < bytes; i++) b[i] = (unsigned char)next();
    }
}

/* 1 if particle i of a equals particle j of b in every field, byte for byte. */
static int same_particle(const sm_particles *a, size_t i, const sm_particles *b, size_t j, int dim) {
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        sm_particle_field f = sm_particle_field_info(dim, k);
        size_t sz = (size_t)f.count * f.elem_size;
        const unsigned char *pa = sm_particles_field_data(a, k), *pb = sm_particles_field_data(b, k);
        if (memcmp(pa + i * sz, pb + j * sz, sz) != 0) return 0;
    }
    return 1;
}

static void copy_all(const sm_particles *src, sm_particles *dst, int dim) {
    CHECK(sm_particles_reserve(dst, dim, src->n) == SM_OK);
    dst->n = src->n;
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        sm_particle_field f = sm_particle_field_info(dim, k);
        memcpy(sm_particles_field_data(dst, k), sm_particles_field_data(src, k), src->n * (size_t)f.count * f.elem_size);
    }
}

static void test_table(int d) {
    size_t sum = 0;
    int hashed = 0;
    sm_particles p;
    memset(&p, 0, sizeof p);
    CHECK(sm_particles_reserve(&p, d, 10) == SM_OK);
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        sm_particle_field f = sm_particle_field_info(d, k);
        CHECK(f.name && f.doc && f.ctype && f.count > 0 && f.elem_size > 0);
        for (int j = 0; j < k; j++) CHECK(strcmp(sm_particle_field_info(d, j).name, f.name) != 0);
        sum += f.elem_size * (size_t)f.count;
        hashed += f.hashed;
        if (f.hashed)
            CHECK(!strcmp(f.name, "x") || !strcmp(f.name, "v") || !strcmp(f.name, "B") || !strcmp(f.name, "F") ||
                  !strcmp(f.name, "q") || !strcmp(f.name, "alpha"));
    }
    CHECK(hashed == 6);
    CHECK(sum == sm_particles_packed_size(d));
    /* x: d doubles (both builds); v: d; B, F: d^2; tau: 3 or 6; vol0, q, alpha: 1; material: one
     * uint16_t; id: one uint32_t. */
    CHECK(sm_particles_packed_size(d) ==
          sizeof(double) * (size_t)d + sizeof(sm_real) * (size_t)(d + 2 * d * d + (d == 3 ? 6 : 3) + 3) + 2 + 4);
    CHECK(sm_particle_field_info(d, SM_PFIELD_x).elem_size == sizeof(double));
    CHECK(!strcmp(sm_particle_field_info(d, SM_PFIELD_x).ctype, "double"));
    CHECK(sm_particle_field_info(d, SM_PFIELD_F).count == d * d);
    CHECK(sm_particle_field_info(d, SM_PFIELD_tau).count == SM_NTAU(d));
    CHECK(sm_particle_field_info(d, SM_PFIELD_mat).elem_size == sizeof(uint16_t));
    CHECK(sm_particles_field_data(&p, SM_PFIELD_x) == (void *)p.x);
    CHECK(sm_particles_field_data(&p, SM_PFIELD_alpha) == (void *)p.alpha);
    CHECK(sm_particles_field_data(&p, SM_PFIELD_mat) == (void *)p.mat);
    CHECK(sm_particles_field_data(&p, SM_PARTICLE_NFIELDS) == NULL);
    sm_particles_free(&p);
}

static void test_rest_and_reserve(int d) {
    sm_particles p, q;
    memset(&p, 0, sizeof p);
    memset(&q, 0, sizeof q);
    CHECK(sm_particles_reserve(&p, d, 100) == SM_OK);
    CHECK(p.cap >= 100);
    p.n = 100;
    fill(&p, d);
    copy_all(&p, &q, d);
    CHECK(sm_particles_reserve(&p, d, 5000) == SM_OK); /* grows: contents kept */
    CHECK(p.cap >= 5000);
    int kept = 1;
    for (size_t i = 0; i < 100; i++) kept &= same_particle(&p, i, &q, i, d);
    CHECK(kept);
    sm_particles_init_rest(&p, d, 100, 50);
    p.n = 150;
    int rest = 1;
    for (size_t i = 100; i < 150; i++) {
        for (int k = 0; k < d * d; k++) rest &= p.F[i * (size_t)(d * d) + (size_t)k] == (k % (d + 1) == 0 ? 1 : 0);
        for (int k = 0; k < d * d; k++) rest &= p.B[i * (size_t)(d * d) + (size_t)k] == 0;
        for (int k = 0; k < d; k++) rest &= p.x[i * (size_t)d + (size_t)k] == 0 && p.v[i * (size_t)d + (size_t)k] == 0;
        for (int k = 0; k < SM_NTAU(d); k++) rest &= p.tau[i * (size_t)SM_NTAU(d) + (size_t)k] == 0;
        rest &= p.vol0[i] == 0 && p.q[i] == 0 && p.alpha[i] == 0 && p.mat[i] == 0;
    }
    CHECK(rest);
    CHECK(same_particle(&p, 99, &q, 99, d)); /* the particles before them untouched */
    sm_particles_free(&p);
    sm_particles_free(&q);
    CHECK(p.x == NULL && p.cap == 0);
}

static void test_pack(int d) {
    sm_particles p;
    memset(&p, 0, sizeof p);
    CHECK(sm_particles_reserve(&p, d, 64) == SM_OK);
    p.n = 64;
    fill(&p, d);
    const size_t sz = sm_particles_packed_size(d);
    unsigned char buf[512], again[512];
    CHECK(sz <= sizeof buf);
    for (size_t i = 0; i < 64; i += 7) {
        memset(buf, 0xA5, sizeof buf);
        sm_particles_pack(&p, d, i, buf);
        CHECK(buf[sz] == 0xA5); /* writes exactly sz bytes */
        /* The buffer holds the fields in list order. */
        size_t off = 0;
        int in_order = 1;
        for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
            sm_particle_field f = sm_particle_field_info(d, k);
            size_t fs = (size_t)f.count * f.elem_size;
            in_order &= memcmp(buf + off, (unsigned char *)sm_particles_field_data(&p, k) + i * fs, fs) == 0;
            off += fs;
        }
        CHECK(in_order);
        size_t j = 63 - i;
        sm_particles_unpack(&p, d, j, buf);
        CHECK(same_particle(&p, i, &p, j, d));
        sm_particles_pack(&p, d, j, again);
        CHECK(memcmp(buf, again, sz) == 0);
    }
    sm_particles_free(&p);
}

/* pair: sm_particles_permute_pair (two threads, half of the fields each) instead of the serial
 * reorder; the same result. */
static void test_permute(int d, int pair) {
    enum { N = 1000 };
    sm_particles p, q;
    memset(&p, 0, sizeof p);
    memset(&q, 0, sizeof q);
    CHECK(sm_particles_reserve(&p, d, N) == SM_OK);
    p.n = N;
    fill(&p, d);
    copy_all(&p, &q, d);
    uint32_t perm[N], want[N];
    for (uint32_t i = 0; i < N; i++) perm[i] = i;
    for (uint32_t i = N - 1; i > 0; i--) { /* Fisher-Yates, leaving some fixed points */
        if (i % 10 == 0) continue;
        uint32_t j = (uint32_t)(next() % (i + 1));
        uint32_t t = perm[i];
        perm[i] = perm[j];
        perm[j] = t;
    }
    memcpy(want, perm, sizeof perm);
    if (pair) {
        uint64_t seen[2 * ((N + 63) / 64)];
        CHECK(!sm_particles_permute_pair(&p, d, perm, seen, sizeof seen - 8)); /* too small: nothing done */
        CHECK(memcmp(perm, want, sizeof perm) == 0);
        CHECK(sm_particles_permute_pair(&p, d, perm, seen, sizeof seen));
    } else {
        sm_particles_permute(&p, d, perm);
    }
    int moved = 1, ident = 1;
    for (uint32_t j = 0; j < N; j++) {
        moved &= same_particle(&p, j, &q, want[j], d);
        ident &= perm[j] == j;
    }
    CHECK(moved);
    CHECK(ident);
    sm_particles_free(&p);
    sm_particles_free(&q);
}

static void test_hash(int d) {
    sm_particles p;
    memset(&p, 0, sizeof p);
    CHECK(sm_particles_reserve(&p, d, 20) == SM_OK);
    p.n = 20;
    fill(&p, d);
    const uint64_t h0 = sm_particles_hash(&p, d);
    for (int k = 0; k < SM_PARTICLE_NFIELDS; k++) {
        sm_particle_field f = sm_particle_field_info(d, k);
        unsigned char *b = (unsigned char *)sm_particles_field_data(&p, k) + 5 * (size_t)f.count * f.elem_size;
        b[0] ^= 1;
        const uint64_t h1 = sm_particles_hash(&p, d);
        CHECK(f.hashed ? h1 != h0 : h1 == h0);
        b[0] ^= 1;
    }
    CHECK(sm_particles_hash(&p, d) == h0);
    p.n = 19;
    CHECK(sm_particles_hash(&p, d) != h0);
    sm_particles_free(&p);
}

int main(void) {
    for (int d = 2; d <= 3; d++) {
        test_table(d);
        test_rest_and_reserve(d);
        test_pack(d);
        test_permute(d, 0);
        test_permute(d, 1);
        test_hash(d);
    }
    return sm_test_summary("test_particles");
}
