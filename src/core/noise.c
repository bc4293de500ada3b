/* noise.c — 3D gradient noise (K. Perlin, "Improving noise", SIGGRAPH 2002): quintic fade,
 * 12 edge gradients, permutation shuffled from a seed with the counter-based RNG. */
#include "squall/noise.h"
#include "squall/rng.h"

void sq_noise_init(sq_noise *n, uint64_t seed)
{
    uint8_t p[256];
    for (int i = 0; i < 256; i++) p[i] = (uint8_t)i;
    for (int i = 255; i > 0; i--) { /* Fisher–Yates */
        uint32_t o[4];
        sq_rng_bits(seed, 0x4E4F495345ull, (uint64_t)i, o);
        int j = (int)(o[0] % (uint32_t)(i + 1));
        uint8_t t = p[i];
        p[i] = p[j];
        p[j] = t;
    }
    for (int i = 0; i < 512; i++) n->perm[i] = p[i & 255];
}

static inline float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
static inline float lerp(float t, float a, float b) { return a + t * (b - a); }
static inline float grad(int hash, float x, float y, float z)
{
    int h = hash & 15;
    float u = h < 8 ? x : y;
    float v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
    return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
}

static inline int fastfloor(float x)
{
    int i = (int)x;
    return x < (float)i ? i - 1 : i;
}

float sq_noise3(const sq_noise *n, float x, float y, float z)
{
    int xi = fastfloor(x), yi = fastfloor(y), zi = fastfloor(z);
    float xf = x - (float)xi, yf = y - (float)yi, zf = z - (float)zi;
    int X = xi & 255, Y = yi & 255, Z = zi & 255;
    float u = fade(xf), v = fade(yf), w = fade(zf);
    const uint8_t *p = n->perm;
    int A = p[X] + Y, AA = p[A] + Z, AB = p[A + 1] + Z;
    int B = p[X + 1] + Y, BA = p[B] + Z, BB = p[B + 1] + Z;
    return lerp(w,
                lerp(v, lerp(u, grad(p[AA], xf, yf, zf), grad(p[BA], xf - 1, yf, zf)),
                     lerp(u, grad(p[AB], xf, yf - 1, zf), grad(p[BB], xf - 1, yf - 1, zf))),
                lerp(v,
                     lerp(u, grad(p[AA + 1], xf, yf, zf - 1),
                          grad(p[BA + 1], xf - 1, yf, zf - 1)),
                     lerp(u, grad(p[AB + 1], xf, yf - 1, zf - 1),
                          grad(p[BB + 1], xf - 1, yf - 1, zf - 1))));
}

float sq_noise_fbm3(const sq_noise *n, float x, float y, float z, int octaves, float lacunarity,
                    float gain)
{
    float sum = 0.0f, amp = 1.0f, norm = 0.0f, f = 1.0f;
    if (octaves < 1) octaves = 1;
    for (int o = 0; o < octaves; o++) {
        sum += amp * sq_noise3(n, x * f, y * f, z * f);
        norm += amp;
        amp *= gain;
        f *= lacunarity;
    }
    return norm > 0.0f ? sum / norm : 0.0f;
}
