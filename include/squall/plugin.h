/* squall/plugin.h — how a phenomenon plugs in: a parameter table (the single source of truth
 * for scene-file keys, --set overrides, `squall params`, docs) and a vtable. One registry line
 * (src/phen/registry.c) makes it available to scenes, the CLI and the renderer. */
#ifndef SQ_PLUGIN_H
#define SQ_PLUGIN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sq_param_type {
    SQ_PARAM_NONE = 0,
    SQ_PARAM_FLOAT = 1,   /* float */
    SQ_PARAM_DOUBLE = 2,  /* double */
    SQ_PARAM_INT = 3,     /* int */
    SQ_PARAM_BOOL = 4,    /* bool */
    SQ_PARAM_ENUM = 5,    /* int index into choices "a|b|c" */
    SQ_PARAM_VEC3 = 6,    /* float[3] (or sq_vec3) */
    SQ_PARAM_STRING = 7,  /* char[SQ_PARAM_STRING_MAX] */
    SQ_PARAM_FLOATS = 8,  /* float[max_count] + int count at count_offset */
    SQ_PARAM_U64 = 9      /* uint64_t (seeds) */
} sq_param_type;

#define SQ_PARAM_STRING_MAX 256

enum {
    SQ_PARAM_ZERO_IS_PHYSICAL = 1u << 0, /* 0 is a real value and is never replaced */
    SQ_PARAM_ADVANCED = 1u << 1,         /* hidden from short listings */
    SQ_PARAM_PATH = 1u << 2,             /* STRING: a file path; the scene resolves a relative
                                            one against the scene file's folder */
    /* a change may apply to a running scene (rendering, forcing, emission): an interactive front
     * end applies it at once; entries without it need a rebuild (domain size, grids, seeds) */
    SQ_PARAM_LIVE = 1u << 3
};

typedef struct sq_param {
    const char *key;      /* dotted key within its section, e.g. "dust.median_radius_m" */
    sq_param_type type;
    const char *unit;     /* SI unit ("m", "m/s", "kg/m3", "1" dimensionless, "" none) */
    size_t offset;        /* offsetof(desc, field) */
    double def;           /* default for numbers, bools (0/1), enums (index) */
    double min, max;      /* inclusive range for numbers and each element of lists/vec3 */
    const char *def_text; /* default for strings, vec3 ("0 0 1") and lists ("1 2 3") */
    const char *choices;  /* ENUM: "desert|urban" */
    int max_count;        /* FLOATS: capacity */
    size_t count_offset;  /* FLOATS: offsetof the int count */
    unsigned flags;
    const char *doc;      /* one or two sentences: meaning, source (S0 §x / SPEC) */
} sq_param;

/* Fills every field of desc from the table's defaults. */
SQ_API void sq_params_defaults(const sq_param *table, size_t n, void *desc);
/* Finds the entry for key (NULL if none). */
SQ_API const sq_param *sq_params_find(const sq_param *table, size_t n, const char *key);
/* Sets key from text (numbers in the table's unit; bools true/false/yes/no/1/0; enums by name;
 * vec3 and lists as "a b c" or "[a, b, c]"). Checks type and range. where names the place for
 * messages (e.g. "scene.yaml:12:5" or "--set"). Errors: SQ_ERR_NOT_FOUND (unknown key, with a
 * "did you mean" suggestion), SQ_ERR_INVALID_ARG (wrong type, out of range with range + unit). */
SQ_API sq_result sq_params_set(const sq_param *table, size_t n, void *desc, const char *section,
                               const char *key, const char *value, const char *where);
/* Writes the current value of an entry as text (YAML scalar or flow list). */
SQ_API void sq_params_format(const sq_param *p, const void *desc, char *buf, size_t size);
/* Checks every entry's range; messages name section.key, value, range and unit. */
SQ_API sq_result sq_params_validate(const sq_param *table, size_t n, const void *desc,
                                    const char *section);
/* Closest key by edit distance (NULL if nothing is close). */
SQ_API const char *sq_params_suggest(const sq_param *table, size_t n, const char *key);
/* Live changes: the first entry whose value differs between descs a and b among the entries with
 * SQ_PARAM_LIVE (live = true) or among those without it (live = false); NULL when none. */
SQ_API const sq_param *sq_params_first_change(const sq_param *table, size_t n, const void *a,
                                              const void *b, bool live);
/* Copies the value of every SQ_PARAM_LIVE entry from src to dst (descs of the same table). */
SQ_API void sq_params_copy_live(const sq_param *table, size_t n, void *dst, const void *src);

/* ---- the phenomenon vtable ------------------------------------------------------------- */
typedef struct sq_phen_plugin {
    const char *name;      /* layer type in scene files: "sandstorm" */
    const char *summary;   /* one line */
    size_t desc_size;      /* sizeof the phenomenon's desc */
    const sq_param *params;
    size_t param_count;
    /* Fills zero fields with defaults (zero-is-physical fields stay). */
    sq_result (*desc_resolve)(void *desc);
    /* Checks the desc against physics and the world (beyond table ranges). */
    sq_result (*validate)(sq_context *ctx, const void *desc, const sq_world *world);
    /* Bytes the instance will allocate (refused before create if too large). */
    sq_result (*memory_bytes)(const void *desc, const sq_world *world, uint64_t *bytes);
    sq_result (*create)(sq_context *ctx, const void *desc, const sq_world *world, void **out);
    void (*destroy)(void *self);
    /* Largest step the phenomenon takes stably now (s); the scene sub-cycles to it. <= 0: any. */
    double (*max_stable_dt)(const void *self);
    sq_result (*step)(void *self, double dt_s);
    /* Optional: the camera for this frame (near-field particles live around it). */
    void (*observe)(void *self, const sq_camera *camera);
    /* Fills up to max drawables; returns the count. */
    int (*drawables)(void *self, sq_drawable *out, int max);
    /* Fills up to max metrics for the current state; returns the count. */
    int (*metrics)(void *self, sq_metric *out, int max);
    /* Fills up to max fields for export; returns the count. */
    int (*fields)(void *self, sq_named_field *out, int max);
    /* Optional (checkpoints): save writes every piece of state the following steps depend on
     * as records (sq_state_put); load reads the same records into an instance created from the
     * same desc and world, after which it continues bit-identically. NULL: the phenomenon cannot
     * be checkpointed (a checkpoint of a scene with it is refused, naming the layer). */
    sq_result (*save_state)(const void *self, sq_state_writer *w);
    sq_result (*load_state)(void *self, sq_state_reader *r);
    /* Optional (interactive front ends): applies the SQ_PARAM_LIVE entries of desc — a complete
     * desc of the same layer, resolved and validated (table ranges and validate), differing from
     * the instance's only in live entries — to the running instance between two steps, and
     * re-derives what depends on them (inflow, thresholds, optics of the drawables), without
     * touching the simulated state or time. On failure the instance is unchanged. NULL: the
     * phenomenon takes no live change; a change of any of its keys rebuilds the layer. */
    sq_result (*apply_live)(void *self, const void *desc);
    /* Optional (distributed runs, squall/par.h): collective, called by every rank once per
     * frame after the frame's steps and before its drawables, metrics and fields. The
     * phenomenon computes there what its metrics need from every rank (reductions), and with
     * gather (rank 0 draws or writes fields this frame) collects its state on rank 0. NULL:
     * the phenomenon is not split, or needs nothing per frame. */
    sq_result (*frame_sync)(void *self, bool gather);
} sq_phen_plugin;

/* Whether a change of entry p applies to a running scene (sq_scene_apply_live; an interactive
 * front end applies it at once) or needs a rebuild: its SQ_PARAM_LIVE flag and, for an entry of
 * a layer's table (plugin not NULL), a plug-in with the apply_live hook. The one rule that
 * `squall params` lists and the viewer's panel follows. (The sun keys of a world on a WRF
 * terrain, whose file places the sun, still rebuild: that depends on the scene.) */
SQ_API bool sq_param_live(const sq_param *p, const sq_phen_plugin *plugin);

/* The phenomena compiled into this library, in a fixed order (sq_plugin_at(0 .. count-1)),
 * and one by name (NULL if there is none of that name). The tables are static. */
SQ_API int sq_plugin_count(void);
SQ_API const sq_phen_plugin *sq_plugin_at(int i);
SQ_API const sq_phen_plugin *sq_plugin_find(const char *name);

#ifdef __cplusplus
}
#endif
#endif
