/* phen/plugin_glue.h — generates a phenomenon's plug-in vtable from its typed C API.
 *
 * A phenomenon <n> exposes a typed API (include/squall/<n>.h: sq_<n>_desc_resolve,
 * sq_<n>_validate, sq_<n>_memory_bytes, sq_<n>_create/destroy, sq_<n>_max_stable_dt,
 * sq_<n>_step) and internal drawables/metrics/fields accessors (sq__<n>_drawables, _metrics,
 * _fields). The scene system calls it through the untyped sq_phen_plugin vtable; the one-line
 * trampolines that cast void* back to the typed object are the same for every phenomenon and are
 * generated here, so that each <n>_plugin.c holds only its parameter table and one
 * SQ__PHEN_PLUGIN(...) line.
 *
 *   SQ__PHEN_PLUGIN(n, summary, memory_takes_world)
 *   SQ__PHEN_PLUGIN_OBSERVING(n, summary, memory_takes_world, observe_fn)
 *     n                   the phenomenon's C name (sandstorm, snowdrift, avalanche)
 *     summary             one-line description shown by `squall scenes` / `squall params`
 *     memory_takes_world  1 when sq_<n>_memory_bytes(desc, world), 0 when sq_<n>_memory_bytes(desc)
 *     observe_fn          void fn(sq_<n> *, const sq_camera *): the camera of each frame
 *
 * It defines `const sq_phen_plugin sq__<n>_plugin` with the parameter table `params` that must be
 * declared before it in the same file. */
#ifndef SQ_PHEN_PLUGIN_GLUE_H
#define SQ_PHEN_PLUGIN_GLUE_H

#include <stddef.h>

#include "squall/plugin.h"

/* ---- parameter-table entries ------------------------------------------------------------------
 * Short constructors for the entries of a plug-in's `params` table. The including file defines
 * S as its desc type first (`#define S sq_<n>_desc`); only <n>_plugin.c files include this
 * header, so the short names stay local to them.
 *   D  double, I int, B bool, E enum ("a|b|c"), V3 float[3] ("x y z" default text),
 *   FL float list with a count field, STR string (char[SQ_PARAM_STRING_MAX]); Z, A and L are
 *   the flags zero-is-physical, advanced and live (a change may apply to a running scene:
 *   rendering, forcing, emission). */
#define D(key, field, unit, def, lo, hi, flags, doc)                                               \
    {key, SQ_PARAM_DOUBLE, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0, flags, doc}
#define I(key, field, unit, def, lo, hi, doc)                                                      \
    {key, SQ_PARAM_INT, unit, offsetof(S, field), def, lo, hi, NULL, NULL, 0, 0, 0, doc}
#define B(key, field, doc)                                                                         \
    {key, SQ_PARAM_BOOL, "", offsetof(S, field), 0, 0, 1, NULL, NULL, 0, 0, 0, doc}
#define E(key, field, choices, doc)                                                                \
    {key, SQ_PARAM_ENUM, "", offsetof(S, field), 0, 0, 0, NULL, choices, 0, 0, 0, doc}
#define V3(key, field, unit, deftext, lo, hi, doc)                                                 \
    {key, SQ_PARAM_VEC3, unit, offsetof(S, field), 0, lo, hi, deftext, NULL, 0, 0, 0, doc}
#define FL(key, field, cnt, unit, deftext, maxc, lo, hi, doc)                                      \
    {key, SQ_PARAM_FLOATS, unit, offsetof(S, field), 0, lo, hi, deftext, NULL, maxc,              \
     offsetof(S, cnt), 0, doc}
#define STR(key, field, deftext, doc)                                                              \
    {key, SQ_PARAM_STRING, "", offsetof(S, field), 0, 0, 0, deftext, NULL, 0, 0, 0, doc}
#define Z SQ_PARAM_ZERO_IS_PHYSICAL
#define A SQ_PARAM_ADVANCED
#define L SQ_PARAM_LIVE

#define SQ__PHEN_MEMORY_0(n, desc, w) sq_##n##_memory_bytes((const sq_##n##_desc *)(desc))
#define SQ__PHEN_MEMORY_1(n, desc, w) sq_##n##_memory_bytes((const sq_##n##_desc *)(desc), (w))

#define SQ__PHEN_OBSERVE_TRAMPOLINE(n, fn)                                                         \
    static void n##_p_observe(void *self, const sq_camera *camera)                                \
    {                                                                                              \
        fn((sq_##n *)self, camera);                                                                \
    }

#define SQ__PHEN_PLUGIN_IMPL(n, summary_text, memory_takes_world, observe_ptr)                          \
    static sq_result n##_p_resolve(void *desc)                                                     \
    {                                                                                              \
        return sq_##n##_desc_resolve((sq_##n##_desc *)desc, (sq_##n##_desc *)desc);                \
    }                                                                                              \
    static sq_result n##_p_validate(sq_context *ctx, const void *desc, const sq_world *w)         \
    {                                                                                              \
        return sq_##n##_validate(ctx, (const sq_##n##_desc *)desc, w);                             \
    }                                                                                              \
    static sq_result n##_p_memory(const void *desc, const sq_world *w, uint64_t *bytes)           \
    {                                                                                              \
        (void)w;                                                                                   \
        *bytes = SQ__PHEN_MEMORY_##memory_takes_world(n, desc, w);                                 \
        return SQ_OK;                                                                              \
    }                                                                                              \
    static sq_result n##_p_create(sq_context *ctx, const void *desc, const sq_world *w,           \
                                  void **out)                                                      \
    {                                                                                              \
        return sq_##n##_create(ctx, (const sq_##n##_desc *)desc, w, (sq_##n **)out);               \
    }                                                                                              \
    static void n##_p_destroy(void *self) { sq_##n##_destroy((sq_##n *)self); }                   \
    static double n##_p_dt(const void *self)                                                       \
    {                                                                                              \
        return sq_##n##_max_stable_dt((const sq_##n *)self);                                       \
    }                                                                                              \
    static sq_result n##_p_step(void *self, double dt_s)                                           \
    {                                                                                              \
        return sq_##n##_step((sq_##n *)self, dt_s);                                                \
    }                                                                                              \
    static int n##_p_drawables(void *self, sq_drawable *out, int max)                              \
    {                                                                                              \
        return sq__##n##_drawables((sq_##n *)self, out, max);                                      \
    }                                                                                              \
    static int n##_p_metrics(void *self, sq_metric *out, int max)                                  \
    {                                                                                              \
        return sq__##n##_metrics((sq_##n *)self, out, max);                                        \
    }                                                                                              \
    static int n##_p_fields(void *self, sq_named_field *out, int max)                              \
    {                                                                                              \
        return sq__##n##_fields((sq_##n *)self, out, max);                                         \
    }                                                                                              \
    const sq_phen_plugin sq__##n##_plugin = {                                                      \
        .name = #n,                                                                                \
        .summary = summary_text,                                                                        \
        .desc_size = sizeof(sq_##n##_desc),                                                        \
        .params = params,                                                                          \
        .param_count = sizeof params / sizeof params[0],                                           \
        .desc_resolve = n##_p_resolve,                                                             \
        .validate = n##_p_validate,                                                                \
        .memory_bytes = n##_p_memory,                                                              \
        .create = n##_p_create,                                                                    \
        .destroy = n##_p_destroy,                                                                  \
        .max_stable_dt = n##_p_dt,                                                                 \
        .step = n##_p_step,                                                                        \
        .observe = observe_ptr,                                                                    \
        .drawables = n##_p_drawables,                                                              \
        .metrics = n##_p_metrics,                                                                  \
        .fields = n##_p_fields,                                                                    \
        .save_state = SQ__PHEN_STATE_SAVE,                                                         \
        .load_state = SQ__PHEN_STATE_LOAD,                                                         \
        .apply_live = SQ__PHEN_APPLY_LIVE,                                                         \
        .frame_sync = SQ__PHEN_FRAME_SYNC,                                                         \
    }

/* Checkpoint hooks: a plug-in that can be checkpointed says, after including this file,
 *   #undef SQ__PHEN_STATE_SAVE
 *   #define SQ__PHEN_STATE_SAVE sq__<n>_save_state   (sq_result (const void *, sq_state_writer *))
 *   #undef SQ__PHEN_STATE_LOAD
 *   #define SQ__PHEN_STATE_LOAD sq__<n>_load_state   (sq_result (void *, sq_state_reader *))
 * before its SQ__PHEN_PLUGIN line; without them the layer is refused by checkpoints. */
#ifndef SQ__PHEN_STATE_SAVE
#define SQ__PHEN_STATE_SAVE NULL
#define SQ__PHEN_STATE_LOAD NULL
#endif

/* Live changes: a plug-in that applies its SQ_PARAM_LIVE keys to a running instance says
 *   #undef SQ__PHEN_APPLY_LIVE
 *   #define SQ__PHEN_APPLY_LIVE sq__<n>_apply_live   (sq_result (void *self, const void *desc))
 * before its SQ__PHEN_PLUGIN line; without it every change rebuilds the layer. */
#ifndef SQ__PHEN_APPLY_LIVE
#define SQ__PHEN_APPLY_LIVE NULL
#endif

/* Distributed runs: a plug-in split over the ranks says
 *   #undef SQ__PHEN_FRAME_SYNC
 *   #define SQ__PHEN_FRAME_SYNC sq__<n>_frame_sync   (sq_result (void *self, bool gather))
 * before its SQ__PHEN_PLUGIN line (see sq_phen_plugin.frame_sync). */
#ifndef SQ__PHEN_FRAME_SYNC
#define SQ__PHEN_FRAME_SYNC NULL
#endif

/* Without a camera hook. */
#define SQ__PHEN_PLUGIN(n, summary, memory_takes_world)                                            \
    SQ__PHEN_PLUGIN_IMPL(n, summary, memory_takes_world, NULL)

/* With a camera hook: observe_fn(sq_<n> *, const sq_camera *) is called once per frame. */
#define SQ__PHEN_PLUGIN_OBSERVING(n, summary, memory_takes_world, observe_fn)                      \
    SQ__PHEN_OBSERVE_TRAMPOLINE(n, observe_fn)                                                     \
    SQ__PHEN_PLUGIN_IMPL(n, summary, memory_takes_world, n##_p_observe)

#endif
