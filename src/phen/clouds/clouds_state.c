/* clouds_state.c — the clouds' checkpoint hooks (issue 17 part 4). The state the following steps
 * depend on: the clock, the drift of the sub-grid pattern, and every particle (position, size,
 * optical depth and its coefficient, age and life, attributes, cloud, respawn counter, which is
 * its random-number counter). The field, the segmentation, the maps, the clusters and the drawn
 * elements are functions of the source at the clock and of the particles: they are rebuilt at
 * load (sq__clouds_refresh) instead of being stored. */
#include <string.h>

#include "clouds_internal.h"

#define PUT(tag, ptr, bytes) sq_state_put(w, "clouds/" tag, (ptr), (bytes))
#define GET(tag, ptr, bytes) sq_state_get(r, "clouds/" tag, (ptr), (bytes))

sq_result sq__clouds_save_state(const void *self, sq_state_writer *w)
{
    const sq_clouds *c = (const sq_clouds *)self;
    const sq__particles *p = &c->parts;
    const size_t n = (size_t)p->n;
    const int32_t count = p->n;
    PUT("time_s", &c->time_s, sizeof c->time_s);
    PUT("version", &c->version, sizeof c->version);
    PUT("subgrid_offset", c->field.sub.offset, sizeof c->field.sub.offset);
    PUT("count", &count, sizeof count);
    PUT("pos", p->pos, 3 * n * sizeof(float));
    PUT("radius", p->radius, n * sizeof(float));
    PUT("tau", p->tau, n * sizeof(float));
    PUT("coef", p->coef, n * sizeof(float));
    PUT("age", p->age, n * sizeof(float));
    PUT("life", p->life, n * sizeof(float));
    PUT("density", p->density, n * sizeof(float));
    PUT("g", p->g, n * sizeof(float));
    PUT("stage", p->stage, n);
    PUT("phase", p->phase, n);
    PUT("cloud", p->cloud, n * sizeof(int32_t));
    PUT("gen", p->gen, n * sizeof(uint32_t));
    PUT("radius_auto", &p->radius_auto, sizeof p->radius_auto);
    return PUT("respawns", &p->respawns, sizeof p->respawns);
}

sq_result sq__clouds_load_state(void *self, sq_state_reader *r)
{
    sq_clouds *c = (sq_clouds *)self;
    sq__particles *p = &c->parts;
    const size_t n = (size_t)p->n;
    int32_t count = 0;
    uint64_t version = 0;
    GET("time_s", &c->time_s, sizeof c->time_s);
    GET("version", &version, sizeof version);
    GET("subgrid_offset", c->field.sub.offset, sizeof c->field.sub.offset);
    sq_result res = GET("count", &count, sizeof count);
    if (res != SQ_OK) return res;
    if (count != p->n)
        return sq__fail(c->ctx, SQ_ERR_INVALID_ARG, "clouds",
                        "checkpoint: %d cloud particles stored, the scene makes %d", (int)count,
                        p->n);
    GET("pos", p->pos, 3 * n * sizeof(float));
    GET("radius", p->radius, n * sizeof(float));
    GET("tau", p->tau, n * sizeof(float));
    GET("coef", p->coef, n * sizeof(float));
    GET("age", p->age, n * sizeof(float));
    GET("life", p->life, n * sizeof(float));
    GET("density", p->density, n * sizeof(float));
    GET("g", p->g, n * sizeof(float));
    GET("stage", p->stage, n);
    GET("phase", p->phase, n);
    GET("cloud", p->cloud, n * sizeof(int32_t));
    GET("gen", p->gen, n * sizeof(uint32_t));
    GET("radius_auto", &p->radius_auto, sizeof p->radius_auto);
    res = GET("respawns", &p->respawns, sizeof p->respawns);
    if (res != SQ_OK) return res;
    const float radius_auto = p->radius_auto;
    res = sq__clouds_refresh(c);
    p->radius_auto = radius_auto; /* the refresh re-derives it; the stored one is exact */
    c->version = version;
    return res;
}
