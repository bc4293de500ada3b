/* squall/rng.h — counter-based random numbers (Philox4x32-10, Salmon et al. SC'11).
 * A value is a pure function of (seed, stream, index): results do not depend on thread count
 * or evaluation order, so a run is reproducible from its seed. */
#ifndef SQ_RNG_H
#define SQ_RNG_H

#include <stdint.h>

#include "squall/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One Philox4x32-10 block: 4 x 32 random bits from a 128-bit counter and a 64-bit key. */
SQ_API void sq_philox4x32(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4]);

/* 4 x 32 bits for (seed, stream, index). stream separates independent uses (e.g. one per
 * phenomenon and purpose), index counts draws within a stream (e.g. cell id * K + step). */
SQ_API void sq_rng_bits(uint64_t seed, uint64_t stream, uint64_t index, uint32_t out[4]);

/* Uniform in [0, 1) with 24 bits (float) or 53 bits (double). */
SQ_API float sq_rng_uniform(uint64_t seed, uint64_t stream, uint64_t index);
SQ_API double sq_rng_uniform_d(uint64_t seed, uint64_t stream, uint64_t index);
/* Four uniforms in [0, 1) from one block. */
SQ_API void sq_rng_uniform4(uint64_t seed, uint64_t stream, uint64_t index, float out[4]);
/* Standard normal (Box–Muller from one block). */
SQ_API double sq_rng_normal(uint64_t seed, uint64_t stream, uint64_t index);

/* Converts 32 random bits to a float in [0, 1). */
static inline float sq_u32_to_unit(uint32_t x) { return (float)(x >> 8) * (1.0f / 16777216.0f); }

#ifdef __cplusplus
}
#endif
#endif
