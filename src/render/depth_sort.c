/* depth_sort.c — the radix sort and float keys of depth_sort.h. */
#include "render/depth_sort.h"

#include <string.h>

void sq__radix_sort_u32(uint32_t *key, uint32_t *idx, uint32_t *k2, uint32_t *i2, size_t n)
{
    for (int shift = 0; shift < 32; shift += 8) {
        size_t count[257] = {0};
        for (size_t i = 0; i < n; i++) count[((key[i] >> shift) & 255u) + 1]++;
        for (int b = 0; b < 256; b++) count[b + 1] += count[b];
        for (size_t i = 0; i < n; i++) {
            const size_t dst = count[(key[i] >> shift) & 255u]++;
            k2[dst] = key[i];
            i2[dst] = idx[i];
        }
        uint32_t *t = key;
        key = k2;
        k2 = t;
        t = idx;
        idx = i2;
        i2 = t;
    }
    /* four passes: the result is back in the caller's arrays */
}

uint32_t sq__float_sort_key(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}
