/* scene_internal.h — section structs behind the world/camera/output parameter tables. */
#ifndef SQ_SCENE_INTERNAL_H
#define SQ_SCENE_INTERNAL_H

#include "squall/scene.h"

/* Indices of the non-procedural choices of world.terrain.kind (scene_tables.c); both become an
 * SQ_TERRAIN_GRID terrain through an io loader. */
enum { SQ__TERRAIN_CHOICE_DEM = 6, SQ__TERRAIN_CHOICE_WRF = 7 };

typedef struct sq__world_section {
    int terrain_kind;
    int terrain_material;
    float size_m[2];
    int size_count;
    float resolution[2];
    int resolution_count;
    float origin_m[2];
    int origin_count;
    float base_m, relief_m, feature_m;
    int octaves;
    float slope_deg, dune_dir_deg;
    uint64_t terrain_seed;
    char heightmap[SQ_PARAM_STRING_MAX];
    float metres_per_px, height_min_m, height_max_m;
    /* terrain from a DEM (GDAL) */
    char dem[SQ_PARAM_STRING_MAX], dem_crs[SQ_PARAM_STRING_MAX], crs[SQ_PARAM_STRING_MAX];
    float roi[4];
    int roi_count;
    float cell_m;
    int nodata, resampling;
    float crs_origin[2];
    int crs_origin_count;
    char wrf[SQ_PARAM_STRING_MAX];
    float vertical_exaggeration;
    float snow_line_m;
    float sun_direction[3];
    int day_of_year;
    float hour, latitude_deg, irradiance;
    char sun_date[SQ_PARAM_STRING_MAX];
    float longitude_deg, clock_scale;
    float turbidity;
    int city_rows, city_cols;
    float city_block_m, city_street_m, city_height_min_m, city_height_max_m;
    float city_center[3];
    uint64_t city_seed;
    int place_kind;
    float place_size_m[2];
    int place_size_count;
    float place_center[2];
    int place_center_count;
    uint64_t place_seed;
    float place_tree_density;
} sq__world_section;

typedef struct sq__mesh_item {
    char file[SQ_PARAM_STRING_MAX];
    float position[3];
    int position_count;
    float yaw_deg;
    float scale[3];
    int scale_count;
    int lods;
    int up;
    float color[3];
} sq__mesh_item;

typedef struct sq__obstacle_item {
    int kind;
    float center[3];
    int center_count;
    float size[3];
    float roof_m, yaw_deg;
    float albedo[3];
} sq__obstacle_item;

/* world.areas[]: a named polygon area from a vector file or raster mask */
typedef struct sq__area_item {
    char name[SQ_PARAM_STRING_MAX];
    char file[SQ_PARAM_STRING_MAX];
    char attribute[SQ_PARAM_STRING_MAX];
    char layer[SQ_PARAM_STRING_MAX];
    char crs[SQ_PARAM_STRING_MAX];
} sq__area_item;

typedef struct sq__camera_section {
    float position[3], target[3], up[3];
    float fov_deg, near_m, far_m;
} sq__camera_section;

typedef struct sq__camera_key_item {
    double t;
    float position[3], target[3];
    float fov_deg;
} sq__camera_key_item;

extern const sq_param sq__world_params[];
extern const size_t sq__world_param_count;
extern const sq_param sq__obstacle_params[];
extern const size_t sq__obstacle_param_count;
extern const sq_param sq__mesh_params[];
extern const size_t sq__mesh_param_count;
extern const sq_param sq__area_params[];
extern const size_t sq__area_param_count;
extern const sq_param sq__camera_params[];
extern const size_t sq__camera_param_count;
extern const sq_param sq__camera_key_params[];
extern const size_t sq__camera_key_param_count;
extern const sq_param sq__output_params[];
extern const size_t sq__output_param_count;

/* Parses a 64-bit unsigned whole number written as decimal digits (surrounding spaces allowed):
 * no sign, exponent, fraction or hex; false above 2^64 - 1. The one rule for seeds and every
 * SQ_PARAM_U64 key. */
bool sq__parse_u64(const char *text, uint64_t *out);

/* Rewrites the current error text of a layer for scene users: solver field names that are the
 * trailing part of exactly one key of the layer's table become "layers.LAYER.KEY"; the text is
 * prefixed "layers.LAYER: " unless it names the layer. Returns r. */
/* Hands layer `layer` what it reads from the scene's other layers (scene_couple.c). */
void sq__scene_couple(sq_scene *s, int layer);
/* Leaves out of a frame's drawables (layer l drew out[first[l] .. first[l + 1] - 1]) what another
 * layer draws in its place (scene_couple.c); returns the count left, out compacted in place. */
int sq__scene_couple_drawables(sq_scene *s, sq_drawable *out, const int *first);

sq_result sq__scene_translate_error(const sq_param *table, size_t n, const char *layer_name,
                                    sq_result r);

/* scene_geo.c: a DEM terrain and polygon areas through the scene's io loaders. Fills the grid
 * terrain, CRS, offset and areas of wd from ws and items; what it allocates stays in keep until
 * sq__scene_geo_release (after sq_world_create has copied it). */
typedef struct sq__scene_geo {
    sq_dem dem;
    sq_area areas[SQ_MAX_WORLD_AREAS];
    sq_world_area views[SQ_MAX_WORLD_AREAS];
    char paths[SQ_MAX_WORLD_AREAS][1024];
    int area_count;
} sq__scene_geo;
sq_result sq__scene_geo_world(sq_context *ctx, const sq_scene_desc *sd,
                              const sq__world_section *ws, const sq__area_item *items,
                              int item_count, sq_world_desc *wd, sq__scene_geo *keep);
void sq__scene_geo_release(sq_context *ctx, sq__scene_geo *keep);

/* Checkpoint access to the scene (scene.c). */
struct sq_phenomenon *sq__scene_layer_handle(const sq_scene *s, int i);
uint64_t sq__scene_steps(const sq_scene *s);
void sq__scene_set_clock(sq_scene *s, double time_s, uint64_t steps);
sq_context *sq__scene_context(const sq_scene *s);

/* Levenshtein distance between two keys (99 when either is longer than 63 characters): the
 * "did you mean" suggestions of the parameter tables and of the scene sections. */
size_t sq__edit_distance(const char *a, const char *b);

#endif
