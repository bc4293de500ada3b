/* geo_common.c — what the GDAL/OGR readers and writers share: GDAL's error text captured on this
 * thread instead of printed to stderr, spatial references from user text with the
 * longitude/latitude (x, y) axis order, and the stubs of include/squall/geo.h for builds
 * without GDAL. */
#include "sq_config.h"

#if SQ_HAVE_GDAL
#include <cpl_conv.h>
#include <string.h>

#include "geo_internal.h"

void sq__geo_quiet_begin(void)
{
    GDALAllRegister(); /* idempotent and internally locked */
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
}

void sq__geo_quiet_end(void) { CPLPopErrorHandler(); }

const char *sq__geo_reason(void)
{
    const char *m = CPLGetLastErrorMsg();
    return m && m[0] ? m : "no reason given";
}

int sq__geo_srs_empty(OGRSpatialReferenceH srs)
{
    if (!srs) return 1;
    char *wkt = NULL;
    const int empty = OSRExportToWkt(srs, &wkt) != OGRERR_NONE || !wkt || !wkt[0];
    CPLFree(wkt);
    return empty;
}

OGRSpatialReferenceH sq__geo_srs_from_user(const char *text)
{
    OGRSpatialReferenceH s = OSRNewSpatialReference(NULL);
    if (!s) return NULL;
    if (OSRSetFromUserInput(s, text) != OGRERR_NONE || sq__geo_srs_empty(s)) {
        OSRDestroySpatialReference(s);
        return NULL;
    }
    OSRSetAxisMappingStrategy(s, OAMS_TRADITIONAL_GIS_ORDER);
    return s;
}

OGRSpatialReferenceH sq__geo_srs_clone(OGRSpatialReferenceH srs)
{
    if (!srs) return NULL;
    OGRSpatialReferenceH s = OSRClone(srs);
    if (s) OSRSetAxisMappingStrategy(s, OAMS_TRADITIONAL_GIS_ORDER);
    return s;
}

int sq__geo_srs_is_metric(OGRSpatialReferenceH srs)
{
    if (!srs || !OSRIsProjected(srs)) return 0;
    const double u = OSRGetLinearUnits(srs, NULL);
    return u > 0.999999 && u < 1.000001;
}

#else /* no GDAL: every entry point says so */

#include <string.h>

#include "core/core_internal.h"
#include "squall/geo.h"

static sq_result no_gdal(sq_context *ctx, const char *what, const char *key)
{
    return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "geo",
                    "%s: %s needs GDAL, which this build does not have (feature 'gdal'; install "
                    "libgdal-dev and rebuild)",
                    key ? key : what, what);
}

sq_result sq_dem_load(sq_context *ctx, const sq_dem_desc *desc, sq_dem *out)
{
    if (out) memset(out, 0, sizeof *out);
    return no_gdal(ctx, "reading a DEM", desc ? desc->key : NULL);
}
void sq_dem_release(sq_context *ctx, sq_dem *dem)
{
    (void)ctx;
    if (dem) memset(dem, 0, sizeof *dem);
}
sq_result sq_area_load(sq_context *ctx, const sq_area_desc *desc, sq_area *out)
{
    if (out) memset(out, 0, sizeof *out);
    return no_gdal(ctx, "reading polygon areas", desc ? desc->key : NULL);
}
void sq_area_release(sq_context *ctx, sq_area *area)
{
    (void)ctx;
    if (area) memset(area, 0, sizeof *area);
}
sq_result sq_raster_write(sq_context *ctx, const sq_raster_desc *desc)
{
    return no_gdal(ctx, "writing georeferenced rasters", desc ? desc->path : NULL);
}
#endif
