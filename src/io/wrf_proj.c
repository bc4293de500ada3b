/* wrf_proj.c — the WRF map projection through PROJ (include/squall/wrf.h): the projected CRS on
 * WRF's sphere (R = 6 370 km) from MAP_PROJ, TRUELAT1/2, STAND_LON, MOAD_CEN_LAT and POLE_LAT/LON
 * (the same definitions as wrf-python's projection.py and salem), the regular grid placed by
 * projecting the file's XLAT/XLONG (so a cropped file, whose CEN_LAT/CEN_LON describe the
 * original domain, is placed right), a check that the file's coordinates really are that grid,
 * the domain centre, the angle between grid north and true north, and the sun over the centre. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "io/wrf_internal.h"

#if SQ_HAVE_NETCDF && SQ_HAVE_PROJ
#include <proj.h>

/* WRF's lat/lon on its own sphere: no datum shift between geographic and projected. */
#define GEOGRAPHIC_CRS "+proj=longlat +R=6370000 +no_defs +type=crs"

static sq_result proj_error(sq_wrf *w, const char *path, const char *doing)
{
    PJ_CONTEXT *pc = (PJ_CONTEXT *)w->pj_ctx;
    const int e = pc ? proj_context_errno(pc) : 0;
    return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf", "%s: PROJ cannot %s ('%s'): %s", path, doing,
                    w->proj_string, e ? proj_context_errno_string(pc, e) : "unknown error");
}

/* The PROJ string of the projected CRS. */
static void build_proj_string(const sq_wrf_info *in, char *buf, size_t size)
{
    const double r = SQ__WRF_EARTH_RADIUS_M;
    switch (in->projection) {
    case SQ_WRF_PROJ_LAMBERT:
        snprintf(buf, size,
                 "+proj=lcc +lat_1=%.10g +lat_2=%.10g +lat_0=%.10g +lon_0=%.10g +x_0=0 +y_0=0 "
                 "+R=%.0f +units=m +no_defs",
                 in->truelat1_deg, in->truelat2_deg, in->moad_cen_lat_deg, in->stand_lon_deg, r);
        break;
    case SQ_WRF_PROJ_POLAR:
        snprintf(buf, size,
                 "+proj=stere +lat_0=%d +lat_ts=%.10g +lon_0=%.10g +x_0=0 +y_0=0 +R=%.0f "
                 "+units=m +no_defs",
                 in->truelat1_deg < 0.0 ? -90 : 90, in->truelat1_deg, in->stand_lon_deg, r);
        break;
    case SQ_WRF_PROJ_MERCATOR:
        snprintf(buf, size,
                 "+proj=merc +lat_ts=%.10g +lon_0=%.10g +x_0=0 +y_0=0 +R=%.0f +units=m +no_defs",
                 in->truelat1_deg, in->stand_lon_deg, r);
        break;
    case SQ_WRF_PROJ_LATLON:
        if (in->pole_lat_deg == 90.0) {
            snprintf(buf, size,
                     "+proj=eqc +lat_ts=0 +lat_0=0 +lon_0=%.10g +x_0=0 +y_0=0 +R=%.0f +units=m "
                     "+no_defs",
                     in->stand_lon_deg, r);
        } else {
            /* rotated pole, as wrf-python's RotatedLatLon: the hemisphere from POLE_LON */
            const bool north = in->pole_lon_deg != 0.0;
            const double o_lat_p = north ? in->pole_lat_deg : -in->pole_lat_deg;
            const double lon_0 = north ? -in->stand_lon_deg : 180.0 - in->stand_lon_deg;
            snprintf(buf, size,
                     "+proj=ob_tran +o_proj=eqc +o_lon_p=%.10g +o_lat_p=%.10g +lon_0=%.10g "
                     "+R=%.0f +units=m +no_defs",
                     180.0 - in->pole_lon_deg, o_lat_p, lon_0, r);
        }
        break;
    default: buf[0] = 0;
    }
}

static bool lonlat_to_proj(const sq_wrf *w, double lon, double lat, double *x, double *y)
{
    PJ_COORD c = proj_coord(lon, lat, 0, 0);
    c = proj_trans((PJ *)w->pj_fwd, PJ_FWD, c);
    *x = c.xy.x;
    *y = c.xy.y;
    return isfinite(*x) && isfinite(*y);
}

static bool proj_to_lonlat(const sq_wrf *w, double x, double y, double *lon, double *lat)
{
    PJ_COORD c = proj_coord(x, y, 0, 0);
    c = proj_trans((PJ *)w->pj_fwd, PJ_INV, c);
    *lon = c.lp.lam;
    *lat = c.lp.phi;
    return isfinite(*lon) && isfinite(*lat);
}

sq_result sq__wrf_proj_setup(sq_wrf *w, const char *path)
{
    sq_wrf_info *in = &w->info;
    build_proj_string(in, w->proj_string, sizeof w->proj_string);
    PJ_CONTEXT *pc = proj_context_create();
    if (!pc) return sq__fail(w->ctx, SQ_ERR_OUT_OF_MEMORY, "wrf", "PROJ: no context");
    w->pj_ctx = pc;
    proj_log_level(pc, PJ_LOG_NONE);
    char crs_string[600];
    snprintf(crs_string, sizeof crs_string, "%s +type=crs", w->proj_string);
    PJ *crs = proj_create(pc, crs_string);
    if (!crs) return proj_error(w, path, "build the CRS");
    const char *wkt = proj_as_wkt(pc, crs, PJ_WKT2_2019, NULL);
    if (!wkt) {
        proj_destroy(crs);
        return proj_error(w, path, "write the CRS as WKT");
    }
    const size_t len = strlen(wkt) + 1;
    w->crs_wkt = (char *)sq_alloc(w->ctx, len);
    if (!w->crs_wkt) {
        proj_destroy(crs);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    memcpy(w->crs_wkt, wkt, len);
    proj_destroy(crs);
    PJ *op = proj_create_crs_to_crs(pc, GEOGRAPHIC_CRS, crs_string, NULL);
    if (!op) return proj_error(w, path, "build the transformation");
    PJ *norm = proj_normalize_for_visualization(pc, op);
    proj_destroy(op);
    if (!norm) return proj_error(w, path, "normalise the transformation");
    w->pj_fwd = norm;

    /* place the regular grid: x_ij = x0 + i DX, y_ij = y0 + j DY fitted to the projected
     * XLAT/XLONG, then every point checked against it */
    const int nx = in->nx, ny = in->ny;
    const double dx = in->dx_m, dy = in->dy_m;
    double sx = 0.0, sy = 0.0;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            const size_t c = (size_t)j * (size_t)nx + (size_t)i;
            double x, y;
            if (!lonlat_to_proj(w, w->lon[c], w->lat[c], &x, &y))
                return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                                "%s: XLAT/XLONG = %g, %g at (south_north %d, west_east %d) cannot "
                                "be projected with MAP_PROJ = %d",
                                path, (double)w->lat[c], (double)w->lon[c], j, i, in->map_proj);
            sx += x - i * dx;
            sy += y - j * dy;
        }
    const double x0 = sx / ((double)nx * ny), y0 = sy / ((double)nx * ny);
    double worst = 0.0;
    int wi = 0, wj = 0;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            const size_t c = (size_t)j * (size_t)nx + (size_t)i;
            double x, y;
            lonlat_to_proj(w, w->lon[c], w->lat[c], &x, &y);
            const double d = hypot(x - (x0 + i * dx), y - (y0 + j * dy));
            if (d > worst) {
                worst = d;
                wi = i;
                wj = j;
            }
        }
    /* float32 latitudes/longitudes carry ~1 m of rounding; 1 % of a cell is far above that and
     * far below what a wrong projection or spacing gives across a domain */
    const double tol = 1.0 + 0.01 * fmin(dx, dy);
    if (worst > tol)
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: XLAT/XLONG do not match MAP_PROJ = %d (%s) with DX = %g m, DY = %g "
                        "m: point (south_north %d, west_east %d) lies %.0f m off the regular grid "
                        "(at most %.0f m)",
                        path, in->map_proj, in->projection_name, dx, dy, wj, wi, worst, tol);
    in->crs_offset_m[0] = x0 + 0.5 * (nx - 1) * dx;
    in->crs_offset_m[1] = y0 + 0.5 * (ny - 1) * dy;
    in->x0_m = -0.5 * (nx - 1) * dx;
    in->y0_m = -0.5 * (ny - 1) * dy;
    w->xw = (float *)sq_alloc(w->ctx, sizeof(float) * (size_t)nx);
    w->yw = (float *)sq_alloc(w->ctx, sizeof(float) * (size_t)ny);
    if (!w->xw || !w->yw) return SQ_ERR_OUT_OF_MEMORY;
    for (int i = 0; i < nx; i++) w->xw[i] = (float)(in->x0_m + i * dx);
    for (int j = 0; j < ny; j++) w->yw[j] = (float)(in->y0_m + j * dy);
    double clon, clat;
    if (!proj_to_lonlat(w, in->crs_offset_m[0], in->crs_offset_m[1], &clon, &clat))
        return proj_error(w, path, "find the domain centre");
    in->center_lon_deg = clon;
    in->center_lat_deg = clat;
    /* true north at the centre, seen in the grid: a small step north */
    const double step = fabs(clat) < 89.0 ? 0.01 : -0.01;
    double xa, ya, xb, yb;
    lonlat_to_proj(w, clon, clat, &xa, &ya);
    lonlat_to_proj(w, clon, clat + step, &xb, &yb);
    double rot = atan2(xb - xa, yb - ya) * 180.0 / SQ_PI;
    if (step < 0.0) rot = atan2(xa - xb, ya - yb) * 180.0 / SQ_PI;
    in->north_rotation_deg = fabs(rot) < 1e-9 ? 0.0 : rot;
    return SQ_OK;
}

void sq__wrf_proj_free(sq_wrf *w)
{
    if (w->pj_fwd) proj_destroy((PJ *)w->pj_fwd);
    if (w->pj_ctx) proj_context_destroy((PJ_CONTEXT *)w->pj_ctx);
    w->pj_fwd = NULL;
    w->pj_ctx = NULL;
}

sq_result sq_wrf_to_world(const sq_wrf *w, double lon_deg, double lat_deg, double *x_m,
                          double *y_m)
{
    double x = NAN, y = NAN;
    if (!w || !x_m || !y_m)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_wrf_to_world: NULL argument");
    if (!lonlat_to_proj(w, lon_deg, lat_deg, &x, &y)) {
        *x_m = *y_m = NAN;
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "lon = %g, lat = %g degrees cannot be projected with MAP_PROJ = %d",
                             lon_deg, lat_deg, w->info.map_proj);
    }
    *x_m = x - w->info.crs_offset_m[0];
    *y_m = y - w->info.crs_offset_m[1];
    return SQ_OK;
}

sq_result sq_wrf_from_world(const sq_wrf *w, double x_m, double y_m, double *lon_deg,
                            double *lat_deg)
{
    if (!w || !lon_deg || !lat_deg)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_wrf_from_world: NULL argument");
    if (!proj_to_lonlat(w, x_m + w->info.crs_offset_m[0], y_m + w->info.crs_offset_m[1], lon_deg,
                        lat_deg)) {
        *lon_deg = *lat_deg = NAN;
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "world x = %g, y = %g m lies outside MAP_PROJ = %d's valid area", x_m,
                             y_m, w->info.map_proj);
    }
    return SQ_OK;
}

sq_result sq_wrf_sun(const sq_wrf *w, double time_s, sq_sun_position *pos, sq_vec3 *dir_world)
{
    if (!w) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_wrf_sun: no sq_wrf");
    const sq_wrf_info *in = &w->info;
    const sq_sun_position p = sq_sun_position_at(in->start_unix_s + time_s, in->center_lat_deg,
                                                 in->center_lon_deg);
    if (pos) *pos = p;
    if (dir_world) {
        /* an azimuth from true north is azimuth + rotation from grid north */
        const double az = (p.azimuth_deg + in->north_rotation_deg) * SQ_PI / 180.0;
        const double el = p.elevation_deg * SQ_PI / 180.0;
        *dir_world = sq_v3((float)(cos(el) * sin(az)), (float)(cos(el) * cos(az)), (float)sin(el));
    }
    return SQ_OK;
}

#endif
