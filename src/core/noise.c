/* noise.c — 3D gradient noise (K. Perlin, "Improving noise", SIGGRAPH 2002): quintic fade,
 * 12 edge gradients, permutation shuffled from a seed with the counter-based RNG. */
#include "squall/noise.h"
#include "squall/rng.h"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

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

#if defined(__AVX2__)
/* sq_noise3 on eight lanes: every operation of the scalar code, in its order (no FMA), so the
 * lanes equal it bit for bit; the permutation table is read by gathers from p32 (its entries
 * widened to 32 bits). */
static inline __m256 fade8(__m256 t)
{
    const __m256 t3 = _mm256_mul_ps(_mm256_mul_ps(t, t), t);
    const __m256 poly = _mm256_add_ps(
        _mm256_mul_ps(t, _mm256_sub_ps(_mm256_mul_ps(t, _mm256_set1_ps(6.0f)),
                                       _mm256_set1_ps(15.0f))),
        _mm256_set1_ps(10.0f));
    return _mm256_mul_ps(t3, poly);
}

static inline __m256 lerp8(__m256 t, __m256 a, __m256 b)
{
    return _mm256_add_ps(a, _mm256_mul_ps(t, _mm256_sub_ps(b, a)));
}

static inline __m256 grad8(__m256i hash, __m256 x, __m256 y, __m256 z)
{
    const __m256i h = _mm256_and_si256(hash, _mm256_set1_epi32(15));
    const __m256 lt8 = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(8), h));
    const __m256 lt4 = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(4), h));
    const __m256 is_x = _mm256_castsi256_ps(
        _mm256_or_si256(_mm256_cmpeq_epi32(h, _mm256_set1_epi32(12)),
                        _mm256_cmpeq_epi32(h, _mm256_set1_epi32(14))));
    const __m256 u = _mm256_blendv_ps(y, x, lt8);
    const __m256 v = _mm256_blendv_ps(_mm256_blendv_ps(z, x, is_x), y, lt4);
    /* (h & 1) ? -u : u, (h & 2) ? -v : v: the sign bit flipped, as unary minus does */
    const __m256 su = _mm256_castsi256_ps(
        _mm256_slli_epi32(_mm256_and_si256(h, _mm256_set1_epi32(1)), 31));
    const __m256 sv = _mm256_castsi256_ps(
        _mm256_slli_epi32(_mm256_and_si256(h, _mm256_set1_epi32(2)), 30));
    return _mm256_add_ps(_mm256_xor_ps(u, su), _mm256_xor_ps(v, sv));
}

static inline __m256i floor8(__m256 x)
{
    const __m256i i = _mm256_cvttps_epi32(x);
    const __m256 below = _mm256_cmp_ps(x, _mm256_cvtepi32_ps(i), _CMP_LT_OQ);
    return _mm256_add_epi32(i, _mm256_castps_si256(below)); /* i - 1 where x < (float)i */
}

static inline __m256i gather8(const int32_t *p32, __m256i idx)
{
    return _mm256_i32gather_epi32((const int *)p32, idx, 4);
}

static __m256 noise8(const int32_t *p32, __m256 x, __m256 y, __m256 z)
{
    const __m256i xi = floor8(x), yi = floor8(y), zi = floor8(z);
    const __m256 xf = _mm256_sub_ps(x, _mm256_cvtepi32_ps(xi));
    const __m256 yf = _mm256_sub_ps(y, _mm256_cvtepi32_ps(yi));
    const __m256 zf = _mm256_sub_ps(z, _mm256_cvtepi32_ps(zi));
    const __m256i m255 = _mm256_set1_epi32(255), one = _mm256_set1_epi32(1);
    const __m256i X = _mm256_and_si256(xi, m255), Y = _mm256_and_si256(yi, m255),
                  Z = _mm256_and_si256(zi, m255);
    const __m256 u = fade8(xf), v = fade8(yf), w = fade8(zf);
    const __m256i A = _mm256_add_epi32(gather8(p32, X), Y);
    const __m256i AA = _mm256_add_epi32(gather8(p32, A), Z);
    const __m256i AB = _mm256_add_epi32(gather8(p32, _mm256_add_epi32(A, one)), Z);
    const __m256i B = _mm256_add_epi32(gather8(p32, _mm256_add_epi32(X, one)), Y);
    const __m256i BA = _mm256_add_epi32(gather8(p32, B), Z);
    const __m256i BB = _mm256_add_epi32(gather8(p32, _mm256_add_epi32(B, one)), Z);
    const __m256 f1 = _mm256_set1_ps(1.0f);
    const __m256 xm = _mm256_sub_ps(xf, f1), ym = _mm256_sub_ps(yf, f1),
                 zm = _mm256_sub_ps(zf, f1);
    const __m256 g000 = grad8(gather8(p32, AA), xf, yf, zf);
    const __m256 g100 = grad8(gather8(p32, BA), xm, yf, zf);
    const __m256 g010 = grad8(gather8(p32, AB), xf, ym, zf);
    const __m256 g110 = grad8(gather8(p32, BB), xm, ym, zf);
    const __m256 g001 = grad8(gather8(p32, _mm256_add_epi32(AA, one)), xf, yf, zm);
    const __m256 g101 = grad8(gather8(p32, _mm256_add_epi32(BA, one)), xm, yf, zm);
    const __m256 g011 = grad8(gather8(p32, _mm256_add_epi32(AB, one)), xf, ym, zm);
    const __m256 g111 = grad8(gather8(p32, _mm256_add_epi32(BB, one)), xm, ym, zm);
    return lerp8(w, lerp8(v, lerp8(u, g000, g100), lerp8(u, g010, g110)),
                 lerp8(v, lerp8(u, g001, g101), lerp8(u, g011, g111)));
}
#endif

void sq_noise3_many(const sq_noise *n, size_t count, const float *x, const float *y,
                    const float *z, float *out)
{
    size_t i = 0;
#if defined(__AVX2__)
    if (count >= 8) {
        int32_t p32[512];
        for (int k = 0; k < 512; k++) p32[k] = n->perm[k];
        for (; i + 8 <= count; i += 8)
            _mm256_storeu_ps(out + i, noise8(p32, _mm256_loadu_ps(x + i), _mm256_loadu_ps(y + i),
                                             _mm256_loadu_ps(z + i)));
    }
#endif
    for (; i < count; i++) out[i] = sq_noise3(n, x[i], y[i], z[i]);
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
