/* squall/wrf.h — WRF model output (wrfout) as a time series of physical fields on the mass grid.
 *
 * One sq_wrf reads one or more wrfout files (netCDF-3 classic or netCDF-4/HDF5; several times per
 * file and several files form one time series, ordered by their Times) and derives, on the mass
 * points (docs/wrf.md has every formula):
 *   z        = ½ (zstag[k] + zstag[k+1]),  zstag = (PH + PHB) / 9.81      m above sea level
 *   p        = P + PB                                                      Pa
 *   theta    = T + 300                                                     K
 *   T        = theta (p / 1e5)^(287/1004.5)                                K
 *   rho      = p / (287 T (1 + 0.608 qv))                                  kg m-3 (moist air)
 *   u, v, w  = mean of the two staggered faces around the mass point       m s-1 (grid-relative)
 *   C_x      = 1000 q_x / V,  V = (1+qv)/rho + (qc+qr)/1000 + (qi+qs+qg)/917   g m-3
 * with the WRF constants (g = 9.81, R_d = 287, c_p = 1004.5; wrf-python uses the same).
 * Mixing ratios down to -1e-4 kg/kg are clamped to 0; anything more negative is an error.
 *
 * The map projection comes from the global attributes (MAP_PROJ 1 Lambert conformal, 2 polar
 * stereographic, 3 Mercator, 6 latitude-longitude, on WRF's sphere of radius 6 370 km) through
 * PROJ. The grid is regular in the projected coordinates; it is placed by fitting XLAT/XLONG, and
 * a file whose XLAT/XLONG do not match its projection attributes is refused.
 *
 * World frame (include/squall/world.h): x east and y north along the projection's grid axes,
 * metres, with the origin at the centre of the mass grid; world (x, y) + crs_offset_m gives the
 * projected coordinates (the CRS of crs_wkt). Heights z are metres above sea level.
 *
 * Arrays: 3D fields are nx*ny*nz floats, index (k*ny + j)*nx + i (x = west_east fastest, then
 * y = south_north, row 0 the SOUTH edge, then z = bottom_top from the ground up); 2D fields are
 * nx*ny, index j*nx + i.
 *
 * Ownership: everything returned by sq_wrf_get_info and sq_wrf_read is owned by the sq_wrf.
 * Info pointers stay valid until sq_wrf_close; state arrays until the next sq_wrf_read (or
 * sq_wrf_scan) on the same sq_wrf, or its close. An sq_wrf is not thread-safe (one caller at a
 * time); it keeps its files open (read-only) until closed and never writes them.
 *
 * Errors: a bad file gives SQ_ERR_IO (missing, not a regular file, unreadable), SQ_ERR_PARSE (not
 * NetCDF, truncated, not WRF output, wrong shape, bad attribute) or SQ_ERR_INVALID_ARG (NaN/fill
 * values, out-of-range time), with one line in sq_last_error() naming the file and variable. */
#ifndef SQ_WRF_H
#define SQ_WRF_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sq_wrf_projection {
    SQ_WRF_PROJ_NONE = 0,
    SQ_WRF_PROJ_LAMBERT = 1,      /* MAP_PROJ = 1: Lambert conformal conic */
    SQ_WRF_PROJ_POLAR = 2,        /* MAP_PROJ = 2: polar stereographic */
    SQ_WRF_PROJ_MERCATOR = 3,     /* MAP_PROJ = 3: Mercator */
    SQ_WRF_PROJ_LATLON = 6        /* MAP_PROJ = 6: (rotated when POLE_LAT != 90) latitude-longitude */
} sq_wrf_projection;

/* Hydrometeor species, in the order of sq_wrf_info.has_species and the sq_wrf_state arrays. */
typedef enum sq_wrf_species {
    SQ_WRF_CLOUD = 0,   /* QCLOUD: cloud water */
    SQ_WRF_ICE = 1,     /* QICE: cloud ice */
    SQ_WRF_SNOW = 2,    /* QSNOW */
    SQ_WRF_RAIN = 3,    /* QRAIN */
    SQ_WRF_GRAUPEL = 4, /* QGRAUP */
    SQ_WRF_SPECIES_COUNT = 5
} sq_wrf_species;

/* Names of the species ("cloud_water", "cloud_ice", "snow", "rain", "graupel") and of their
 * WRF variables ("QCLOUD", ...). */
SQ_API const char *sq_wrf_species_name(sq_wrf_species s);
SQ_API const char *sq_wrf_species_variable(sq_wrf_species s);

#define SQ_WRF_TIME_STRLEN 20 /* "YYYY-MM-DD_hh:mm:ss" + NUL */

/* Facts about the series (all pointers owned by the sq_wrf; valid until sq_wrf_close). */
typedef struct sq_wrf_info {
    int nx, ny, nz;             /* mass points: west_east, south_north, bottom_top */
    double dx_m, dy_m;          /* grid spacing (DX, DY attributes) */
    /* map projection */
    sq_wrf_projection projection;
    int map_proj;               /* the MAP_PROJ attribute */
    const char *projection_name; /* "Lambert conformal", ... */
    double truelat1_deg, truelat2_deg, stand_lon_deg, moad_cen_lat_deg;
    double pole_lat_deg, pole_lon_deg;
    double earth_radius_m;      /* 6 370 000 (WRF's sphere) */
    const char *proj_string;    /* PROJ string of the projected CRS, e.g. "+proj=lcc ..." */
    const char *crs_wkt;        /* the same CRS as WKT2 (for sq_world_desc.crs_wkt) */
    double crs_offset_m[2];     /* projected (x, y) of the world origin = centre of the mass grid */
    double x0_m, y0_m;          /* world x, y of mass point (0, 0): -(nx-1)/2 dx, -(ny-1)/2 dy */
    double center_lat_deg, center_lon_deg; /* geographic position of the world origin */
    /* Angle from grid north (+y) to true north at the domain centre, degrees, positive when
     * true north lies clockwise of +y (east of it). 0 for Mercator and lat-lon. */
    double north_rotation_deg;
    /* times */
    int time_count;             /* stored times in the series (>= 1) */
    const double *times_s;      /* time_count values: seconds since times[0], increasing */
    const char *const *time_strings; /* time_count strings "YYYY-MM-DD_hh:mm:ss" (UTC) */
    double start_unix_s;        /* times[0] as seconds since 1970-01-01 00:00:00 UTC */
    double duration_s;          /* times_s[time_count - 1] */
    /* content */
    bool has_species[SQ_WRF_SPECIES_COUNT]; /* which hydrometeor mixing ratios exist */
    bool has_ice_number, has_rain_number;   /* QNICE, QNRAIN (number mixing ratios) */
    bool has_cloud_fraction;                /* CLDFRA */
    int mp_physics;             /* MP_PHYSICS attribute (-1 when absent) */
    int file_count;
    const char *title;          /* TITLE attribute of the first file ("" when absent) */
} sq_wrf_info;

/* The fields at one time (borrowed; valid until the next sq_wrf_read/sq_wrf_scan or close). */
typedef struct sq_wrf_state {
    double time_s;              /* the time read (seconds since times[0]) */
    int index0, index1;         /* stored times around it (equal at a stored time) */
    double weight1;             /* linear weight of index1: field = (1-w) f[index0] + w f[index1] */
    /* 3D on mass points (nx*ny*nz) */
    const float *z_m;           /* geopotential height, m above sea level */
    const float *height_agl_m;  /* z - terrain height */
    const float *p_pa;          /* pressure */
    const float *theta_k;       /* potential temperature */
    const float *t_k;           /* temperature */
    const float *rho_kg_m3;     /* moist air density */
    const float *qv_kg_kg;      /* water vapour mixing ratio (clamped >= 0) */
    const float *u_mps, *v_mps, *w_mps; /* wind along world x, y (grid axes) and up */
    /* mass concentrations, g m-3, by sq_wrf_species; NULL where the file lacks the species */
    const float *q_g_m3[SQ_WRF_SPECIES_COUNT];
    const float *ice_number_m3; /* QNICE * dry-air density: ice particles per m3 (or NULL) */
    const float *rain_number_m3; /* QNRAIN likewise (or NULL) */
    /* CLDFRA, the cloud fraction of the radiation scheme, clamped to [0, 1] (or NULL). Some
     * schemes write a fraction, others only 0 or 1 (a cloud flag: then is_flag is true at both
     * stored times around time_s, and values between them are only the time interpolation's) */
    const float *cloud_fraction;
    bool cloud_fraction_is_flag;
    /* 3D on w-levels (nx*ny*(nz+1)): zstag, m above sea level (cell faces, for column sums) */
    const float *z_w_m;
    /* 2D (nx*ny) */
    const float *terrain_m;     /* HGT */
    const float *lat_deg, *lon_deg; /* XLAT, XLONG (from the first stored time) */
    /* 1D: world coordinates of the mass points (nx and ny values) */
    const float *x_m, *y_m;
    /* the sun at this time over the domain centre */
    sq_sun_position sun;
    sq_vec3 sun_dir;            /* toward the sun in the world frame (x east along the grid) */
} sq_wrf_state;

/* Per-field value ranges over every stored time (sq_wrf_scan). */
typedef struct sq_wrf_range {
    double min, max;
} sq_wrf_range;

typedef struct sq_wrf_ranges {
    sq_wrf_range z_m, height_agl_m, p_pa, theta_k, t_k, rho_kg_m3, qv_kg_kg;
    sq_wrf_range u_mps, v_mps, w_mps, terrain_m, lat_deg, lon_deg;
    sq_wrf_range q_g_m3[SQ_WRF_SPECIES_COUNT]; /* {0, 0} for absent species */
    double z_top_m;                     /* highest w-level */
    double cloudy_fraction;             /* share of (cells x times) with cloud water + ice
                                           above 1e-3 g m-3 */
    int64_t clamped_negative;           /* tiny negative mixing ratios set to 0 */
    sq_wrf_range cloud_fraction;        /* CLDFRA ({0, 0} when absent) */
    bool cloud_fraction_is_flag;        /* CLDFRA holds only 0 and 1 at every stored time */
} sq_wrf_ranges;

typedef struct sq_wrf sq_wrf;

/* Opens count wrfout files as one time series. Reads the dimensions, attributes, Times,
 * XLAT/XLONG and checks every variable's presence and shape; the fields themselves are read on
 * demand. paths are borrowed for the call. Files must share the grid, projection and species;
 * their times are merged in order (a repeated time is an error). Refuses non-regular files. */
SQ_API sq_result sq_wrf_open(sq_context *ctx, const char *const *paths, int count, sq_wrf **out);
/* Closes the files and frees everything (accepts NULL). */
SQ_API void sq_wrf_close(sq_wrf *w);

/* Grid, projection, times and species of the open files. */
SQ_API void sq_wrf_get_info(const sq_wrf *w, sq_wrf_info *out);

/* Bytes an open sq_wrf uses for its caches once it has read a time (3 sets of fields). */
SQ_API uint64_t sq_wrf_memory_bytes(const sq_wrf *w);

/* The fields at time_s (seconds since the first stored time, 0 <= time_s <= duration): at a
 * stored time exactly the derived fields of that time, between two stored times their linear
 * interpolation (so an animation flows). Outside the range: SQ_ERR_INVALID_ARG. The derived
 * fields of the two stored times around time_s are cached, so stepping forward through an
 * interval reads each stored time once. */
SQ_API sq_result sq_wrf_read(sq_wrf *w, double time_s, sq_wrf_state *out);
/* The fields at stored time index (0 <= index < time_count), exactly. */
SQ_API sq_result sq_wrf_read_index(sq_wrf *w, int index, sq_wrf_state *out);

/* Reads every stored time (checking all values) and returns the value ranges. Invalidates
 * states returned before. */
SQ_API sq_result sq_wrf_scan(sq_wrf *w, sq_wrf_ranges *out);

/* Projected coordinates: geographic (lon, lat in degrees) to world (x, y) metres and back. */
SQ_API sq_result sq_wrf_to_world(const sq_wrf *w, double lon_deg, double lat_deg, double *x_m,
                                 double *y_m);
SQ_API sq_result sq_wrf_from_world(const sq_wrf *w, double x_m, double y_m, double *lon_deg,
                                   double *lat_deg);

/* The sun over the domain centre at time_s (from Times, UTC; true solar time from the longitude
 * and the equation of time) and its direction in the world frame (rotated from true north to
 * grid north by north_rotation_deg). */
SQ_API sq_result sq_wrf_sun(const sq_wrf *w, double time_s, sq_sun_position *pos,
                            sq_vec3 *dir_world);

/* Fills a world description from the series: terrain = HGT of the first stored time as an
 * SQ_TERRAIN_GRID (heights and crs_wkt borrowed from w: keep w open until sq_world_create
 * returns), the georeference, and the sun's clock (sq_sun_desc.utc_set: date = the series' time
 * time_s, place = the domain centre, north rotation; direction set to zero so the clock is used).
 * Other fields of *desc (vertical exaggeration, sky, obstacles ...) are left as they are. */
SQ_API sq_result sq_wrf_world_desc(sq_wrf *w, double time_s, sq_world_desc *desc);

/* The scene's loader for terrain kind wrf (sq_scene_desc.load_wrf_world, squall/scene.h):
 * sq_wrf_world_desc of the file at its first time, with the heights and WKT copied into *owned
 * (one sq_alloc block, freed by the caller with sq_free after sq_world_create). */
SQ_API sq_result sq_scene_wrf_world_loader(sq_context *ctx, const char *path, sq_world_desc *desc,
                                           void **owned);

/* Column optical depth of the cloud condensate (cloud water + cloud ice) on the mass grid
 * (nx*ny), for a state read from w: tau = sum_k beta_k (zstag[k+1] - zstag[k]) with
 * beta = sq_cloud_extinction() of each species at its default effective radius
 * (include/squall/optics.h). out holds nx*ny floats. */
SQ_API void sq_wrf_cloud_optical_depth(const sq_wrf_info *info, const sq_wrf_state *s,
                                       float *out);

/* ---- export: CF-1.8 NetCDF of the derived fields (src/io/wrf_export.c) --------------------- */
typedef struct sq_wrf_export_desc {
    const char *path;   /* output file; written to a temporary name and renamed when complete */
    int index;          /* stored time to write; -1: the time time_s (interpolated between) */
    double time_s;      /* used when index < 0 */
    bool overwrite;     /* replace an existing path */
} sq_wrf_export_desc;

/* Writes netCDF-4 with CF-1.8 metadata: dimensions (bottom_top, south_north, west_east), the
 * projected coordinates x(west_east), y(south_north) in metres with a grid_mapping variable
 * "crs" (CF projection attributes, crs_wkt, the PROJ string), lat/lon auxiliary coordinates, a
 * scalar time coordinate; float variables z, height_above_ground, pressure, theta, temperature,
 * air_density, qvapor, u, v, w, cloud_water, cloud_ice, snow, rain, graupel (the species the
 * file has), extinction (cloud water + ice, m-1), and 2D terrain_height and
 * cloud_optical_depth. Nothing is written when reading or checking the time fails. */
SQ_API sq_result sq_wrf_export_netcdf(sq_wrf *w, const sq_wrf_export_desc *desc);

#ifdef __cplusplus
}
#endif
#endif
