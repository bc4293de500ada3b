/* wrf_export.c — the derived fields of one WRF time as netCDF-4 with CF-1.8 metadata
 * (include/squall/wrf.h, `squall wrf export`).
 *
 * Layout:
 *   dimensions   bottom_top (nz), south_north (ny), west_east (nx) — WRF's names and C order
 *   x(west_east), y(south_north)   double, m, projection_x/y_coordinate: the projected
 *                coordinates of the mass points in the CRS of "crs" (false easting/northing 0)
 *   crs          int scalar grid mapping: CF projection attributes on WRF's sphere
 *                (earth_radius 6370000), crs_wkt (WKT2 from PROJ) and proj4_params; for MAP_PROJ 6
 *                (lat-lon, projected equirectangular) CF has no grid_mapping_name, so only the
 *                WKT and PROJ string are given and lat/lon carry the geolocation
 *   lat, lon     float (south_north, west_east), degrees_north/east (XLAT/XLONG)
 *   time         double scalar, "seconds since <first time of the series>" (standard calendar)
 *   3D fields    float (bottom_top, south_north, west_east) with units, long_name, standard_name
 *                where CF has one, grid_mapping "crs", coordinates "time z lat lon"
 *   2D fields    terrain_height, cloud_optical_depth (south_north, west_east)
 * Written to a temporary name and renamed when complete (output.c). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "io/io_internal.h"
#include "io/wrf_internal.h"
#include "squall/optics.h"

#if SQ_HAVE_NETCDF && SQ_HAVE_PROJ
#include <netcdf.h>

typedef struct ex_var {
    const char *name;
    const float *data;
    bool is2d;
    const char *units, *standard_name, *long_name;
    int varid;
} ex_var;

static int put_text(int ncid, int varid, const char *name, const char *text)
{
    return nc_put_att_text(ncid, varid, name, strlen(text), text);
}

static int put_double(int ncid, int varid, const char *name, double v)
{
    return nc_put_att_double(ncid, varid, name, NC_DOUBLE, 1, &v);
}

/* The CF grid mapping attributes of the projection. */
static int def_crs(int ncid, const sq_wrf_info *in, int *varid)
{
    int st = nc_def_var(ncid, "crs", NC_INT, 0, NULL, varid);
    const int v = *varid;
    switch (in->projection) {
    case SQ_WRF_PROJ_LAMBERT: {
        const double sp[2] = {in->truelat1_deg, in->truelat2_deg};
        if (st == NC_NOERR) st = put_text(ncid, v, "grid_mapping_name", "lambert_conformal_conic");
        if (st == NC_NOERR)
            st = nc_put_att_double(ncid, v, "standard_parallel", NC_DOUBLE,
                                   sp[0] == sp[1] ? 1 : 2, sp);
        if (st == NC_NOERR) st = put_double(ncid, v, "longitude_of_central_meridian",
                                            in->stand_lon_deg);
        if (st == NC_NOERR) st = put_double(ncid, v, "latitude_of_projection_origin",
                                            in->moad_cen_lat_deg);
        break;
    }
    case SQ_WRF_PROJ_POLAR:
        if (st == NC_NOERR) st = put_text(ncid, v, "grid_mapping_name", "polar_stereographic");
        if (st == NC_NOERR) st = put_double(ncid, v, "straight_vertical_longitude_from_pole",
                                            in->stand_lon_deg);
        if (st == NC_NOERR) st = put_double(ncid, v, "latitude_of_projection_origin",
                                            in->truelat1_deg < 0 ? -90.0 : 90.0);
        if (st == NC_NOERR) st = put_double(ncid, v, "standard_parallel", in->truelat1_deg);
        break;
    case SQ_WRF_PROJ_MERCATOR:
        if (st == NC_NOERR) st = put_text(ncid, v, "grid_mapping_name", "mercator");
        if (st == NC_NOERR) st = put_double(ncid, v, "longitude_of_projection_origin",
                                            in->stand_lon_deg);
        if (st == NC_NOERR) st = put_double(ncid, v, "standard_parallel", in->truelat1_deg);
        break;
    default: break;
    }
    if (st == NC_NOERR && in->projection != SQ_WRF_PROJ_LATLON) {
        st = put_double(ncid, v, "false_easting", 0.0);
        if (st == NC_NOERR) st = put_double(ncid, v, "false_northing", 0.0);
    }
    if (st == NC_NOERR) st = put_double(ncid, v, "earth_radius", in->earth_radius_m);
    if (st == NC_NOERR) st = put_text(ncid, v, "crs_wkt", in->crs_wkt);
    if (st == NC_NOERR) st = put_text(ncid, v, "proj4_params", in->proj_string);
    if (st == NC_NOERR) st = put_text(ncid, v, "long_name", in->projection_name);
    return st;
}

static void history_text(char *buf, size_t size)
{
    time_t now = time(NULL);
    const char *epoch = getenv("SOURCE_DATE_EPOCH");
    if (epoch && *epoch) {
        char *end = NULL;
        long long e = strtoll(epoch, &end, 10);
        if (end && !*end && e >= 0) now = (time_t)e;
    }
    struct tm tm;
    char stamp[32] = "unknown time";
    if (gmtime_r(&now, &tm)) strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
    snprintf(buf, size, "%s squall %s: wrf export", stamp, SQ_VERSION_STRING);
}

static sq_result write_file(sq_wrf *w, int ncid, const sq_wrf_state *s, const float *ext,
                            const float *tau, const char *path)
{
    const sq_wrf_info *in = &w->info;
    const size_t nx = (size_t)in->nx, ny = (size_t)in->ny;
    ex_var vars[] = {
        {"z", s->z_m, false, "m", "geopotential_height",
         "geopotential height of the mass points above mean sea level, (PH + PHB)/9.81 averaged "
         "from the w-levels", 0},
        {"height_above_ground", s->height_agl_m, false, "m", "height",
         "height of the mass points above the terrain (z - HGT)", 0},
        {"pressure", s->p_pa, false, "Pa", "air_pressure", "pressure P + PB", 0},
        {"theta", s->theta_k, false, "K", "air_potential_temperature",
         "potential temperature T + 300", 0},
        {"temperature", s->t_k, false, "K", "air_temperature",
         "temperature theta (p / 1e5)^(287/1004.5)", 0},
        {"air_density", s->rho_kg_m3, false, "kg m-3", "air_density",
         "moist air density p / (287 T (1 + 0.608 qv))", 0},
        {"qvapor", s->qv_kg_kg, false, "kg kg-1", "humidity_mixing_ratio",
         "water vapour mixing ratio QVAPOR", 0},
        {"u", s->u_mps, false, "m s-1", "x_wind", "wind along the grid's x axis (U at mass points)",
         0},
        {"v", s->v_mps, false, "m s-1", "y_wind", "wind along the grid's y axis (V at mass points)",
         0},
        {"w", s->w_mps, false, "m s-1", "upward_air_velocity", "vertical wind (W at mass points)",
         0},
        {"cloud_water", s->q_g_m3[SQ_WRF_CLOUD], false, "g m-3", NULL,
         "mass concentration of cloud liquid water (QCLOUD per unit volume)", 0},
        {"cloud_ice", s->q_g_m3[SQ_WRF_ICE], false, "g m-3", NULL,
         "mass concentration of cloud ice (QICE per unit volume)", 0},
        {"snow", s->q_g_m3[SQ_WRF_SNOW], false, "g m-3", NULL,
         "mass concentration of snow (QSNOW per unit volume)", 0},
        {"rain", s->q_g_m3[SQ_WRF_RAIN], false, "g m-3", NULL,
         "mass concentration of rain (QRAIN per unit volume)", 0},
        {"graupel", s->q_g_m3[SQ_WRF_GRAUPEL], false, "g m-3", NULL,
         "mass concentration of graupel (QGRAUP per unit volume)", 0},
        {"extinction", ext, false, "m-1", NULL,
         "visible extinction coefficient of cloud water and cloud ice, 3 C / (2 rho r_eff)", 0},
        {"terrain_height", s->terrain_m, true, "m", "surface_altitude", "terrain height HGT", 0},
        {"cloud_optical_depth", tau, true, "1", NULL,
         "column visible optical depth of cloud water and cloud ice", 0},
    };
    const int nv = (int)(sizeof vars / sizeof vars[0]);
    int dz, dy, dx;
    const char *doing = "defining dimensions";
    int st = nc_def_dim(ncid, "bottom_top", (size_t)in->nz, &dz);
    if (st == NC_NOERR) st = nc_def_dim(ncid, "south_north", ny, &dy);
    if (st == NC_NOERR) st = nc_def_dim(ncid, "west_east", nx, &dx);
    int vx = -1, vy = -1, vlat = -1, vlon = -1, vt = -1, vcrs = -1;
    const bool has_mapping = in->projection != SQ_WRF_PROJ_LATLON;
    if (st == NC_NOERR) {
        doing = "defining coordinates";
        st = nc_def_var(ncid, "x", NC_DOUBLE, 1, &dx, &vx);
        if (st == NC_NOERR) st = put_text(ncid, vx, "units", "m");
        if (st == NC_NOERR) st = put_text(ncid, vx, "axis", "X");
        if (st == NC_NOERR && has_mapping)
            st = put_text(ncid, vx, "standard_name", "projection_x_coordinate");
        if (st == NC_NOERR)
            st = put_text(ncid, vx, "long_name", "projected x (grid east) of the mass points");
        if (st == NC_NOERR) st = nc_def_var(ncid, "y", NC_DOUBLE, 1, &dy, &vy);
        if (st == NC_NOERR) st = put_text(ncid, vy, "units", "m");
        if (st == NC_NOERR) st = put_text(ncid, vy, "axis", "Y");
        if (st == NC_NOERR && has_mapping)
            st = put_text(ncid, vy, "standard_name", "projection_y_coordinate");
        if (st == NC_NOERR)
            st = put_text(ncid, vy, "long_name", "projected y (grid north) of the mass points");
        const int d2[2] = {dy, dx};
        if (st == NC_NOERR) st = nc_def_var(ncid, "lat", NC_FLOAT, 2, d2, &vlat);
        if (st == NC_NOERR) st = put_text(ncid, vlat, "units", "degrees_north");
        if (st == NC_NOERR) st = put_text(ncid, vlat, "standard_name", "latitude");
        if (st == NC_NOERR) st = put_text(ncid, vlat, "long_name", "latitude (XLAT)");
        if (st == NC_NOERR) st = nc_def_var(ncid, "lon", NC_FLOAT, 2, d2, &vlon);
        if (st == NC_NOERR) st = put_text(ncid, vlon, "units", "degrees_east");
        if (st == NC_NOERR) st = put_text(ncid, vlon, "standard_name", "longitude");
        if (st == NC_NOERR) st = put_text(ncid, vlon, "long_name", "longitude (XLONG)");
        if (st == NC_NOERR) st = nc_def_var(ncid, "time", NC_DOUBLE, 0, NULL, &vt);
        char units[64];
        const char *t0 = in->time_strings[0];
        snprintf(units, sizeof units, "seconds since %.10s %.8s", t0, t0 + 11);
        if (st == NC_NOERR) st = put_text(ncid, vt, "units", units);
        if (st == NC_NOERR) st = put_text(ncid, vt, "standard_name", "time");
        if (st == NC_NOERR) st = put_text(ncid, vt, "calendar", "standard");
        if (st == NC_NOERR) st = put_text(ncid, vt, "axis", "T");
        if (st == NC_NOERR) st = def_crs(ncid, in, &vcrs);
    }
    const float fill = NC_FILL_FLOAT;
    const int d3[3] = {dz, dy, dx}, d2[2] = {dy, dx};
    for (int i = 0; i < nv && st == NC_NOERR; i++) {
        ex_var *v = &vars[i];
        if (!v->data) continue;
        doing = v->name;
        st = nc_def_var(ncid, v->name, NC_FLOAT, v->is2d ? 2 : 3, v->is2d ? d2 : d3, &v->varid);
        if (st == NC_NOERR) st = nc_def_var_fill(ncid, v->varid, 0, &fill);
        if (st == NC_NOERR) st = put_text(ncid, v->varid, "units", v->units);
        if (st == NC_NOERR && v->standard_name)
            st = put_text(ncid, v->varid, "standard_name", v->standard_name);
        if (st == NC_NOERR) st = put_text(ncid, v->varid, "long_name", v->long_name);
        if (st == NC_NOERR && has_mapping) st = put_text(ncid, v->varid, "grid_mapping", "crs");
        if (st == NC_NOERR)
            st = put_text(ncid, v->varid, "coordinates",
                          v->is2d || v->data == s->z_m ? "time lat lon" : "time z lat lon");
        if (st == NC_NOERR && (v->data == ext || v->data == tau)) {
            char c[200];
            snprintf(c, sizeof c,
                     "geometric optics (Q_ext = 2); effective radius %.0f um for droplets "
                     "(density 1000 kg m-3) and %.0f um for ice (917 kg m-3)",
                     SQ_CLOUD_DROPLET_R_EFF_M * 1e6, SQ_CLOUD_ICE_R_EFF_M * 1e6);
            st = put_text(ncid, v->varid, "comment", c);
        }
        if (st == NC_NOERR && v->data == tau)
            st = put_text(ncid, v->varid, "cell_methods", "bottom_top: sum");
    }
    if (st == NC_NOERR) {
        doing = "global attributes";
        char buf[600];
        st = put_text(ncid, NC_GLOBAL, "Conventions", "CF-1.8");
        snprintf(buf, sizeof buf, "WRF fields at %s%s", s->index0 == s->index1 ? "" : "about ",
                 in->time_strings[s->index0]);
        if (st == NC_NOERR) st = put_text(ncid, NC_GLOBAL, "title", buf);
        snprintf(buf, sizeof buf, "squall %s from %s (%s)", SQ_VERSION_STRING, w->files[0].path,
                 in->title && *in->title ? in->title : "WRF output");
        if (st == NC_NOERR) st = put_text(ncid, NC_GLOBAL, "source", buf);
        history_text(buf, sizeof buf);
        if (st == NC_NOERR) st = put_text(ncid, NC_GLOBAL, "history", buf);
        if (st == NC_NOERR)
            st = put_text(ncid, NC_GLOBAL, "references",
                          "formulas: docs/wrf.md (WRF constants g 9.81, R_d 287, c_p 1004.5; "
                          "mass concentrations as NCEP UPP CALVIS)");
        if (st == NC_NOERR) st = put_double(ncid, NC_GLOBAL, "wrf_time_s", s->time_s);
    }
    if (st == NC_NOERR) {
        doing = "leaving define mode";
        st = nc_enddef(ncid);
    }
    if (st == NC_NOERR) {
        doing = "writing coordinates";
        double buf[4096];
        for (size_t i = 0; i < nx && st == NC_NOERR; i += 4096) {
            const size_t m = nx - i < 4096 ? nx - i : 4096;
            for (size_t a = 0; a < m; a++) buf[a] = in->crs_offset_m[0] + (double)s->x_m[i + a];
            st = nc_put_vara_double(ncid, vx, &i, &m, buf);
        }
        for (size_t j = 0; j < ny && st == NC_NOERR; j += 4096) {
            const size_t m = ny - j < 4096 ? ny - j : 4096;
            for (size_t a = 0; a < m; a++) buf[a] = in->crs_offset_m[1] + (double)s->y_m[j + a];
            st = nc_put_vara_double(ncid, vy, &j, &m, buf);
        }
        if (st == NC_NOERR) st = nc_put_var_float(ncid, vlat, s->lat_deg);
        if (st == NC_NOERR) st = nc_put_var_float(ncid, vlon, s->lon_deg);
        if (st == NC_NOERR) st = nc_put_var_double(ncid, vt, &s->time_s);
        const int zero = 0;
        if (st == NC_NOERR) st = nc_put_var_int(ncid, vcrs, &zero);
    }
    for (int i = 0; i < nv && st == NC_NOERR; i++) {
        if (!vars[i].data) continue;
        doing = vars[i].name;
        st = nc_put_var_float(ncid, vars[i].varid, vars[i].data);
    }
    if (st != NC_NOERR)
        return sq__fail(w->ctx, st == NC_ENOMEM ? SQ_ERR_OUT_OF_MEMORY : SQ_ERR_IO, "wrf",
                        "cannot write '%s' (%s): %s", path, doing, nc_strerror(st));
    return SQ_OK;
}

sq_result sq_wrf_export_netcdf(sq_wrf *w, const sq_wrf_export_desc *desc)
{
    if (!w || !desc || !desc->path)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_wrf_export_netcdf: NULL argument");
    sq_result r = sq_output_check(desc->path, desc->overwrite);
    if (r != SQ_OK) return sq__io_relog(w->ctx, r);
    r = sq_output_check_inputs(w->ctx, desc->path, false); /* the WRF file itself, say */
    if (r != SQ_OK) return r;
    sq_wrf_state s;
    r = desc->index >= 0 ? sq_wrf_read_index(w, desc->index, &s) : sq_wrf_read(w, desc->time_s, &s);
    if (r != SQ_OK) return r;
    const sq_wrf_info *in = &w->info;
    const size_t plane = (size_t)in->nx * (size_t)in->ny, n = plane * (size_t)in->nz;
    float *ext = (float *)sq_alloc(w->ctx, sizeof(float) * (n + plane));
    if (!ext) return SQ_ERR_OUT_OF_MEMORY;
    float *tau = ext + n;
    const float *qc = s.q_g_m3[SQ_WRF_CLOUD], *qi = s.q_g_m3[SQ_WRF_ICE];
    for (size_t c = 0; c < n; c++)
        ext[c] = (float)((qc ? sq_cloud_extinction(1e-3 * (double)qc[c], SQ_WATER_DENSITY_KG_M3,
                                                   SQ_CLOUD_DROPLET_R_EFF_M)
                             : 0.0) +
                         (qi ? sq_cloud_extinction(1e-3 * (double)qi[c], SQ_ICE_DENSITY_KG_M3,
                                                   SQ_CLOUD_ICE_R_EFF_M)
                             : 0.0));
    sq_wrf_cloud_optical_depth(in, &s, tau);

    r = sq__io_relog(w->ctx, sq_output_check(desc->path, desc->overwrite));
    if (r != SQ_OK) {
        sq_free(w->ctx, ext);
        return r;
    }
    int ncid = -1;
    int st = sq__nc_create_memory(desc->path, NC_NETCDF4, 1u << 20, &ncid);
    if (st != NC_NOERR) {
        sq_free(w->ctx, ext);
        return sq__fail(w->ctx, st == NC_ENOMEM ? SQ_ERR_OUT_OF_MEMORY : SQ_ERR_IO, "wrf",
                        "cannot write '%s' (creating it in memory): %s", desc->path,
                        nc_strerror(st));
    }
    r = write_file(w, ncid, &s, ext, tau, desc->path);
    sq_free(w->ctx, ext);
    if (r == SQ_OK)
        r = sq__nc_write_memory(w->ctx, ncid, desc->path, desc->overwrite, "wrf");
    else
        nc_abort(ncid);
    if (r == SQ_OK) sq_log(w->ctx, SQ_LOG_INFO, "wrf", "wrote '%s'", desc->path);
    return r;
}

#else

sq_result sq_wrf_export_netcdf(sq_wrf *w, const sq_wrf_export_desc *desc)
{
    (void)w, (void)desc;
    return sq__set_error(SQ_ERR_UNSUPPORTED,
                         "squall was built without the WRF reader (it needs NetCDF and PROJ)");
}

#endif
