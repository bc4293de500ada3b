/* squall/geo.h — georeferenced data through GDAL/OGR: digital elevation models (any raster GDAL
 * reads: GeoTIFF, ESRI ASCII grid, ...) reprojected to a metric CRS and cropped to a region of
 * interest, polygon areas (vector files through OGR, or raster masks) in the world's CRS, and
 * rasters written as GeoTIFF or ESRI ASCII grids with their CRS and geotransform.
 *
 * Coordinates: a metric CRS with x = easting, y = northing (m). Grids are stored with row 0 at
 * the SOUTH edge (the world's convention); the writers flip to GDAL's north-up order.
 * Every array the loaders return is allocated through the context (sq_alloc), so that sq_free
 * may release it piece by piece; sq_dem_release / sq_area_release free all of them.
 * Without GDAL (feature "gdal" off) every function fails with SQ_ERR_UNSUPPORTED. */
#ifndef SQ_GEO_H
#define SQ_GEO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- digital elevation models ---------------------------------------------------------------- */
typedef enum sq_dem_nodata {
    SQ_DEM_NODATA_FILL = 0, /* default: fill no-data samples by inverse-distance interpolation
                               from the valid ones (GDALFillNodata) and mark them in void_mask */
    SQ_DEM_NODATA_FAIL = 1  /* refuse a region of interest with any no-data sample */
} sq_dem_nodata;

typedef enum sq_dem_resampling {
    SQ_DEM_RESAMPLE_CUBIC = 0,  /* default: cubic convolution (smooth slopes, no facets) */
    SQ_DEM_RESAMPLE_BILINEAR = 1,
    SQ_DEM_RESAMPLE_CUBICSPLINE = 2,
    SQ_DEM_RESAMPLE_NEAREST = 3
} sq_dem_resampling;

typedef struct sq_dem_desc {
    const char *path;        /* any raster GDAL opens; band 1 holds the elevations (m) */
    const char *key;         /* prefix of the option names in messages ("world.terrain" gives
                                world.terrain.dem, .roi, .crs, .dem_crs, .nodata); NULL ->
                                "terrain" */
    /* Region of interest (xmin, ymin, xmax, ymax) in the DEM's own CRS (degrees for a
     * geographic DEM); all zero = the whole DEM. It must lie inside the DEM. The terrain is
     * the largest axis-aligned rectangle of the target CRS inside it. */
    double roi[4];
    /* Target CRS: NULL/"" = the DEM's own when it is projected in metres, else the UTM zone of
     * the region's centre (WGS 84); "utm" forces that; anything OGRSpatialReference accepts
     * ("EPSG:32632", WKT, PROJ strings) names one, which must be projected in metres. */
    const char *crs;
    const char *assign_crs;  /* CRS of a DEM whose file carries none (else it is refused) */
    double cell_m;           /* target cell (m); 0 = the DEM's finer pixel side in metres */
    int nodata;              /* sq_dem_nodata */
    int resampling;          /* sq_dem_resampling */
    int64_t max_samples;     /* refuse larger targets; 0 -> 8192 x 8192 */
} sq_dem_desc;

typedef struct sq_dem {
    int nx, ny;              /* samples along x (east) and y (north) */
    double dx, dy;           /* sample spacing (m) */
    double x0, y0;           /* CRS coordinates of sample (0, 0), the south-west sample centre */
    float *heights_m;        /* nx*ny, [j*nx + i], row 0 = south; sq_alloc'd */
    uint8_t *void_mask;      /* nx*ny, 1 where the DEM had no data (filled); NULL if none */
    size_t void_count;
    char *crs_wkt;           /* the target CRS as WKT; sq_alloc'd */
    char crs_name[128];      /* e.g. "WGS 84 / UTM zone 32N" */
    int epsg;                /* EPSG code of the target CRS, 0 if it has none */
    bool reprojected;        /* the DEM's CRS was geographic (or another was named) */
    double height_min_m, height_max_m;
} sq_dem;

/* Loads, reprojects, crops and fills a DEM. Errors (SQ_ERR_IO for files GDAL cannot open, with
 * GDAL's reason; SQ_ERR_INVALID_ARG for a missing CRS, a region outside the DEM, no-data with
 * SQ_DEM_NODATA_FAIL, ...) name desc->key, the file and the rule. On failure *out is zeroed. */
SQ_API sq_result sq_dem_load(sq_context *ctx, const sq_dem_desc *desc, sq_dem *out);
/* Frees what sq_dem_load allocated; accepts a zeroed dem. */
SQ_API void sq_dem_release(sq_context *ctx, sq_dem *dem);

/* ---- polygon areas ----------------------------------------------------------------------------- */
typedef struct sq_area_desc {
    const char *path;        /* vector file OGR opens (GeoJSON, Shapefile, GeoPackage, ...) or a
                                raster mask GDAL opens (pixels != 0 and != no-data are inside) */
    const char *key;         /* names the input in messages ("world.areas[0]" gives
                                world.areas[0].file, .crs); NULL -> "area" */
    const char *layer;       /* vector layer name; NULL/"" = the first layer */
    const char *attribute;   /* numeric attribute read per feature (e.g. "thickness");
                                NULL/"" = none; missing or null values read as NaN */
    const char *assign_crs;  /* CRS of a file that carries none (else it is refused) */
    const char *target_crs_wkt; /* the world's CRS; required */
    double offset_m[2];      /* subtracted after the transformation: world = CRS - offset */
} sq_area_desc;

/* Polygons in world coordinates. A point is inside feature f when it lies inside an odd number
 * of f's rings (outer rings and holes alike); features may overlap. */
typedef struct sq_area {
    int feature_count;
    double *feature_value;   /* per feature: the attribute (NaN = not given) */
    double *feature_area_m2; /* per feature: polygon area (holes subtracted) */
    int ring_count;
    int *ring_start;         /* ring_count + 1 offsets (in points) into xy_m */
    int *ring_feature;       /* feature of each ring */
    double *xy_m;            /* x, y pairs (world coordinates) */
    double bounds[4];        /* xmin, ymin, xmax, ymax of all rings */
    double area_m2;          /* sum of the features' areas */
} sq_area;

/* Reads the polygons of a vector file (points and lines are skipped; a file with none is
 * refused) or polygonises a raster mask, transforms them to target_crs_wkt and subtracts the
 * offset. Errors name desc->key, the file and the rule. On failure *out is zeroed. */
SQ_API sq_result sq_area_load(sq_context *ctx, const sq_area_desc *desc, sq_area *out);
SQ_API void sq_area_release(sq_context *ctx, sq_area *area);

/* ---- rasters out ---------------------------------------------------------------------------- */
typedef enum sq_raster_format {
    SQ_RASTER_GEOTIFF = 0,   /* Float32 GeoTIFF, DEFLATE compressed, CRS and geotransform */
    SQ_RASTER_ASCII = 1      /* ESRI ASCII grid (.asc) plus its .prj (ESRI WKT) */
} sq_raster_format;

typedef struct sq_raster_desc {
    const char *path;        /* final name (written to a temporary name and renamed) */
    int format;              /* sq_raster_format */
    const char *crs_wkt;     /* NULL/"" = no CRS written */
    int nx, ny;
    double x0, y0;           /* CRS coordinates of the SOUTH-WEST CORNER of cell (0, 0) */
    double cell_m;           /* square cells */
    const float *data;       /* nx*ny, row 0 = south; NaN cells are written as no-data */
    double nodata;           /* the no-data value written for NaN cells (e.g. -9999) */
    const char *description; /* band description (GeoTIFF) / none (ASCII) */
    const char *units;       /* band unit type (GeoTIFF) */
    bool overwrite;
} sq_raster_desc;

/* Writes desc->data as a single-band raster (GeoTIFF or ESRI ASCII grid through GDAL) under
 * the output rules of squall/io.h: temporary + rename, never over an input, SQ_ERR_EXISTS
 * without overwrite. SQ_ERR_UNSUPPORTED without GDAL; SQ_ERR_INVALID_ARG for a bad size or cell. */
SQ_API sq_result sq_raster_write(sq_context *ctx, const sq_raster_desc *desc);

#ifdef __cplusplus
}
#endif
#endif
