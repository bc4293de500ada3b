/* wrf_read.c — reading the fields of a WRF series (include/squall/wrf.h): one stored time is read
 * variable by variable, every value checked (finite, not the fill value, pressure and
 * temperature positive, mixing ratios >= 0 after clamping rounding noise), derived on the mass
 * points (wrf_derive.c) and cached; a time between two stored times is their linear
 * interpolation. Also the value ranges over the series, the column cloud optical depth and the
 * world description (terrain, georeference, sun). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "io/wrf_internal.h"
#include "squall/optics.h"

#if SQ_HAVE_NETCDF && SQ_HAVE_PROJ
#include <netcdf.h>

static const char *const var_name[WV_COUNT] = {
    "PH",     "PHB",  "P",     "PB",    "T",      "QVAPOR", "U",     "V",     "W",
    "HGT",    "QCLOUD", "QICE", "QSNOW", "QRAIN", "QGRAUP", "QNICE", "QNRAIN", "CLDFRA"};

/* Sizes of a variable without its Time dimension (slowest first). */
static int var_shape(const sq_wrf *w, wrf_var v, size_t shape[3])
{
    const size_t nx = (size_t)w->info.nx, ny = (size_t)w->info.ny, nz = (size_t)w->info.nz;
    switch (v) {
    case WV_PH:
    case WV_PHB:
    case WV_W: shape[0] = nz + 1, shape[1] = ny, shape[2] = nx; return 3;
    case WV_U: shape[0] = nz, shape[1] = ny, shape[2] = nx + 1; return 3;
    case WV_V: shape[0] = nz, shape[1] = ny + 1, shape[2] = nx; return 3;
    case WV_HGT: shape[0] = ny, shape[1] = nx; return 2;
    default: shape[0] = nz, shape[1] = ny, shape[2] = nx; return 3;
    }
}

/* "[Time 2, bottom_top 3, south_north 1, west_east 4]" for element e of the hyperslab. */
static void place_text(const wrf_file *f, int varid, const size_t *start, const size_t *count,
                       int nd, size_t e, char *buf, size_t size)
{
    int dims[NC_MAX_VAR_DIMS];
    size_t idx[NC_MAX_VAR_DIMS];
    if (nd > NC_MAX_VAR_DIMS || nc_inq_vardimid(f->ncid, varid, dims) != NC_NOERR) {
        snprintf(buf, size, "element %zu", e);
        return;
    }
    for (int d = nd - 1; d >= 0; d--) {
        idx[d] = start[d] + e % count[d];
        e /= count[d];
    }
    size_t used = (size_t)snprintf(buf, size, "[");
    for (int d = 0; d < nd && used < size; d++) {
        char name[NC_MAX_NAME + 1] = "?";
        nc_inq_dimname(f->ncid, dims[d], name);
        used += (size_t)snprintf(buf + used, size - used, "%s%s %zu", d ? ", " : "", name, idx[d]);
    }
    if (used < size) snprintf(buf + used, size - used, "]");
}

/* The variable's fill value: _FillValue, else missing_value, else NetCDF's default. */
static float fill_value(const wrf_file *f, int varid, bool *has_missing, float *missing)
{
    float v = NC_FILL_FLOAT;
    nc_type type;
    size_t len = 0;
    if (nc_inq_att(f->ncid, varid, "_FillValue", &type, &len) == NC_NOERR && len == 1)
        nc_get_att_float(f->ncid, varid, "_FillValue", &v);
    *has_missing = false;
    if (nc_inq_att(f->ncid, varid, "missing_value", &type, &len) == NC_NOERR && len == 1 &&
        nc_get_att_float(f->ncid, varid, "missing_value", missing) == NC_NOERR)
        *has_missing = true;
    return v;
}

sq_result sq__wrf_get_floats(sq_wrf *w, const wrf_file *f, int varid, const char *name,
                             const size_t *start, const size_t *count, int ndims, float *dst)
{
    int st = nc_get_vara_float(f->ncid, varid, start, count, dst);
    if (st != NC_NOERR)
        return sq__fail(w->ctx, st == NC_ENOMEM ? SQ_ERR_OUT_OF_MEMORY : SQ_ERR_PARSE, "wrf",
                        "%s: cannot read variable '%s': %s", f->path, name, nc_strerror(st));
    size_t n = 1;
    for (int d = 0; d < ndims; d++) n *= count[d];
    bool has_missing = false;
    float missing = 0.0f;
    const float fill = fill_value(f, varid, &has_missing, &missing);
    size_t bad = n;
    for (size_t e = 0; e < n; e++) {
        const float v = dst[e];
        if (!isfinite(v) || v == fill || (has_missing && v == missing)) {
            bad = e;
            break;
        }
    }
    if (bad == n) return SQ_OK;
    char place[192];
    place_text(f, varid, start, count, ndims, bad, place, sizeof place);
    const float v = dst[bad];
    if (!isfinite(v))
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                        "%s: variable '%s' is %s at %s; WRF fields must be finite", f->path, name,
                        isnan(v) ? "NaN" : "infinite", place);
    return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                    "%s: variable '%s' holds the fill value %g at %s (missing data); WRF fields "
                    "must be complete",
                    f->path, name, (double)v, place);
}

/* Reads variable v of file f at its time `local` into dst. */
static sq_result read_var(sq_wrf *w, const wrf_file *f, int local, wrf_var v, float *dst)
{
    size_t shape[3];
    const int nd = var_shape(w, v, shape);
    size_t start[4] = {0, 0, 0, 0}, count[4];
    int n = 0;
    if (f->var_time[v]) {
        start[0] = (size_t)local;
        count[n++] = 1;
    }
    for (int d = 0; d < nd; d++) count[n++] = shape[d];
    return sq__wrf_get_floats(w, f, f->varid[v], var_name[v], start, count, n, dst);
}

sq_result sq__wrf_read_hgt0(sq_wrf *w)
{
    const size_t plane = (size_t)w->info.nx * (size_t)w->info.ny;
    w->hgt0 = (float *)sq_alloc(w->ctx, sizeof(float) * plane);
    if (!w->hgt0) return SQ_ERR_OUT_OF_MEMORY;
    const wrf_entry *e = &w->entries[0];
    return read_var(w, &w->files[e->file], e->local, WV_HGT, w->hgt0);
}

/* Cloud fraction: rounding noise outside [0, 1] (up to 0.01) is clamped, more is an error. */
static sq_result clamp_fraction(sq_wrf *w, const wrf_file *f, int local, float *q, size_t n)
{
    for (size_t c = 0; c < n; c++) {
        if (q[c] >= 0.0f && q[c] <= 1.0f) continue;
        if (q[c] >= -0.01f && q[c] <= 1.01f) {
            q[c] = q[c] < 0.0f ? 0.0f : 1.0f;
            w->clamped++;
            continue;
        }
        const size_t nx = (size_t)w->info.nx, ny = (size_t)w->info.ny;
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                        "%s: variable 'CLDFRA' = %g at [Time %d, bottom_top %zu, south_north "
                        "%zu, west_east %zu]; a cloud fraction must be in [0, 1] (rounding noise "
                        "up to 0.01 beyond is clamped)",
                        f->path, (double)q[c], local, c / (nx * ny), c / nx % ny, c % nx);
    }
    return SQ_OK;
}

/* Mixing ratios: rounding noise below zero is clamped, real negatives are an error. */
static sq_result clamp_mixing_ratio(sq_wrf *w, const wrf_file *f, int local, wrf_var v, float *q,
                                    size_t n, bool number)
{
    for (size_t c = 0; c < n; c++) {
        if (q[c] >= 0.0f) continue;
        if (number || q[c] >= (float)SQ__WRF_NEGATIVE_Q_LIMIT) {
            q[c] = 0.0f;
            w->clamped++;
            continue;
        }
        const size_t nx = (size_t)w->info.nx, ny = (size_t)w->info.ny;
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                        "%s: variable '%s' = %g kg/kg at [Time %d, bottom_top %zu, south_north "
                        "%zu, west_east %zu]; mixing ratios must be >= 0 (rounding noise down to "
                        "%g is set to 0)",
                        f->path, var_name[v], (double)q[c], local, c / (nx * ny), c / nx % ny,
                        c % nx, SQ__WRF_NEGATIVE_Q_LIMIT);
    }
    return SQ_OK;
}

/* Pressure and potential temperature must be positive (a corrupt field otherwise). */
static sq_result check_thermo(sq_wrf *w, const wrf_file *f, int local)
{
    const size_t nx = (size_t)w->info.nx, ny = (size_t)w->info.ny;
    const size_t n = nx * ny * (size_t)w->info.nz;
    const sq__wrf_raw *r = &w->raw;
    for (size_t c = 0; c < n; c++) {
        const double p = (double)r->p[c] + (double)r->pb[c];
        const double th = (double)r->t[c] + SQ__WRF_T0;
        if (p > 0.0 && th > 0.0) continue;
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                        "%s: %s = %g %s at [Time %d, bottom_top %zu, south_north %zu, west_east "
                        "%zu]; it must be > 0",
                        f->path, p > 0.0 ? "T + 300 (potential temperature)" : "P + PB (pressure)",
                        p > 0.0 ? th : p, p > 0.0 ? "K" : "Pa", local, c / (nx * ny), c / nx % ny,
                        c % nx);
    }
    return SQ_OK;
}

static uint64_t raw_floats(const sq_wrf *w)
{
    const uint64_t nx = (uint64_t)w->info.nx, ny = (uint64_t)w->info.ny,
                   nz = (uint64_t)w->info.nz;
    const uint64_t n = nx * ny * nz, ns = nx * ny * (nz + 1);
    uint64_t q = 0;
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) q += w->info.has_species[s];
    q += w->info.has_ice_number + w->info.has_rain_number + w->info.has_cloud_fraction;
    return 3 * ns + (4 + q) * n + nz * ny * (nx + 1) + nz * (ny + 1) * nx + nx * ny;
}

static uint64_t field_floats(const sq_wrf *w)
{
    const uint64_t nx = (uint64_t)w->info.nx, ny = (uint64_t)w->info.ny,
                   nz = (uint64_t)w->info.nz;
    const uint64_t n = nx * ny * nz, ns = nx * ny * (nz + 1);
    uint64_t q = 0;
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) q += w->info.has_species[s];
    q += w->info.has_ice_number + w->info.has_rain_number + w->info.has_cloud_fraction;
    return (10 + q) * n + ns + nx * ny;
}

uint64_t sq_wrf_memory_bytes(const sq_wrf *w)
{
    if (!w) return 0;
    return (raw_floats(w) + 3 * field_floats(w)) * sizeof(float) + 64 * 64;
}

/* Carves the fields out of one block. */
static float *carve(float **cursor, size_t n)
{
    float *p = *cursor;
    /* keep every array 64-byte aligned */
    *cursor += (n + 15) / 16 * 16;
    return p;
}

static sq_result alloc_fields(sq_wrf *w, sq__wrf_fields *f)
{
    const size_t nx = (size_t)w->info.nx, ny = (size_t)w->info.ny, nz = (size_t)w->info.nz;
    const size_t n = nx * ny * nz, ns = nx * ny * (nz + 1), plane = nx * ny;
    const size_t total = (size_t)field_floats(w) + 16 * 32;
    f->block = sq_alloc(w->ctx, total * sizeof(float));
    if (!f->block) return SQ_ERR_OUT_OF_MEMORY;
    float *cur = (float *)f->block;
    float **three[] = {&f->z, &f->agl, &f->p, &f->theta, &f->t, &f->rho, &f->qv, &f->u, &f->v,
                       &f->w};
    for (size_t i = 0; i < sizeof three / sizeof three[0]; i++) *three[i] = carve(&cur, n);
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++)
        f->q[s] = w->info.has_species[s] ? carve(&cur, n) : NULL;
    f->ni = w->info.has_ice_number ? carve(&cur, n) : NULL;
    f->nr = w->info.has_rain_number ? carve(&cur, n) : NULL;
    f->cldfra = w->info.has_cloud_fraction ? carve(&cur, n) : NULL;
    f->zw = carve(&cur, ns);
    f->hgt = carve(&cur, plane);
    f->index = -1;
    return SQ_OK;
}

sq_result sq__wrf_alloc_buffers(sq_wrf *w)
{
    if (w->raw_block) return SQ_OK;
    char what[96];
    snprintf(what, sizeof what, "WRF fields of %d x %d x %d points (raw + 3 derived sets)",
             w->info.nx, w->info.ny, w->info.nz);
    sq_result r = sq_context_check_memory(w->ctx, sq_wrf_memory_bytes(w), what);
    if (r != SQ_OK) return r;
    const size_t nx = (size_t)w->info.nx, ny = (size_t)w->info.ny, nz = (size_t)w->info.nz;
    const size_t n = nx * ny * nz, ns = nx * ny * (nz + 1);
    w->raw_block = sq_alloc(w->ctx, ((size_t)raw_floats(w) + 16 * 32) * sizeof(float));
    if (!w->raw_block) return SQ_ERR_OUT_OF_MEMORY;
    float *cur = (float *)w->raw_block;
    sq__wrf_raw *raw = &w->raw;
    raw->ph = carve(&cur, ns);
    raw->phb = carve(&cur, ns);
    raw->w = carve(&cur, ns);
    raw->p = carve(&cur, n);
    raw->pb = carve(&cur, n);
    raw->t = carve(&cur, n);
    raw->qv = carve(&cur, n);
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++)
        raw->q[s] = w->info.has_species[s] ? carve(&cur, n) : NULL;
    raw->qni = w->info.has_ice_number ? carve(&cur, n) : NULL;
    raw->qnr = w->info.has_rain_number ? carve(&cur, n) : NULL;
    raw->cldfra = w->info.has_cloud_fraction ? carve(&cur, n) : NULL;
    raw->u = carve(&cur, nz * ny * (nx + 1));
    raw->v = carve(&cur, nz * (ny + 1) * nx);
    raw->hgt = carve(&cur, nx * ny);
    for (int s = 0; s < 3 && r == SQ_OK; s++) r = alloc_fields(w, s < 2 ? &w->slot[s] : &w->out);
    if (r != SQ_OK) sq__wrf_free_buffers(w); /* all or nothing: the next read tries again */
    return r;
}

void sq__wrf_free_buffers(sq_wrf *w)
{
    sq_free(w->ctx, w->raw_block);
    w->raw_block = NULL;
    for (int s = 0; s < 2; s++) {
        sq_free(w->ctx, w->slot[s].block);
        w->slot[s].block = NULL;
        w->slot[s].index = -1;
    }
    sq_free(w->ctx, w->out.block);
    w->out.block = NULL;
    w->out.index = -1;
}

sq_result sq__wrf_load(sq_wrf *w, int index, sq__wrf_fields *dst)
{
    sq_result r = sq__wrf_alloc_buffers(w);
    if (r != SQ_OK) return r;
    dst->index = -1;
    const wrf_entry *e = &w->entries[index];
    const wrf_file *f = &w->files[e->file];
    const int t = e->local;
    sq__wrf_raw *raw = &w->raw;
    const size_t n = (size_t)w->info.nx * (size_t)w->info.ny * (size_t)w->info.nz;
    struct {
        wrf_var v;
        float *dst;
    } reads[] = {{WV_PH, raw->ph},  {WV_PHB, raw->phb},      {WV_P, raw->p},
                 {WV_PB, raw->pb},  {WV_T, raw->t},          {WV_QVAPOR, raw->qv},
                 {WV_U, raw->u},    {WV_V, raw->v},          {WV_W, raw->w},
                 {WV_HGT, raw->hgt}, {WV_QCLOUD, raw->q[0]}, {WV_QICE, raw->q[1]},
                 {WV_QSNOW, raw->q[2]}, {WV_QRAIN, raw->q[3]}, {WV_QGRAUP, raw->q[4]},
                 {WV_QNICE, raw->qni}, {WV_QNRAIN, raw->qnr}, {WV_CLDFRA, raw->cldfra}};
    for (size_t i = 0; i < sizeof reads / sizeof reads[0] && r == SQ_OK; i++) {
        if (!reads[i].dst) continue;
        r = read_var(w, f, t, reads[i].v, reads[i].dst);
        if (r == SQ_OK && reads[i].v == WV_CLDFRA)
            r = clamp_fraction(w, f, t, raw->cldfra, n);
        else if (r == SQ_OK && (reads[i].v == WV_QVAPOR || reads[i].v >= WV_QCLOUD))
            r = clamp_mixing_ratio(w, f, t, reads[i].v, reads[i].dst, n,
                                   reads[i].v == WV_QNICE || reads[i].v == WV_QNRAIN);
    }
    if (r == SQ_OK) r = check_thermo(w, f, t);
    if (r != SQ_OK) return r;
    sq__wrf_derive(w->info.nx, w->info.ny, w->info.nz, raw, dst, sq_context_threads(w->ctx));
    dst->index = index;
    return SQ_OK;
}

/* Makes slots hold stored times i0 and i1 (i1 may equal i0); returns their slot numbers. */
static sq_result ensure_slots(sq_wrf *w, int i0, int i1, int *s0, int *s1)
{
    *s0 = w->slot[0].index == i0 ? 0 : w->slot[1].index == i0 ? 1 : -1;
    *s1 = w->slot[0].index == i1 ? 0 : w->slot[1].index == i1 ? 1 : -1;
    sq_result r = SQ_OK;
    if (*s0 < 0) {
        *s0 = *s1 == 0 ? 1 : 0;
        r = sq__wrf_load(w, i0, &w->slot[*s0]);
        if (i1 == i0) *s1 = *s0;
    }
    if (r == SQ_OK && *s1 < 0) {
        *s1 = *s0 == 0 ? 1 : 0;
        r = sq__wrf_load(w, i1, &w->slot[*s1]);
    }
    return r;
}

static void fill_state(sq_wrf *w, const sq__wrf_fields *f, double time_s, int i0, int i1,
                       double a, sq_wrf_state *o)
{
    memset(o, 0, sizeof *o);
    o->time_s = time_s;
    o->index0 = i0;
    o->index1 = i1;
    o->weight1 = a;
    o->z_m = f->z;
    o->height_agl_m = f->agl;
    o->p_pa = f->p;
    o->theta_k = f->theta;
    o->t_k = f->t;
    o->rho_kg_m3 = f->rho;
    o->qv_kg_kg = f->qv;
    o->u_mps = f->u;
    o->v_mps = f->v;
    o->w_mps = f->w;
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) o->q_g_m3[s] = f->q[s];
    o->ice_number_m3 = f->ni;
    o->rain_number_m3 = f->nr;
    o->cloud_fraction = f->cldfra;
    o->cloud_fraction_is_flag = f->cldfra_flag;
    o->z_w_m = f->zw;
    o->terrain_m = f->hgt;
    o->lat_deg = w->lat;
    o->lon_deg = w->lon;
    o->x_m = w->xw;
    o->y_m = w->yw;
    sq_wrf_sun(w, time_s, &o->sun, &o->sun_dir);
}

sq_result sq_wrf_read_index(sq_wrf *w, int index, sq_wrf_state *out)
{
    if (out) memset(out, 0, sizeof *out);
    if (!w || !out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_wrf_read_index: NULL argument");
    if (index < 0 || index >= w->info.time_count)
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                        "%s: time index %d is out of range; the series has %d time%s (0..%d)",
                        w->files[0].path, index, w->info.time_count,
                        w->info.time_count == 1 ? "" : "s", w->info.time_count - 1);
    int s0, s1;
    sq_result r = ensure_slots(w, index, index, &s0, &s1);
    if (r != SQ_OK) return r;
    fill_state(w, &w->slot[s0], w->times_s[index], index, index, 0.0, out);
    return SQ_OK;
}

sq_result sq_wrf_read(sq_wrf *w, double time_s, sq_wrf_state *out)
{
    if (out) memset(out, 0, sizeof *out);
    if (!w || !out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_wrf_read: NULL argument");
    const int nt = w->info.time_count;
    const double end = w->times_s[nt - 1];
    if (!(time_s >= 0.0 && time_s <= end))
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                        "%s: time %g s is outside the series: 0..%g s (%s to %s)",
                        w->files[0].path, time_s, end, w->time_ptrs[0], w->time_ptrs[nt - 1]);
    int i0 = 0;
    while (i0 + 1 < nt && w->times_s[i0 + 1] <= time_s) i0++;
    if (w->times_s[i0] == time_s) return sq_wrf_read_index(w, i0, out);
    const int i1 = i0 + 1;
    int s0, s1;
    sq_result r = ensure_slots(w, i0, i1, &s0, &s1);
    if (r != SQ_OK) return r;
    const double a = (time_s - w->times_s[i0]) / (w->times_s[i1] - w->times_s[i0]);
    sq__wrf_lerp(w->info.nx, w->info.ny, w->info.nz, &w->slot[s0], &w->slot[s1], a, &w->out,
                 sq_context_threads(w->ctx));
    fill_state(w, &w->out, time_s, i0, i1, a, out);
    return SQ_OK;
}

static void range_init(sq_wrf_range *r)
{
    r->min = INFINITY;
    r->max = -INFINITY;
}

static void range_add(sq_wrf_range *r, const float *a, size_t n)
{
    if (!a) return;
    double mn = r->min, mx = r->max;
    for (size_t c = 0; c < n; c++) {
        const double v = (double)a[c];
        mn = v < mn ? v : mn;
        mx = v > mx ? v : mx;
    }
    r->min = mn;
    r->max = mx;
}

static void range_finish(sq_wrf_range *r)
{
    if (!(r->min <= r->max)) r->min = r->max = 0.0;
}

sq_result sq_wrf_scan(sq_wrf *w, sq_wrf_ranges *out)
{
    if (out) memset(out, 0, sizeof *out);
    if (!w || !out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_wrf_scan: NULL argument");
    sq_wrf_ranges g;
    memset(&g, 0, sizeof g);
    sq_wrf_range *all[] = {&g.z_m,     &g.height_agl_m, &g.p_pa,    &g.theta_k,   &g.t_k,
                           &g.rho_kg_m3, &g.qv_kg_kg,   &g.u_mps,   &g.v_mps,     &g.w_mps,
                           &g.terrain_m, &g.lat_deg,    &g.lon_deg, &g.q_g_m3[0], &g.q_g_m3[1],
                           &g.q_g_m3[2], &g.q_g_m3[3],  &g.q_g_m3[4], &g.cloud_fraction};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) range_init(all[i]);
    const size_t plane = (size_t)w->info.nx * (size_t)w->info.ny;
    const size_t n = plane * (size_t)w->info.nz;
    const int64_t clamped_before = w->clamped;
    int64_t cloudy = 0;
    g.z_top_m = -INFINITY;
    g.cloud_fraction_is_flag = w->info.has_cloud_fraction;
    for (int t = 0; t < w->info.time_count; t++) {
        /* slot 0 is reused; slot 1 keeps whatever an animation had */
        sq__wrf_fields *f = &w->slot[0];
        sq_result r = sq__wrf_alloc_buffers(w);
        if (r == SQ_OK) r = sq__wrf_load(w, t, f);
        if (r != SQ_OK) return r;
        range_add(&g.z_m, f->z, n);
        range_add(&g.height_agl_m, f->agl, n);
        range_add(&g.p_pa, f->p, n);
        range_add(&g.theta_k, f->theta, n);
        range_add(&g.t_k, f->t, n);
        range_add(&g.rho_kg_m3, f->rho, n);
        range_add(&g.qv_kg_kg, f->qv, n);
        range_add(&g.u_mps, f->u, n);
        range_add(&g.v_mps, f->v, n);
        range_add(&g.w_mps, f->w, n);
        range_add(&g.terrain_m, f->hgt, plane);
        for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) range_add(&g.q_g_m3[s], f->q[s], n);
        range_add(&g.cloud_fraction, f->cldfra, n);
        g.cloud_fraction_is_flag = g.cloud_fraction_is_flag && f->cldfra_flag;
        for (size_t c = plane * (size_t)w->info.nz; c < plane * (size_t)(w->info.nz + 1); c++)
            g.z_top_m = fmax(g.z_top_m, (double)f->zw[c]);
        for (size_t c = 0; c < n; c++) {
            const double cond = (f->q[SQ_WRF_CLOUD] ? (double)f->q[SQ_WRF_CLOUD][c] : 0.0) +
                                (f->q[SQ_WRF_ICE] ? (double)f->q[SQ_WRF_ICE][c] : 0.0);
            cloudy += cond > 1e-3;
        }
    }
    range_add(&g.lat_deg, w->lat, plane);
    range_add(&g.lon_deg, w->lon, plane);
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) range_finish(all[i]);
    g.cloudy_fraction = (double)cloudy / ((double)n * w->info.time_count);
    g.clamped_negative = w->clamped - clamped_before;
    *out = g;
    return SQ_OK;
}

sq_result sq_wrf_world_desc(sq_wrf *w, double time_s, sq_world_desc *desc)
{
    if (!w || !desc) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_wrf_world_desc: NULL argument");
    const sq_wrf_info *in = &w->info;
    if (!(time_s >= 0.0 && time_s <= in->duration_s))
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "wrf",
                        "%s: time %g s is outside the series: 0..%g s", w->files[0].path, time_s,
                        in->duration_s);
    sq_terrain_desc *t = &desc->terrain;
    t->kind = SQ_TERRAIN_GRID;
    t->grid_heights_m = w->hgt0;
    t->grid_w = in->nx;
    t->grid_h = in->ny;
    t->grid_dx_m = (float)in->dx_m;
    t->grid_dy_m = (float)in->dy_m;
    t->origin_m[0] = (float)in->x0_m;
    t->origin_m[1] = (float)in->y0_m;
    t->origin_set = true;
    desc->crs_wkt = w->crs_wkt;
    desc->crs_offset_m[0] = in->crs_offset_m[0];
    desc->crs_offset_m[1] = in->crs_offset_m[1];
    /* the sun's clock: the world computes the sun as sq_wrf_sun does and moves it with time */
    desc->sun.direction = sq_v3(0.0f, 0.0f, 0.0f);
    desc->sun.utc_set = true;
    desc->sun.utc_start_unix_s = in->start_unix_s + time_s;
    desc->sun.latitude_deg = (float)in->center_lat_deg;
    desc->sun.longitude_deg = (float)in->center_lon_deg;
    desc->sun.north_rotation_deg = (float)in->north_rotation_deg;
    return SQ_OK;
}

sq_result sq_scene_wrf_world_loader(sq_context *ctx, const char *path, sq_world_desc *desc,
                                    void **owned)
{
    if (owned) *owned = NULL;
    if (!desc || !owned)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "wrf", "WRF world loader: NULL argument");
    sq_wrf *w = NULL;
    const char *paths[1] = {path};
    sq_result r = sq_wrf_open(ctx, paths, 1, &w);
    if (r != SQ_OK) return r;
    const sq_wrf_info *in = &w->info;
    const size_t plane = (size_t)in->nx * (size_t)in->ny;
    const size_t wkt_len = strlen(w->crs_wkt) + 1;
    char *block = (char *)sq_alloc(ctx, plane * sizeof(float) + wkt_len);
    if (!block) {
        sq_wrf_close(w);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    /* the desc must outlive w: heights and WKT go into the caller's allocation */
    float *heights = (float *)block;
    char *wkt = block + plane * sizeof(float);
    memcpy(heights, w->hgt0, plane * sizeof(float));
    memcpy(wkt, w->crs_wkt, wkt_len);
    r = sq_wrf_world_desc(w, 0.0, desc);
    desc->terrain.grid_heights_m = heights;
    desc->crs_wkt = wkt;
    sq_wrf_close(w);
    if (r != SQ_OK) {
        sq_free(ctx, block);
        return r;
    }
    *owned = block;
    return SQ_OK;
}

#else /* without NetCDF or PROJ */

static sq_result unsupported(void)
{
    return sq__set_error(SQ_ERR_UNSUPPORTED,
                         "squall was built without the WRF reader (it needs NetCDF and PROJ)");
}

uint64_t sq_wrf_memory_bytes(const sq_wrf *w)
{
    (void)w;
    return 0;
}
sq_result sq_wrf_read(sq_wrf *w, double time_s, sq_wrf_state *out)
{
    (void)w, (void)time_s, (void)out;
    return unsupported();
}
sq_result sq_wrf_read_index(sq_wrf *w, int index, sq_wrf_state *out)
{
    (void)w, (void)index, (void)out;
    return unsupported();
}
sq_result sq_wrf_scan(sq_wrf *w, sq_wrf_ranges *out)
{
    (void)w, (void)out;
    return unsupported();
}
sq_result sq_wrf_to_world(const sq_wrf *w, double lon_deg, double lat_deg, double *x_m,
                          double *y_m)
{
    (void)w, (void)lon_deg, (void)lat_deg, (void)x_m, (void)y_m;
    return unsupported();
}
sq_result sq_wrf_from_world(const sq_wrf *w, double x_m, double y_m, double *lon_deg,
                            double *lat_deg)
{
    (void)w, (void)x_m, (void)y_m, (void)lon_deg, (void)lat_deg;
    return unsupported();
}
sq_result sq_wrf_sun(const sq_wrf *w, double time_s, sq_sun_position *pos, sq_vec3 *dir_world)
{
    (void)w, (void)time_s, (void)pos, (void)dir_world;
    return unsupported();
}
sq_result sq_wrf_world_desc(sq_wrf *w, double time_s, sq_world_desc *desc)
{
    (void)w, (void)time_s, (void)desc;
    return unsupported();
}
sq_result sq_scene_wrf_world_loader(sq_context *ctx, const char *path, sq_world_desc *desc,
                                    void **owned)
{
    (void)ctx, (void)path, (void)desc;
    if (owned) *owned = NULL;
    return unsupported();
}

#endif

/* Column optical depth of cloud water + cloud ice: pure, no file access. */
void sq_wrf_cloud_optical_depth(const sq_wrf_info *info, const sq_wrf_state *s, float *out)
{
    const size_t nx = (size_t)info->nx, ny = (size_t)info->ny, nz = (size_t)info->nz;
    const size_t plane = nx * ny;
    const float *qc = s->q_g_m3[SQ_WRF_CLOUD], *qi = s->q_g_m3[SQ_WRF_ICE];
    for (size_t c = 0; c < plane; c++) {
        double tau = 0.0;
        for (size_t k = 0; k < nz; k++) {
            const size_t n = k * plane + c;
            const double dz = (double)s->z_w_m[n + plane] - (double)s->z_w_m[n];
            double beta = 0.0;
            if (qc)
                beta += sq_cloud_extinction(1e-3 * (double)qc[n], SQ_WATER_DENSITY_KG_M3,
                                            SQ_CLOUD_DROPLET_R_EFF_M);
            if (qi)
                beta += sq_cloud_extinction(1e-3 * (double)qi[n], SQ_ICE_DENSITY_KG_M3,
                                            SQ_CLOUD_ICE_R_EFF_M);
            tau += beta * dz;
        }
        out[c] = (float)tau;
    }
}
