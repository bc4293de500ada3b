/* squall/world.h — the world every phenomenon lives in: terrain heightfield, obstacles
 * (buildings, fences as boxes with optional gable roofs), meshes placed as instances
 * (squall/mesh.h), sun and sky, and the camera type.
 * World axes: x east, y north, z up, metres. */
#ifndef SQ_WORLD_H
#define SQ_WORLD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/mesh.h"
#include "squall/sqmath.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- the sun at a date and place (src/world/sun.c) --------------------------------------- */
/* Position of the sun for an instant (UTC) and a place: the NOAA solar calculator's algorithm
 * (Meeus, "Astronomical Algorithms", ch. 25, low-precision solar coordinates; about 0.01 degree
 * for years 1900-2100). True solar time = UTC + longitude/15 h + equation of time. */
typedef struct sq_sun_position {
    double declination_deg;      /* apparent declination */
    double equation_of_time_min; /* apparent minus mean solar time, minutes (about -14..+16) */
    double true_solar_time_h;    /* local apparent solar time at the longitude, 0..24 h */
    double hour_angle_deg;       /* 0 at solar noon, positive in the afternoon, -180..180 */
    double zenith_deg;           /* geometric zenith angle (no refraction), 0..180 */
    double elevation_deg;        /* apparent elevation: 90 - zenith + refraction (Saemundsson,
                                    1010 hPa, 10 C; none below -1 degree) */
    double azimuth_deg;          /* from true north, clockwise (east 90, south 180), 0..360 */
} sq_sun_position;

/* unix_time_s: seconds since 1970-01-01 00:00:00 UTC; latitude north, longitude east. */
SQ_API sq_sun_position sq_sun_position_at(double unix_time_s, double latitude_deg,
                                          double longitude_deg);
/* Unit vector toward the sun (apparent elevation) in east-north-up axes. */
SQ_API sq_vec3 sq_sun_position_direction(const sq_sun_position *p);
/* Seconds since 1970-01-01 00:00:00 UTC of a proleptic Gregorian UTC date and time (no leap
 * seconds). Fields are not range-checked: month 13 is January of the next year. */
SQ_API double sq_unix_time(int year, int month, int day, int hour, int minute, double second);

typedef enum sq_terrain_kind {
    SQ_TERRAIN_DEFAULT = 0,   /* = SQ_TERRAIN_HILLS */
    SQ_TERRAIN_FLAT = 1,      /* z = base_m everywhere */
    SQ_TERRAIN_HILLS = 2,     /* fBm gradient noise */
    SQ_TERRAIN_DUNES = 3,     /* transverse dunes (sharp crests) plus noise */
    SQ_TERRAIN_MOUNTAIN = 4,  /* a slope for avalanches: inclined plane + ridges + run-out */
    SQ_TERRAIN_HEIGHTMAP = 5, /* 16-bit PNG heightmap (loaded by the io layer) */
    SQ_TERRAIN_GRID = 6       /* float heights in metres on a regular grid (a DEM, WRF's HGT,
                                 or the caller's own array) */
} sq_terrain_kind;

typedef enum sq_terrain_material {
    SQ_GROUND_DEFAULT = 0, /* by terrain kind: sand on dunes, meadow elsewhere */
    SQ_GROUND_SAND = 1,
    SQ_GROUND_SNOW = 2,
    SQ_GROUND_ROCK = 3,
    SQ_GROUND_GRASS = 4,
    SQ_GROUND_ASPHALT = 5
} sq_terrain_material;

typedef struct sq_terrain_desc {
    sq_terrain_kind kind;
    sq_terrain_material material; /* surface cover; 0 = by kind */
    float size_m[2];        /* extent along x and y; 0 -> 2000 x 2000 (heightmap: from pixels) */
    int resolution[2];      /* samples along x and y; 0 -> 257 x 257 (heightmap: pixels) */
    float origin_m[2];      /* world x, y of sample (0,0); NaN/0 -> centred on the origin */
    bool origin_set;        /* true if origin_m was given (0 is physical) */
    float base_m;           /* base elevation; 0 is physical */
    float relief_m;         /* height amplitude for procedural kinds; 0 -> 60 m */
    float feature_m;        /* horizontal feature size of the noise; 0 -> 400 m */
    int octaves;            /* 0 -> 5 */
    float slope_deg;        /* SQ_TERRAIN_MOUNTAIN: slope of the release area; 0 -> 35 */
    float dune_dir_deg;     /* SQ_TERRAIN_DUNES: crest normal azimuth (deg from east) */
    uint64_t seed;          /* 0 is a valid seed */
    /* heightmap: 16-bit grey samples (borrowed for the create call; row 0 = north edge),
     * metres per pixel and the heights that 0 and 65535 map to */
    const uint16_t *heightmap;
    int heightmap_w, heightmap_h;
    float metres_per_px;
    float height_min_m, height_max_m;
    /* grid: float heights in metres (borrowed for the create call). Sample (i, j) is
     * grid_heights_m[j*grid_w + i] at (origin.x + i*grid_dx_m, origin.y + j*grid_dy_m): row 0 is
     * the SOUTH edge, x east, y north. Every value must be finite (fill no-data before). */
    const float *grid_heights_m;
    int grid_w, grid_h;
    float grid_dx_m, grid_dy_m;
    /* grid: optional, 1 where the source had no data and the height was filled (same layout;
     * borrowed for the create call; NULL = every sample measured) */
    const uint8_t *grid_void;
    /* heights (base included) are multiplied by this, for every kind: a vertical exaggeration of
     * real terrain (WRF domains are hundreds of km wide and a few km high); 0 -> 1 */
    float vertical_exaggeration;
    /* snow material: the snow line (m above sea level, after the exaggeration): snow-covered
     * above it, alpine meadow and scree below, over a ~100 m band roughened by noise; rock on
     * faces steeper than ~45 deg either way. 0 = snow at every altitude. */
    float snow_line_m;
} sq_terrain_desc;

typedef enum sq_obstacle_kind {
    SQ_OBSTACLE_BOX = 0,   /* plain box: a building block */
    SQ_OBSTACLE_HOUSE = 1, /* box walls plus a gable roof (ridge along x) */
    SQ_OBSTACLE_FENCE = 2  /* thin porous wall (solid for solvers at their resolution) */
} sq_obstacle_kind;

typedef struct sq_obstacle {
    sq_obstacle_kind kind;
    sq_vec3 center_m;      /* x, y of the footprint centre; z of its base (NaN -> on terrain) */
    sq_vec3 size_m;        /* footprint x, y and wall height z */
    float roof_m;          /* HOUSE: ridge height above the walls */
    float yaw_deg;         /* rotation about z (0 = axes aligned); solvers voxelise it */
    sq_vec3 albedo;        /* 0 -> a default per kind */
} sq_obstacle;

#define SQ_MAX_OBSTACLES 256

/* A named polygon area in world coordinates (e.g. avalanche release zones), read by the io layer
 * from a vector file or a raster mask (include/squall/geo.h). A point is inside feature f when
 * it lies inside an odd number of f's rings (outer rings and holes alike); the rings of a
 * feature are consecutive and features come in increasing order. */
typedef struct sq_world_area {
    const char *name;             /* the key phenomena use to find it */
    const char *source;           /* the file it came from (messages) */
    int feature_count;
    const double *feature_value;  /* per feature: its numeric attribute (NaN = not given) */
    const double *feature_area_m2;
    int ring_count;
    const int *ring_start;        /* ring_count + 1 offsets (points) into xy_m */
    const int *ring_feature;      /* feature of each ring */
    const double *xy_m;           /* x, y pairs */
    double bounds[4];             /* xmin, ymin, xmax, ymax */
    double area_m2;
} sq_world_area;

#define SQ_MAX_WORLD_AREAS 16

typedef struct sq_sky_desc {
    float turbidity;        /* Preetham-style haze 2..10; 0 -> 3 */
    sq_vec3 ground_albedo;  /* 0 -> sand-grey default */
} sq_sky_desc;

typedef struct sq_sun_desc {
    sq_vec3 direction;      /* direction TOWARD the sun; zero -> from date/time/latitude */
    int day_of_year;        /* 1..366; 0 -> 172 (June solstice) */
    float hour_solar;       /* local solar time in hours; 0 -> 15.0 */
    bool hour_set;          /* true if hour_solar was given (0 = midnight is physical) */
    float latitude_deg;     /* 0 is physical (equator) */
    float irradiance_w_m2;  /* direct normal irradiance at the ground; 0 -> 1000 */
    /* The sun at a date (optional; used when direction is zero): at scene time t the sun stands
     * where it does at the UTC instant utc_start_unix_s + clock_scale * t over latitude_deg,
     * longitude_deg (sq_sun_position_at), its azimuth turned into the world by
     * north_rotation_deg (true north, degrees clockwise from the world's +y: WRF grids). The
     * world follows the scene clock through sq_world_set_time. */
    bool utc_set;
    double utc_start_unix_s;   /* seconds since 1970-01-01 00:00:00 UTC at scene time 0 */
    float longitude_deg;       /* east; 0 is physical */
    float north_rotation_deg;  /* 0 is physical */
    float clock_scale;         /* simulated seconds per scene second; 0 -> 1 */
} sq_sun_desc;

typedef struct sq_world_desc {
    sq_terrain_desc terrain;
    sq_sun_desc sun;
    sq_sky_desc sky;
    const sq_obstacle *obstacles; /* borrowed for the create call */
    int obstacle_count;
    /* Georeference (optional): the coordinate reference system of the world's x/y as WKT (or any
     * string PROJ accepts, e.g. "EPSG:32632"), copied at create; NULL or "" = a local metric frame
     * with no CRS. World (x, y) + crs_offset_m = (easting, northing) in that CRS, so world
     * coordinates stay small (float precision) while outputs are georeferenced. */
    const char *crs_wkt;
    double crs_offset_m[2];
    /* named polygon areas (borrowed for the create call, copied) */
    const sq_world_area *areas;
    int area_count;
} sq_world_desc;

/* The world after creation, opaque: its layout is not part of the ABI (it holds up to
 * SQ_MAX_OBSTACLES obstacles and SQ_MAX_WORLD_AREAS areas inline, caches and private parts).
 * Read it through the calls below; every pointer they return is borrowed from the world: valid
 * until sq_world_destroy (mesh instances: until the next sq_world_set_meshes). Read-only for
 * phenomena and the renderer; only sq_world_set_meshes, sq_world_set_time and
 * sq_world_set_sky change it. */
typedef struct sq_world sq_world;

/* The terrain heightfield. */
typedef struct sq_world_terrain {
    int nx, ny;               /* samples along x and y */
    float dx, dy;             /* sample spacing, m */
    sq_vec3 origin;           /* world x, y of sample (0, 0); z unused */
    const float *heights;     /* nx*ny heights above datum (m): heights[j*nx + i] at
                                 (origin.x + i*dx, origin.y + j*dy), row 0 the south edge */
    const float *normals;     /* 3*nx*ny unit normals, same order */
    const uint8_t *void_mask; /* nx*ny, 1 where the source had no data (filled); NULL = none */
    float height_min, height_max;  /* m */
    sq_terrain_kind kind;
    sq_terrain_material material;
    float vertical_exaggeration;   /* the factor the heights were multiplied by (1 = none) */
    float snow_line_m;             /* SQ_GROUND_SNOW: the snow line (m a.s.l.); 0 = none */
} sq_world_terrain;
/* The terrain as borrowed arrays and its geometry. */
SQ_API void sq_world_get_terrain(const sq_world *w, sq_world_terrain *out);

/* Sun and sky as the renderer uses them, at the world's time. */
typedef struct sq_world_light {
    sq_vec3 sun_dir;          /* unit vector toward the sun */
    sq_vec3 sun_radiance;     /* linear RGB irradiance scale of the sun at the ground */
    sq_vec3 sky_zenith;       /* linear RGB sky radiance at the zenith */
    sq_vec3 sky_horizon;      /* linear RGB sky radiance at the horizon */
    sq_vec3 ground_albedo;
    float turbidity;
    double time_s;            /* the world's time (sq_world_set_time), s */
    bool sun_follows_clock;   /* the sun moves with time_s (sq_sun_desc.utc_set) */
    sq_sun_position sun_position; /* with sun_follows_clock: the sun's place at time_s */
} sq_world_light;
/* The sun, sky and time of the world. */
SQ_API void sq_world_get_light(const sq_world *w, sq_world_light *out);

/* Obstacles (copies of the desc's, z resolved on the terrain): count, and the array of count
 * entries (borrowed). */
SQ_API int sq_world_obstacle_count(const sq_world *w);
SQ_API const sq_obstacle *sq_world_obstacles(const sq_world *w);
/* Named polygon areas: count, and area i in [0, count) (NULL outside; borrowed). */
SQ_API int sq_world_area_count(const sq_world *w);
SQ_API const sq_world_area *sq_world_area_at(const sq_world *w, int i);
/* The georeference: the CRS as given (WKT or what PROJ accepts; NULL when the world has none)
 * and, if offset_m is not NULL, the offset with world (x, y) + offset = CRS (easting, northing). */
SQ_API const char *sq_world_crs(const sq_world *w, double offset_m[2]);
/* The meshes placed by sq_world_set_meshes (each pointer may be NULL): the mesh array and its
 * count, the instances (z resolved, scale 0 replaced by 1); returns the instance count. */
SQ_API int sq_world_mesh_instances(const sq_world *w, const sq_mesh *const **meshes,
                                   int *mesh_count, const sq_mesh_instance **instances);
/* Triangles of the placed meshes at LOD 0, summed over all instances (0 without meshes). */
SQ_API int64_t sq_world_mesh_face_count(const sq_world *w);
/* A number that changes whenever the terrain, obstacles or meshes change (caches key on it). */
SQ_API uint64_t sq_world_generation(const sq_world *w);

/* Copies in to out with zero fields replaced by their defaults; never validates. */
SQ_API sq_result sq_world_desc_resolve(const sq_world_desc *in, sq_world_desc *out);
/* Creates the world: terrain generated or copied (the desc's arrays are borrowed for the call),
 * obstacles and areas copied, sun and sky computed. SQ_ERR_INVALID_ARG naming
 * sq_world_desc.<field> (sizes, non-finite heights, more than SQ_MAX_OBSTACLES obstacles ...);
 * SQ_ERR_TOO_LARGE for memory. *out is NULL on failure. */
SQ_API sq_result sq_world_create(sq_context *ctx, const sq_world_desc *desc, sq_world **out);
/* Frees the world (NULL accepted); nothing made on it may be used afterwards. */
SQ_API void sq_world_destroy(sq_context *ctx, sq_world *w);
/* Changes the sun and the sky of a world (a live change of a running scene): turbidity and
 * irradiance as in sq_sky_desc / sq_sun_desc; a sun following the clock takes latitude_deg and
 * clock_scale (its place at the world's time is computed again), a sun placed by day and hour
 * takes day_of_year, hour_solar and latitude_deg; a sun given by direction keeps it. The sky's
 * radiances are derived again. Not synchronised with a renderer drawing the world: the frame
 * loop (squall/run.h) draws each frame with a copy of the sun and sky taken when the frame was
 * made, so a change between two steps shows from the next published frame on. */
SQ_API void sq_world_set_sky(sq_world *w, int day_of_year, float hour_solar, float latitude_deg,
                             double clock_scale, float turbidity, float irradiance_w_m2);

/* Places meshes in the world (replacing any placed before): validates every instance (mesh
 * index, finite position, scale > 0, footprint inside the terrain — SQ_ERR_INVALID_ARG naming
 * the instance, its mesh and the rule), resolves z on the terrain (NaN: the lowest terrain under
 * the footprint), builds the BVHs the solid queries use and bumps the generation. Closed meshes
 * become solids for sq_world_solid_at; every mesh raises sq_world_surface_at. */
/* The rule every placed instance meets (sq_world_set_meshes checks it for each): finite
 * position and yaw, scale factors > 0 (or all 0 = 1), the footprint inside the terrain. */
SQ_API sq_result sq_world_check_mesh_instance(sq_context *ctx, const sq_world *w,
                                              const sq_mesh *mesh, const sq_mesh_instance *inst);
SQ_API sq_result sq_world_set_meshes(sq_context *ctx, sq_world *w, const sq_mesh *const *meshes,
                                     int mesh_count, const sq_mesh_instance *instances,
                                     int instance_count);

/* Sets the world's time (scene seconds): with a sun clock (sq_sun_desc.utc_set) the sun's
 * direction, radiance and the sky colours move to that time; otherwise only time_s changes. */
SQ_API void sq_world_set_time(sq_world *w, double t_s);

/* Terrain height and normal at (x, y), bilinear; outside the heightfield the edge is extended.
 * A NaN coordinate gives a NaN height and the vertical (0, 0, 1). */
SQ_API float sq_world_height_at(const sq_world *w, float x, float y);
SQ_API sq_vec3 sq_world_normal_at(const sq_world *w, float x, float y);
/* Highest surface (terrain, obstacle top/roof or mesh) at (x, y). */
SQ_API float sq_world_surface_at(const sq_world *w, float x, float y);
/* True if the point is inside the terrain, an obstacle or a closed mesh instance. */
SQ_API bool sq_world_solid_at(const sq_world *w, sq_vec3 p);
/* What sq_world_voxelise includes (bits; SQ_SOLID_ALL = what sq_world_solid_at answers). */
enum { SQ_SOLID_TERRAIN = 1, SQ_SOLID_OBSTACLES = 2, SQ_SOLID_MESHES = 4, SQ_SOLID_ALL = 7 };
/* Voxelises the world's solids on cells of size h_m: cell (i, j, k) is centred at origin_m +
 * (i + 1/2, j + 1/2, k + 1/2) h_m (each coordinate rounded to float) and solid[i + n[0] (j + n[1]
 * k)] gets 1 where it is inside one of the parts (SQ_SOLID_* bits), else 0. With SQ_SOLID_ALL
 * these are sq_world_solid_at's answers, from one pass along each column's vertical line
 * instead of one query per cell. */
SQ_API sq_result sq_world_voxelise(const sq_world *w, const double origin_m[3], double h_m,
                                   const int n[3], int parts, uint8_t *solid);
/* World bounds of the terrain: min/max x, y and heights. */
SQ_API void sq_world_bounds(const sq_world *w, sq_vec3 *min_out, sq_vec3 *max_out);
/* The area of that name (NULL if none). */
SQ_API const sq_world_area *sq_world_area_find(const sq_world *w, const char *name);
/* The feature of the area containing (x, y) (the first, if several overlap); -1 if none. */
SQ_API int sq_world_area_feature_at(const sq_world_area *a, double x, double y);
/* True if the terrain sample nearest (x, y) was filled because the source had no data. */
SQ_API bool sq_world_void_at(const sq_world *w, float x, float y);
/* Sun direction (toward the sun) from day of year, local solar time and latitude (Cooper's
 * declination; about 1 degree accurate: for scenes without a date). */
SQ_API sq_vec3 sq_sun_direction(int day_of_year, float hour_solar, float latitude_deg);


/* ---- camera ------------------------------------------------------------------------------ */
typedef struct sq_camera {
    sq_vec3 position_m;
    sq_vec3 target_m;
    sq_vec3 up;          /* zero -> (0, 0, 1) */
    float fov_y_deg;     /* vertical field of view; 0 -> 50 */
    float near_m;        /* 0 -> 0.5 */
    float far_m;         /* 0 -> 20000 */
} sq_camera;

typedef struct sq_camera_key {
    double time_s;
    sq_vec3 position_m;
    sq_vec3 target_m;
    float fov_y_deg;     /* 0 -> keep the base camera's */
} sq_camera_key;

#define SQ_MAX_CAMERA_KEYS 64

/* Camera at time t along keys (sorted by time; Catmull–Rom through positions and targets,
 * clamped at the ends). With no keys returns base. */
SQ_API sq_camera sq_camera_at(const sq_camera *base, const sq_camera_key *keys, int key_count,
                              double t);
SQ_API sq_camera sq_camera_resolve(sq_camera c);
SQ_API sq_mat4 sq_camera_view(const sq_camera *c);
SQ_API sq_mat4 sq_camera_proj(const sq_camera *c, float aspect);

#ifdef __cplusplus
}
#endif
#endif
