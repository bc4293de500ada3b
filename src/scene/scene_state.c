/* scene_state.c — the scene's part of a checkpoint (issue 17 part 4): its clock and, per layer,
 * the name and type (so that a checkpoint restores into the same layers) followed by the
 * phenomenon's own records (its save_state hook). */
#include <stdio.h>
#include <string.h>

#include "core/core_internal.h"
#include "phen/phenomenon_internal.h"
#include "scene_internal.h"

static sq_result put_text(sq_state_writer *w, const char *tag, const char *text)
{
    return sq_state_put(w, tag, text, strlen(text));
}

/* Reads a text record of at most size - 1 bytes. */
static sq_result get_text(sq_state_reader *r, const char *tag, char *buf, size_t size)
{
    const char *t = NULL;
    uint64_t n = 0;
    sq_result res = sq_state_peek(r, &t, &n);
    if (res != SQ_OK) return res;
    if (n >= size) n = size; /* refused by sq_state_get as the wrong size */
    res = sq_state_get(r, tag, buf, (size_t)n);
    buf[res == SQ_OK ? n : 0] = 0;
    return res;
}

sq_result sq_scene_save_state(const sq_scene *s, sq_state_writer *w)
{
    if (!s || !w) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_scene_save_state: NULL argument");
    sq_context *ctx = sq__scene_context(s);
    const int n = sq_scene_layer_count(s);
    for (int i = 0; i < n; i++) {
        const sq_phen_plugin *pl = sq_plugin_find(sq_scene_layer_type(s, i));
        if (!pl || !pl->save_state || !pl->load_state)
            return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "scene",
                            "layers.%s (%s) cannot be checkpointed: the phenomenon has no state "
                            "hooks",
                            sq_scene_layer_name(s, i), sq_scene_layer_type(s, i));
    }
    const double t = sq_scene_time(s);
    const uint64_t steps = sq__scene_steps(s);
    const int32_t count = n;
    sq_state_put(w, "scene/time_s", &t, sizeof t);
    sq_state_put(w, "scene/steps", &steps, sizeof steps);
    sq_state_put(w, "scene/layers", &count, sizeof count);
    for (int i = 0; i < n && w->status == SQ_OK; i++) {
        put_text(w, "layer/name", sq_scene_layer_name(s, i));
        put_text(w, "layer/type", sq_scene_layer_type(s, i));
        if (w->status == SQ_OK) sq__phenomenon_save_state(sq__scene_layer_handle(s, i), w);
    }
    return w->status;
}

sq_result sq_scene_load_state(sq_scene *s, sq_state_reader *r)
{
    if (!s || !r) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_scene_load_state: NULL argument");
    sq_context *ctx = sq__scene_context(s);
    double t = 0;
    uint64_t steps = 0;
    int32_t count = 0;
    sq_state_get(r, "scene/time_s", &t, sizeof t);
    sq_state_get(r, "scene/steps", &steps, sizeof steps);
    if (sq_state_get(r, "scene/layers", &count, sizeof count) != SQ_OK) return r->status;
    const int n = sq_scene_layer_count(s);
    if (count != n)
        return r->status = sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                                    "checkpoint '%s' holds %d layers; this scene has %d",
                                    r->source, (int)count, n);
    for (int i = 0; i < n && r->status == SQ_OK; i++) {
        char name[256], type[256];
        get_text(r, "layer/name", name, sizeof name);
        get_text(r, "layer/type", type, sizeof type);
        if (r->status != SQ_OK) break;
        if (strcmp(name, sq_scene_layer_name(s, i)) || strcmp(type, sq_scene_layer_type(s, i)))
            return r->status = sq__fail(ctx, SQ_ERR_INVALID_ARG, "scene",
                                        "checkpoint '%s': layer %d is '%s' (%s); this scene's is "
                                        "'%s' (%s)",
                                        r->source, i, name, type, sq_scene_layer_name(s, i),
                                        sq_scene_layer_type(s, i));
        sq__phenomenon_load_state(sq__scene_layer_handle(s, i), r);
    }
    if (r->status == SQ_OK) sq__scene_set_clock(s, t, steps);
    return r->status;
}
