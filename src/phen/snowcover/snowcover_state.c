/* snowcover_state.c — the snow cover's checkpoint hooks: the clock, the water fallen, the
 * accumulation grid, the flake pool (positions, velocities, birth offsets, rotation, spin), the
 * noise counter and the emitter's camera. Sizes and fades are recomputed for each frame. */
#include <string.h>

#include "snowcover_internal.h"

sq_result sq__snowcover_save_state(const void *self, sq_state_writer *w)
{
    const sq_snowcover *s = (const sq_snowcover *)self;
    const size_t cells = (size_t)s->nx * (size_t)s->ny, nf = (size_t)s->nflakes;
    const double clock[2] = {s->time_s, s->water_m};
    sq_state_put(w, "snowcover/clock", clock, sizeof clock);
    const int64_t grid[2] = {s->nx, s->ny};
    sq_state_put(w, "snowcover/grid", grid, sizeof grid);
    sq_state_put(w, "snowcover/depth", s->depth, cells * sizeof(float));
    sq_state_put(w, "snowcover/version", &s->version, sizeof s->version);
    const int64_t pool[4] = {s->nflakes, (int64_t)s->flake_step, s->seeded, s->have_camera};
    sq_state_put(w, "snowcover/pool", pool, sizeof pool);
    sq_state_put(w, "snowcover/camera", &s->camera, sizeof s->camera);
    sq_state_put(w, "snowcover/centre", s->centre, sizeof s->centre);
    if (nf > 0) {
        sq_state_put(w, "snowcover/pos", s->pos, 3 * nf * sizeof(float));
        sq_state_put(w, "snowcover/vel", s->vel, 3 * nf * sizeof(float));
        sq_state_put(w, "snowcover/birth", s->birth, 2 * nf * sizeof(float));
        sq_state_put(w, "snowcover/rot", s->rot, nf * sizeof(float));
        sq_state_put(w, "snowcover/spin", s->spin, nf * sizeof(float));
    }
    return w->status;
}

sq_result sq__snowcover_load_state(void *self, sq_state_reader *r)
{
    sq_snowcover *s = (sq_snowcover *)self;
    double clock[2] = {0, 0};
    int64_t grid[2] = {0, 0}, pool[4] = {0, 0, 0, 0};
    sq_state_get(r, "snowcover/clock", clock, sizeof clock);
    if (sq_state_get(r, "snowcover/grid", grid, sizeof grid) != SQ_OK) return r->status;
    if (grid[0] != s->nx || grid[1] != s->ny)
        return r->status = sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "snowcover",
                                    "checkpoint '%s': a %lldx%lld snow grid; this layer has %dx%d",
                                    r->source, (long long)grid[0], (long long)grid[1], s->nx, s->ny);
    const size_t cells = (size_t)s->nx * (size_t)s->ny, nf = (size_t)s->nflakes;
    sq_state_get(r, "snowcover/depth", s->depth, cells * sizeof(float));
    sq_state_get(r, "snowcover/version", &s->version, sizeof s->version);
    if (sq_state_get(r, "snowcover/pool", pool, sizeof pool) != SQ_OK) return r->status;
    if (pool[0] != s->nflakes)
        return r->status = sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "snowcover",
                                    "checkpoint '%s': %lld flakes; this layer has %d", r->source,
                                    (long long)pool[0], s->nflakes);
    sq_state_get(r, "snowcover/camera", &s->camera, sizeof s->camera);
    sq_state_get(r, "snowcover/centre", s->centre, sizeof s->centre);
    if (nf > 0) {
        sq_state_get(r, "snowcover/pos", s->pos, 3 * nf * sizeof(float));
        sq_state_get(r, "snowcover/vel", s->vel, 3 * nf * sizeof(float));
        sq_state_get(r, "snowcover/birth", s->birth, 2 * nf * sizeof(float));
        sq_state_get(r, "snowcover/rot", s->rot, nf * sizeof(float));
        sq_state_get(r, "snowcover/spin", s->spin, nf * sizeof(float));
    }
    if (r->status != SQ_OK) return r->status;
    s->time_s = clock[0];
    s->water_m = clock[1];
    s->flake_step = (uint64_t)pool[1];
    s->seeded = pool[2] != 0;
    s->have_camera = pool[3] != 0;
    return SQ_OK;
}
