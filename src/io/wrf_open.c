/* wrf_open.c — opening wrfout files as one time series (include/squall/wrf.h): each file is
 * checked before any field is read — a regular file, NetCDF (classic or netCDF-4/HDF5), the WRF
 * variables present with the shapes their dimensions imply, the projection attributes, the Times
 * strings — and the files' times are merged in order. Sizes come from the dimension lengths,
 * never from the *_GRID_DIMENSION attributes (cropped files keep the original domain's); the
 * time-string dimension is the second dimension of Times, whatever its name. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "io/io_internal.h"
#include "io/nc3_header.h"
#include "io/wrf_internal.h"

#if SQ_HAVE_NETCDF && SQ_HAVE_PROJ
#include <netcdf.h>

static const char *const species_name[SQ_WRF_SPECIES_COUNT] = {"cloud_water", "cloud_ice", "snow",
                                                               "rain", "graupel"};
static const char *const species_var[SQ_WRF_SPECIES_COUNT] = {"QCLOUD", "QICE", "QSNOW", "QRAIN",
                                                              "QGRAUP"};

const char *sq_wrf_species_name(sq_wrf_species s)
{
    return (unsigned)s < SQ_WRF_SPECIES_COUNT ? species_name[s] : "unknown";
}

const char *sq_wrf_species_variable(sq_wrf_species s)
{
    return (unsigned)s < SQ_WRF_SPECIES_COUNT ? species_var[s] : "unknown";
}

/* Dimensions a variable may have (after an optional leading Time). */
enum { D_WE, D_SN, D_BT, D_WES, D_SNS, D_BTS, D_COUNT };
static const char *const dim_name[D_COUNT] = {"west_east",      "south_north",
                                              "bottom_top",     "west_east_stag",
                                              "south_north_stag", "bottom_top_stag"};

typedef struct var_spec {
    const char *name;
    bool required;
    int nd;
    int dims[3];
} var_spec;

static const var_spec var_specs[WV_COUNT] = {
    [WV_PH] = {"PH", true, 3, {D_BTS, D_SN, D_WE}},
    [WV_PHB] = {"PHB", true, 3, {D_BTS, D_SN, D_WE}},
    [WV_P] = {"P", true, 3, {D_BT, D_SN, D_WE}},
    [WV_PB] = {"PB", true, 3, {D_BT, D_SN, D_WE}},
    [WV_T] = {"T", true, 3, {D_BT, D_SN, D_WE}},
    [WV_QVAPOR] = {"QVAPOR", true, 3, {D_BT, D_SN, D_WE}},
    [WV_U] = {"U", true, 3, {D_BT, D_SN, D_WES}},
    [WV_V] = {"V", true, 3, {D_BT, D_SNS, D_WE}},
    [WV_W] = {"W", true, 3, {D_BTS, D_SN, D_WE}},
    [WV_HGT] = {"HGT", true, 2, {D_SN, D_WE}},
    [WV_QCLOUD] = {"QCLOUD", false, 3, {D_BT, D_SN, D_WE}},
    [WV_QICE] = {"QICE", false, 3, {D_BT, D_SN, D_WE}},
    [WV_QSNOW] = {"QSNOW", false, 3, {D_BT, D_SN, D_WE}},
    [WV_QRAIN] = {"QRAIN", false, 3, {D_BT, D_SN, D_WE}},
    [WV_QGRAUP] = {"QGRAUP", false, 3, {D_BT, D_SN, D_WE}},
    [WV_QNICE] = {"QNICE", false, 3, {D_BT, D_SN, D_WE}},
    [WV_QNRAIN] = {"QNRAIN", false, 3, {D_BT, D_SN, D_WE}},
    [WV_CLDFRA] = {"CLDFRA", false, 3, {D_BT, D_SN, D_WE}},
};
static const var_spec latlon_spec[2] = {{"XLAT", true, 2, {D_SN, D_WE}},
                                        {"XLONG", true, 2, {D_SN, D_WE}}};

/* Per-file dimension facts while opening. */
typedef struct file_dims {
    int time_dim;
    int dim[D_COUNT];
    size_t len[D_COUNT];
    size_t time_len;
} file_dims;

static sq_result nc_error(sq_wrf *w, const char *path, int st, const char *what)
{
    sq_result r = st == NC_ENOMEM ? SQ_ERR_OUT_OF_MEMORY : SQ_ERR_PARSE;
    return sq__fail(w->ctx, r, "wrf", "%s: %s: %s", path, what, nc_strerror(st));
}

static sq_result check_regular_file(sq_wrf *w, const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return sq__fail(w->ctx, SQ_ERR_IO, "wrf", "%s: cannot open: %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode)) {
        const char *kind = S_ISDIR(st.st_mode)    ? "a directory"
                           : S_ISFIFO(st.st_mode) ? "a FIFO"
                           : S_ISCHR(st.st_mode)  ? "a character device"
                           : S_ISSOCK(st.st_mode) ? "a socket"
                                                  : "not a regular file";
        return sq__fail(w->ctx, SQ_ERR_IO, "wrf",
                        "%s: is %s; a WRF file must be a regular file", path, kind);
    }
    return SQ_OK;
}

/* "(Time=4, bottom_top=27, ...)" of a variable. */
static void shape_text(int ncid, int varid, char *buf, size_t size)
{
    int nd = 0, dims[NC_MAX_VAR_DIMS];
    buf[0] = 0;
    if (nc_inq_varndims(ncid, varid, &nd) != NC_NOERR || nc_inq_vardimid(ncid, varid, dims))
        return;
    size_t used = (size_t)snprintf(buf, size, "(");
    for (int d = 0; d < nd && used < size; d++) {
        char name[NC_MAX_NAME + 1] = "?";
        size_t len = 0;
        nc_inq_dim(ncid, dims[d], name, &len);
        used += (size_t)snprintf(buf + used, size - used, "%s%s=%zu", d ? ", " : "", name, len);
    }
    if (used < size) snprintf(buf + used, size - used, ")");
}

static void expected_text(const var_spec *s, bool with_time, char *buf, size_t size)
{
    size_t used = (size_t)snprintf(buf, size, "(%s", with_time ? "Time, " : "");
    for (int d = 0; d < s->nd && used < size; d++)
        used += (size_t)snprintf(buf + used, size - used, "%s%s", d ? ", " : "",
                                 dim_name[s->dims[d]]);
    if (used < size) snprintf(buf + used, size - used, ")");
}

/* Checks the shape of a numeric variable: the spec's dimensions, with or without a leading Time. */
static sq_result check_var(sq_wrf *w, const char *path, int ncid, const file_dims *fd,
                           const var_spec *s, int varid, bool *has_time)
{
    nc_type type;
    int nd = 0, dims[NC_MAX_VAR_DIMS];
    int st = nc_inq_var(ncid, varid, NULL, &type, &nd, dims, NULL);
    if (st != NC_NOERR) return nc_error(w, path, st, s->name);
    if (type == NC_CHAR || type == NC_STRING)
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: variable '%s' holds text; WRF writes it as numbers", path, s->name);
    bool ok = false, t = false;
    if (nd == s->nd + 1 && dims[0] == fd->time_dim) {
        t = true;
        ok = true;
        for (int d = 0; d < s->nd; d++) ok = ok && dims[d + 1] == fd->dim[s->dims[d]];
    } else if (nd == s->nd) {
        ok = true;
        for (int d = 0; d < s->nd; d++) ok = ok && dims[d] == fd->dim[s->dims[d]];
    }
    if (!ok) {
        char have[256], want[160];
        shape_text(ncid, varid, have, sizeof have);
        expected_text(s, true, want, sizeof want);
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: variable '%s' has the shape %s; expected %s", path, s->name, have,
                        want);
    }
    *has_time = t;
    return SQ_OK;
}

static sq_result find_dims(sq_wrf *w, const char *path, int ncid, int varid_times, file_dims *fd)
{
    /* the time dimension and the string length: the two dimensions of Times, found by shape */
    nc_type type;
    int nd = 0, dims[NC_MAX_VAR_DIMS];
    int st = nc_inq_var(ncid, varid_times, NULL, &type, &nd, dims, NULL);
    if (st != NC_NOERR) return nc_error(w, path, st, "Times");
    size_t slen = 0;
    if (type != NC_CHAR || nd != 2 || nc_inq_dimlen(ncid, dims[1], &slen) != NC_NOERR ||
        slen < 19 || slen > 256) {
        char have[256];
        shape_text(ncid, varid_times, have, sizeof have);
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: variable 'Times' is %s %s; expected characters (Time, 19)", path,
                        type == NC_CHAR ? "char" : "numeric", have);
    }
    fd->time_dim = dims[0];
    nc_inq_dimlen(ncid, dims[0], &fd->time_len);
    for (int d = 0; d < D_COUNT; d++) {
        st = nc_inq_dimid(ncid, dim_name[d], &fd->dim[d]);
        if (st != NC_NOERR)
            return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                            "%s: not WRF output: dimension '%s' is missing", path, dim_name[d]);
        nc_inq_dimlen(ncid, fd->dim[d], &fd->len[d]);
    }
    const size_t nx = fd->len[D_WE], ny = fd->len[D_SN], nz = fd->len[D_BT];
    if (nx < 2 || ny < 2 || nz < 1 || nx > 100000 || ny > 100000 || nz > 10000)
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: grid of %zu x %zu x %zu mass points; each horizontal size must be "
                        "2..100000 and bottom_top 1..10000",
                        path, nx, ny, nz);
    const struct {
        int d;
        size_t want;
    } stag[3] = {{D_WES, nx + 1}, {D_SNS, ny + 1}, {D_BTS, nz + 1}};
    for (int s = 0; s < 3; s++)
        if (fd->len[stag[s].d] != stag[s].want)
            return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                            "%s: dimension '%s' = %zu; a staggered dimension must be one longer "
                            "than '%s' (%zu)",
                            path, dim_name[stag[s].d], fd->len[stag[s].d],
                            dim_name[stag[s].d - 3], stag[s].want - 1);
    if (fd->time_len < 1)
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf", "%s: the Time dimension is empty", path);
    if (fd->time_len > 1000000)
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: the Time dimension has %zu entries; at most 1000000", path,
                        fd->time_len);
    return SQ_OK;
}

/* Global numeric attribute; *found = false when absent. */
static sq_result att_double(sq_wrf *w, const char *path, int ncid, const char *name, bool required,
                            const char *why, double *out, bool *found)
{
    nc_type type;
    size_t len = 0;
    if (found) *found = false;
    int st = nc_inq_att(ncid, NC_GLOBAL, name, &type, &len);
    if (st != NC_NOERR) {
        if (!required) return SQ_OK;
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf", "%s: global attribute '%s' is missing%s",
                        path, name, why);
    }
    double v = NAN;
    if (type == NC_CHAR || type == NC_STRING || len != 1 ||
        nc_get_att_double(ncid, NC_GLOBAL, name, &v) != NC_NOERR || !isfinite(v))
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: global attribute '%s' must be one finite number", path, name);
    *out = v;
    if (found) *found = true;
    return SQ_OK;
}

static const char *projection_name(int code)
{
    switch (code) {
    case 1: return "Lambert conformal";
    case 2: return "polar stereographic";
    case 3: return "Mercator";
    case 6: return "latitude-longitude";
    default: return "unknown";
    }
}

/* Reads the projection attributes into info. */
static sq_result read_projection(sq_wrf *w, const char *path, int ncid, sq_wrf_info *in)
{
    double v = 0;
    sq_result r = att_double(w, path, ncid, "MAP_PROJ", true, "; WRF output names its map "
                             "projection", &v, NULL);
    if (r != SQ_OK) return r;
    in->map_proj = (int)v;
    if ((double)in->map_proj != v || !(in->map_proj == 1 || in->map_proj == 2 ||
                                        in->map_proj == 3 || in->map_proj == 6))
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: global attribute MAP_PROJ = %g: unknown map projection; supported "
                        "are 1 (Lambert conformal), 2 (polar stereographic), 3 (Mercator) and 6 "
                        "(latitude-longitude)",
                        path, v);
    in->projection = (sq_wrf_projection)in->map_proj;
    in->projection_name = projection_name(in->map_proj);
    char why[96];
    snprintf(why, sizeof why, " (needed for MAP_PROJ = %d, %s)", in->map_proj,
             in->projection_name);
    r = att_double(w, path, ncid, "DX", true, why, &in->dx_m, NULL);
    if (r == SQ_OK) r = att_double(w, path, ncid, "DY", true, why, &in->dy_m, NULL);
    if (r != SQ_OK) return r;
    if (!(in->dx_m > 0.0) || !(in->dy_m > 0.0))
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: global attributes DX = %g, DY = %g; grid spacings must be > 0", path,
                        in->dx_m, in->dy_m);
    const bool lcc = in->map_proj == 1, ps = in->map_proj == 2, merc = in->map_proj == 3;
    const bool ll = in->map_proj == 6;
    bool found = false;
    r = att_double(w, path, ncid, "STAND_LON", true, why, &in->stand_lon_deg, NULL);
    if (r == SQ_OK) r = att_double(w, path, ncid, "TRUELAT1", lcc || ps || merc, why,
                                   &in->truelat1_deg, NULL);
    if (r == SQ_OK) r = att_double(w, path, ncid, "TRUELAT2", false, why, &in->truelat2_deg, &found);
    if (r == SQ_OK && !found) in->truelat2_deg = in->truelat1_deg;
    if (r == SQ_OK) r = att_double(w, path, ncid, "MOAD_CEN_LAT", lcc, why, &in->moad_cen_lat_deg,
                                   &found);
    if (r == SQ_OK && !found) in->moad_cen_lat_deg = in->truelat1_deg;
    in->pole_lat_deg = 90.0;
    in->pole_lon_deg = 0.0;
    if (r == SQ_OK) r = att_double(w, path, ncid, "POLE_LAT", false, why, &in->pole_lat_deg, NULL);
    if (r == SQ_OK) r = att_double(w, path, ncid, "POLE_LON", false, why, &in->pole_lon_deg, NULL);
    if (r != SQ_OK) return r;
    if ((lcc || ps) && (fabs(in->truelat1_deg) > 90.0 || fabs(in->truelat2_deg) > 90.0 ||
                        in->truelat1_deg == 0.0))
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: TRUELAT1 = %g, TRUELAT2 = %g: a %s projection needs true latitudes "
                        "in [-90, 90], TRUELAT1 != 0",
                        path, in->truelat1_deg, in->truelat2_deg, in->projection_name);
    if (lcc && in->truelat1_deg * in->truelat2_deg < 0.0)
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: TRUELAT1 = %g and TRUELAT2 = %g lie in different hemispheres", path,
                        in->truelat1_deg, in->truelat2_deg);
    if (merc && fabs(in->truelat1_deg) >= 90.0)
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: TRUELAT1 = %g; Mercator needs |TRUELAT1| < 90", path,
                        in->truelat1_deg);
    (void)ll;
    in->earth_radius_m = SQ__WRF_EARTH_RADIUS_M;
    return SQ_OK;
}

/* Parses "YYYY-MM-DD_hh:mm:ss" (also ' ' or 'T' between date and time). */
static bool parse_time(const char *s, double *unix_s)
{
    int y, mo, d, h, mi, sec;
    char sep;
    if (sscanf(s, "%4d-%2d-%2d%c%2d:%2d:%2d", &y, &mo, &d, &sep, &h, &mi, &sec) != 7) return false;
    if (sep != '_' && sep != ' ' && sep != 'T') return false;
    if (mo < 1 || mo > 12 || d < 1 || d > 31 || h < 0 || h > 23 || mi < 0 || mi > 59 || sec < 0 ||
        sec > 60)
        return false;
    *unix_s = sq_unix_time(y, mo, d, h, mi, (double)sec);
    return true;
}

static sq_result read_times(sq_wrf *w, const char *path, int ncid, int varid, size_t nt,
                            int file_index, wrf_entry *dst)
{
    size_t slen = 0;
    int dims[2];
    nc_inq_vardimid(ncid, varid, dims);
    nc_inq_dimlen(ncid, dims[1], &slen);
    char *buf = (char *)sq_alloc(w->ctx, nt * slen + 1);
    if (!buf) return SQ_ERR_OUT_OF_MEMORY;
    const size_t start[2] = {0, 0}, count[2] = {nt, slen};
    int st = nc_get_vara_text(ncid, varid, start, count, buf);
    sq_result r = SQ_OK;
    if (st != NC_NOERR) r = nc_error(w, path, st, "reading variable 'Times'");
    for (size_t t = 0; t < nt && r == SQ_OK; t++) {
        char text[64] = {0};
        memcpy(text, buf + t * slen, slen < 63 ? slen : 63);
        for (int c = (int)strlen(text) - 1; c >= 0 && (text[c] == ' ' || text[c] == 0); c--)
            text[c] = 0;
        double u = 0;
        if (!parse_time(text, &u) || strlen(text) != 19)
            r = sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                         "%s: Times[%zu] = '%.40s'; expected YYYY-MM-DD_hh:mm:ss", path, t, text);
        dst[t].file = file_index;
        dst[t].local = (int)t;
        dst[t].unix_s = u;
        memcpy(dst[t].text, text, 19);
        dst[t].text[10] = '_';
        dst[t].text[19] = 0;
    }
    sq_free(w->ctx, buf);
    return r;
}

static sq_result text_att(int ncid, const char *name, char *buf, size_t size)
{
    nc_type type;
    size_t len = 0;
    buf[0] = 0;
    if (nc_inq_att(ncid, NC_GLOBAL, name, &type, &len) != NC_NOERR || type != NC_CHAR) return SQ_OK;
    char *tmp = (char *)malloc(len + 1);
    if (!tmp) return SQ_OK;
    if (nc_get_att_text(ncid, NC_GLOBAL, name, tmp) == NC_NOERR) {
        tmp[len] = 0;
        const char *p = tmp;
        while (*p == ' ') p++;
        snprintf(buf, size, "%s", p);
    }
    free(tmp);
    return SQ_OK;
}

/* Opens and checks one file; the first one (index 0) sets the series' grid and projection,
 * later ones must match it. Appends its times to *entries. */
static sq_result open_file(sq_wrf *w, int index, const char *path, wrf_entry **entries,
                           int *entry_count)
{
    wrf_file *f = &w->files[index];
    f->ncid = -1;
    size_t plen = strlen(path) + 1;
    f->path = (char *)sq_alloc(w->ctx, plen);
    if (!f->path) return SQ_ERR_OUT_OF_MEMORY;
    memcpy(f->path, path, plen);
    sq_result r = check_regular_file(w, path);
    if (r == SQ_OK) r = sq__input_guard(w->ctx, "wrf", "WRF file", path); /* never written */
    if (r == SQ_OK) r = sq__nc3_check_header(w->ctx, "wrf", path); /* before libnetcdf trusts it */
    if (r != SQ_OK) return r;
    int st = nc_open(path, NC_NOWRITE, &f->ncid);
    if (st != NC_NOERR) {
        f->ncid = -1;
        const char *what = st == NC_ENOTNC    ? "not a NetCDF file"
                           : st == NC_ETRUNC  ? "truncated NetCDF file"
                           : st == NC_EHDFERR ? "corrupt or truncated netCDF-4 file"
                                              : "cannot open as NetCDF";
        return nc_error(w, path, st, what);
    }
    const int ncid = f->ncid;
    /* presence of the variables, in the order of the message */
    static const char *const required[] = {"Times", "XLAT", "XLONG", "HGT", "PH", "PHB", "P",
                                           "PB",    "T",    "QVAPOR", "U",  "V",  "W"};
    const int nreq = (int)(sizeof required / sizeof required[0]);
    int missing = 0, first_missing = -1, varid = -1;
    for (int v = 0; v < nreq; v++)
        if (nc_inq_varid(ncid, required[v], &varid) != NC_NOERR) {
            if (first_missing < 0) first_missing = v;
            missing++;
        }
    if (missing > 0) {
        if (missing == 1)
            return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                            "%s: not WRF output: variable '%s' is missing", path,
                            required[first_missing]);
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: not WRF output: variable '%s' is missing (and %d more of Times, "
                        "XLAT, XLONG, HGT, PH, PHB, P, PB, T, QVAPOR, U, V, W)",
                        path, required[first_missing], missing - 1);
    }
    nc_inq_varid(ncid, "Times", &f->varid_times);
    nc_inq_varid(ncid, "XLAT", &f->varid_xlat);
    nc_inq_varid(ncid, "XLONG", &f->varid_xlong);
    file_dims fd;
    r = find_dims(w, path, ncid, f->varid_times, &fd);
    if (r != SQ_OK) return r;
    bool has_time = false;
    for (int v = 0; v < WV_COUNT; v++) {
        f->varid[v] = -1;
        if (nc_inq_varid(ncid, var_specs[v].name, &f->varid[v]) != NC_NOERR) {
            f->varid[v] = -1;
            continue;
        }
        r = check_var(w, path, ncid, &fd, &var_specs[v], f->varid[v], &has_time);
        if (r != SQ_OK) return r;
        f->var_time[v] = has_time;
    }
    bool lat_time = false, lon_time = false;
    r = check_var(w, path, ncid, &fd, &latlon_spec[0], f->varid_xlat, &lat_time);
    if (r == SQ_OK) r = check_var(w, path, ncid, &fd, &latlon_spec[1], f->varid_xlong, &lon_time);
    if (r != SQ_OK) return r;
    f->latlon_has_time = lat_time;
    if (lat_time != lon_time)
        return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                        "%s: XLAT %s a Time dimension but XLONG %s", path,
                        lat_time ? "has" : "has no", lon_time ? "has" : "has none");
    f->time_count = (int)fd.time_len;

    /* grid and projection: the first file sets them, the others must agree */
    sq_wrf_info in;
    memset(&in, 0, sizeof in);
    in.nx = (int)fd.len[D_WE];
    in.ny = (int)fd.len[D_SN];
    in.nz = (int)fd.len[D_BT];
    r = read_projection(w, path, ncid, &in);
    if (r != SQ_OK) return r;
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) in.has_species[s] = f->varid[WV_QCLOUD + s] >= 0;
    in.has_ice_number = f->varid[WV_QNICE] >= 0;
    in.has_rain_number = f->varid[WV_QNRAIN] >= 0;
    in.has_cloud_fraction = f->varid[WV_CLDFRA] >= 0;
    /* MP_PHYSICS is informative only: absent or malformed gives -1 */
    int mp = -1;
    nc_type mp_type;
    size_t mp_len = 0;
    if (nc_inq_att(ncid, NC_GLOBAL, "MP_PHYSICS", &mp_type, &mp_len) != NC_NOERR ||
        mp_len != 1 || mp_type == NC_CHAR || mp_type == NC_STRING ||
        nc_get_att_int(ncid, NC_GLOBAL, "MP_PHYSICS", &mp) != NC_NOERR)
        mp = -1;
    in.mp_physics = mp;
    if (index == 0) {
        w->info = in;
        text_att(ncid, "TITLE", w->title, sizeof w->title);
    } else {
        const sq_wrf_info *a = &w->info;
        const char *first = w->files[0].path;
        if (in.nx != a->nx || in.ny != a->ny || in.nz != a->nz)
            return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                            "%s: grid of %d x %d x %d points differs from %d x %d x %d in %s; "
                            "the files of one series must share the grid",
                            path, in.nx, in.ny, in.nz, a->nx, a->ny, a->nz, first);
        if (in.map_proj != a->map_proj || in.dx_m != a->dx_m || in.dy_m != a->dy_m ||
            in.truelat1_deg != a->truelat1_deg || in.truelat2_deg != a->truelat2_deg ||
            in.stand_lon_deg != a->stand_lon_deg || in.moad_cen_lat_deg != a->moad_cen_lat_deg ||
            in.pole_lat_deg != a->pole_lat_deg || in.pole_lon_deg != a->pole_lon_deg)
            return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                            "%s: projection (MAP_PROJ, DX, DY, TRUELAT1/2, STAND_LON, "
                            "MOAD_CEN_LAT, POLE_LAT/LON) differs from %s; the files of one "
                            "series must share the grid",
                            path, first);
        for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++)
            if (in.has_species[s] != a->has_species[s])
                return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                                "%s: variable '%s' is %s but %s in %s; the files of one series "
                                "must hold the same hydrometeors",
                                path, species_var[s], in.has_species[s] ? "present" : "missing",
                                a->has_species[s] ? "present" : "missing", first);
        if (in.has_ice_number != a->has_ice_number || in.has_rain_number != a->has_rain_number)
            return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                            "%s: QNICE/QNRAIN presence differs from %s", path, first);
        if (in.has_cloud_fraction != a->has_cloud_fraction)
            return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                            "%s: variable 'CLDFRA' is %s but %s in %s; the files of one series "
                            "must hold the same variables",
                            path, in.has_cloud_fraction ? "present" : "missing",
                            a->has_cloud_fraction ? "present" : "missing", first);
    }
    /* times */
    wrf_entry *grown = (wrf_entry *)sq_alloc(
        w->ctx, sizeof(wrf_entry) * (size_t)(*entry_count + f->time_count));
    if (!grown) return SQ_ERR_OUT_OF_MEMORY;
    if (*entry_count) memcpy(grown, *entries, sizeof(wrf_entry) * (size_t)*entry_count);
    sq_free(w->ctx, *entries);
    *entries = grown;
    r = read_times(w, path, ncid, f->varid_times, (size_t)f->time_count, index,
                   grown + *entry_count);
    if (r != SQ_OK) return r;
    *entry_count += f->time_count;
    return SQ_OK;
}

static int entry_cmp(const void *a, const void *b)
{
    const wrf_entry *x = (const wrf_entry *)a, *y = (const wrf_entry *)b;
    if (x->unix_s != y->unix_s) return x->unix_s < y->unix_s ? -1 : 1;
    if (x->file != y->file) return x->file < y->file ? -1 : 1;
    return x->local - y->local;
}

/* XLAT/XLONG of the first file (its first time when they have one), checked. */
static sq_result read_latlon(sq_wrf *w)
{
    const wrf_file *f = &w->files[0];
    const size_t nx = (size_t)w->info.nx, ny = (size_t)w->info.ny;
    char what[96];
    snprintf(what, sizeof what, "%s: XLAT, XLONG and HGT of %zu x %zu points", f->path, nx, ny);
    sq_result r = sq_context_check_memory(w->ctx, 3 * sizeof(float) * nx * ny, what);
    if (r != SQ_OK) return r;
    w->lat = (float *)sq_alloc(w->ctx, sizeof(float) * nx * ny);
    w->lon = (float *)sq_alloc(w->ctx, sizeof(float) * nx * ny);
    if (!w->lat || !w->lon) return SQ_ERR_OUT_OF_MEMORY;
    const size_t start[3] = {0, 0, 0};
    const size_t count3[3] = {1, ny, nx}, count2[2] = {ny, nx};
    const int nd = f->latlon_has_time ? 3 : 2;
    const size_t *count = f->latlon_has_time ? count3 : count2;
    r = sq__wrf_get_floats(w, f, f->varid_xlat, "XLAT", start, count, nd, w->lat);
    if (r == SQ_OK) r = sq__wrf_get_floats(w, f, f->varid_xlong, "XLONG", start, count, nd, w->lon);
    if (r != SQ_OK) return r;
    for (size_t c = 0; c < nx * ny; c++)
        if (fabsf(w->lat[c]) > 90.0f || fabsf(w->lon[c]) > 540.0f)
            return sq__fail(w->ctx, SQ_ERR_PARSE, "wrf",
                            "%s: %s = %g at (south_north %zu, west_east %zu); latitudes must be "
                            "in [-90, 90] and longitudes in [-540, 540] degrees",
                            f->path, fabsf(w->lat[c]) > 90.0f ? "XLAT" : "XLONG",
                            (double)(fabsf(w->lat[c]) > 90.0f ? w->lat[c] : w->lon[c]), c / nx,
                            c % nx);
    return SQ_OK;
}

sq_result sq_wrf_open(sq_context *ctx, const char *const *paths, int count, sq_wrf **out)
{
    if (out) *out = NULL;
    if (!ctx || !out || !paths || count < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "wrf",
                        "sq_wrf_open: needs a context, an output pointer and at least one path "
                        "(count = %d)",
                        count);
    for (int i = 0; i < count; i++)
        if (!paths[i] || !*paths[i])
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "wrf", "sq_wrf_open: path %d is empty", i);
    sq_wrf *w = (sq_wrf *)sq_alloc_zero(ctx, sizeof *w);
    if (!w) return SQ_ERR_OUT_OF_MEMORY;
    w->ctx = ctx;
    w->slot[0].index = w->slot[1].index = w->out.index = -1;
    w->files = (wrf_file *)sq_alloc_zero(ctx, sizeof(wrf_file) * (size_t)count);
    if (!w->files) {
        sq_wrf_close(w);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    for (int i = 0; i < count; i++) w->files[i].ncid = -1;
    w->file_count = count;
    wrf_entry *entries = NULL;
    int n = 0;
    sq_result r = SQ_OK;
    for (int i = 0; i < count && r == SQ_OK; i++) r = open_file(w, i, paths[i], &entries, &n);
    w->entries = entries;
    if (r == SQ_OK) {
        qsort(entries, (size_t)n, sizeof *entries, entry_cmp);
        for (int i = 1; i < n && r == SQ_OK; i++)
            if (entries[i].unix_s == entries[i - 1].unix_s)
                r = sq__fail(ctx, SQ_ERR_INVALID_ARG, "wrf",
                             "%s: time %s (Times[%d]) is also in %s (Times[%d]); the times of a "
                             "series must differ",
                             w->files[entries[i].file].path, entries[i].text, entries[i].local,
                             w->files[entries[i - 1].file].path, entries[i - 1].local);
    }
    if (r == SQ_OK) {
        w->times_s = (double *)sq_alloc(ctx, sizeof(double) * (size_t)n);
        w->time_ptrs = (const char **)sq_alloc(ctx, sizeof(char *) * (size_t)n);
        if (!w->times_s || !w->time_ptrs) r = SQ_ERR_OUT_OF_MEMORY;
    }
    if (r == SQ_OK) {
        for (int i = 0; i < n; i++) {
            w->times_s[i] = entries[i].unix_s - entries[0].unix_s;
            w->time_ptrs[i] = entries[i].text;
        }
        r = read_latlon(w);
    }
    if (r == SQ_OK) r = sq__wrf_read_hgt0(w);
    if (r == SQ_OK) r = sq__wrf_proj_setup(w, paths[0]);
    if (r != SQ_OK) {
        sq_wrf_close(w);
        return r;
    }
    sq_wrf_info *in = &w->info;
    in->time_count = n;
    in->times_s = w->times_s;
    in->time_strings = w->time_ptrs;
    in->start_unix_s = entries[0].unix_s;
    in->duration_s = w->times_s[n - 1];
    in->file_count = count;
    in->title = w->title;
    in->proj_string = w->proj_string;
    in->crs_wkt = w->crs_wkt;
    sq_log(ctx, SQ_LOG_INFO, "wrf", "opened %d file(s): %d x %d x %d points, %d times, %s",
           count, in->nx, in->ny, in->nz, n, in->projection_name);
    *out = w;
    return SQ_OK;
}

void sq_wrf_close(sq_wrf *w)
{
    if (!w) return;
    sq_context *ctx = w->ctx;
    sq__wrf_free_buffers(w);
    sq__wrf_proj_free(w);
    if (w->files)
        for (int i = 0; i < w->file_count; i++) {
            if (w->files[i].ncid >= 0) nc_close(w->files[i].ncid);
            sq_free(ctx, w->files[i].path);
        }
    sq_free(ctx, w->files);
    sq_free(ctx, w->entries);
    sq_free(ctx, w->times_s);
    sq_free(ctx, (void *)w->time_ptrs);
    sq_free(ctx, w->lat);
    sq_free(ctx, w->lon);
    sq_free(ctx, w->xw);
    sq_free(ctx, w->yw);
    sq_free(ctx, w->hgt0);
    sq_free(ctx, w->crs_wkt);
    sq_free(ctx, w);
}

void sq_wrf_get_info(const sq_wrf *w, sq_wrf_info *out)
{
    if (!out) return;
    if (!w) {
        memset(out, 0, sizeof *out);
        return;
    }
    *out = w->info;
}

#else /* without NetCDF or PROJ */

const char *sq_wrf_species_name(sq_wrf_species s)
{
    (void)s;
    return "unknown";
}

const char *sq_wrf_species_variable(sq_wrf_species s)
{
    (void)s;
    return "unknown";
}

sq_result sq_wrf_open(sq_context *ctx, const char *const *paths, int count, sq_wrf **out)
{
    (void)paths;
    (void)count;
    if (out) *out = NULL;
    return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "wrf",
                    "squall was built without the WRF reader (it needs NetCDF and PROJ)");
}

void sq_wrf_close(sq_wrf *w) { (void)w; }

void sq_wrf_get_info(const sq_wrf *w, sq_wrf_info *out)
{
    (void)w;
    if (out) memset(out, 0, sizeof *out);
}

#endif
