/* tonemap_internal.h — the scalar pieces of the shared tone curve (tonemap.c), for the reference
 * path tracer and tests. No GL. */
#ifndef SQ_TONEMAP_INTERNAL_H
#define SQ_TONEMAP_INTERNAL_H

#include <stdint.h>

/* ACES filmic fit (Narkowicz 2015) of a linear value; 0 for negatives/NaN, saturates at 1. */
float sq__tonemap_aces(float x);
/* sRGB transfer function (IEC 61966-2-1), input clamped to [0, 1]. */
float sq__srgb_encode(float c);
float sq__srgb_decode(float v);
/* One channel: linear * exposure -> ACES -> sRGB -> round to 8 bits. */
uint8_t sq__tonemap_channel(float linear, float exposure);

#endif
