/* netcdf_fields.c — field output as netCDF-4 following the CF conventions 1.8 (issue 3 part 5,
 * issue 17 part 7: files the standard tools accept).
 *
 * Format: netCDF-4 (HDF5) in the classic data model (no groups or user types), the variant that
 * every reader accepts, netCDF4-python's MFDataset and NCO included.
 *
 * Layout (C order, x fastest, matching sq_named_field):
 *   dimensions  time = UNLIMITED (one record per file, so ncrcat joins the files of successive
 *               frames into one time series), z = nz (only when nz > 1), y = ny, x = nx
 *   x(x), y(y)  double, units "m", axis "X"/"Y", standard_name projection_x_coordinate /
 *               projection_y_coordinate: world axes x east, y north (ARCHITECTURE.md), cell
 *               centres origin + i * spacing. When the world has a CRS (desc->crs_wkt), the
 *               values are world + crs_offset_m, i.e. easting and northing in that CRS, and a
 *               scalar int variable "crs" holds the WKT (attributes crs_wkt, and spatial_ref for
 *               GDAL); every field names it in grid_mapping. Without a CRS the grid is a local
 *               Cartesian frame and no grid_mapping is written.
 *   z(z)        double, units "m", axis "Z", positive "up", standard_name "altitude": the world z
 *               (for a georeferenced world, heights above sea level as in its DEM or WRF file;
 *               for a procedural world, above its datum z = 0).
 *   2D maps     fields with nz == 1 are (time, y, x) and carry their level as a scalar
 *               coordinate named in "coordinates": a horizontal slice (SQ_FIELD_LEVEL_ALTITUDE)
 *               a scalar "z" (altitude) at its world z; a terrain-following map
 *               (SQ_FIELD_LEVEL_HEIGHT, e.g. visibility 2 m above the ground) a scalar "height"
 *               (standard_name height: above the surface) at its height; maps at different
 *               levels get one coordinate each (z_2m, height_10m ...). A surface property
 *               (SQ_FIELD_LEVEL_SURFACE: snow depth) has no vertical coordinate.
 *   time(time)  double, standard_name "time", axis "T", calendar "standard", units
 *               "seconds since <reference_time>" (desc; default "2000-01-01 00:00:00", an
 *               arbitrary origin). CF requires a reference date in time units; a bare "s" would
 *               make time a duration, not a time coordinate.
 *   fields      float (time, [z,] y, x) with units, long_name (the name when none is given),
 *               standard_name where given, _FillValue = NC_FILL_FLOAT (9.96921e36) in every cell
 *               the field marks invalid (inside solids, below the ground) and wherever it is NaN.
 *   globals     Conventions "CF-1.8", title, source, history ("<UTC time> squall <version>:
 *               written"; SOURCE_DATE_EPOCH, when set, replaces the clock for reproducibility).
 * The file is built in memory and written whole to a temporary name, renamed when complete
 * (nc_memory.c, output.c); a full disk is reported as "no space left on device" naming the file. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "io/io_internal.h"

#if SQ_HAVE_NETCDF
#include <netcdf.h>

#define SQ__NC_DEFAULT_REFERENCE "2000-01-01 00:00:00"

/* "YYYY-MM-DD" optionally followed by " hh:mm:ss" or "Thh:mm:ss" (optionally "Z"). */
static bool reference_time_ok(const char *s)
{
    static const char pattern[] = "dddd-dd-dd dd:dd:dd";
    size_t n = strlen(s);
    if (n > 0 && s[n - 1] == 'Z') n--;
    if (n != 10 && n != 19) return false;
    for (size_t i = 0; i < n; i++) {
        const char p = pattern[i], c = s[i];
        if (p == 'd' && !(c >= '0' && c <= '9')) return false;
        if (p == ' ' && c != ' ' && c != 'T') return false;
        if (p != 'd' && p != ' ' && c != p) return false;
    }
    return true;
}

static void history_text(char *buf, size_t size)
{
    time_t now = time(NULL);
    const char *epoch = getenv("SOURCE_DATE_EPOCH");
    if (epoch && *epoch) {
        char *end = NULL;
        long long v = strtoll(epoch, &end, 10);
        if (end && !*end && v >= 0) now = (time_t)v;
    }
    struct tm tm;
    char stamp[32] = "unknown time";
    if (gmtime_r(&now, &tm)) strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
    snprintf(buf, size, "%s squall %s: written", stamp, SQ_VERSION_STRING);
}

typedef struct nc_writer {
    sq_context *ctx;
    const char *path;
    int ncid;
} nc_writer;

static sq_result nc_fail(const nc_writer *w, int status, const char *doing)
{
    /* the file is built in memory (nc_memory.c): a full disk is reported by the write */
    return sq__fail(w->ctx, status == NC_ENOMEM ? SQ_ERR_OUT_OF_MEMORY : SQ_ERR_IO, "io",
                    "cannot write '%s' (%s): %s", w->path, doing, nc_strerror(status));
}

static int put_text(int ncid, int varid, const char *name, const char *text)
{
    return nc_put_att_text(ncid, varid, name, strlen(text), text);
}

/* Defines a coordinate variable with its attributes. dim < 0: a scalar coordinate. */
static int def_coord(int ncid, const char *name, int dim, const char *units, const char *axis,
                     const char *standard_name, const char *long_name, int *varid)
{
    int st = nc_def_var(ncid, name, NC_DOUBLE, dim >= 0 ? 1 : 0, dim >= 0 ? &dim : NULL, varid);
    if (st == NC_NOERR) st = put_text(ncid, *varid, "units", units);
    if (st == NC_NOERR && axis) st = put_text(ncid, *varid, "axis", axis);
    if (st == NC_NOERR && standard_name)
        st = put_text(ncid, *varid, "standard_name", standard_name);
    if (st == NC_NOERR) st = put_text(ncid, *varid, "long_name", long_name);
    return st;
}

static int put_axis(int ncid, int varid, size_t n, double origin, double spacing)
{
    /* Written in blocks to bound the stack; coordinates are exact multiples of the spacing. */
    double buf[256];
    int st = NC_NOERR;
    for (size_t i0 = 0; i0 < n && st == NC_NOERR; i0 += 256) {
        size_t m = n - i0 < 256 ? n - i0 : 256;
        for (size_t i = 0; i < m; i++) buf[i] = origin + (double)(i0 + i) * spacing;
        st = nc_put_vara_double(ncid, varid, &i0, &m, buf);
    }
    return st;
}

/* The scalar level coordinate of a 2D map: one variable per distinct (kind, value). */
#define SQ__NC_MAX_LEVELS 32
typedef struct nc_level {
    sq_field_level kind;
    double value;
    char name[48];
    int varid;
} nc_level;

static void level_name(const nc_level *l, int index, int same_kind, char *buf, size_t size)
{
    const char *base = l->kind == SQ_FIELD_LEVEL_HEIGHT ? "height" : "z";
    if (same_kind <= 1) {
        snprintf(buf, size, "%s", base);
        return;
    }
    char v[24];
    snprintf(v, sizeof v, "%g", l->value);
    for (char *c = v; *c; c++)
        if (*c == '.') *c = 'p';
        else if (*c == '-') *c = 'm';
        else if (*c == '+') *c = '_';
    int n = snprintf(buf, size, "%s_%sm", base, v);
    if (n < 0 || (size_t)n >= size) snprintf(buf, size, "%s_%d", base, index);
}

/* Writes field f of record 0, slab by slab, with invalid cells and NaN as the fill value. */
static int put_field(nc_writer *w, int varid, const sq_named_field *f, bool has_z, float *slab)
{
    const size_t nxy = (size_t)f->nx * (size_t)f->ny;
    int st = NC_NOERR;
    for (int k = 0; k < f->nz && st == NC_NOERR; k++) {
        const float *src = f->data + (size_t)k * nxy;
        const uint8_t *inv = f->invalid ? f->invalid + (size_t)k * nxy : NULL;
        for (size_t c = 0; c < nxy; c++)
            slab[c] = (inv && inv[c]) || isnan(src[c]) ? NC_FILL_FLOAT : src[c];
        size_t start[4] = {0, 0, 0, 0}, count[4] = {1, 1, 1, 1};
        int d = 1;
        if (has_z) start[d++] = (size_t)k;
        count[d] = (size_t)f->ny;
        count[d + 1] = (size_t)f->nx;
        st = nc_put_vara_float(w->ncid, varid, start, count, slab);
    }
    return st;
}

/* Defines, fills and closes the file; ncid is open in define mode. */
static sq_result write_contents(nc_writer *w, const sq_field_file_desc *desc,
                                const sq_named_field *fields, int count, const char *reference)
{
    const int ncid = w->ncid;
    const sq_named_field *g = &fields[0];
    const bool has_z_dim = g->nz > 1;
    const bool georef = desc->crs_wkt && *desc->crs_wkt;
    const double off_x = georef ? desc->crs_offset_m[0] : 0.0;
    const double off_y = georef ? desc->crs_offset_m[1] : 0.0;
    int dim_t, dim_z = -1, dim_y, dim_x;
    int st = nc_def_dim(ncid, "time", NC_UNLIMITED, &dim_t);
    if (st == NC_NOERR && has_z_dim) st = nc_def_dim(ncid, "z", (size_t)g->nz, &dim_z);
    if (st == NC_NOERR) st = nc_def_dim(ncid, "y", (size_t)g->ny, &dim_y);
    if (st == NC_NOERR) st = nc_def_dim(ncid, "x", (size_t)g->nx, &dim_x);
    if (st != NC_NOERR) return nc_fail(w, st, "defining dimensions");

    int var_t, var_z = -1, var_y, var_x, var_crs = -1;
    char time_units[64];
    snprintf(time_units, sizeof time_units, "seconds since %s", reference);
    st = def_coord(ncid, "time", dim_t, time_units, "T", "time", "simulation time", &var_t);
    if (st == NC_NOERR) st = put_text(ncid, var_t, "calendar", "standard");
    if (st == NC_NOERR && has_z_dim) {
        st = def_coord(ncid, "z", dim_z, "m", "Z", "altitude", "altitude of cell centres", &var_z);
        if (st == NC_NOERR) st = put_text(ncid, var_z, "positive", "up");
    }
    if (st == NC_NOERR)
        st = def_coord(ncid, "y", dim_y, "m", "Y", "projection_y_coordinate",
                       georef ? "northing of cell centres" : "y (north) of cell centres", &var_y);
    if (st == NC_NOERR)
        st = def_coord(ncid, "x", dim_x, "m", "X", "projection_x_coordinate",
                       georef ? "easting of cell centres" : "x (east) of cell centres", &var_x);
    if (st == NC_NOERR && georef) {
        st = nc_def_var(ncid, "crs", NC_INT, 0, NULL, &var_crs);
        if (st == NC_NOERR) st = put_text(ncid, var_crs, "crs_wkt", desc->crs_wkt);
        if (st == NC_NOERR) st = put_text(ncid, var_crs, "spatial_ref", desc->crs_wkt);
        if (st == NC_NOERR)
            st = put_text(ncid, var_crs, "long_name", "coordinate reference system of x and y");
    }
    if (st != NC_NOERR) return nc_fail(w, st, "defining coordinates");

    /* levels of the 2D maps */
    nc_level levels[SQ__NC_MAX_LEVELS];
    int nlev = 0;
    int *level_of = (int *)sq_alloc(w->ctx, sizeof(int) * (size_t)count);
    if (!level_of) return sq__io_relog(w->ctx, SQ_ERR_OUT_OF_MEMORY);
    for (int i = 0; i < count; i++) {
        level_of[i] = -1;
        if (has_z_dim || fields[i].level == SQ_FIELD_LEVEL_SURFACE) continue;
        const double v = (double)fields[i].origin_m.z;
        int L = 0;
        while (L < nlev && !(levels[L].kind == fields[i].level && levels[L].value == v)) L++;
        if (L == nlev) {
            if (nlev == SQ__NC_MAX_LEVELS) {
                sq_free(w->ctx, level_of);
                return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "io",
                                "NetCDF file '%s': 2D maps at more than %d levels", w->path,
                                SQ__NC_MAX_LEVELS);
            }
            levels[nlev].kind = fields[i].level;
            levels[nlev].value = v;
            nlev++;
        }
        level_of[i] = L;
    }
    for (int L = 0; L < nlev && st == NC_NOERR; L++) {
        int same = 0;
        for (int M = 0; M < nlev; M++) same += levels[M].kind == levels[L].kind;
        level_name(&levels[L], L, same, levels[L].name, sizeof levels[L].name);
        const bool h = levels[L].kind == SQ_FIELD_LEVEL_HEIGHT;
        st = def_coord(ncid, levels[L].name, -1, "m", "Z", h ? "height" : "altitude",
                       h ? "height above the terrain surface" : "altitude of the slice",
                       &levels[L].varid);
        if (st == NC_NOERR) st = put_text(ncid, levels[L].varid, "positive", "up");
    }
    if (st != NC_NOERR) {
        sq_free(w->ctx, level_of);
        return nc_fail(w, st, "defining levels");
    }

    int dims4[4], nd = 0;
    dims4[nd++] = dim_t;
    if (has_z_dim) dims4[nd++] = dim_z;
    dims4[nd++] = dim_y;
    dims4[nd++] = dim_x;
    int *varids = (int *)sq_alloc(w->ctx, sizeof(int) * (size_t)count);
    float *slab = (float *)sq_alloc(w->ctx, sizeof(float) * (size_t)g->nx * (size_t)g->ny);
    if (!varids || !slab) {
        sq_free(w->ctx, varids);
        sq_free(w->ctx, slab);
        sq_free(w->ctx, level_of);
        return sq__io_relog(w->ctx, SQ_ERR_OUT_OF_MEMORY);
    }
    const float fill = NC_FILL_FLOAT;
    char doing[192] = "";
    for (int i = 0; i < count && st == NC_NOERR; i++) {
        const sq_named_field *f = &fields[i];
        snprintf(doing, sizeof doing, "defining variable '%s'", f->name);
        st = nc_def_var(ncid, f->name, NC_FLOAT, nd, dims4, &varids[i]);
        if (st == NC_NOERR) st = nc_def_var_fill(ncid, varids[i], 0, &fill);
        if (st == NC_NOERR && f->units && *f->units)
            st = put_text(ncid, varids[i], "units", f->units);
        if (st == NC_NOERR)
            st = put_text(ncid, varids[i], "long_name",
                          f->long_name && *f->long_name ? f->long_name : f->name);
        if (st == NC_NOERR && f->standard_name && *f->standard_name)
            st = put_text(ncid, varids[i], "standard_name", f->standard_name);
        if (st == NC_NOERR && level_of[i] >= 0)
            st = put_text(ncid, varids[i], "coordinates", levels[level_of[i]].name);
        if (st == NC_NOERR && georef) st = put_text(ncid, varids[i], "grid_mapping", "crs");
    }
    if (st == NC_NOERR) {
        char history[128];
        history_text(history, sizeof history);
        char source[128];
        snprintf(source, sizeof source, "squall %s", SQ_VERSION_STRING);
        snprintf(doing, sizeof doing, "global attributes");
        st = put_text(ncid, NC_GLOBAL, "Conventions", "CF-1.8");
        if (st == NC_NOERR)
            st = put_text(ncid, NC_GLOBAL, "title",
                          desc->title && *desc->title ? desc->title : "squall fields");
        if (st == NC_NOERR)
            st = put_text(ncid, NC_GLOBAL, "source",
                          desc->source && *desc->source ? desc->source : source);
        if (st == NC_NOERR) st = put_text(ncid, NC_GLOBAL, "history", history);
    }
    if (st == NC_NOERR) {
        snprintf(doing, sizeof doing, "leaving define mode");
        st = nc_enddef(ncid);
    }
    if (st == NC_NOERR) {
        snprintf(doing, sizeof doing, "writing coordinates");
        const size_t t0 = 0, t1 = 1;
        st = nc_put_vara_double(ncid, var_t, &t0, &t1, &desc->time_s);
        if (st == NC_NOERR && has_z_dim)
            st = put_axis(ncid, var_z, (size_t)g->nz, (double)g->origin_m.z, (double)g->spacing_m.z);
        for (int L = 0; L < nlev && st == NC_NOERR; L++)
            st = nc_put_var_double(ncid, levels[L].varid, &levels[L].value);
        if (st == NC_NOERR)
            st = put_axis(ncid, var_y, (size_t)g->ny, (double)g->origin_m.y + off_y,
                          (double)g->spacing_m.y);
        if (st == NC_NOERR)
            st = put_axis(ncid, var_x, (size_t)g->nx, (double)g->origin_m.x + off_x,
                          (double)g->spacing_m.x);
        if (st == NC_NOERR && georef) st = nc_put_var_int(ncid, var_crs, &(int){0});
    }
    for (int i = 0; i < count && st == NC_NOERR; i++) {
        snprintf(doing, sizeof doing, "writing variable '%s'", fields[i].name);
        st = put_field(w, varids[i], &fields[i], has_z_dim, slab);
    }
    sq_free(w->ctx, varids);
    sq_free(w->ctx, slab);
    sq_free(w->ctx, level_of);
    if (st != NC_NOERR) return nc_fail(w, st, doing);
    return SQ_OK;
}

sq_result sq_netcdf_write_fields(sq_context *ctx, const sq_field_file_desc *desc,
                                 const sq_named_field *fields, int count)
{
    sq_result r = sq__field_file_check(ctx, desc, fields, count, "NetCDF file");
    if (r != SQ_OK) return r;
    const char *reference = desc->reference_time ? desc->reference_time : SQ__NC_DEFAULT_REFERENCE;
    if (!reference_time_ok(reference))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                        "NetCDF file '%s': reference_time = '%s'; must be \"YYYY-MM-DD\" or "
                        "\"YYYY-MM-DD hh:mm:ss\"",
                        desc->path, reference);
    r = sq_output_check_inputs(ctx, desc->path, false);
    if (r == SQ_OK) r = sq__io_relog(ctx, sq_output_check(desc->path, desc->overwrite));
    if (r != SQ_OK) return r;

    nc_writer w = {.ctx = ctx, .path = desc->path, .ncid = -1};
    size_t bytes = 65536;
    for (int i = 0; i < count; i++)
        bytes += (size_t)fields[i].nx * (size_t)fields[i].ny * (size_t)fields[i].nz * sizeof(float);
    int st = sq__nc_create_memory(desc->path, NC_NETCDF4 | NC_CLASSIC_MODEL, bytes, &w.ncid);
    if (st != NC_NOERR) return nc_fail(&w, st, "creating it in memory");
    r = write_contents(&w, desc, fields, count, reference);
    if (r == SQ_OK)
        r = sq__nc_write_memory(ctx, w.ncid, desc->path, desc->overwrite, "io");
    else
        nc_abort(w.ncid);
    if (r == SQ_OK) sq_log(ctx, SQ_LOG_INFO, "io", "wrote '%s' (%d fields)", desc->path, count);
    return r;
}

#else /* !SQ_HAVE_NETCDF */

sq_result sq_netcdf_write_fields(sq_context *ctx, const sq_field_file_desc *desc,
                                 const sq_named_field *fields, int count)
{
    (void)desc;
    (void)fields;
    (void)count;
    return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "io",
                    "squall was built without NetCDF support (SQ_WITH_NETCDF=OFF); write VTK "
                    "(.vti) instead");
}

#endif
