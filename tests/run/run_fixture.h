/* run_fixture.h — the small scene and the sinks the frame-loop tests share. */
#ifndef SQ_RUN_FIXTURE_H
#define SQ_RUN_FIXTURE_H

#include <stdlib.h>
#include <string.h>

#include "sq_config.h"
#include "sq_test.h"
#include "squall/io.h"
#include "squall/run.h"
#include "squall/scene.h"

#define FRAMES 6

static sq_context *mkctx(void)
{
    sq_context_desc cd = {0};
    cd.threads = 1; /* bit-reproducible */
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

/* A small desert sandstorm with dust flowing in (or no layer when no sandstorm is built). */
static sq_scene *mkscene(sq_context *ctx, const char *extra_output)
{
    char text[2048];
    snprintf(text, sizeof text,
             "name: run-test\n"
             "world:\n"
             "  terrain: {kind: flat, size_m: [2000, 2000], resolution: [33, 33]}\n"
             "camera: {position: [0, -900, 60], target: [0, 0, 60]}\n"
             "%s"
             "output: {width: 64, height: 36, fps: 4, frames: %d, warmup_s: 1.5%s%s}\n",
             SQ_HAVE_SANDSTORM ? "layers:\n"
                                 "  - type: sandstorm\n"
                                 "    domain: {nx: 12, ny: 12, nz: 6, cell_size_m: 100}\n"
                                 "    dust: {bins: 1, inflow_kg_m3: 0.002}\n"
                               : "",
             FRAMES, extra_output ? ", " : "", extra_output ? extra_output : "");
    sq_cfg *cfg = NULL;
    SQ_CHECK_OK(sq_cfg_parse(ctx, text, strlen(text), "run.yaml", &cfg));
    if (!cfg) return NULL;
    sq_scene_desc sd = {.cfg = cfg};
    sq_scene *s = NULL;
    SQ_CHECK_OK(sq_scene_create(ctx, &sd, &s));
    sq_cfg_destroy(cfg);
    return s;
}

typedef struct sink_log {
    int metric_rows, field_sets, frames_seen;
    double times[FRAMES + 4];
    int last_frame;
    uint8_t *last_rgba;
    int stop_after; /* cancel once this many metric rows arrived (0 = never) */
} sink_log;

__attribute__((unused)) static sq_result on_metrics(void *user, int frame, double t, const sq_metric *m, int n)
{
    sink_log *l = (sink_log *)user;
    if (frame < FRAMES + 4) l->times[frame] = t;
    l->metric_rows++;
    (void)m;
    (void)n;
    return SQ_OK;
}

__attribute__((unused)) static sq_result on_fields(void *user, int frame, double t, const sq_named_field *f, int n)
{
    sink_log *l = (sink_log *)user;
    l->field_sets++;
    (void)frame;
    (void)t;
    for (int i = 0; i < n; i++)
        if (!f[i].name || !f[i].units || !f[i].data) return sq_set_error(SQ_ERR_INTERNAL, "bad field");
    return SQ_OK;
}

__attribute__((unused)) static sq_result on_frame(void *user, const sq_run_frame *f)
{
    sink_log *l = (sink_log *)user;
    if (f->index < l->last_frame) return sq_set_error(SQ_ERR_INTERNAL, "frames out of order");
    l->last_frame = f->index;
    l->frames_seen++;
    free(l->last_rgba);
    l->last_rgba = malloc((size_t)f->width * f->height * 4);
    if (l->last_rgba) memcpy(l->last_rgba, f->rgba, (size_t)f->width * f->height * 4);
    return SQ_OK;
}

#endif
