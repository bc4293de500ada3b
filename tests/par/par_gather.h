/* par_gather.h — for the distributed grid tests: a slab's samples of a velocity component or
 * a scalar assembled into the whole grid's array on every rank. */
#ifndef SQ_TEST_PAR_GATHER_H
#define SQ_TEST_PAR_GATHER_H

#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "sq_test.h"
#include "squall/grid.h"
#include "squall/par.h"

/* samples of lattice c (0..2: the velocity's face lattices, 3..: cells) for cells n */
static inline void par_lattice_dims(sq_dims n, int c, int m[3])
{
    m[0] = n.nx + (c == 0);
    m[1] = n.ny + (c == 1);
    m[2] = n.nz + (c == 2);
}

/* component c: the velocity (0..2) or scalar c - 3 */
static inline sq_field3 *par_field_of(sq_grid *g, int c)
{
    return c < 3 ? sq_grid_velocity_field(g, c) : sq_grid_scalar_field(g, c - 3);
}

/* Fills a grid (whole, or the slab at lo with n cells) with components 0..count-1 of a field
 * given by global sample index (value(c, i, j, k)) and its solid cells (solid(i, j, k)). */
static inline void par_fill(sq_grid *g, const int lo[3], sq_dims n, int count,
                            float (*value)(int c, int i, int j, int k),
                            bool (*solid)(int i, int j, int k))
{
    for (int c = 0; c < count; c++) {
        sq_field3 *f = par_field_of(g, c);
        int m[3];
        par_lattice_dims(n, c, m);
        for (int k = 0; k < m[2]; k++)
            for (int j = 0; j < m[1]; j++)
                for (int i = 0; i < m[0]; i++)
                    *sq_field3_at(f, i, j, k) = value(c, i + lo[0], j + lo[1], k + lo[2]);
    }
    uint8_t *mask = (uint8_t *)calloc((size_t)n.nx * n.ny * n.nz, 1);
    SQ_CHECK(mask != NULL);
    for (int k = 0; mask && k < n.nz; k++)
        for (int j = 0; j < n.ny; j++)
            for (int i = 0; i < n.nx; i++)
                mask[i + (size_t)n.nx * (j + (size_t)n.ny * k)] = solid(i + lo[0], j + lo[1], k + lo[2]);
    if (mask) SQ_CHECK_OK(sq_grid_set_solid_mask(g, mask));
    free(mask);
}

/* Collective: every slab's samples of component c in one array of the whole grid G (x
 * fastest; faces held by two slabs: the later rank's). Caller frees. */
static inline float *par_gather(sq_grid *g, int c, sq_dims G)
{
    const int size = sq_par_size(), rank = sq_par_rank();
    int lo[3];
    sq_dims global;
    SQ_CHECK_OK(sq_grid_get_block(g, lo, &global));
    const sq_dims n = sq_grid_get_info(g).cells;
    int64_t meta[6 * 64] = {0};
    SQ_CHECK(size <= 64);
    const int64_t mine_meta[6] = {lo[0], lo[1], lo[2], n.nx, n.ny, n.nz};
    memcpy(meta + 6 * rank, mine_meta, sizeof mine_meta);
    sq_par_sum_i64(meta, 6 * size);
    int64_t counts[64];
    size_t tot = 0;
    for (int q = 0; q < size; q++) {
        int m[3];
        par_lattice_dims((sq_dims){(int)meta[6 * q + 3], (int)meta[6 * q + 4], (int)meta[6 * q + 5]}, c, m);
        counts[q] = (int64_t)m[0] * m[1] * m[2];
        tot += (size_t)counts[q];
    }
    int m[3];
    par_lattice_dims(n, c, m);
    float *mine = (float *)malloc((size_t)counts[rank] * sizeof(float));
    const sq_field3 *f = par_field_of(g, c);
    size_t t = 0;
    for (int k = 0; k < m[2]; k++)
        for (int j = 0; j < m[1]; j++)
            for (int i = 0; i < m[0]; i++) mine[t++] = *sq_field3_at(f, i, j, k);
    float *all = (float *)malloc(tot * sizeof(float));
    SQ_CHECK_OK(sq_par_allgather_f32(mine, counts, all));
    int gm[3];
    par_lattice_dims(G, c, gm);
    float *out = (float *)calloc((size_t)gm[0] * gm[1] * gm[2], sizeof(float));
    size_t off = 0;
    for (int q = 0; q < size; q++) {
        int mq[3];
        par_lattice_dims((sq_dims){(int)meta[6 * q + 3], (int)meta[6 * q + 4], (int)meta[6 * q + 5]}, c, mq);
        for (int k = 0; k < mq[2]; k++)
            for (int j = 0; j < mq[1]; j++)
                for (int i = 0; i < mq[0]; i++) {
                    const size_t gi = (size_t)(i + meta[6 * q]) +
                                      (size_t)gm[0] * ((size_t)(j + meta[6 * q + 1]) +
                                                       (size_t)gm[1] * (size_t)(k + meta[6 * q + 2]));
                    out[gi] = all[off++];
                }
    }
    free(mine);
    free(all);
    return out;
}

#endif
