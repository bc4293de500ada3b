/* snow_fixtures.h — what the snow-cover tests build their cases on: a one-thread context and a
 * flat world at z = 0 (with an optional box obstacle). Test-only; each test file includes it once. */
#ifndef SQ_TESTS_SNOW_FIXTURES_H
#define SQ_TESTS_SNOW_FIXTURES_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "squall/core.h"
#include "squall/world.h"

static inline sq_context *snow_test_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.threads = 1;
    if (sq_context_create(&cd, &ctx) != SQ_OK) exit(1);
    return ctx;
}

/* Flat ground size_m x size_m (17 x 17 vertices) centred on the origin; box (NULL: none). */
static inline sq_world *snow_test_world(sq_context *ctx, float size_m, const sq_obstacle *box)
{
    sq_world_desc d;
    memset(&d, 0, sizeof d);
    d.terrain.kind = SQ_TERRAIN_FLAT;
    d.terrain.size_m[0] = d.terrain.size_m[1] = size_m;
    d.terrain.resolution[0] = d.terrain.resolution[1] = 17;
    d.obstacles = box;
    d.obstacle_count = box ? 1 : 0;
    sq_world *w = NULL;
    if (sq_world_create(ctx, &d, &w) != SQ_OK) {
        fprintf(stderr, "world: %s\n", sq_last_error());
        exit(1);
    }
    return w;
}

#endif
