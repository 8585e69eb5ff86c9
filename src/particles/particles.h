/* Particle storage: structure of arrays, one array per field, grown geometrically.
 *
 * The fields are listed ONCE, in SM_PARTICLE_FIELDS below; everything that touches every field
 * is generated from that list: the struct, grow/free, initialisation of new particles, the
 * in-place reorder by grid block, packing one particle into a byte buffer and back (MPI
 * migration), the runtime descriptor table (checkpoints: name, element size, count for d,
 * pointer), the memory accounting and the state hash. Adding a field (e.g. a stable particle id)
 * is one line in the list.
 *
 * A particle's mass is its material's density times vol0: not stored (memory per particle is the
 * budget, tests/test_memory.c). Storage order is not stable: the step reorders particles by grid
 * block when that pays (sm_particles_permute).
 *
 * Positions are double in both builds. A step moves a particle by dt |v|, which for slow creep is
 * far below the rounding of a float position (at x = 0.7 m, v = 5e-4 m/s, dt = 3.4e-5 s the
 * displacement 1.7e-8 m is a quarter of a float ulp: float positions did not move at all while
 * F^E took the full velocity gradient). In double the rounding at 1e3 m is 1.1e-13 m. The
 * stencil's fractional offset (x - x_lo)/dx - base is formed in double and only then rounded to
 * sm_real, so the weights are as accurate as in a double build (transfer/stencil_dim.h). */
#ifndef SM_PARTICLES_H
#define SM_PARTICLES_H

#include "core/common.h"

/* Values of the Kirchhoff stress tau per particle (symmetric, core/common.h's SM_NSYM order). */
#define SM_NTAU(d) SM_NSYM(d)

/* Value of a field in a new particle (sm_particles_init_rest); the caller then sets what it
 * knows (position, velocity, volume, alpha, material). */
#define SM_REST_ZERO 0
#define SM_REST_IDENTITY 1 /* a d x d identity matrix (F^E of an undeformed particle) */

/* The field list: X(name, C type, values per particle for dimension d, rest value, hashed, p2g,
 * doc). hashed = 1: part of sm_world_state_hash, the evolving state (tau is a function of F^E;
 * vol0 and the material never change). p2g = 1: read by P2G, so a ghost of an explicit step
 * (dist/exchange.c) carries it; the others (F^E and the plastic state, read by G2P and the
 * plasticity of owned particles only) stay with the owner. Order = storage order of packed
 * particles and of the hash. */
#define SM_PARTICLE_FIELDS(X, d)                                                                     \
    X(x, double, (d), SM_REST_ZERO, 1, 1, "m: position (double in both builds: see below)")         \
    X(v, sm_real, (d), SM_REST_ZERO, 1, 1, "m/s: velocity")                                          \
    X(B, sm_real, (d) * (d), SM_REST_ZERO, 1, 1, "m^2/s: APIC affine matrix B_p (3.84), row-major")  \
    X(F, sm_real, (d) * (d), SM_REST_IDENTITY, 1, 0, "1: elastic deformation gradient F^E, row-major") \
    X(tau, sm_real, SM_NTAU(d), SM_REST_ZERO, 0, 1,                                                  \
      "Pa: Kirchhoff stress of F^E (P F^T = tau), symmetric, computed by the previous step's "       \
      "plasticity (or at insertion), so that P2G needs no second SVD")                               \
    X(vol0, sm_real, 1, SM_REST_ZERO, 0, 1, "m^3 (m^2 in 2D): initial volume V0")                    \
    X(q, sm_real, 1, SM_REST_ZERO, 1, 0, "1: hardening state (3.78)")                                \
    X(alpha, sm_real, 1, SM_REST_ZERO, 1, 0, "1: Drucker-Prager alpha (3.80)")                       \
    X(mat, uint16_t, 1, SM_REST_ZERO, 0, 1, "material id")                                           \
    X(id, uint32_t, 1, SM_REST_ZERO, 0, 1, "stable particle id: 0, 1, 2, ... in order of insertion")

typedef struct sm_particles {
    size_t n, cap; /* particles stored, particles allocated */
#define SM_X_(name, type, count, rest, hashed, p2g, doc) type *name;
    SM_PARTICLE_FIELDS(SM_X_, 0)
#undef SM_X_
} sm_particles;

enum {
#define SM_X_(name, type, count, rest, hashed, p2g, doc) SM_PFIELD_##name,
    SM_PARTICLE_FIELDS(SM_X_, 0)
#undef SM_X_
    SM_PARTICLE_NFIELDS
};

/* Runtime description of one field (checkpoints write and read every field from this table). */
typedef struct sm_particle_field {
    const char *name;  /* as in the list: "x", "v", ... */
    const char *ctype; /* "sm_real" (float or double by build: see elem_size), "uint16_t", "uint32_t" */
    const char *doc;   /* "unit: meaning" */
    size_t elem_size;  /* bytes of one value */
    int count;         /* values per particle */
    int hashed;        /* part of the state hash */
} sm_particle_field;

/* Descriptor of field k (0 <= k < SM_PARTICLE_NFIELDS) for dimension dim. */
sm_particle_field sm_particle_field_info(int dim, int k);
/* The array of field k (n * count values of elem_size bytes). */
void *sm_particles_field_data(const sm_particles *p, int k);

/* Bytes of one particle over all fields (= sm_particles_pack's buffer size). */
size_t sm_particles_packed_size(int dim);

/* Grows storage to hold at least n particles (contents kept). */
sm_status sm_particles_reserve(sm_particles *p, int dim, size_t n);
void sm_particles_free(sm_particles *p);

/* Sets every field of particles [first, first + count) to its rest value (storage must exist). */
void sm_particles_init_rest(sm_particles *p, int dim, size_t first, size_t count);

/* Copies every field of particle i into buf (sm_particles_packed_size bytes, fields in list
 * order, native representation), and back into particle i (i < cap; n is not changed). */
void sm_particles_pack(const sm_particles *p, int dim, size_t i, void *buf);
void sm_particles_unpack(sm_particles *p, int dim, size_t i, const void *buf);
/* The same for the p2g fields only (sm_particles_p2g_size bytes): particle i's other fields are
 * left as they were. */
size_t sm_particles_p2g_size(int dim);
void sm_particles_pack_p2g(const sm_particles *p, int dim, size_t i, void *buf);
void sm_particles_unpack_p2g(sm_particles *p, int dim, size_t i, const void *buf);

/* Moves particle perm[j] to position j for every j < n, in place (following the permutation's
 * cycles; the top bit of perm's entries is used as a mark), then sets perm to the identity. */
void sm_particles_permute(sm_particles *p, int dim, uint32_t *perm);

/* The same on two threads (particles/permute.c), each moving half of the fields, with the same
 * result; scratch: at least 2 * ceil(n / 64) 8-byte-aligned words. Returns 0 (and does nothing)
 * when scratch is too small. */
int sm_particles_permute_pair(sm_particles *p, int dim, uint32_t *perm, void *scratch, size_t scratch_bytes);

/* Copies every field of particle src to position dst (both < cap). */
void sm_particles_move(sm_particles *p, int dim, size_t dst, size_t src);

/* FNV-1a hash of the particle count and the hashed fields of particles [0, n). */
uint64_t sm_particles_hash(const sm_particles *p, int dim);
/* The same hash with the particles taken in the given order (order[i] < n, a permutation):
 * sm_particles_hash when order is the identity. */
uint64_t sm_particles_hash_ordered(const sm_particles *p, int dim, const uint32_t *order);
/* The hash in ascending id (the same for any storage order); 0 when out of memory. */
uint64_t sm_particles_hash_by_id(const sm_particles *p, int dim);

#endif
