/* geo_raster.c — georeferenced rasters out: a Float32 GeoTIFF (DEFLATE, floating-point
 * predictor) with CRS, geotransform, no-data value, band description and unit, or an ESRI ASCII
 * grid (.asc) with its .prj (the CRS as ESRI WKT). Rows are flipped from the world's south-first
 * order to the north-up order both formats use. Every file goes through a temporary name and is
 * renamed when complete (io_internal.h); a GeoTIFF is built in GDAL's memory filesystem and
 * written by output.c's loop, so a full disk is reported like any other output's. */
#include "sq_config.h"

#if SQ_HAVE_GDAL
#include <cpl_conv.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <errno.h>
#include <stdatomic.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "geo_internal.h"
#include "io/io_internal.h"

#define MOD "raster"

/* The GeoTIFF is built in /vsimem/ and its bytes written to d->path (temporary + rename). */
static sq_result write_geotiff(sq_context *ctx, const sq_raster_desc *d)
{
    static atomic_uint serial;
    char mem[96];
    snprintf(mem, sizeof mem, "/vsimem/squall-raster-%ld-%u.tif", (long)getpid(),
             atomic_fetch_add(&serial, 1u));
    GDALDriverH drv = GDALGetDriverByName("GTiff");
    if (!drv) return sq__fail(ctx, SQ_ERR_UNSUPPORTED, MOD, "GDAL has no GTiff driver");
    char **opt = NULL;
    opt = CSLSetNameValue(opt, "COMPRESS", "DEFLATE");
    opt = CSLSetNameValue(opt, "PREDICTOR", "3");
    opt = CSLSetNameValue(opt, "TILED", d->nx >= 512 && d->ny >= 512 ? "YES" : "NO");
    GDALDatasetH ds = GDALCreate(drv, mem, d->nx, d->ny, 1, GDT_Float32, opt);
    CSLDestroy(opt);
    if (!ds)
        return sq__fail(ctx, SQ_ERR_IO, MOD, "cannot create '%s': %s", d->path, sq__geo_reason());
    sq_result r = SQ_OK;
    double gt[6] = {d->x0, d->cell_m, 0.0, d->y0 + d->ny * d->cell_m, 0.0, -d->cell_m};
    GDALSetGeoTransform(ds, gt);
    if (d->crs_wkt && d->crs_wkt[0] && GDALSetProjection(ds, d->crs_wkt) != CE_None)
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "'%s': the CRS is not valid WKT: %s", d->path,
                     sq__geo_reason());
    GDALRasterBandH b = GDALGetRasterBand(ds, 1);
    GDALSetRasterNoDataValue(b, d->nodata);
    if (d->description) GDALSetDescription(b, d->description);
    if (d->units) GDALSetRasterUnitType(b, d->units);
    float *row = (float *)sq_alloc(ctx, (size_t)d->nx * sizeof(float));
    if (!row && r == SQ_OK) r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "out of memory");
    for (int y = 0; y < d->ny && r == SQ_OK; y++) {
        const float *src = d->data + (size_t)(d->ny - 1 - y) * (size_t)d->nx;
        for (int x = 0; x < d->nx; x++) row[x] = isfinite(src[x]) ? src[x] : (float)d->nodata;
        if (GDALRasterIO(b, GF_Write, 0, y, d->nx, 1, row, d->nx, 1, GDT_Float32, 0, 0) !=
            CE_None)
            r = sq__fail(ctx, SQ_ERR_IO, MOD, "writing '%s': %s", d->path, sq__geo_reason());
    }
    sq_free(ctx, row);
    CPLErrorReset();
    GDALClose(ds); /* flushes; GDAL 3.6 reports a failure only through the error state */
    if (CPLGetLastErrorType() >= CE_Failure && r == SQ_OK)
        r = sq__fail(ctx, SQ_ERR_IO, MOD, "writing '%s': %s", d->path, sq__geo_reason());
    vsi_l_offset size = 0;
    GByte *bytes = r == SQ_OK ? VSIGetMemFileBuffer(mem, &size, FALSE) : NULL;
    if (r == SQ_OK && !bytes)
        r = sq__fail(ctx, SQ_ERR_IO, MOD, "writing '%s': GDAL's memory file is missing", d->path);
    if (r == SQ_OK)
        r = sq__io_relog(ctx, sq_output_write_file(d->path, bytes, (size_t)size, d->overwrite));
    VSIUnlink(mem);
    return r;
}

/* ESRI ASCII grid: header, then rows north first; values with 7 significant digits. */
static sq_result write_ascii(sq_context *ctx, const sq_raster_desc *d, int fd)
{
    FILE *f = fdopen(fd, "w");
    if (!f) {
        const int e = errno;
        close(fd);
        return sq__write_error(ctx, d->path, e, NULL);
    }
    fprintf(f, "ncols %d\nnrows %d\nxllcorner %.6f\nyllcorner %.6f\ncellsize %.9g\n"
               "NODATA_value %.9g\n", d->nx, d->ny, d->x0, d->y0, d->cell_m, d->nodata);
    for (int y = d->ny - 1; y >= 0; y--) {
        const float *src = d->data + (size_t)y * (size_t)d->nx;
        for (int x = 0; x < d->nx; x++)
            fprintf(f, x ? " %.7g" : "%.7g", isfinite(src[x]) ? (double)src[x] : d->nodata);
        fputc('\n', f);
    }
    int e = ferror(f) ? errno : 0;
    if (fclose(f) != 0 && !e) e = errno;
    return e ? sq__write_error(ctx, d->path, e, NULL) : SQ_OK;
}

/* The name of the .prj beside an ASCII grid: the grid's name with .prj for its extension. */
static void prj_path(const char *path, char *prj, size_t size)
{
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    const int stem = dot && (!slash || dot > slash) ? (int)(dot - path) : (int)strlen(path);
    snprintf(prj, size, "%.*s.prj", stem, path);
}

/* The .prj beside an ASCII grid: the CRS morphed to ESRI WKT. */
static sq_result write_prj(sq_context *ctx, const sq_raster_desc *d)
{
    if (!d->crs_wkt || !d->crs_wkt[0]) return SQ_OK;
    char prj[SQ__TEMP_NAME_MAX];
    prj_path(d->path, prj, sizeof prj);
    OGRSpatialReferenceH s = sq__geo_srs_from_user(d->crs_wkt);
    char *wkt = NULL;
    if (!s || OSRMorphToESRI(s) != OGRERR_NONE || OSRExportToWkt(s, &wkt) != OGRERR_NONE) {
        if (s) OSRDestroySpatialReference(s);
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "'%s': the CRS cannot be written as ESRI "
                        "WKT: %s", prj, sq__geo_reason());
    }
    sq_result r = sq_output_write_file(prj, wkt, strlen(wkt), d->overwrite);
    if (r != SQ_OK) r = sq__io_relog(ctx, r);
    CPLFree(wkt);
    OSRDestroySpatialReference(s);
    return r;
}

sq_result sq_raster_write(sq_context *ctx, const sq_raster_desc *d)
{
    if (!d || !d->path || !d->data)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "sq_raster_write: desc, path and data are "
                        "required");
    if (d->nx < 1 || d->ny < 1 || !(d->cell_m > 0.0) || !isfinite(d->cell_m) ||
        !isfinite(d->x0) || !isfinite(d->y0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "'%s': raster of %dx%d cells of %g m at (%g, %g); needs >= 1x1 cells, a "
                        "cell > 0 and a finite corner", d->path, d->nx, d->ny, d->cell_m, d->x0,
                        d->y0);
    char tmp[SQ__TEMP_NAME_MAX];
    int fd = -1;
    sq_result r = sq_output_check_inputs(ctx, d->path, false);
    if (r == SQ_OK && d->format == SQ_RASTER_ASCII && d->crs_wkt && d->crs_wkt[0]) {
        char prj[SQ__TEMP_NAME_MAX];
        prj_path(d->path, prj, sizeof prj);
        r = sq_output_check_inputs(ctx, prj, false); /* before the grid is written */
    }
    if (r != SQ_OK) return r;
    if (d->format != SQ_RASTER_ASCII) {
        r = sq__io_relog(ctx, sq_output_check(d->path, d->overwrite));
        if (r != SQ_OK) return r;
        sq__geo_quiet_begin();
        r = write_geotiff(ctx, d);
        sq__geo_quiet_end();
        return r;
    }
    r = sq__output_open_temp(d->path, d->overwrite, tmp, sizeof tmp, &fd);
    if (r != SQ_OK) return sq__io_relog(ctx, r);
    r = write_ascii(ctx, d, fd);
    if (r == SQ_OK) r = write_prj(ctx, d);
    if (r != SQ_OK) {
        sq__output_discard(tmp);
        return r;
    }
    r = sq__output_finish(tmp, d->path, d->overwrite);
    return sq__io_relog(ctx, r);
}
#endif
