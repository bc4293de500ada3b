/* squall/noise.h — 3D gradient noise (Perlin 2002 "improved noise" with a seeded
 * permutation) and fractional Brownian motion by octaves. Output of sq_noise3 is in about
 * [-1, 1]; fbm is normalised by the sum of octave amplitudes. */
#ifndef SQ_NOISE_H
#define SQ_NOISE_H

#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sq_noise {
    uint8_t perm[512]; /* permutation table repeated twice */
} sq_noise;

/* Fills the permutation table from seed (same seed, same noise on every machine). */
SQ_API void sq_noise_init(sq_noise *n, uint64_t seed);
/* Gradient noise at (x, y, z), about in [-1, 1], 0 at integer lattice points. */
SQ_API float sq_noise3(const sq_noise *n, float x, float y, float z);
/* sq_noise3 at count points: out[i] = sq_noise3(n, x[i], y[i], z[i]), bit for bit (the same
 * float operations in the same order), eight points at a time where the CPU has AVX2. */
SQ_API void sq_noise3_many(const sq_noise *n, size_t count, const float *x, const float *y,
                           const float *z, float *out);
/* Sum over octaves o = 0..octaves-1 of gain^o * noise(lacunarity^o * p), divided by
 * the sum of gain^o. Typical lacunarity 2, gain 0.5. */
SQ_API float sq_noise_fbm3(const sq_noise *n, float x, float y, float z, int octaves,
                           float lacunarity, float gain);

#ifdef __cplusplus
}
#endif
#endif
