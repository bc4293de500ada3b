/* rng.c — Philox4x32-10 counter-based generator (Salmon, Moraes, Dror, Shaw, "Parallel random
 * numbers: as easy as 1, 2, 3", SC 2011). Constants from that paper. */
#include <math.h>

#include "core_internal.h"
#include "squall/rng.h"

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

static inline void mulhilo(uint32_t a, uint32_t b, uint32_t *hi, uint32_t *lo)
{
    uint64_t p = (uint64_t)a * (uint64_t)b;
    *hi = (uint32_t)(p >> 32);
    *lo = (uint32_t)p;
}

void sq_philox4x32(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4])
{
    uint32_t c0 = ctr[0], c1 = ctr[1], c2 = ctr[2], c3 = ctr[3];
    uint32_t k0 = key[0], k1 = key[1];
    for (int r = 0; r < 10; r++) {
        uint32_t hi0, lo0, hi1, lo1;
        mulhilo(PHILOX_M0, c0, &hi0, &lo0);
        mulhilo(PHILOX_M1, c2, &hi1, &lo1);
        uint32_t n0 = hi1 ^ c1 ^ k0;
        uint32_t n1 = lo1;
        uint32_t n2 = hi0 ^ c3 ^ k1;
        uint32_t n3 = lo0;
        c0 = n0; c1 = n1; c2 = n2; c3 = n3;
        k0 += PHILOX_W0;
        k1 += PHILOX_W1;
    }
    out[0] = c0; out[1] = c1; out[2] = c2; out[3] = c3;
}

void sq_rng_bits(uint64_t seed, uint64_t stream, uint64_t index, uint32_t out[4])
{
    const uint32_t ctr[4] = {(uint32_t)index, (uint32_t)(index >> 32), (uint32_t)stream,
                             (uint32_t)(stream >> 32)};
    const uint32_t key[2] = {(uint32_t)seed, (uint32_t)(seed >> 32)};
    sq_philox4x32(ctr, key, out);
}

float sq_rng_uniform(uint64_t seed, uint64_t stream, uint64_t index)
{
    uint32_t o[4];
    sq_rng_bits(seed, stream, index, o);
    return sq_u32_to_unit(o[0]);
}

double sq_rng_uniform_d(uint64_t seed, uint64_t stream, uint64_t index)
{
    uint32_t o[4];
    sq_rng_bits(seed, stream, index, o);
    uint64_t v = ((uint64_t)o[0] << 21) ^ (uint64_t)(o[1] >> 11);
    return (double)(v & ((1ull << 53) - 1)) * (1.0 / 9007199254740992.0);
}

void sq_rng_uniform4(uint64_t seed, uint64_t stream, uint64_t index, float out[4])
{
    uint32_t o[4];
    sq_rng_bits(seed, stream, index, o);
    for (int i = 0; i < 4; i++) out[i] = sq_u32_to_unit(o[i]);
}

double sq_rng_normal(uint64_t seed, uint64_t stream, uint64_t index)
{
    uint32_t o[4];
    sq_rng_bits(seed, stream, index, o);
    double u1 = ((double)o[0] + 1.0) * (1.0 / 4294967297.0); /* (0, 1] */
    double u2 = (double)o[1] * (1.0 / 4294967296.0);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * 3.14159265358979323846 * u2);
}
