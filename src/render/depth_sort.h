/* depth_sort.h — back-to-front ordering of drawn elements (billboards, sprites, light sweeps):
 * a stable LSD radix sort of (key, index) pairs and the order-preserving float -> key map, the
 * one home of both (the cloud pass, the soft-particle pass and the cloud light sweeps use them).
 * No GL. */
#ifndef SQ_DEPTH_SORT_H
#define SQ_DEPTH_SORT_H

#include <stddef.h>
#include <stdint.h>

/* Stable LSD radix sort of n (key, idx) pairs by key ascending, 8 bits per pass (the result is
 * back in key and idx; k2 and i2 are scratch of n entries). */
void sq__radix_sort_u32(uint32_t *key, uint32_t *idx, uint32_t *k2, uint32_t *i2, size_t n);
/* Order-preserving map of a float to uint32 (ascending floats -> ascending keys; ~key sorts
 * descending, e.g. back to front by view depth). */
uint32_t sq__float_sort_key(float f);

#endif
