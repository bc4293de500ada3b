/* test_fields.c — the field-file writers' conventions (issue 17 part 7), read back through the
 * netCDF C library: time is the UNLIMITED record dimension, invalid cells and NaN are
 * _FillValue, 2D maps carry their level (height above the surface, a slice's altitude, or none
 * for a surface property), coordinates have standard names, a georeferenced world gets
 * grid_mapping with the WKT and x/y in the CRS. The run-level check with independent readers is
 * tests/cli/fields_readers.sh. */
#include <math.h>
#include <unistd.h>

#include "sq_config.h"
#include "sq_test.h"
#include "squall/io.h"

#if SQ_HAVE_NETCDF
#include <netcdf.h>
#endif

SQ_LABEL(unit)

#if SQ_HAVE_NETCDF
static void att_is(int nc, int var, const char *att, const char *want)
{
    char buf[512] = "";
    size_t len = 0;
    int st = nc_inq_attlen(nc, var, att, &len);
    if (st == NC_NOERR && len < sizeof buf) st = nc_get_att_text(nc, var, att, buf);
    buf[len < sizeof buf ? len : 0] = 0;
    SQ_CHECK_MSG(st == NC_NOERR && strcmp(buf, want) == 0, "attribute %s = '%s', expected '%s'", att,
                 buf, want);
}

SQ_TEST(netcdf_conventions)
{
    sq_context *ctx = NULL;
    sq_context_create(NULL, &ctx);
    char path[] = "/tmp/sq-fields-XXXXXX";
    int fd = mkstemp(path);
    SQ_CHECK(fd >= 0);
    close(fd);
    unlink(path);
    /* 3D: a 3x2x2 grid with one invalid cell and one NaN */
    float a[12];
    for (int i = 0; i < 12; i++) a[i] = (float)i;
    a[5] = NAN;
    uint8_t inv[12] = {0};
    inv[0] = 1;
    sq_named_field f3 = {"a", "kg m-3", "a field", NULL, a, 3, 2, 2, sq_v3(10, 20, 1),
                         sq_v3(1, 1, 2), inv, SQ_FIELD_LEVEL_ALTITUDE};
    sq_field_file_desc d = {0};
    d.path = path;
    d.time_s = 1.25;
    d.crs_wkt = "PROJCS[\"test\"]";
    d.crs_offset_m[0] = 500000.0;
    d.crs_offset_m[1] = 4000000.0;
    SQ_CHECK_OK(sq_netcdf_write_fields(ctx, &d, &f3, 1));
    int nc = -1, unlim = -1, vt = -1, va = -1, vx = -1, vz = -1, vcrs = -1;
    SQ_CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR);
    SQ_CHECK(nc_inq_unlimdim(nc, &unlim) == NC_NOERR && unlim >= 0);
    char dname[NC_MAX_NAME + 1] = "";
    nc_inq_dimname(nc, unlim, dname);
    SQ_CHECK_MSG(strcmp(dname, "time") == 0, "unlimited dimension '%s'", dname);
    SQ_CHECK(nc_inq_varid(nc, "time", &vt) == NC_NOERR);
    SQ_CHECK(nc_inq_varid(nc, "a", &va) == NC_NOERR);
    SQ_CHECK(nc_inq_varid(nc, "x", &vx) == NC_NOERR);
    SQ_CHECK(nc_inq_varid(nc, "z", &vz) == NC_NOERR);
    SQ_CHECK(nc_inq_varid(nc, "crs", &vcrs) == NC_NOERR);
    att_is(nc, vz, "standard_name", "altitude");
    att_is(nc, vx, "standard_name", "projection_x_coordinate");
    att_is(nc, va, "grid_mapping", "crs");
    att_is(nc, vcrs, "crs_wkt", "PROJCS[\"test\"]");
    double x0 = 0, t = 0;
    nc_get_var1_double(nc, vx, (size_t[]){0}, &x0);
    nc_get_var1_double(nc, vt, (size_t[]){0}, &t);
    SQ_CHECK_NEAR(x0, 500010.0, 1e-9);
    SQ_CHECK(t == 1.25);
    float back[12];
    SQ_CHECK(nc_get_var_float(nc, va, back) == NC_NOERR);
    SQ_CHECK(back[0] == NC_FILL_FLOAT && back[5] == NC_FILL_FLOAT && back[4] == 4.0f &&
             back[11] == 11.0f);
    nc_close(nc);
    unlink(path);
    /* 2D maps at two heights above the ground, a slice and a surface property */
    float m[6] = {1, 2, 3, 4, 5, 6};
    sq_named_field maps[4] = {
        {"vis_2m", "m", NULL, "visibility_in_air", m, 3, 2, 1, sq_v3(0, 0, 2), sq_v3(1, 1, 1),
         NULL, SQ_FIELD_LEVEL_HEIGHT},
        {"vis_10m", "m", NULL, "visibility_in_air", m, 3, 2, 1, sq_v3(0, 0, 10), sq_v3(1, 1, 1),
         NULL, SQ_FIELD_LEVEL_HEIGHT},
        {"slice", "1", NULL, NULL, m, 3, 2, 1, sq_v3(0, 0, 300), sq_v3(1, 1, 1), NULL,
         SQ_FIELD_LEVEL_ALTITUDE},
        {"depth", "m", NULL, "surface_snow_thickness", m, 3, 2, 1, sq_v3(0, 0, 0), sq_v3(1, 1, 1),
         NULL, SQ_FIELD_LEVEL_SURFACE}};
    d.crs_wkt = NULL;
    SQ_CHECK_OK(sq_netcdf_write_fields(ctx, &d, maps, 4));
    SQ_CHECK(nc_open(path, NC_NOWRITE, &nc) == NC_NOERR);
    int v2 = -1, v10 = -1, vs = -1, vd = -1, vh = -1, vzz = -1;
    nc_inq_varid(nc, "vis_2m", &v2);
    nc_inq_varid(nc, "vis_10m", &v10);
    nc_inq_varid(nc, "slice", &vs);
    nc_inq_varid(nc, "depth", &vd);
    att_is(nc, v2, "coordinates", "height_2m");
    att_is(nc, v10, "coordinates", "height_10m");
    att_is(nc, vs, "coordinates", "z");
    SQ_CHECK(nc_inq_attlen(nc, vd, "coordinates", &(size_t){0}) == NC_ENOTATT);
    SQ_CHECK(nc_inq_varid(nc, "height_10m", &vh) == NC_NOERR);
    att_is(nc, vh, "standard_name", "height");
    double hv = 0, zv = 0;
    nc_get_var_double(nc, vh, &hv);
    SQ_CHECK(nc_inq_varid(nc, "z", &vzz) == NC_NOERR);
    nc_get_var_double(nc, vzz, &zv);
    SQ_CHECK(hv == 10.0 && zv == 300.0);
    SQ_CHECK(nc_inq_varid(nc, "crs", &vcrs) == NC_ENOTVAR);
    nc_close(nc);
    unlink(path);
    sq_context_destroy(ctx);
}
#endif
