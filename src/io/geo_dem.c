/* geo_dem.c — digital elevation models through GDAL: any raster GDAL opens, reprojected to a
 * metric CRS (the DEM's own when it is projected in metres, else the UTM zone of the region's
 * centre, or one the caller names), cropped to a region of interest given in the DEM's CRS,
 * resampled to the requested cell (cubic convolution by default) and with no-data samples
 * filled by inverse-distance interpolation (GDALFillNodata) or refused. The result is a float
 * grid with row 0 at the south edge and sample (0, 0) at the south-west cell centre. */
#include "sq_config.h"

#if SQ_HAVE_GDAL
#include <cpl_conv.h>
#include <cpl_string.h>
#include <gdal_alg.h>
#include <gdal_utils.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geo_internal.h"
#include "io/io_internal.h"

#define MOD "dem"
#define DEM_NODATA (-99999.0)
#define EDGE_POINTS 33 /* points per edge of the region when transforming it */

typedef struct dem_job {
    sq_context *ctx;
    const sq_dem_desc *d;
    const char *key;
    GDALDatasetH src, dst;
    OGRSpatialReferenceH s_srs, t_srs, wgs84;
    OGRCoordinateTransformationH to_t, to_ll;
    double gt[6];
    double bounds[4]; /* the DEM's extent in its CRS */
    double roi[4];
} dem_job;

static void job_close(dem_job *j)
{
    if (j->to_t) OCTDestroyCoordinateTransformation(j->to_t);
    if (j->to_ll) OCTDestroyCoordinateTransformation(j->to_ll);
    if (j->s_srs) OSRDestroySpatialReference(j->s_srs);
    if (j->t_srs) OSRDestroySpatialReference(j->t_srs);
    if (j->wgs84) OSRDestroySpatialReference(j->wgs84);
    if (j->dst) GDALClose(j->dst);
    if (j->src) GDALClose(j->src);
    sq__geo_quiet_end();
}

#define FAIL(code, ...)                                                                            \
    do {                                                                                           \
        r = sq__fail(j->ctx, code, MOD, __VA_ARGS__);                                              \
        goto done;                                                                                 \
    } while (0)

/* The source CRS: the file's, or the assigned one for a file without. */
static sq_result source_crs(dem_job *j)
{
    const sq_dem_desc *d = j->d;
    OGRSpatialReferenceH s = GDALGetSpatialRef(j->src);
    if (!sq__geo_srs_empty(s)) {
        j->s_srs = sq__geo_srs_clone(s);
        return SQ_OK;
    }
    if (!d->assign_crs || !d->assign_crs[0])
        return sq__fail(j->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.dem = '%s': the file has no coordinate reference system; name the one its "
                        "coordinates are in with %s.dem_crs (e.g. EPSG:4326 for longitude/latitude "
                        "in degrees, EPSG:32632 for UTM zone 32N)",
                        j->key, d->path, j->key);
    j->s_srs = sq__geo_srs_from_user(d->assign_crs);
    if (!j->s_srs)
        return sq__fail(j->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.dem_crs = '%s': not a coordinate reference system GDAL knows (%s)", j->key,
                        d->assign_crs, sq__geo_reason());
    return SQ_OK;
}

/* The target CRS (see sq_dem_desc.crs) and the transformations to it and to WGS 84. */
static sq_result target_crs(dem_job *j)
{
    const sq_dem_desc *d = j->d;
    const char *want = d->crs && d->crs[0] ? d->crs : NULL;
    const int utm = want && (strcmp(want, "utm") == 0 || strcmp(want, "UTM") == 0);
    j->wgs84 = sq__geo_srs_from_user("EPSG:4326");
    if (!j->wgs84)
        return sq__fail(j->ctx, SQ_ERR_IO, MOD, "%s: GDAL has no EPSG:4326 definition (%s); is "
                        "gdal-data / proj-data installed?", j->key, sq__geo_reason());
    j->to_ll = OCTNewCoordinateTransformation(j->s_srs, j->wgs84);
    if (want && !utm) {
        j->t_srs = sq__geo_srs_from_user(want);
        if (!j->t_srs)
            return sq__fail(j->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "%s.crs = '%s': not a coordinate reference system GDAL knows (%s)",
                            j->key, want, sq__geo_reason());
        if (!sq__geo_srs_is_metric(j->t_srs))
            return sq__fail(j->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "%s.crs = '%s' (%s) is not projected in metres; the terrain needs a "
                            "metric CRS (e.g. a UTM zone, EPSG:326NN)",
                            j->key, want, OSRGetName(j->t_srs) ? OSRGetName(j->t_srs) : "?");
    } else if (!utm && sq__geo_srs_is_metric(j->s_srs)) {
        j->t_srs = sq__geo_srs_clone(j->s_srs);
    } else {
        /* the UTM zone (WGS 84) of the region's centre */
        if (!j->to_ll)
            return sq__fail(j->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "%s.dem = '%s': cannot relate its CRS to longitude/latitude to choose a "
                            "UTM zone (%s); name a metric CRS with the crs option",
                            j->key, d->path, sq__geo_reason());
        double cx = 0.5 * (j->roi[0] + j->roi[2]), cy = 0.5 * (j->roi[1] + j->roi[3]);
        if (!OCTTransform(j->to_ll, 1, &cx, &cy, NULL) || !isfinite(cx) || !isfinite(cy))
            return sq__fail(j->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "%s.dem = '%s': the region's centre has no longitude/latitude (%s)",
                            j->key, d->path, sq__geo_reason());
        if (fabs(cy) > 90.0 || fabs(cx) > 540.0)
            return sq__fail(j->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "%s.dem = '%s': the region's centre maps to longitude %g, latitude %g, "
                            "not a place on Earth; check the file's georeferencing or name a "
                            "metric CRS with the crs option",
                            j->key, d->path, cx, cy);
        /* UTM zones count 6-degree bands eastwards from 180 W; wrap the longitude first */
        const double lon = cx - 360.0 * floor((cx + 180.0) / 360.0);
        int zone = (int)floor((lon + 180.0) / 6.0) + 1;
        if (zone < 1) zone = 1;
        if (zone > 60) zone = 60;
        const int epsg = (cy >= 0.0 ? 32600 : 32700) + zone;
        j->t_srs = OSRNewSpatialReference(NULL);
        if (!j->t_srs || OSRImportFromEPSG(j->t_srs, epsg) != OGRERR_NONE)
            return sq__fail(j->ctx, SQ_ERR_IO, MOD,
                            "%s: GDAL has no definition of EPSG:%d (%s); is proj-data installed?",
                            j->key, epsg, sq__geo_reason());
        OSRSetAxisMappingStrategy(j->t_srs, OAMS_TRADITIONAL_GIS_ORDER);
    }
    j->to_t = OCTNewCoordinateTransformation(j->s_srs, j->t_srs);
    if (!j->to_t)
        return sq__fail(j->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.dem = '%s': no transformation from its CRS to %s (%s)", j->key, d->path,
                        OSRGetName(j->t_srs) ? OSRGetName(j->t_srs) : "the target CRS",
                        sq__geo_reason());
    return SQ_OK;
}

/* The largest axis-aligned rectangle of the target CRS inside the region (x0 y0 x1 y1): the
 * region's edges are transformed point by point; the left edge's largest x, the right edge's
 * smallest x, and so on. */
static int inner_rect(dem_job *j, double out[4])
{
    double xs[EDGE_POINTS], ys[EDGE_POINTS];
    const double *q = j->roi;
    double lim[4] = {-INFINITY, -INFINITY, INFINITY, INFINITY};
    for (int e = 0; e < 4; e++) {
        for (int k = 0; k < EDGE_POINTS; k++) {
            const double t = (double)k / (EDGE_POINTS - 1);
            switch (e) {
            case 0: xs[k] = q[0]; ys[k] = q[1] + t * (q[3] - q[1]); break; /* west */
            case 1: xs[k] = q[0] + t * (q[2] - q[0]); ys[k] = q[1]; break; /* south */
            case 2: xs[k] = q[2]; ys[k] = q[1] + t * (q[3] - q[1]); break; /* east */
            default: xs[k] = q[0] + t * (q[2] - q[0]); ys[k] = q[3]; break; /* north */
            }
        }
        if (!OCTTransform(j->to_t, EDGE_POINTS, xs, ys, NULL)) return 0;
        for (int k = 0; k < EDGE_POINTS; k++) {
            if (!isfinite(xs[k]) || !isfinite(ys[k])) return 0;
            if (e == 0 && xs[k] > lim[0]) lim[0] = xs[k];
            if (e == 1 && ys[k] > lim[1]) lim[1] = ys[k];
            if (e == 2 && xs[k] < lim[2]) lim[2] = xs[k];
            if (e == 3 && ys[k] < lim[3]) lim[3] = ys[k];
        }
    }
    memcpy(out, lim, sizeof lim);
    return out[2] > out[0] && out[3] > out[1];
}

/* The DEM's finer pixel side in metres of the target CRS, measured at the region's centre. */
static double native_cell(dem_job *j)
{
    const double cx = 0.5 * (j->roi[0] + j->roi[2]), cy = 0.5 * (j->roi[1] + j->roi[3]);
    double xs[3] = {cx, cx + j->gt[1], cx + j->gt[2]};
    double ys[3] = {cy, cy + j->gt[4], cy + j->gt[5]};
    if (!OCTTransform(j->to_t, 3, xs, ys, NULL)) return 0.0;
    const double a = hypot(xs[1] - xs[0], ys[1] - ys[0]);
    const double b = hypot(xs[2] - xs[0], ys[2] - ys[0]);
    const double c = a < b ? a : b;
    return isfinite(c) ? c : 0.0;
}

static const char *resample_name(int r)
{
    switch (r) {
    case SQ_DEM_RESAMPLE_BILINEAR: return "bilinear";
    case SQ_DEM_RESAMPLE_CUBICSPLINE: return "cubicspline";
    case SQ_DEM_RESAMPLE_NEAREST: return "near";
    default: return "cubic";
    }
}

sq_result sq_dem_load(sq_context *ctx, const sq_dem_desc *desc, sq_dem *out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "sq_dem_load: out is NULL");
    memset(out, 0, sizeof *out);
    if (!desc) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "sq_dem_load: desc is NULL");
    dem_job job;
    memset(&job, 0, sizeof job);
    dem_job *j = &job;
    j->ctx = ctx;
    j->d = desc;
    j->key = desc->key && desc->key[0] ? desc->key : "terrain";
    const sq_dem_desc *d = desc;
    if (!d->path || !d->path[0])
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "%s.dem: no file given", j->key);
    const int roi_set = d->roi[0] != 0.0 || d->roi[1] != 0.0 || d->roi[2] != 0.0 || d->roi[3] != 0.0;
    for (int k = 0; k < 4; k++)
        if (!isfinite(d->roi[k]))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "%s.roi: not finite", j->key);
    if (roi_set && !(d->roi[2] > d->roi[0] && d->roi[3] > d->roi[1]))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.roi = [%.7g, %.7g, %.7g, %.7g]: must be [xmin, ymin, xmax, ymax] "
                        "with xmax > xmin and ymax > ymin",
                        j->key, d->roi[0], d->roi[1], d->roi[2], d->roi[3]);
    if (!(d->cell_m >= 0.0) || !isfinite(d->cell_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "%s.cell_m = %g m; must be > 0 (0 = native)",
                        j->key, d->cell_m);
    const int64_t max_samples = d->max_samples > 0 ? d->max_samples : (int64_t)8192 * 8192;

    sq_result r = sq__input_guard(ctx, MOD, "DEM", d->path); /* no FIFO; never written */
    if (r != SQ_OK) return r;
    sq__geo_quiet_begin();
    j->src = GDALOpenEx(d->path, GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, NULL,
                        NULL, NULL);
    if (!j->src)
        FAIL(SQ_ERR_IO, "%s.dem = '%s': GDAL cannot open it as a raster: %s", j->key, d->path,
             sq__geo_reason());
    if (GDALGetRasterCount(j->src) < 1)
        FAIL(SQ_ERR_INVALID_ARG, "%s.dem = '%s': the file has no raster band", j->key, d->path);
    const int W = GDALGetRasterXSize(j->src), Hh = GDALGetRasterYSize(j->src);
    if (W < 2 || Hh < 2)
        FAIL(SQ_ERR_INVALID_ARG, "%s.dem = '%s': %dx%d pixels; at least 2x2 needed", j->key, d->path,
             W, Hh);
    if (GDALGetGeoTransform(j->src, j->gt) != CE_None)
        FAIL(SQ_ERR_INVALID_ARG,
             "%s.dem = '%s': the file has no geotransform (pixel size and position); use a "
             "georeferenced raster (GeoTIFF, ESRI ASCII grid, ...)", j->key, d->path);
    r = source_crs(j);
    if (r != SQ_OK) goto done;
    {
        /* the DEM's extent from its four corners (a rotated geotransform included) */
        double bx[4] = {0, (double)W, 0, (double)W}, by[4] = {0, 0, (double)Hh, (double)Hh};
        j->bounds[0] = j->bounds[1] = INFINITY;
        j->bounds[2] = j->bounds[3] = -INFINITY;
        for (int k = 0; k < 4; k++) {
            const double X = j->gt[0] + bx[k] * j->gt[1] + by[k] * j->gt[2];
            const double Y = j->gt[3] + bx[k] * j->gt[4] + by[k] * j->gt[5];
            if (X < j->bounds[0]) j->bounds[0] = X;
            if (Y < j->bounds[1]) j->bounds[1] = Y;
            if (X > j->bounds[2]) j->bounds[2] = X;
            if (Y > j->bounds[3]) j->bounds[3] = Y;
        }
    }
    if (roi_set) {
        const double *b = j->bounds, *q = d->roi;
        const double tol = 1e-9 * (fabs(b[2]) + fabs(b[3]) + 1.0);
        const int overlap = q[0] < b[2] && q[2] > b[0] && q[1] < b[3] && q[3] > b[1];
        const int inside = q[0] >= b[0] - tol && q[2] <= b[2] + tol && q[1] >= b[1] - tol &&
                           q[3] <= b[3] + tol;
        if (!inside)
            FAIL(SQ_ERR_INVALID_ARG,
                 "%s.roi = [%.7g, %.7g, %.7g, %.7g] %s the DEM '%s', which covers "
                 "[%.10g, %.10g, %.10g, %.10g] in its CRS (%s); the region of interest must lie "
                 "inside it",
                 j->key, q[0], q[1], q[2], q[3], overlap ? "reaches outside" : "lies outside",
                 d->path, b[0], b[1], b[2], b[3],
                 OSRGetName(j->s_srs) ? OSRGetName(j->s_srs) : "?");
        memcpy(j->roi, q, sizeof j->roi);
    } else {
        memcpy(j->roi, j->bounds, sizeof j->roi);
    }
    r = target_crs(j);
    if (r != SQ_OK) goto done;
    out->reprojected = !OSRIsSame(j->s_srs, j->t_srs);

    double rect[4];
    if (!inner_rect(j, rect))
        FAIL(SQ_ERR_INVALID_ARG, "%s.dem = '%s': the region of interest does not transform to %s (%s)",
             j->key, d->path, OSRGetName(j->t_srs) ? OSRGetName(j->t_srs) : "the target CRS",
             sq__geo_reason());
    double cell = d->cell_m > 0.0 ? d->cell_m : native_cell(j);
    if (!(cell > 0.0))
        FAIL(SQ_ERR_INVALID_ARG, "%s.dem = '%s': cannot measure its pixel size in metres; give the "
             "cell size", j->key, d->path);
    /* the samples: inside the rectangle, on the source's pixel-centre lattice when the CRS is
     * kept (no resampling at the native cell), else on multiples of the cell size */
    double ax = 0.0, ay = 0.0;
    if (!out->reprojected && j->gt[2] == 0.0 && j->gt[4] == 0.0) {
        ax = j->gt[0] + 0.5 * j->gt[1];
        ay = j->gt[3] + 0.5 * j->gt[5];
        rect[0] += 0.5 * fabs(j->gt[1]);
        rect[2] -= 0.5 * fabs(j->gt[1]);
        rect[1] += 0.5 * fabs(j->gt[5]);
        rect[3] -= 0.5 * fabs(j->gt[5]);
    }
    const double gx0 = ax + ceil((rect[0] - ax) / cell - 1e-9) * cell;
    const double gx1 = ax + floor((rect[2] - ax) / cell + 1e-9) * cell;
    const double gy0 = ay + ceil((rect[1] - ay) / cell - 1e-9) * cell;
    const double gy1 = ay + floor((rect[3] - ay) / cell + 1e-9) * cell;
    const double fnx = floor((gx1 - gx0) / cell + 0.5) + 1.0, fny = floor((gy1 - gy0) / cell + 0.5) + 1.0;
    if (!(fnx >= 2.0 && fny >= 2.0))
        FAIL(SQ_ERR_INVALID_ARG,
             "%s: the region of interest is %.1f x %.1f m in %s, less than 2 x 2 cells of %g m",
             j->key, rect[2] - rect[0], rect[3] - rect[1],
             OSRGetName(j->t_srs) ? OSRGetName(j->t_srs) : "the target CRS", cell);
    if (fnx * fny > (double)max_samples)
        FAIL(SQ_ERR_TOO_LARGE,
             "%s: %.0f x %.0f samples of %g m over the region of interest; at most %lld; give a "
             "larger cell or a smaller region", j->key, fnx, fny, cell, (long long)max_samples);
    const int nx = (int)fnx, ny = (int)fny;
    r = sq_context_check_memory(ctx, (uint64_t)nx * (uint64_t)ny * 9u, "DEM grid");
    if (r != SQ_OK) goto done;

    /* warp into an in-memory dataset: cells centred on the samples */
    {
        GDALDriverH mem = GDALGetDriverByName("MEM");
        if (!mem) FAIL(SQ_ERR_INTERNAL, "%s: GDAL has no MEM driver", j->key);
        j->dst = GDALCreate(mem, "", nx, ny, 1, GDT_Float32, NULL);
        if (!j->dst) FAIL(SQ_ERR_OUT_OF_MEMORY, "%s: %s", j->key, sq__geo_reason());
        double dgt[6] = {gx0 - 0.5 * cell, cell, 0.0, gy0 + (ny - 0.5) * cell, 0.0, -cell};
        GDALSetGeoTransform(j->dst, dgt);
        GDALSetSpatialRef(j->dst, j->t_srs);
        GDALRasterBandH band = GDALGetRasterBand(j->dst, 1);
        GDALSetRasterNoDataValue(band, DEM_NODATA);
        GDALFillRaster(band, DEM_NODATA, 0.0);
        char **argv = NULL;
        argv = CSLAddString(argv, "-r");
        argv = CSLAddString(argv, resample_name(d->resampling));
        argv = CSLAddString(argv, "-dstnodata");
        argv = CSLAddString(argv, "-99999");
        argv = CSLAddString(argv, "-et");
        argv = CSLAddString(argv, "0");
        if (sq__geo_srs_empty(GDALGetSpatialRef(j->src))) {
            char *wkt = NULL;
            OSRExportToWkt(j->s_srs, &wkt);
            argv = CSLAddString(argv, "-s_srs");
            argv = CSLAddString(argv, wkt ? wkt : "");
            CPLFree(wkt);
        }
        GDALWarpAppOptions *wo = GDALWarpAppOptionsNew(argv, NULL);
        CSLDestroy(argv);
        if (!wo) FAIL(SQ_ERR_INTERNAL, "%s: warp options refused: %s", j->key, sq__geo_reason());
        int usage = 0;
        GDALDatasetH got = GDALWarp(NULL, j->dst, 1, &j->src, wo, &usage);
        GDALWarpAppOptionsFree(wo);
        if (!got)
            FAIL(SQ_ERR_IO, "%s.dem = '%s': GDAL could not reproject it: %s", j->key, d->path,
                 sq__geo_reason());
    }
    {
        GDALRasterBandH band = GDALGetRasterBand(j->dst, 1);
        const size_t n = (size_t)nx * (size_t)ny;
        out->heights_m = (float *)sq_alloc(ctx, n * sizeof(float));
        float *north = (float *)sq_alloc(ctx, (size_t)nx * sizeof(float));
        if (!out->heights_m || !north) {
            sq_free(ctx, north);
            FAIL(SQ_ERR_OUT_OF_MEMORY, "%s: out of memory for %dx%d samples", j->key, nx, ny);
        }
        /* no-data: count, then fill or refuse */
        size_t voids = 0;
        for (int row = 0; row < ny && r == SQ_OK; row++) {
            if (GDALRasterIO(band, GF_Read, 0, row, nx, 1, north, nx, 1, GDT_Float32, 0, 0) !=
                CE_None)
                r = sq__fail(ctx, SQ_ERR_IO, MOD, "%s.dem = '%s': reading row %d: %s", j->key,
                             d->path, row, sq__geo_reason());
            for (int i = 0; i < nx; i++)
                if (!isfinite(north[i]) || north[i] <= (float)DEM_NODATA + 1.0f) voids++;
        }
        if (r != SQ_OK) {
            sq_free(ctx, north);
            goto done;
        }
        if (voids == n) {
            sq_free(ctx, north);
            FAIL(SQ_ERR_INVALID_ARG, "%s.dem = '%s': no valid elevation in the region of interest "
                 "(all %zu samples are no-data)", j->key, d->path, n);
        }
        if (voids > 0 && d->nodata == SQ_DEM_NODATA_FAIL) {
            sq_free(ctx, north);
            FAIL(SQ_ERR_INVALID_ARG,
                 "%s.dem = '%s': %zu of %zu samples (%.2f %%) in the region of interest have no "
                 "data and %s.nodata = fail; choose a region without voids or fill them "
                 "(nodata: fill)", j->key, d->path, voids, n, 100.0 * (double)voids / (double)n,
                 j->key);
        }
        if (voids > 0) {
            out->void_mask = (uint8_t *)sq_alloc_zero(ctx, n);
            if (!out->void_mask) {
                sq_free(ctx, north);
                FAIL(SQ_ERR_OUT_OF_MEMORY, "%s: out of memory", j->key);
            }
            for (int row = 0; row < ny; row++) {
                if (GDALRasterIO(band, GF_Read, 0, row, nx, 1, north, nx, 1, GDT_Float32, 0,
                                 0) != CE_None)
                    continue; /* read again below, where a failure is reported */
                for (int i = 0; i < nx; i++)
                    if (!isfinite(north[i]) || north[i] <= (float)DEM_NODATA + 1.0f)
                        out->void_mask[(size_t)(ny - 1 - row) * (size_t)nx + (size_t)i] = 1;
            }
            char **fo = CSLAddString(NULL, "INTERPOLATION=INV_DIST");
            const double reach = (double)(nx > ny ? nx : ny);
            CPLErr fe = GDALFillNodata(band, NULL, reach, 0, 0, fo, NULL, NULL);
            CSLDestroy(fo);
            if (fe != CE_None) {
                sq_free(ctx, north);
                FAIL(SQ_ERR_IO, "%s.dem = '%s': filling %zu no-data samples failed: %s", j->key,
                     d->path, voids, sq__geo_reason());
            }
            out->void_count = voids;
        }
        double hmin = INFINITY, hmax = -INFINITY;
        for (int row = 0; row < ny && r == SQ_OK; row++) {
            if (GDALRasterIO(band, GF_Read, 0, row, nx, 1, north, nx, 1, GDT_Float32, 0, 0) !=
                CE_None) {
                r = sq__fail(ctx, SQ_ERR_IO, MOD, "%s.dem = '%s': reading row %d: %s", j->key,
                             d->path, row, sq__geo_reason());
                break;
            }
            float *dst = out->heights_m + (size_t)(ny - 1 - row) * (size_t)nx;
            for (int i = 0; i < nx; i++) {
                const float h = north[i];
                if (!isfinite(h) || h <= (float)DEM_NODATA + 1.0f || fabsf(h) > 1.0e5f) {
                    r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                                 "%s.dem = '%s': elevation %g m at sample (%d, %d) of the region "
                                 "(row 0 south) is not a height on Earth (|h| <= 100 km)",
                                 j->key, d->path, (double)h, i, ny - 1 - row);
                    break;
                }
                dst[i] = h;
                if ((double)h < hmin) hmin = (double)h;
                if ((double)h > hmax) hmax = (double)h;
            }
        }
        sq_free(ctx, north);
        if (r != SQ_OK) goto done;
        out->height_min_m = hmin;
        out->height_max_m = hmax;
    }
    out->nx = nx;
    out->ny = ny;
    out->dx = out->dy = cell;
    out->x0 = gx0;
    out->y0 = gy0;
    {
        char *wkt = NULL;
        if (OSRExportToWkt(j->t_srs, &wkt) != OGRERR_NONE || !wkt)
            FAIL(SQ_ERR_INTERNAL, "%s: cannot write the target CRS as WKT: %s", j->key,
                 sq__geo_reason());
        const size_t len = strlen(wkt) + 1;
        out->crs_wkt = (char *)sq_alloc(ctx, len);
        if (out->crs_wkt) memcpy(out->crs_wkt, wkt, len);
        CPLFree(wkt);
        if (!out->crs_wkt) FAIL(SQ_ERR_OUT_OF_MEMORY, "%s: out of memory", j->key);
        const char *nm = OSRGetName(j->t_srs);
        snprintf(out->crs_name, sizeof out->crs_name, "%s", nm ? nm : "unnamed CRS");
        OGRSpatialReferenceH id = OSRClone(j->t_srs);
        if (id) {
            OSRAutoIdentifyEPSG(id);
            const char *auth = OSRGetAuthorityName(id, NULL);
            const char *code = OSRGetAuthorityCode(id, NULL);
            if (auth && code && strcmp(auth, "EPSG") == 0) out->epsg = atoi(code);
            OSRDestroySpatialReference(id);
        }
    }
    sq_log(ctx, SQ_LOG_INFO, MOD,
           "%s: '%s' -> %dx%d samples of %g m in %s, elevations %.0f-%.0f m%s", j->key, d->path,
           nx, ny, cell, out->crs_name, out->height_min_m, out->height_max_m,
           out->void_count ? " (no-data filled)" : "");
done:
    job_close(j);
    if (r != SQ_OK) sq_dem_release(ctx, out);
    return r;
}

void sq_dem_release(sq_context *ctx, sq_dem *dem)
{
    if (!dem) return;
    sq_free(ctx, dem->heights_m);
    sq_free(ctx, dem->void_mask);
    sq_free(ctx, dem->crs_wkt);
    memset(dem, 0, sizeof *dem);
}
#endif
