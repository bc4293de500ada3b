/* test_geo.c — georeferenced data through GDAL/OGR (src/io/geo_*.c): the SRTM DEM of the
 * Hintereisferner area (data/dem/hef_srtm.tif, EPSG:4326) reprojected to UTM 32N and compared
 * with GDAL's own reading of the raw pixels at the same places; region-of-interest cropping;
 * no-data filling and refusal; files GDAL cannot open and files without a CRS; polygon areas from
 * GeoJSON (with a hole, with a thickness attribute) and from a raster mask; zero-area and
 * point-only inputs refused; GeoTIFF and ESRI ASCII rasters read back through GDAL. Each case
 * works in its own directory under /tmp. The independent checks use GDAL directly. */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sq_config.h"
#include "sq_test.h"
#include "squall/geo.h"
#include "squall/io.h"
#include "squall/scene.h"
#include "squall/world.h"

SQ_LABEL(unit)

static inline sq_world_terrain terrain_of(const sq_world *w)
{
    sq_world_terrain t;
    sq_world_get_terrain(w, &t);
    return t;
}

#if SQ_HAVE_GDAL
#include <cpl_conv.h>
#include <gdal.h>
#include <ogr_srs_api.h>

static char g_dir[512];

static void make_dir(void)
{
    const char *base = getenv("TMPDIR");
    if (!base || !*base) base = "/tmp";
    snprintf(g_dir, sizeof g_dir, "%s/sq_geo_XXXXXX", base);
    if (!mkdtemp(g_dir)) SQ_FAIL_AT("mkdtemp(%s): %s", g_dir, strerror(errno));
}

static const char *in_dir(char *buf, size_t size, const char *name)
{
    snprintf(buf, size, "%s/%s", g_dir, name);
    return buf;
}

static void remove_dir(void)
{
    DIR *d = opendir(g_dir);
    if (!d) return;
    char p[1024];
    for (struct dirent *e; (e = readdir(d));) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        snprintf(p, sizeof p, "%s/%s", g_dir, e->d_name);
        unlink(p);
    }
    closedir(d);
    rmdir(g_dir);
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        SQ_FAIL_AT("cannot write %s", path);
        return;
    }
    fputs(text, f);
    fclose(f);
}

static const char *hef_path(void)
{
    static char p[1024];
    snprintf(p, sizeof p, "%s/data/dem/hef_srtm.tif", SQ_TEST_SOURCE_DIR);
    return p;
}

static sq_context *make_ctx(void)
{
    sq_context_desc cd = {0};
    cd.threads = 1;
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

/* Bilinear height of our grid at CRS (x, y). */
static double grid_at(const sq_dem *d, double x, double y)
{
    const double gx = (x - d->x0) / d->dx, gy = (y - d->y0) / d->dy;
    int i = (int)floor(gx), j = (int)floor(gy);
    if (i < 0 || j < 0 || i > d->nx - 2 || j > d->ny - 2) return NAN;
    const double fx = gx - i, fy = gy - j;
    const float *h = d->heights_m;
    const size_t n = (size_t)d->nx;
    return (1 - fy) * ((1 - fx) * h[j * n + i] + fx * h[j * n + i + 1]) +
           fy * ((1 - fx) * h[(j + 1) * n + i] + fx * h[(j + 1) * n + i + 1]);
}

/* Bilinear height of the raw DEM at longitude/latitude (pixel centres), read through GDAL. */
static double raw_at(GDALDatasetH ds, const double gt[6], double lon, double lat)
{
    const double px = (lon - gt[0]) / gt[1] - 0.5, py = (lat - gt[3]) / gt[5] - 0.5;
    const int i = (int)floor(px), j = (int)floor(py);
    float v[4];
    if (GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Read, i, j, 2, 2, v, 2, 2, GDT_Float32, 0, 0) !=
        CE_None)
        return NAN;
    const double fx = px - i, fy = py - j;
    return (1 - fy) * ((1 - fx) * v[0] + fx * v[1]) + fy * ((1 - fx) * v[2] + fx * v[3]);
}

#else
/* without GDAL every entry point refuses */
static void no_gdal(void)
{
    sq_dem dem;
    sq_dem_desc d = {0};
    d.path = "x.tif";
    SQ_CHECK_ERR(sq_dem_load(NULL, &d, &dem), SQ_ERR_UNSUPPORTED, "GDAL");
}
#endif

SQ_TEST(dem_geographic_reprojected_to_utm_matches_the_raw_pixels)
{
#if SQ_HAVE_GDAL
    sq_context *ctx = make_ctx();
    sq_dem_desc d = {0};
    d.path = hef_path();
    d.cell_m = 50.0;
    sq_dem dem;
    SQ_CHECK_OK(sq_dem_load(ctx, &d, &dem));
    /* 10.60-10.92 E, 46.68-46.91 N: UTM zone 32 north */
    SQ_CHECK(dem.epsg == 32632);
    SQ_CHECK(strstr(dem.crs_name, "UTM zone 32N") != NULL);
    SQ_CHECK(dem.reprojected);
    SQ_CHECK(dem.crs_wkt && strstr(dem.crs_wkt, "UTM") != NULL);
    SQ_CHECK(dem.void_count == 0 && dem.void_mask == NULL);
    /* the DEM spans 0.32 deg x 0.2367 deg: about 24.4 x 26.3 km; the inscribed UTM rectangle is a
     * little smaller */
    SQ_CHECK_MSG(dem.nx * 50.0 > 23000 && dem.nx * 50.0 < 24500, "width %d cells", dem.nx);
    SQ_CHECK_MSG(dem.ny * 50.0 > 25500 && dem.ny * 50.0 < 26400, "height %d cells", dem.ny);
    SQ_CHECK_MSG(dem.height_min_m > 1000 && dem.height_max_m < 3800 && dem.height_max_m > 3500,
                 "heights %g..%g", dem.height_min_m, dem.height_max_m);
    SQ_CHECK(fmod(dem.x0, 50.0) == 0.0 && fmod(dem.y0, 50.0) == 0.0);

    /* independent: the raw pixels at the same longitude/latitude, through GDAL and OSR */
    GDALAllRegister();
    GDALDatasetH ds = GDALOpen(hef_path(), GA_ReadOnly);
    SQ_CHECK(ds != NULL);
    double gt[6];
    GDALGetGeoTransform(ds, gt);
    OGRSpatialReferenceH ll = OSRNewSpatialReference(NULL), utm = OSRNewSpatialReference(NULL);
    OSRImportFromEPSG(ll, 4326);
    OSRImportFromEPSG(utm, 32632);
    OSRSetAxisMappingStrategy(ll, OAMS_TRADITIONAL_GIS_ORDER);
    OSRSetAxisMappingStrategy(utm, OAMS_TRADITIONAL_GIS_ORDER);
    OGRCoordinateTransformationH ct = OCTNewCoordinateTransformation(ll, utm);
    double err[64];
    int n = 0;
    for (int a = 0; a < 8; a++)
        for (int b = 0; b < 8; b++) {
            double lon = 10.65 + 0.03 * a, lat = 46.72 + 0.022 * b;
            const double raw = raw_at(ds, gt, lon, lat);
            double x = lon, y = lat;
            OCTTransform(ct, 1, &x, &y, NULL);
            const double ours = grid_at(&dem, x, y);
            SQ_CHECK_MSG(isfinite(ours) && isfinite(raw), "point %d,%d", a, b);
            err[n++] = fabs(ours - raw);
        }
    /* median and worst over 64 points: resampling from ~64 x 93 m pixels to 50 m cells on alpine
     * slopes smooths, but the surface stays the same */
    for (int i = 1; i < n; i++)
        for (int k = i; k > 0 && err[k] < err[k - 1]; k--) {
            double t = err[k];
            err[k] = err[k - 1];
            err[k - 1] = t;
        }
    printf("height differences ours - raw: median %.2f m, max %.2f m\n", err[n / 2], err[n - 1]);
    SQ_CHECK_MSG(err[n / 2] < 8.0, "median |diff| %.2f m", err[n / 2]);
    SQ_CHECK_MSG(err[n - 1] < 60.0, "max |diff| %.2f m", err[n - 1]);
    OCTDestroyCoordinateTransformation(ct);
    OSRDestroySpatialReference(ll);
    OSRDestroySpatialReference(utm);
    GDALClose(ds);
    sq_dem_release(ctx, &dem);
    SQ_CHECK(dem.heights_m == NULL);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
#else
    no_gdal();
#endif
}

SQ_TEST(dem_region_of_interest_crops_inside_it)
{
#if SQ_HAVE_GDAL
    sq_context *ctx = make_ctx();
    sq_dem_desc d = {0};
    d.path = hef_path();
    d.roi[0] = 10.70;
    d.roi[1] = 46.76;
    d.roi[2] = 10.80;
    d.roi[3] = 46.84;
    d.cell_m = 25.0;
    d.crs = "EPSG:32632";
    sq_dem dem;
    SQ_CHECK_OK(sq_dem_load(ctx, &d, &dem));
    /* every corner sample of the grid lies inside the ROI in longitude/latitude, and the grid
     * fills most of it (0.1 deg x 0.08 deg ~ 7.6 x 8.9 km) */
    OGRSpatialReferenceH ll = OSRNewSpatialReference(NULL), utm = OSRNewSpatialReference(NULL);
    OSRImportFromEPSG(ll, 4326);
    OSRImportFromEPSG(utm, 32632);
    OSRSetAxisMappingStrategy(ll, OAMS_TRADITIONAL_GIS_ORDER);
    OSRSetAxisMappingStrategy(utm, OAMS_TRADITIONAL_GIS_ORDER);
    OGRCoordinateTransformationH ct = OCTNewCoordinateTransformation(utm, ll);
    for (int c = 0; c < 4; c++) {
        double x = dem.x0 + ((c & 1) ? (dem.nx - 1) * 25.0 : 0.0);
        double y = dem.y0 + ((c & 2) ? (dem.ny - 1) * 25.0 : 0.0);
        OCTTransform(ct, 1, &x, &y, NULL);
        SQ_CHECK_MSG(x >= 10.70 && x <= 10.80 && y >= 46.76 && y <= 46.84,
                     "corner %d at %.5f E %.5f N outside the ROI", c, x, y);
    }
    SQ_CHECK_MSG(dem.nx * 25.0 > 7000 && dem.ny * 25.0 > 8500, "%dx%d", dem.nx, dem.ny);
    OCTDestroyCoordinateTransformation(ct);
    OSRDestroySpatialReference(ll);
    OSRDestroySpatialReference(utm);
    sq_dem_release(ctx, &dem);

    /* outside, and reaching outside: refused naming the DEM's extent */
    d.roi[0] = 11.0;
    d.roi[2] = 11.1;
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_INVALID_ARG, "lies outside the DEM");
    SQ_CHECK(strstr(sq_last_error(), "terrain.roi") != NULL);
    d.roi[0] = 10.9;
    d.roi[2] = 10.95;
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_INVALID_ARG, "reaches outside the DEM");
    d.roi[0] = 10.8;
    d.roi[2] = 10.7;
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_INVALID_ARG, "xmax > xmin");
    /* a geographic CRS named as the target is refused (not metric) */
    d.roi[0] = 10.7;
    d.roi[2] = 10.8;
    d.crs = "EPSG:4326";
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_INVALID_ARG, "not projected in metres");
    SQ_CHECK(dem.heights_m == NULL);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
#else
    no_gdal();
#endif
}

SQ_TEST(dem_unreadable_and_without_crs_are_refused_with_reasons)
{
#if SQ_HAVE_GDAL
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024], q[1024];
    sq_dem dem;
    sq_dem_desc d = {0};
    d.key = "world.terrain";
    d.path = in_dir(p, sizeof p, "missing.tif");
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_IO, "GDAL cannot open it");
    SQ_CHECK(strstr(sq_last_error(), "world.terrain.dem = '") != NULL);
    SQ_CHECK(strstr(sq_last_error(), "No such file") != NULL);
    write_text(in_dir(q, sizeof q, "junk.tif"), "this is not a raster\n");
    d.path = q;
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_IO, "not recognized as a supported");
    /* an ESRI ASCII grid without .prj: no CRS */
    write_text(in_dir(q, sizeof q, "plain.asc"),
               "ncols 4\nnrows 3\nxllcorner 650000\nyllcorner 5180000\ncellsize 10\n"
               "NODATA_value -9999\n"
               "100 101 102 103\n110 111 112 113\n120 121 122 123\n");
    d.path = q;
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_INVALID_ARG, "no coordinate reference system");
    SQ_CHECK(strstr(sq_last_error(), "world.terrain.dem_crs") != NULL);
    /* given one: the grid is read as is (metric, no reprojection), rows south first */
    d.assign_crs = "EPSG:32632";
    d.resampling = SQ_DEM_RESAMPLE_NEAREST;
    SQ_CHECK_OK(sq_dem_load(ctx, &d, &dem));
    SQ_CHECK(!dem.reprojected && dem.epsg == 32632);
    SQ_CHECK(dem.nx == 4 && dem.ny == 3 && dem.dx == 10.0);
    SQ_CHECK_NEAR(dem.x0, 650005.0, 1e-6);
    SQ_CHECK_NEAR(dem.y0, 5180005.0, 1e-6);
    SQ_CHECK_NEAR(dem.heights_m[0], 120.0, 1e-4);          /* south-west */
    SQ_CHECK_NEAR(dem.heights_m[2 * 4 + 3], 103.0, 1e-4);  /* north-east */
    sq_dem_release(ctx, &dem);
    d.assign_crs = "EPSG:999999";
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_INVALID_ARG, "dem_crs = 'EPSG:999999'");
    /* degrees off the Earth (the fuzzer's find: a UTM zone from longitude 2e171 overflowed) */
    write_text(in_dir(q, sizeof q, "offworld.asc"),
               "ncols 4\nnrows 3\nxllcorner 1e12\nyllcorner 45\ncellsize 0.001\n"
               "100 101 102 103\n110 111 112 113\n120 121 122 123\n");
    d.path = q;
    d.assign_crs = "EPSG:4326";
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_INVALID_ARG, "not a place on Earth");
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
#else
    no_gdal();
#endif
}

SQ_TEST(dem_nodata_filled_and_marked_or_refused)
{
#if SQ_HAVE_GDAL
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024];
    /* a plane h = 100 + x/10 with two voids: filling interpolates the plane's values */
    write_text(in_dir(p, sizeof p, "voids.asc"),
               "ncols 6\nnrows 5\nxllcorner 0\nyllcorner 0\ncellsize 10\nNODATA_value -9999\n"
               "100.5 101.5 102.5 103.5 104.5 105.5\n"
               "100.5 101.5 102.5 103.5 104.5 105.5\n"
               "100.5 101.5 -9999 -9999 104.5 105.5\n"
               "100.5 101.5 102.5 103.5 104.5 105.5\n"
               "100.5 101.5 102.5 103.5 104.5 105.5\n");
    sq_dem_desc d = {0};
    d.path = p;
    d.assign_crs = "EPSG:32633";
    d.resampling = SQ_DEM_RESAMPLE_NEAREST;
    sq_dem dem;
    SQ_CHECK_OK(sq_dem_load(ctx, &d, &dem));
    SQ_CHECK(dem.void_count == 2 && dem.void_mask != NULL);
    if (dem.void_mask) {
        int marked = 0;
        for (int k = 0; k < 30; k++) marked += dem.void_mask[k];
        SQ_CHECK(marked == 2);
        SQ_CHECK(dem.void_mask[2 * 6 + 2] == 1 && dem.void_mask[2 * 6 + 3] == 1);
    }
    /* inverse distance from symmetric neighbours: between the values left and right of the gap */
    SQ_CHECK_MSG(dem.heights_m[2 * 6 + 2] > 101.5 && dem.heights_m[2 * 6 + 2] < 104.5,
                 "filled %g", (double)dem.heights_m[2 * 6 + 2]);
    SQ_CHECK_MSG(dem.heights_m[2 * 6 + 3] > 101.5 && dem.heights_m[2 * 6 + 3] < 104.5,
                 "filled %g", (double)dem.heights_m[2 * 6 + 3]);
    sq_dem_release(ctx, &dem);
    d.nodata = SQ_DEM_NODATA_FAIL;
    SQ_CHECK_ERR(sq_dem_load(ctx, &d, &dem), SQ_ERR_INVALID_ARG, "2 of 30 samples");
    /* the world keeps the mask */
    d.nodata = SQ_DEM_NODATA_FILL;
    SQ_CHECK_OK(sq_dem_load(ctx, &d, &dem));
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_GRID;
    wd.terrain.grid_heights_m = dem.heights_m;
    wd.terrain.grid_void = dem.void_mask;
    wd.terrain.grid_w = dem.nx;
    wd.terrain.grid_h = dem.ny;
    wd.terrain.grid_dx_m = wd.terrain.grid_dy_m = 10.0f;
    wd.terrain.origin_set = true;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    if (w) {
        SQ_CHECK(sq_world_void_at(w, 20.0f, 20.0f));
        SQ_CHECK(sq_world_void_at(w, 30.0f, 20.0f));
        SQ_CHECK(!sq_world_void_at(w, 10.0f, 20.0f));
        SQ_CHECK(!sq_world_void_at(w, 20.0f, 30.0f));
    }
    sq_world_destroy(ctx, w);
    sq_dem_release(ctx, &dem);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
#else
    no_gdal();
#endif
}

#if SQ_HAVE_GDAL
static const char *UTM32 = "EPSG:32632";
#endif

SQ_TEST(area_polygons_from_geojson_with_hole_and_attribute)
{
#if SQ_HAVE_GDAL
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024];
    /* feature 0: a 200 x 100 m rectangle with a 20 x 20 m hole, thickness 1.5; feature 1: a
     * 50 x 50 m square without thickness; both in UTM 32N */
    write_text(in_dir(p, sizeof p, "rel.geojson"),
               "{\"type\":\"FeatureCollection\",\"crs\":{\"type\":\"name\",\"properties\":"
               "{\"name\":\"urn:ogc:def:crs:EPSG::32632\"}},\"features\":["
               "{\"type\":\"Feature\",\"properties\":{\"thickness\":1.5},\"geometry\":"
               "{\"type\":\"Polygon\",\"coordinates\":[[[640000,5180000],[640200,5180000],"
               "[640200,5180100],[640000,5180100],[640000,5180000]],[[640090,5180040],"
               "[640110,5180040],[640110,5180060],[640090,5180060],[640090,5180040]]]}},"
               "{\"type\":\"Feature\",\"properties\":{},\"geometry\":"
               "{\"type\":\"Polygon\",\"coordinates\":[[[640300,5180000],[640350,5180000],"
               "[640350,5180050],[640300,5180050],[640300,5180000]]]}}]}");
    OGRSpatialReferenceH s = OSRNewSpatialReference(NULL);
    OSRImportFromEPSG(s, 32632);
    char *wkt = NULL;
    OSRExportToWkt(s, &wkt);
    sq_area_desc d = {0};
    d.path = p;
    d.attribute = "thickness";
    d.target_crs_wkt = wkt;
    d.offset_m[0] = 640000.0;
    d.offset_m[1] = 5180000.0;
    sq_area a;
    SQ_CHECK_OK(sq_area_load(ctx, &d, &a));
    SQ_CHECK(a.feature_count == 2 && a.ring_count == 3);
    SQ_CHECK_NEAR(a.feature_area_m2[0], 200.0 * 100.0 - 400.0, 1e-6);
    SQ_CHECK_NEAR(a.feature_area_m2[1], 2500.0, 1e-6);
    SQ_CHECK_NEAR(a.area_m2, 22100.0, 1e-6);
    SQ_CHECK_NEAR(a.feature_value[0], 1.5, 1e-12);
    SQ_CHECK(isnan(a.feature_value[1]));
    SQ_CHECK_NEAR(a.bounds[0], 0.0, 1e-6);
    SQ_CHECK_NEAR(a.bounds[2], 350.0, 1e-6);
    /* as a world area: inside, in the hole, in the second feature, outside */
    sq_world_area wa = {"release", p, a.feature_count, a.feature_value, a.feature_area_m2,
                        a.ring_count, a.ring_start, a.ring_feature, a.xy_m,
                        {a.bounds[0], a.bounds[1], a.bounds[2], a.bounds[3]}, a.area_m2};
    SQ_CHECK(sq_world_area_feature_at(&wa, 10.0, 10.0) == 0);
    SQ_CHECK(sq_world_area_feature_at(&wa, 100.0, 50.0) == -1); /* the hole */
    SQ_CHECK(sq_world_area_feature_at(&wa, 85.0, 50.0) == 0);
    SQ_CHECK(sq_world_area_feature_at(&wa, 320.0, 20.0) == 1);
    SQ_CHECK(sq_world_area_feature_at(&wa, 250.0, 20.0) == -1);
    SQ_CHECK(sq_world_area_feature_at(&wa, 10.0, 120.0) == -1);
    sq_area_release(ctx, &a);

    /* the same rectangle in longitude/latitude (a GeoJSON default): transformed, area kept
     * within the UTM scale error (~1e-3 here) */
    write_text(p, "{\"type\":\"Feature\",\"properties\":{\"thickness\":2},\"geometry\":"
                  "{\"type\":\"Polygon\",\"coordinates\":[[[10.80,46.80],[10.81,46.80],"
                  "[10.81,46.81],[10.80,46.81],[10.80,46.80]]]}}");
    SQ_CHECK_OK(sq_area_load(ctx, &d, &a));
    SQ_CHECK(a.feature_count == 1);
    /* 0.01 deg x 0.01 deg at 46.8 N: 762 x 1112 m */
    SQ_CHECK_MSG(a.area_m2 > 0.84e6 && a.area_m2 < 0.855e6, "area %g", a.area_m2);
    sq_area_release(ctx, &a);

    /* refusals: zero area, points only, no CRS */
    write_text(p, "{\"type\":\"Feature\",\"properties\":{},\"geometry\":{\"type\":\"Polygon\","
                  "\"coordinates\":[[[10.80,46.80],[10.81,46.80],[10.82,46.80],[10.80,46.80]]]}}");
    SQ_CHECK_ERR(sq_area_load(ctx, &d, &a), SQ_ERR_INVALID_ARG, "zero area");
    write_text(p, "{\"type\":\"Feature\",\"properties\":{},\"geometry\":{\"type\":\"Point\","
                  "\"coordinates\":[10.80,46.80]}}");
    SQ_CHECK_ERR(sq_area_load(ctx, &d, &a), SQ_ERR_INVALID_ARG, "no polygon");
    /* a bow tie: two lobes of 0.005 x 0.005 deg whose signed areas cancel (OGR's area: 0); it
     * is named as a boundary that crosses itself, not as a zero area */
    write_text(p, "{\"type\":\"Feature\",\"properties\":{},\"geometry\":{\"type\":\"Polygon\","
                  "\"coordinates\":[[[10.80,46.80],[10.81,46.805],[10.81,46.80],[10.80,46.805],"
                  "[10.80,46.80]]]}}");
    SQ_CHECK_ERR(sq_area_load(ctx, &d, &a), SQ_ERR_INVALID_ARG, "must not cross itself");
    /* an attribute that is text, NaN or infinite is refused; null keeps the default (NAN) */
    static const char *const bad_thickness[] = {"\"thick\"", "NaN", "Infinity", "\"\""};
    static const char *const bad_said[] = {"'thick' is not a number", "nan is not a finite",
                                           "inf is not a finite", "'' is not a number"};
    for (int k = 0; k < 4; k++) {
        char text[512];
        snprintf(text, sizeof text,
                 "{\"type\":\"Feature\",\"properties\":{\"thickness\":%s},\"geometry\":"
                 "{\"type\":\"Polygon\",\"coordinates\":[[[10.80,46.80],[10.81,46.80],"
                 "[10.81,46.81],[10.80,46.81],[10.80,46.80]]]}}",
                 bad_thickness[k]);
        write_text(p, text);
        SQ_CHECK_ERR(sq_area_load(ctx, &d, &a), SQ_ERR_INVALID_ARG, bad_said[k]);
    }
    write_text(p, "{\"type\":\"Feature\",\"properties\":{\"thickness\":null},\"geometry\":"
                  "{\"type\":\"Polygon\",\"coordinates\":[[[10.80,46.80],[10.81,46.80],"
                  "[10.81,46.81],[10.80,46.81],[10.80,46.80]]]}}");
    SQ_CHECK_OK(sq_area_load(ctx, &d, &a));
    SQ_CHECK(a.feature_count == 1 && isnan(a.feature_value[0]));
    sq_area_release(ctx, &a);
    d.path = in_dir(p, sizeof p, "none.geojson");
    SQ_CHECK_ERR(sq_area_load(ctx, &d, &a), SQ_ERR_IO, "cannot open it");
    CPLFree(wkt);
    OSRDestroySpatialReference(s);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
#else
    no_gdal();
#endif
}

SQ_TEST(area_from_raster_mask_has_the_pixel_area)
{
#if SQ_HAVE_GDAL
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024];
    /* 6 pixels of 10 m inside (non-zero, not no-data) */
    write_text(in_dir(p, sizeof p, "mask.asc"),
               "ncols 5\nnrows 4\nxllcorner 500000\nyllcorner 5000000\ncellsize 10\n"
               "NODATA_value -1\n0 0 0 0 0\n0 1 1 1 0\n0 2 1 -1 0\n0 0 3 0 0\n");
    OGRSpatialReferenceH s = OSRNewSpatialReference(NULL);
    OSRImportFromEPSG(s, 32632);
    char *wkt = NULL;
    OSRExportToWkt(s, &wkt);
    sq_area_desc d = {0};
    d.path = p;
    d.assign_crs = UTM32;
    d.target_crs_wkt = wkt;
    d.offset_m[0] = 500000.0;
    d.offset_m[1] = 5000000.0;
    sq_area a;
    SQ_CHECK_OK(sq_area_load(ctx, &d, &a));
    SQ_CHECK_NEAR(a.area_m2, 600.0, 1e-6);
    SQ_CHECK_NEAR(a.bounds[0], 10.0, 1e-6);
    SQ_CHECK_NEAR(a.bounds[3], 30.0, 1e-6);
    sq_area_release(ctx, &a);
    write_text(p, "ncols 3\nnrows 2\nxllcorner 500000\nyllcorner 5000000\ncellsize 10\n"
                  "NODATA_value -1\n0 0 -1\n0 0 0\n");
    SQ_CHECK_ERR(sq_area_load(ctx, &d, &a), SQ_ERR_INVALID_ARG, "zero area");
    CPLFree(wkt);
    OSRDestroySpatialReference(s);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
#else
    no_gdal();
#endif
}

SQ_TEST(raster_geotiff_and_ascii_read_back_through_gdal)
{
#if SQ_HAVE_GDAL
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024], q[1024];
    float data[3 * 2] = {1.0f, 2.0f, 3.0f, /* south row */ 4.0f, NAN, 6.0f};
    sq_raster_desc r = {0};
    r.path = in_dir(p, sizeof p, "depth.tif");
    r.crs_wkt = NULL;
    OGRSpatialReferenceH s = OSRNewSpatialReference(NULL);
    OSRImportFromEPSG(s, 32632);
    char *wkt = NULL;
    OSRExportToWkt(s, &wkt);
    r.crs_wkt = wkt;
    r.nx = 3;
    r.ny = 2;
    r.x0 = 640000.0;
    r.y0 = 5180000.0;
    r.cell_m = 5.0;
    r.data = data;
    r.nodata = -9999.0;
    r.description = "peak flow depth";
    r.units = "m";
    SQ_CHECK_OK(sq_raster_write(ctx, &r));
    SQ_CHECK_ERR(sq_raster_write(ctx, &r), SQ_ERR_EXISTS, "exists");
    GDALDatasetH ds = GDALOpen(p, GA_ReadOnly);
    SQ_CHECK(ds != NULL);
    if (ds) {
        double gt[6];
        GDALGetGeoTransform(ds, gt);
        SQ_CHECK_NEAR(gt[0], 640000.0, 1e-9);
        SQ_CHECK_NEAR(gt[3], 5180010.0, 1e-9); /* north edge */
        SQ_CHECK_NEAR(gt[1], 5.0, 1e-12);
        SQ_CHECK_NEAR(gt[5], -5.0, 1e-12);
        OGRSpatialReferenceH got = OSRClone(GDALGetSpatialRef(ds));
        OSRAutoIdentifyEPSG(got);
        SQ_CHECK(OSRGetAuthorityCode(got, NULL) && !strcmp(OSRGetAuthorityCode(got, NULL), "32632"));
        OSRDestroySpatialReference(got);
        GDALRasterBandH b = GDALGetRasterBand(ds, 1);
        int has = 0;
        SQ_CHECK_NEAR(GDALGetRasterNoDataValue(b, &has), -9999.0, 0.0);
        SQ_CHECK(has);
        SQ_CHECK(!strcmp(GDALGetRasterUnitType(b), "m"));
        float v[6];
        SQ_CHECK(GDALRasterIO(b, GF_Read, 0, 0, 3, 2, v, 3, 2, GDT_Float32, 0, 0) == CE_None);
        SQ_CHECK(v[0] == 4.0f && v[1] == -9999.0f && v[2] == 6.0f); /* north row first */
        SQ_CHECK(v[3] == 1.0f && v[5] == 3.0f);
        GDALClose(ds);
    }
    r.path = in_dir(q, sizeof q, "depth.asc");
    r.format = SQ_RASTER_ASCII;
    SQ_CHECK_OK(sq_raster_write(ctx, &r));
    ds = GDALOpen(q, GA_ReadOnly);
    SQ_CHECK(ds != NULL);
    if (ds) {
        double gt[6];
        GDALGetGeoTransform(ds, gt);
        SQ_CHECK_NEAR(gt[0], 640000.0, 1e-6);
        SQ_CHECK_NEAR(gt[3], 5180010.0, 1e-6);
        SQ_CHECK(GDALGetSpatialRef(ds) != NULL); /* from the .prj */
        float v[6];
        SQ_CHECK(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Read, 0, 0, 3, 2, v, 3, 2, GDT_Float32,
                              0, 0) == CE_None);
        SQ_CHECK(v[0] == 4.0f && v[1] == -9999.0f && v[3] == 1.0f);
        GDALClose(ds);
    }
    struct stat st;
    SQ_CHECK(stat(in_dir(p, sizeof p, "depth.prj"), &st) == 0);
    CPLFree(wkt);
    OSRDestroySpatialReference(s);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
#else
    no_gdal();
#endif
}

/* Inputs are never written (issue 17): a raster written onto the DEM it was made from, by name
 * or through a symbolic link, is refused even with overwrite, and the DEM is unchanged. The DEM
 * is a copy in the test's directory, so a broken guard cannot damage the shared sample. */
SQ_TEST(raster_refuses_its_input)
{
#if SQ_HAVE_GDAL
    make_dir();
    sq_context *ctx = make_ctx();
    char dem_path[1024], link_path[1024];
    in_dir(dem_path, sizeof dem_path, "dem.tif");
    in_dir(link_path, sizeof link_path, "link.tif");
    FILE *in = fopen(hef_path(), "rb");
    FILE *out = fopen(dem_path, "wb");
    SQ_CHECK(in && out);
    long size = 0;
    for (int c; in && out && (c = fgetc(in)) != EOF; size++) fputc(c, out);
    if (in) fclose(in);
    if (out) fclose(out);
    SQ_CHECK(symlink("dem.tif", link_path) == 0);
    sq_dem_desc d = {0};
    d.path = dem_path;
    d.cell_m = 400.0; /* coarse: only the reading matters here */
    sq_dem dem;
    SQ_CHECK_OK(sq_dem_load(ctx, &d, &dem));
    sq_raster_desc r = {0};
    r.crs_wkt = dem.crs_wkt;
    r.nx = dem.nx;
    r.ny = dem.ny;
    r.x0 = dem.x0;
    r.y0 = dem.y0;
    r.cell_m = 400.0;
    r.data = dem.heights_m;
    r.nodata = -9999.0;
    r.overwrite = true;
    r.path = dem_path;
    SQ_CHECK_ERR(sq_raster_write(ctx, &r), SQ_ERR_INVALID_ARG, "inputs are never written");
    r.path = link_path;
    SQ_CHECK_ERR(sq_raster_write(ctx, &r), SQ_ERR_INVALID_ARG, "through a link");
    /* an ESRI ASCII grid whose .prj would be the DEM (a hard link named grid.prj): refused
     * before the grid itself is written */
    char prj_path[1024], asc_path[1024];
    in_dir(prj_path, sizeof prj_path, "grid.prj");
    in_dir(asc_path, sizeof asc_path, "grid.asc");
    SQ_CHECK(link(dem_path, prj_path) == 0);
    r.format = SQ_RASTER_ASCII;
    r.path = asc_path;
    SQ_CHECK_ERR(sq_raster_write(ctx, &r), SQ_ERR_INVALID_ARG, "grid.prj");
    struct stat st;
    SQ_CHECK(stat(asc_path, &st) != 0); /* nothing written */
    remove(prj_path);
    SQ_CHECK(stat(dem_path, &st) == 0 && st.st_size == size);
    SQ_CHECK(lstat(link_path, &st) == 0 && S_ISLNK(st.st_mode));
    sq_dem_release(ctx, &dem);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
#else
    no_gdal();
#endif
}


SQ_TEST(scene_dem_terrain_and_area_in_world_coordinates)
{
#if SQ_HAVE_GDAL
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024], yaml[4096];
    write_text(in_dir(p, sizeof p, "rel.geojson"),
               "{\"type\":\"Feature\",\"properties\":{\"thickness\":1.2},\"geometry\":"
               "{\"type\":\"Polygon\",\"coordinates\":[[[10.76,46.80],[10.765,46.80],"
               "[10.765,46.803],[10.76,46.803],[10.76,46.80]]]}}");
    snprintf(yaml, sizeof yaml,
             "world:\n"
             "  terrain: {kind: dem, dem: %s, roi: [10.74, 46.78, 10.80, 46.82], cell_m: 30,\n"
             "            crs_origin_m: [640000, 5185000]}\n"
             "  areas: [{name: release, file: %s}]\n",
             hef_path(), p);
    sq_cfg *cfg = NULL;
    SQ_CHECK_OK(sq_cfg_parse(ctx, yaml, strlen(yaml), "test.yaml", &cfg));
    sq_scene_desc sd = {.cfg = cfg, .load_dem = sq_dem_load, .load_area = sq_area_load,
                        .validate_only = true};
    sq_scene *sc = NULL;
    SQ_CHECK_OK(sq_scene_create(ctx, &sd, &sc));
    const sq_world *w = sc ? sq_scene_world(sc) : NULL;
    SQ_CHECK(w && sq_world_crs(w, NULL) && strstr(sq_world_crs(w, NULL), "UTM zone 32N"));
    if (w) {
        double off[2];
        sq_world_crs(w, off);
        SQ_CHECK(off[0] == 640000.0 && off[1] == 5185000.0);
        SQ_CHECK(terrain_of(w).kind == SQ_TERRAIN_GRID && terrain_of(w).dx == 30.0f);
        /* the terrain's origin is a multiple of 30 m in UTM */
        SQ_CHECK_NEAR(fmod((double)terrain_of(w).origin.x + 640000.0, 30.0), 0.0, 1e-3);
        const sq_world_area *a = sq_world_area_find(w, "release");
        SQ_CHECK(a != NULL);
        if (a) {
            SQ_CHECK(a->feature_count == 1 && a->feature_value[0] == 1.2);
            /* its south-west corner, transformed independently */
            OGRSpatialReferenceH ll = OSRNewSpatialReference(NULL);
            OGRSpatialReferenceH utm = OSRNewSpatialReference(NULL);
            OSRImportFromEPSG(ll, 4326);
            OSRImportFromEPSG(utm, 32632);
            OSRSetAxisMappingStrategy(ll, OAMS_TRADITIONAL_GIS_ORDER);
            OSRSetAxisMappingStrategy(utm, OAMS_TRADITIONAL_GIS_ORDER);
            OGRCoordinateTransformationH ct = OCTNewCoordinateTransformation(ll, utm);
            double x = 10.76, y = 46.80;
            OCTTransform(ct, 1, &x, &y, NULL);
            SQ_CHECK_NEAR(a->xy_m[0], x - 640000.0, 1e-6);
            SQ_CHECK_NEAR(a->xy_m[1], y - 5185000.0, 1e-6);
            SQ_CHECK(sq_world_area_feature_at(a, x - 640000.0 + 50.0, y - 5185000.0 + 50.0) == 0);
            SQ_CHECK(sq_world_area_feature_at(a, x - 640000.0 - 50.0, y - 5185000.0 + 50.0) == -1);
            OCTDestroyCoordinateTransformation(ct);
            OSRDestroySpatialReference(ll);
            OSRDestroySpatialReference(utm);
        }
    }
    sq_scene_destroy(sc);
    sq_cfg_destroy(cfg);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
#else
    no_gdal();
#endif
}
