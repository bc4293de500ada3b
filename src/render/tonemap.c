/* tonemap.c — the tone curve shared by the GL renderer (tonemap.frag.glsl mirrors it line for
 * line) and the reference path tracer: linear RGB * exposure -> ACES filmic fit (Narkowicz
 * 2015, "ACES Filmic Tone Mapping Curve") -> sRGB transfer (IEC 61966-2-1) -> 8 bits.
 * Plain C, no GL. */
#include <math.h>
#include <stdint.h>

#include "render/tonemap_internal.h"
#include "squall/render.h"

float sq__tonemap_aces(float x)
{
    if (!(x > 0.0f)) return 0.0f; /* negatives and NaN */
    const float a = 2.51f, b = 0.03f, c = 2.43f, d = 0.59f, e = 0.14f;
    const float y = (x * (a * x + b)) / (x * (c * x + d) + e);
    return y < 1.0f ? y : 1.0f;
}

float sq__srgb_encode(float c)
{
    if (c <= 0.0031308f) return 12.92f * (c > 0.0f ? c : 0.0f);
    return 1.055f * powf(c < 1.0f ? c : 1.0f, 1.0f / 2.4f) - 0.055f;
}

float sq__srgb_decode(float v)
{
    if (v <= 0.04045f) return v / 12.92f;
    return powf((v + 0.055f) / 1.055f, 2.4f);
}

uint8_t sq__tonemap_channel(float linear, float exposure)
{
    const float v = sq__srgb_encode(sq__tonemap_aces(linear * exposure));
    return (uint8_t)lrintf(v * 255.0f);
}

void sq_tonemap_rgba8(const float *rgb, int width, int height, float exposure, uint8_t *rgba)
{
    if (!rgb || !rgba || width <= 0 || height <= 0) return;
    const size_t n = (size_t)width * (size_t)height;
    for (size_t i = 0; i < n; i++) {
        rgba[4 * i + 0] = sq__tonemap_channel(rgb[3 * i + 0], exposure);
        rgba[4 * i + 1] = sq__tonemap_channel(rgb[3 * i + 1], exposure);
        rgba[4 * i + 2] = sq__tonemap_channel(rgb[3 * i + 2], exposure);
        rgba[4 * i + 3] = 255;
    }
}
