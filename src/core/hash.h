#ifndef SM_CORE_HASH_H
#define SM_CORE_HASH_H
#include <stddef.h>
#include <stdint.h>
#define SM_HASH_INIT 0xcbf29ce484222325ULL
/* FNV-1a, continuing from h (start with SM_HASH_INIT). */
uint64_t sm_hash64(const void *data, size_t n, uint64_t h);
/* splitmix64 finaliser: a well-mixed 64-bit function of z (used as a counter-based RNG). */
uint64_t sm_mix64(uint64_t z);
/* Uniform double in [0, 1) from a 64-bit value. */
static inline double sm_u01(uint64_t z) { return (double)(z >> 11) * (1.0 / 9007199254740992.0); }
#endif
