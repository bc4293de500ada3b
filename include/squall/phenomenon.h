/* squall/phenomenon.h — one handle for every phenomenon (sandstorm, snowdrift, avalanche, and
 * any plug-in added later) over the plug-in table of squall/plugin.h: create it from a type name
 * and either a typed desc or "key=value" settings, step it, give it the camera, and read what it
 * publishes — named 2D/3D fields with units and grid geometry, scalar metrics with units, and the
 * drawables a renderer draws. A new phenomenon needs no new calls here.
 *
 * The typed calls of each phenomenon (squall/sandstorm.h, ...) stay for users who want them;
 * sq_phenomenon_typed() returns the typed object behind a handle.
 *
 * Ownership and lifetime: the handle is created and destroyed by its owner (sq_phenomenon_create
 * / sq_phenomenon_destroy), or borrowed from a scene (sq_scene_layer: owned by the scene, valid
 * until sq_scene_destroy). It borrows the context and the world, which must outlive it. Every
 * view it returns (field data, metric names, drawables) is borrowed: valid until the next
 * sq_phenomenon_step, sq_phenomenon_observe or destroy of the handle (or of its scene).
 *
 * Threads: a handle is externally synchronised — one thread at a time may call into it. Errors:
 * functions that can fail return sq_result, with the reason in sq_last_error(); messages about a
 * desc name its C type and parameter key, e.g. "sq_sandstorm_desc.wind.speed_mps = -5 m/s: ...".
 * Units are SI. */
#ifndef SQ_PHENOMENON_H
#define SQ_PHENOMENON_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/plugin.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sq_phenomenon sq_phenomenon;

typedef struct sq_phenomenon_desc {
    /* plug-in name: "sandstorm", "snowdrift", "avalanche" (sq_plugin_count/at list them) */
    const char *type;
    /* instance name used in messages and as the metric prefix of a scene; NULL -> type */
    const char *name;
    /* optional typed desc: a filled sq_<type>_desc (zero fields take their defaults), copied at
     * create; typed_desc_size must be sizeof(sq_<type>_desc). NULL: every parameter at the
     * default of the parameter table (`squall params <type>`). */
    const void *typed_desc;
    size_t typed_desc_size;
    /* optional "key=value" settings through the parameter table, applied after typed_desc, e.g.
     * "wind.speed_mps=20" (values in the table's unit; lists as "[1, 2]"); borrowed for the call */
    const char *const *settings;
    int setting_count;
} sq_phenomenon_desc;

/* Creates the phenomenon on world: settings are applied and checked (type, range, unknown keys
 * with a suggestion), the desc is resolved and validated by the phenomenon (rules against the
 * world included) and its memory is checked against the context's limit before anything is
 * allocated. Errors: SQ_ERR_NOT_FOUND (unknown type or key), SQ_ERR_INVALID_ARG (bad value or
 * rule; the message names sq_<type>_desc.<key>, the value and the rule), SQ_ERR_TOO_LARGE
 * (memory), SQ_ERR_OUT_OF_MEMORY. *out is NULL on failure. */
SQ_API sq_result sq_phenomenon_create(sq_context *ctx, const sq_phenomenon_desc *desc,
                                      const sq_world *world, sq_phenomenon **out);
/* Destroys a handle made by sq_phenomenon_create (NULL is accepted). Never call it on a handle
 * borrowed from a scene. */
SQ_API void sq_phenomenon_destroy(sq_phenomenon *p);

/* The plug-in name ("sandstorm"), the instance name (desc.name or the type) and the plug-in
 * table; all valid as long as the handle. */
SQ_API const char *sq_phenomenon_type(const sq_phenomenon *p);
SQ_API const char *sq_phenomenon_name(const sq_phenomenon *p);
SQ_API const sq_phen_plugin *sq_phenomenon_plugin(const sq_phenomenon *p);
/* The resolved desc (a const sq_<type>_desc *), read-only, valid as long as the handle. */
SQ_API const void *sq_phenomenon_desc_get(const sq_phenomenon *p);
/* The typed object (sq_sandstorm *, sq_snowdrift *, ...) when type names this handle's type,
 * else NULL: for the typed calls of squall/<type>.h. Owned by the handle. */
SQ_API void *sq_phenomenon_typed(sq_phenomenon *p, const char *type);
/* Bytes the phenomenon declared before create (its memory_bytes). */
SQ_API uint64_t sq_phenomenon_memory_bytes(const sq_phenomenon *p);

/* Simulated time (s) since creation: the sum of the dt_s passed to sq_phenomenon_step. */
SQ_API double sq_phenomenon_time(const sq_phenomenon *p);
/* Largest step (s) the phenomenon takes stably now; <= 0: any. */
SQ_API double sq_phenomenon_max_stable_dt(const sq_phenomenon *p);
/* Advances by dt_s > 0 seconds, sub-cycled in equal steps no longer than the stable step (more
 * than 100000 sub-steps is refused with SQ_ERR_UNSTABLE). A numerical blow-up returns
 * SQ_ERR_UNSTABLE with the step, place and field in the message; the handle may then only be
 * read or destroyed. Invalidates every view. */
SQ_API sq_result sq_phenomenon_step(sq_phenomenon *p, double dt_s);
/* The camera of the next frame (phenomena with near-field particles place them around it; the
 * others ignore it). Invalidates the drawables. */
SQ_API void sq_phenomenon_observe(sq_phenomenon *p, const sq_camera *camera);
/* A distributed run (mpirun): collective, once per frame on every rank after the steps, before
 * the frame's views; gather: rank 0 reads the drawables or fields of this frame. Invalidates
 * every view. Nothing for a phenomenon that is not split. */
SQ_API sq_result sq_phenomenon_frame_sync(sq_phenomenon *p, bool gather);

/* ---- live changes (interactive front ends) -------------------------------------------------- */
/* What a live change did: applied (changed > 0), nothing to do (changed == 0), or refused because
 * it needs a rebuild (rebuild, with the key in reason); nothing is applied when rebuild is set. */
typedef struct sq_live_result {
    bool rebuild;      /* a key without SQ_PARAM_LIVE changed, or the phenomenon takes no live
                          change (no apply_live hook): rebuild the layer (restart from t = 0) */
    char reason[320];  /* with rebuild: which key, e.g. "sq_sandstorm_desc.domain.nx changed: ..." */
    int changed;       /* live entries that changed and were applied */
} sq_live_result;

/* Applies a changed desc to the running phenomenon between two steps: desc is a complete
 * sq_<type>_desc of desc_size bytes (zero fields take their defaults), checked exactly as at
 * create (table ranges, the phenomenon's rules against the world: the same messages). Only the
 * entries flagged SQ_PARAM_LIVE may differ from the current desc (sq_phenomenon_desc_get); they
 * go to the phenomenon's apply_live hook, which keeps the simulated state and time. res (cleared
 * by the caller) says what happened. Errors: SQ_ERR_INVALID_ARG (a refused value: nothing
 * applied), or the hook's. Not thread-safe against a step of the same handle. */
SQ_API sq_result sq_phenomenon_apply_live(sq_phenomenon *p, const void *desc, size_t desc_size,
                                          sq_live_result *res);

/* ---- what it publishes (views valid until the next step / observe / destroy) -------------- */
/* Fields for export and analysis: a named 3D grid (or a 2D map with nz = 1) of floats, x
 * fastest, with units (UDUNITS), CF names where they exist, the centre of cell (0,0,0) and the
 * spacing in metres. Computed once per step on first request (some are derived). */
SQ_API int sq_phenomenon_field_count(sq_phenomenon *p);
/* Field i in [0, count): SQ_ERR_NOT_FOUND outside. out->data is borrowed. */
SQ_API sq_result sq_phenomenon_field(sq_phenomenon *p, int i, sq_named_field *out);
/* Field by name (e.g. "dust_mass_concentration", "u", "snow_depth"); SQ_ERR_NOT_FOUND names
 * the fields there are. */
SQ_API sq_result sq_phenomenon_field_find(sq_phenomenon *p, const char *name,
                                          sq_named_field *out);
/* Scalar metrics of the current state, e.g. {"visibility_2m_min", 312.5, "m"}. */
SQ_API int sq_phenomenon_metric_count(sq_phenomenon *p);
SQ_API sq_result sq_phenomenon_metric(sq_phenomenon *p, int i, sq_metric *out);
SQ_API sq_result sq_phenomenon_metric_find(sq_phenomenon *p, const char *name, sq_metric *out);
/* Up to max drawables for the renderer (sq_renderer_draw / sq_renderer_draw_to); returns the
 * count (at most 16 per phenomenon). */
SQ_API int sq_phenomenon_drawables(sq_phenomenon *p, sq_drawable *out, int max);

#ifdef __cplusplus
}
#endif
#endif
