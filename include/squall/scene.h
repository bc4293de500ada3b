/* squall/scene.h — a scene = world + phenomena (layers) + camera + outputs, stepped on one
 * clock. Scenes are built from a configuration tree (parsed from YAML by the io layer, or a
 * built-in preset) through the parameter tables of each section and plug-in. */
#ifndef SQ_SCENE_H
#define SQ_SCENE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/geo.h"
#include "squall/phenomenon.h"
#include "squall/plugin.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- configuration tree ------------------------------------------------------------------ */
typedef enum sq_cfg_kind { SQ_CFG_SCALAR = 0, SQ_CFG_MAP = 1, SQ_CFG_SEQ = 2 } sq_cfg_kind;

typedef struct sq_cfg_node {
    sq_cfg_kind kind;
    char *key;      /* for entries of a map */
    char *value;    /* for scalars */
    int line, col;  /* 1-based position in the source (0 for --set) */
    struct sq_cfg_node *child; /* first entry of a map or sequence */
    struct sq_cfg_node *next;  /* next sibling */
} sq_cfg_node;

typedef struct sq_cfg {
    sq_cfg_node *root;   /* a map */
    char source[256];    /* file name or "preset NAME" */
    char base_dir[512];  /* directory relative paths in the file are resolved against */
} sq_cfg;

/* The configuration tree: an empty tree (root = an empty map), freed with sq_cfg_destroy
 * (NULL accepted). Nodes are made with sq_cfg_node_new (key and value copied; NULL on out of
 * memory) and freed with sq_cfg_node_free (with their children and following siblings). */
SQ_API sq_result sq_cfg_create(sq_cfg **out);
SQ_API void sq_cfg_destroy(sq_cfg *cfg);
SQ_API sq_cfg_node *sq_cfg_node_new(sq_cfg_kind kind, const char *key, const char *value,
                                    int line, int col);
SQ_API void sq_cfg_node_free(sq_cfg_node *n);
/* Appends child to parent's list. */
SQ_API void sq_cfg_node_append(sq_cfg_node *parent, sq_cfg_node *child);
/* Map lookup (NULL if absent or parent is not a map). */
SQ_API sq_cfg_node *sq_cfg_get(const sq_cfg_node *map, const char *key);
/* Applies "path.to.key=value". Path parts (separated by single dots) address map keys; for
 * sequences a part is an index or, in `layers`, a layer's name or type. Missing map keys are
 * created. A value starting with '[' is a list "[a, b, c]" of plain values and must end with
 * ']'. The whole text must be UTF-8 without control characters (what a scene file can hold).
 * On failure the tree is unchanged. */
SQ_API sq_result sq_cfg_set(sq_cfg *cfg, const char *assignment);
/* The rule for the text of an assignment (sq_cfg_set applies it as "--set"): UTF-8 without
 * control characters. SQ_ERR_INVALID_ARG naming what (e.g. "--metrics") and the byte. */
SQ_API sq_result sq_cfg_check_text(const char *what, const char *text);
/* Writes the tree as YAML into a malloc'd string (free with free()); sq_cfg_parse reads it
 * back as the same tree. NULL (error text set) when the tree holds invalid UTF-8. */
SQ_API char *sq_cfg_to_yaml(const sq_cfg *cfg);
/* True when text is valid UTF-8 without control characters (U+0000..U+001F, U+007F). */
SQ_API bool sq_cfg_text_ok(const char *text);

/* Built-in presets (the YAML files of scenes/ compiled into the library). */
SQ_API int sq_preset_count(void);
SQ_API const char *sq_preset_name(int i);
SQ_API const char *sq_preset_text(const char *name); /* NULL if unknown */
/* The default scene of `squall render` without arguments and of `make demo`. */
SQ_API const char *sq_preset_default(void);

/* ---- section tables (world, camera, output) for `squall params` -------------------------- */
SQ_API const sq_param *sq_scene_section_params(const char *section, size_t *count);

/* ---- scene outputs ------------------------------------------------------------------------- */
typedef enum sq_field_format {
    SQ_FIELDS_NETCDF = 0,
    SQ_FIELDS_VTK = 1,
    SQ_FIELDS_BOTH = 2
} sq_field_format;

typedef struct sq_scene_output {
    int width, height;        /* frame size */
    int fps;                  /* frames per second of video time */
    double duration_s;        /* video length; frames = round(duration * fps) unless frames set */
    int frames;               /* frame count (0 = from duration) */
    int steps_per_frame;      /* simulation steps per frame (>= 1) */
    double time_scale;        /* simulated seconds per video second (1 = real time) */
    double warmup_s;          /* simulated time stepped before the first frame */
    char video[SQ_PARAM_STRING_MAX];      /* MP4 path ("" = none) */
    char frames_dir[SQ_PARAM_STRING_MAX]; /* PNG frames directory ("" = none) */
    char metrics[SQ_PARAM_STRING_MAX];    /* CSV path ("" = none) */
    char fields[SQ_PARAM_STRING_MAX];     /* field file prefix ("" = none) */
    int fields_every;         /* write fields every N frames (0 = last frame only) */
    int fields_format;        /* sq_field_format */
    float exposure;
    int volume_slices;
    int light_buffer;
    bool volume_noise;
    int shadow_cascades;      /* opaque sun shadows: cascades (0 = none), map size, distance */
    int shadow_map_size;
    float shadow_distance_m;
    float lod_pixels, cull_pixels, mesh_distance_m; /* world meshes (sq_render_desc) */
} sq_scene_output;

/* ---- the scene ------------------------------------------------------------------------------- */
typedef struct sq_scene sq_scene;

/* Loads a 16-bit heightmap for the scene (supplied by the io layer). */
typedef sq_result (*sq_heightmap_loader)(sq_context *ctx, const char *path, uint16_t **out,
                                         int *width, int *height);

/* Loads a mesh file for the scene (supplied by the io layer: sq_scene_mesh_loader). */
typedef sq_result (*sq_mesh_loader)(sq_context *ctx, const sq_mesh_import_desc *desc,
                                    sq_mesh **out);
/* Loads a DEM / polygon areas for the scene (supplied by the io layer: sq_dem_load and
 * sq_area_load of squall/geo.h). What they return is allocated through ctx (sq_alloc). */
typedef sq_result (*sq_dem_loader)(sq_context *ctx, const sq_dem_desc *desc, sq_dem *out);
typedef sq_result (*sq_area_loader)(sq_context *ctx, const sq_area_desc *desc, sq_area *out);
/* Fills a world description from a WRF file (supplied by the io layer:
 * sq_scene_wrf_world_loader in squall/wrf.h): the terrain (HGT) as a float grid, the
 * georeference and the sun's date and place. *owned receives one allocation (sq_alloc) holding
 * what desc points to; the scene frees it with sq_free after creating the world. */
typedef sq_result (*sq_wrf_world_loader)(sq_context *ctx, const char *path, sq_world_desc *desc,
                                         void **owned);

typedef struct sq_scene_desc {
    const sq_cfg *cfg;
    sq_heightmap_loader load_heightmap; /* NULL: heightmap terrains are refused */
    bool validate_only;                 /* resolve and check everything, create no phenomena */
    sq_mesh_loader load_mesh;           /* NULL: world.meshes are refused */
    sq_dem_loader load_dem;             /* NULL: DEM terrains are refused */
    sq_area_loader load_area;           /* NULL: world.areas are refused */
    sq_wrf_world_loader load_wrf_world; /* NULL: terrain kind wrf is refused */
} sq_scene_desc;

/* Builds the scene of desc->cfg: every section and layer key checked through the tables
 * (type, range, unknown keys with a suggestion; messages "file:line:col: key = value: rule"),
 * the world created and every layer validated before any is created. Errors as the tables and
 * phenomena report them (SQ_ERR_INVALID_ARG, SQ_ERR_NOT_FOUND, SQ_ERR_IO, SQ_ERR_TOO_LARGE). */
SQ_API sq_result sq_scene_create(sq_context *ctx, const sq_scene_desc *desc, sq_scene **out);
/* Destroys the layers, the world and the scene (NULL accepted). */
SQ_API void sq_scene_destroy(sq_scene *s);

/* Read-only parts of the scene, valid until sq_scene_destroy: the output section, the world,
 * the name, the seed, the simulated time (s) and the number of frames of the output section. */
SQ_API const sq_scene_output *sq_scene_output_settings(const sq_scene *s);
SQ_API const sq_world *sq_scene_world(const sq_scene *s);
SQ_API const char *sq_scene_name(const sq_scene *s);
SQ_API uint64_t sq_scene_seed(const sq_scene *s);
SQ_API double sq_scene_time(const sq_scene *s);
SQ_API int sq_scene_frame_count(const sq_scene *s);
/* Simulated seconds between frames. */
SQ_API double sq_scene_frame_dt(const sq_scene *s);

/* For rendering: the camera's position, every camera.path key and the path between keys must
 * be at least 0.1 m above the terrain (the renderer's rule); the message names the key and its
 * file:line. Simulation alone needs no camera and does not call it. */
SQ_API sq_result sq_scene_check_camera(const sq_scene *s);
/* Advances every layer by dt (each sub-cycled to its max stable step). */
SQ_API sq_result sq_scene_step(sq_scene *s, double dt_s);
/* A distributed run (mpirun): collective, once per frame on every rank after the frame's steps
 * and before its views (sq_run does it); gather: rank 0 draws or writes the fields of this
 * frame. Each layer's sq_phenomenon_frame_sync. */
SQ_API sq_result sq_scene_frame_sync(sq_scene *s, bool gather);
/* The camera at the current time (calls each layer's observe hook). */
SQ_API sq_camera sq_scene_camera(sq_scene *s);
SQ_API int sq_scene_drawables(sq_scene *s, sq_drawable *out, int max);
/* Metrics of every layer, names prefixed "<layer>." (names valid until the next call). */
SQ_API int sq_scene_metrics(sq_scene *s, sq_metric *out, int max);
SQ_API int sq_scene_fields(sq_scene *s, sq_named_field *out, int max);
SQ_API int sq_scene_layer_count(const sq_scene *s);
SQ_API const char *sq_scene_layer_name(const sq_scene *s, int i);
SQ_API const char *sq_scene_layer_type(const sq_scene *s, int i);
/* Checkpoints: the scene's clock (time, step count) and every layer's complete state as
 * records (squall/core.h, sq_state_*); load restores them into a scene created from the same
 * configuration, which then continues bit-identically. A layer whose phenomenon has no state
 * hooks is refused (SQ_ERR_UNSUPPORTED, naming it); load refuses records of other layers or
 * sizes (SQ_ERR_INVALID_ARG). The file around them: squall/io.h, sq_checkpoint_*. */
SQ_API sq_result sq_scene_save_state(const sq_scene *s, sq_state_writer *w);
SQ_API sq_result sq_scene_load_state(sq_scene *s, sq_state_reader *r);
/* Live changes (an interactive front end: a slider moved): desc->cfg is the scene's configuration
 * as edited (e.g. by sq_cfg_set on a copy of the one the scene was built from), with the same
 * loaders. Every section is checked exactly as sq_scene_create checks it (same rules, same
 * messages naming file:line or "(--set)", key, value and rule: SQ_ERR_INVALID_ARG / NOT_FOUND,
 * nothing applied). When only SQ_PARAM_LIVE entries changed — output rendering keys, the camera
 * and its path, the live keys of each layer whose phenomenon has an apply_live hook — they are
 * applied to the running scene, keeping its simulated time and state (res->changed counts them);
 * else nothing is applied and res->rebuild names the first key that needs a rebuild (the world,
 * the seed, the layer list, a non-live key). Call it on the thread that steps the scene, between
 * two steps (sq_run_apply_live does so for a run and republishes the current frame). */
SQ_API sq_result sq_scene_apply_live(sq_scene *s, const sq_scene_desc *desc, sq_live_result *res);
/* Layer i as a generic phenomenon handle (squall/phenomenon.h), owned by the scene: valid until
 * sq_scene_destroy; never destroy it yourself. NULL outside [0, layer count). Stepping it alone
 * puts it ahead of the scene's clock; read it, or step the scene. */
SQ_API sq_phenomenon *sq_scene_layer(sq_scene *s, int i);
/* Total bytes the layers declared (memory_bytes) at creation. */
SQ_API uint64_t sq_scene_memory_bytes(const sq_scene *s);

#ifdef __cplusplus
}
#endif
#endif
