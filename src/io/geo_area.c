/* geo_area.c — polygon areas through OGR: the polygons of a vector file (GeoJSON, Shapefile,
 * GeoPackage, ... — points and lines are skipped) or of a raster mask (GDALPolygonize of the
 * pixels that are neither zero nor no-data), transformed to the world's CRS and shifted by the
 * world's offset, each feature with one numeric attribute (e.g. a release thickness). */
#include "sq_config.h"

#if SQ_HAVE_GDAL
#include <cpl_conv.h>
#include <cpl_string.h>
#include <gdal_alg.h>
#include <math.h>
#include <ogr_api.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geo_internal.h"
#include "io/io_internal.h"

#define MOD "area"

/* Growable arrays of the result. */
typedef struct area_build {
    sq_context *ctx;
    double *xy;
    size_t np, cap_p;
    int *ring_start, *ring_feature;
    size_t nr, cap_r;
    double *fval, *farea;
    size_t nf, cap_f;
    int oom;
} area_build;

static int grow(sq_context *ctx, void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap) return 1;
    size_t c = *cap ? *cap : 64;
    while (c < need) c *= 2;
    void *q = sq_alloc(ctx, c * elem);
    if (!q) return 0;
    if (*p) memcpy(q, *p, *cap * elem);
    sq_free(ctx, *p);
    *p = q;
    *cap = c;
    return 1;
}

/* Appends one ring (without its closing point); rings of fewer than 3 points are dropped. */
static void add_ring(area_build *b, OGRGeometryH ring, int feature)
{
    int n = OGR_G_GetPointCount(ring);
    if (n >= 2 && OGR_G_GetX(ring, 0) == OGR_G_GetX(ring, n - 1) &&
        OGR_G_GetY(ring, 0) == OGR_G_GetY(ring, n - 1))
        n--;
    if (n < 3) return;
    size_t cr = b->cap_r;
    if (!grow(b->ctx, (void **)&b->ring_start, &cr, b->nr + 2, sizeof(int)) ||
        !grow(b->ctx, (void **)&b->ring_feature, &b->cap_r, b->nr + 2, sizeof(int)) ||
        !grow(b->ctx, (void **)&b->xy, &b->cap_p, 2 * (b->np + (size_t)n), sizeof(double))) {
        b->oom = 1;
        return;
    }
    b->ring_start[b->nr] = (int)b->np;
    b->ring_feature[b->nr] = feature;
    for (int k = 0; k < n; k++) {
        b->xy[2 * b->np] = OGR_G_GetX(ring, k);
        b->xy[2 * b->np + 1] = OGR_G_GetY(ring, k);
        b->np++;
    }
    b->nr++;
    b->ring_start[b->nr] = (int)b->np;
}

/* The rings of every polygon in g (polygons, multipolygons, collections); returns how many
 * polygons it held. */
static int add_polygons(area_build *b, OGRGeometryH g, int feature)
{
    const OGRwkbGeometryType t = wkbFlatten(OGR_G_GetGeometryType(g));
    if (t == wkbPolygon || t == wkbTriangle) {
        for (int k = 0; k < OGR_G_GetGeometryCount(g); k++)
            add_ring(b, OGR_G_GetGeometryRef(g, k), feature);
        return 1;
    }
    if (t == wkbMultiPolygon || t == wkbGeometryCollection || t == wkbMultiSurface ||
        t == wkbPolyhedralSurface || t == wkbTIN) {
        int n = 0;
        for (int k = 0; k < OGR_G_GetGeometryCount(g); k++)
            n += add_polygons(b, OGR_G_GetGeometryRef(g, k), feature);
        return n;
    }
    if (t == wkbCurvePolygon) {
        OGRGeometryH lin = OGR_G_GetLinearGeometry(g, 0.0, NULL);
        int n = lin ? add_polygons(b, lin, feature) : 0;
        if (lin) OGR_G_DestroyGeometry(lin);
        return n;
    }
    return 0;
}

/* A raster mask as an in-memory polygon layer (pixels neither zero nor no-data), in the
 * raster's CRS. */
static sq_result polygonize(sq_context *ctx, const char *key, const char *path, GDALDatasetH src,
                            GDALDatasetH *vec_out, OGRLayerH *layer_out)
{
    *vec_out = NULL;
    *layer_out = NULL;
    const int W = GDALGetRasterXSize(src), H = GDALGetRasterYSize(src);
    double gt[6];
    if (GDALGetGeoTransform(src, gt) != CE_None)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.file = '%s': the raster mask has no geotransform (georeferencing)", key,
                        path);
    GDALRasterBandH sb = GDALGetRasterBand(src, 1);
    int has_nd = 0;
    const double nd = GDALGetRasterNoDataValue(sb, &has_nd);
    GDALDriverH mem = GDALGetDriverByName("MEM");
    GDALDatasetH m = mem ? GDALCreate(mem, "", W, H, 1, GDT_Byte, NULL) : NULL;
    if (!m) return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "%s: %s", key, sq__geo_reason());
    GDALSetGeoTransform(m, gt);
    OGRSpatialReferenceH srs = GDALGetSpatialRef(src);
    if (srs) GDALSetSpatialRef(m, srs);
    GDALRasterBandH mb = GDALGetRasterBand(m, 1);
    double *row = (double *)sq_alloc(ctx, (size_t)W * sizeof(double));
    unsigned char *bin = (unsigned char *)sq_alloc(ctx, (size_t)W);
    sq_result r = row && bin ? SQ_OK : SQ_ERR_OUT_OF_MEMORY;
    size_t inside = 0;
    for (int y = 0; y < H && r == SQ_OK; y++) {
        if (GDALRasterIO(sb, GF_Read, 0, y, W, 1, row, W, 1, GDT_Float64, 0, 0) != CE_None) {
            r = sq__fail(ctx, SQ_ERR_IO, MOD, "%s.file = '%s': reading row %d: %s", key, path, y,
                         sq__geo_reason());
            break;
        }
        for (int x = 0; x < W; x++) {
            const int in = isfinite(row[x]) && row[x] != 0.0 && !(has_nd && row[x] == nd);
            bin[x] = (unsigned char)in;
            inside += (size_t)in;
        }
        if (GDALRasterIO(mb, GF_Write, 0, y, W, 1, bin, W, 1, GDT_Byte, 0, 0) != CE_None)
            r = sq__fail(ctx, SQ_ERR_IO, MOD, "%s: writing the mask: %s", key, sq__geo_reason());
    }
    sq_free(ctx, row);
    sq_free(ctx, bin);
    if (r == SQ_ERR_OUT_OF_MEMORY) r = sq__fail(ctx, r, MOD, "%s: out of memory", key);
    if (r == SQ_OK && inside == 0)
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                     "%s.file = '%s': the raster mask has no pixel inside (every pixel is 0 or "
                     "no-data); the area would be empty (zero area)", key, path);
    if (r != SQ_OK) {
        GDALClose(m);
        return r;
    }
    GDALDriverH vd = GDALGetDriverByName("Memory");
    GDALDatasetH v = vd ? GDALCreate(vd, "", 0, 0, 0, GDT_Unknown, NULL) : NULL;
    OGRLayerH lyr = v ? GDALDatasetCreateLayer(v, "mask", srs, wkbPolygon, NULL) : NULL;
    if (lyr) {
        OGRFieldDefnH fd = OGR_Fld_Create("value", OFTInteger);
        OGR_L_CreateField(lyr, fd, 1);
        OGR_Fld_Destroy(fd);
    }
    if (!lyr || GDALPolygonize(mb, mb, lyr, 0, NULL, NULL, NULL) != CE_None) {
        r = sq__fail(ctx, SQ_ERR_IO, MOD, "%s.file = '%s': polygonising the mask failed: %s", key,
                     path, sq__geo_reason());
        if (v) GDALClose(v);
        GDALClose(m);
        return r;
    }
    GDALClose(m);
    *vec_out = v;
    *layer_out = lyr;
    return SQ_OK;
}

/* The area a polygon that is not valid encloses once repaired (its lobes): > 0 for a ring
 * that crosses itself, 0 for a degenerate one (collinear points), which the caller refuses as
 * "zero area". */
static double crossing_lobes_area(OGRGeometryH g)
{
    OGRGeometryH fixed = OGR_G_MakeValid(g);
    if (!fixed) return 0.0;
    const double a = OGR_G_Area(fixed);
    OGR_G_DestroyGeometry(fixed);
    return a;
}

/* A feature's attribute as a number: a text that is not one, NaN or an infinity is refused
 * (a missing or null attribute leaves NAN: the caller's default applies). What range the
 * value must have is the caller's rule (e.g. the avalanche's release thickness > 0). */
static sq_result attribute_value(sq_context *ctx, const char *key, const sq_area_desc *desc,
                                 OGRFeatureH f, int fi, int fidx, double *v)
{
    const OGRFieldType t = OGR_Fld_GetType(OGR_F_GetFieldDefnRef(f, fi));
    if (t == OFTInteger || t == OFTInteger64 || t == OFTReal) {
        *v = OGR_F_GetFieldAsDouble(f, fi);
    } else {
        const char *text = OGR_F_GetFieldAsString(f, fi);
        char *end = NULL;
        *v = strtod(text, &end);
        while (end && (*end == ' ' || *end == '\t')) end++;
        if (!text[0] || end == text || (end && *end))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "%s.file = '%s': feature %d's %s = '%s' is not a number", key,
                            desc->path, fidx, desc->attribute, text);
    }
    if (!isfinite(*v))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.file = '%s': feature %d's %s = %g is not a finite number "
                        "(leave it out or null to use the default)", key, desc->path, fidx,
                        desc->attribute, *v);
    return SQ_OK;
}

sq_result sq_area_load(sq_context *ctx, const sq_area_desc *desc, sq_area *out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "sq_area_load: out is NULL");
    memset(out, 0, sizeof *out);
    if (!desc) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "sq_area_load: desc is NULL");
    const char *key = desc->key && desc->key[0] ? desc->key : "area";
    if (!desc->path || !desc->path[0])
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "%s.file: no file given", key);
    if (!desc->target_crs_wkt || !desc->target_crs_wkt[0])
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.file = '%s': polygon areas need a georeferenced world (a DEM terrain); "
                        "this world has no CRS", key, desc->path);
    sq_result r = sq__input_guard(ctx, MOD, "area file", desc->path); /* no FIFO; never written */
    if (r != SQ_OK) return r;
    area_build b;
    memset(&b, 0, sizeof b);
    b.ctx = ctx;
    GDALDatasetH ds = NULL, poly = NULL;
    OGRSpatialReferenceH s_srs = NULL, t_srs = NULL;
    OGRCoordinateTransformationH ct = NULL;
    OGRLayerH lyr = NULL;
    sq__geo_quiet_begin();
    ds = GDALOpenEx(desc->path, GDAL_OF_VECTOR | GDAL_OF_RASTER | GDAL_OF_READONLY |
                                    GDAL_OF_VERBOSE_ERROR, NULL, NULL, NULL);
    if (!ds) {
        r = sq__fail(ctx, SQ_ERR_IO, MOD, "%s.file = '%s': GDAL/OGR cannot open it: %s", key,
                     desc->path, sq__geo_reason());
        goto done;
    }
    if (GDALDatasetGetLayerCount(ds) > 0) {
        lyr = desc->layer && desc->layer[0] ? GDALDatasetGetLayerByName(ds, desc->layer)
                                            : GDALDatasetGetLayer(ds, 0);
        if (!lyr) {
            r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "%s.file = '%s': no layer '%s' in the file",
                         key, desc->path, desc->layer);
            goto done;
        }
    } else if (GDALGetRasterCount(ds) > 0) {
        r = polygonize(ctx, key, desc->path, ds, &poly, &lyr);
        if (r != SQ_OK) goto done;
    } else {
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                     "%s.file = '%s': neither a vector layer nor a raster band in the file", key,
                     desc->path);
        goto done;
    }
    {
        OGRSpatialReferenceH ls = OGR_L_GetSpatialRef(lyr);
        if (ls && !sq__geo_srs_empty(ls)) {
            s_srs = sq__geo_srs_clone(ls);
        } else if (desc->assign_crs && desc->assign_crs[0]) {
            s_srs = sq__geo_srs_from_user(desc->assign_crs);
            if (!s_srs) {
                r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                             "%s.crs = '%s': not a coordinate reference system GDAL knows (%s)",
                             key, desc->assign_crs, sq__geo_reason());
                goto done;
            }
        } else {
            r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                         "%s.file = '%s': the file has no coordinate reference system; name the one "
                         "its coordinates are in with %s.crs (e.g. EPSG:4326 for "
                         "longitude/latitude, EPSG:32632 for UTM zone 32N)",
                         key, desc->path, key);
            goto done;
        }
        t_srs = sq__geo_srs_from_user(desc->target_crs_wkt);
        if (!t_srs) {
            r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "%s: the world's CRS is not valid (%s)",
                         key, sq__geo_reason());
            goto done;
        }
        ct = OCTNewCoordinateTransformation(s_srs, t_srs);
        if (!ct) {
            r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                         "%s.file = '%s': no transformation from its CRS to the world's (%s)", key,
                         desc->path, sq__geo_reason());
            goto done;
        }
    }
    OGR_L_ResetReading(lyr);
    OGRFeatureH f;
    int fidx = 0;
    while ((f = OGR_L_GetNextFeature(lyr)) != NULL) {
        OGRGeometryH g = OGR_F_GetGeometryRef(f);
        /* degenerate (zero-area) polygons are judged in the file's own coordinates, where
         * collinear vertices give exactly zero, before the projection curves their edges */
        double src_area = 0.0, src_span2 = 0.0;
        if (g) {
            OGREnvelope env;
            OGR_G_GetEnvelope(g, &env);
            src_area = OGR_G_Area(g);
            src_span2 = (env.MaxX - env.MinX) * (env.MaxX - env.MinX) +
                        (env.MaxY - env.MinY) * (env.MaxY - env.MinY);
        }
        /* a ring that crosses itself (a bow tie) has lobes whose signed areas cancel: name
         * the defect, not a "zero area" (GEOS through OGR; the reason gives the place) */
        if (g && OGR_G_IsValid(g) == 0 && crossing_lobes_area(g) > 1e-9 * src_span2) {
            r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                         "%s.file = '%s': polygon feature %d is not a valid polygon (%s); a "
                         "release or area boundary must not cross itself (QGIS: Vector > "
                         "Geometry Tools > Fix Geometries)", key, desc->path, fidx,
                         sq__geo_reason());
            OGR_F_Destroy(f);
            goto done;
        }
        if (g && OGR_G_Transform(g, ct) != OGRERR_NONE) {
            r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                         "%s.file = '%s': feature %d does not transform to the world's CRS (%s)", key,
                         desc->path, fidx, sq__geo_reason());
            OGR_F_Destroy(f);
            goto done;
        }
        const size_t ring0 = b.nr;
        const int polys = g ? add_polygons(&b, g, (int)b.nf) : 0;
        if (b.oom) {
            OGR_F_Destroy(f);
            r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "%s: out of memory", key);
            goto done;
        }
        if (polys > 0) {
            const double area = OGR_G_Area(g);
            if (!(area > 0.0) || !(src_area > 1e-9 * src_span2) || b.nr == ring0) {
                r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                             "%s.file = '%s': polygon feature %d has zero area (%g m2); every "
                             "polygon must enclose an area", key, desc->path, fidx, area);
                OGR_F_Destroy(f);
                goto done;
            }
            size_t cf = b.cap_f;
            if (!grow(ctx, (void **)&b.fval, &cf, b.nf + 1, sizeof(double)) ||
                !grow(ctx, (void **)&b.farea, &b.cap_f, b.nf + 1, sizeof(double))) {
                OGR_F_Destroy(f);
                r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "%s: out of memory", key);
                goto done;
            }
            double v = NAN;
            if (desc->attribute && desc->attribute[0]) {
                const int fi = OGR_F_GetFieldIndex(f, desc->attribute);
                if (fi >= 0 && OGR_F_IsFieldSetAndNotNull(f, fi)) {
                    r = attribute_value(ctx, key, desc, f, fi, fidx, &v);
                    if (r != SQ_OK) {
                        OGR_F_Destroy(f);
                        goto done;
                    }
                }
            }
            b.fval[b.nf] = v;
            b.farea[b.nf] = area;
            b.nf++;
        }
        OGR_F_Destroy(f);
        fidx++;
    }
    if (b.nf == 0) {
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                     "%s.file = '%s': no polygon in %d feature(s) (points and lines have no area); "
                     "an area needs polygons", key, desc->path, fidx);
        goto done;
    }
    out->feature_count = (int)b.nf;
    out->feature_value = b.fval;
    out->feature_area_m2 = b.farea;
    out->ring_count = (int)b.nr;
    out->ring_start = b.ring_start;
    out->ring_feature = b.ring_feature;
    out->xy_m = b.xy;
    b.fval = b.farea = b.xy = NULL;
    b.ring_start = b.ring_feature = NULL;
    out->bounds[0] = out->bounds[1] = INFINITY;
    out->bounds[2] = out->bounds[3] = -INFINITY;
    for (size_t k = 0; k < b.np; k++) {
        double *p = out->xy_m + 2 * k;
        p[0] -= desc->offset_m[0];
        p[1] -= desc->offset_m[1];
        if (p[0] < out->bounds[0]) out->bounds[0] = p[0];
        if (p[1] < out->bounds[1]) out->bounds[1] = p[1];
        if (p[0] > out->bounds[2]) out->bounds[2] = p[0];
        if (p[1] > out->bounds[3]) out->bounds[3] = p[1];
    }
    for (int k = 0; k < out->feature_count; k++) out->area_m2 += out->feature_area_m2[k];
    sq_log(ctx, SQ_LOG_INFO, MOD, "%s: '%s': %d polygon feature(s), %d ring(s), %.0f m2", key,
           desc->path, out->feature_count, out->ring_count, out->area_m2);
done:
    sq_free(ctx, b.xy);
    sq_free(ctx, b.ring_start);
    sq_free(ctx, b.ring_feature);
    sq_free(ctx, b.fval);
    sq_free(ctx, b.farea);
    if (ct) OCTDestroyCoordinateTransformation(ct);
    if (s_srs) OSRDestroySpatialReference(s_srs);
    if (t_srs) OSRDestroySpatialReference(t_srs);
    if (poly) GDALClose(poly);
    if (ds) GDALClose(ds);
    sq__geo_quiet_end();
    if (r != SQ_OK) sq_area_release(ctx, out);
    return r;
}

void sq_area_release(sq_context *ctx, sq_area *a)
{
    if (!a) return;
    sq_free(ctx, a->feature_value);
    sq_free(ctx, a->feature_area_m2);
    sq_free(ctx, a->ring_start);
    sq_free(ctx, a->ring_feature);
    sq_free(ctx, a->xy_m);
    memset(a, 0, sizeof *a);
}
#endif
