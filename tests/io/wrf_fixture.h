/* wrf_fixture.h — small synthetic wrfout files for the WRF reader's tests, written with libnetcdf
 * directly. Fields are simple analytic functions of (t, k, j, i) so the tests can compute the
 * expected derived values independently; XLAT/XLONG come from Snyder's spherical projection
 * formulas ("Map Projections — A Working Manual", USGS PP 1395: Lambert conformal conic eqs
 * 15-1..15-4, polar stereographic 21-5..21-8, Mercator 7-1..7-5, equirectangular 12-1), not from
 * PROJ, so the reader's PROJ set-up is checked against an independent implementation. */
#ifndef SQ_WRF_FIXTURE_H
#define SQ_WRF_FIXTURE_H

#include <math.h>
#include <netcdf.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#define FX_R 6370000.0
#define FX_G 9.81
#define FX_D2R (M_PI / 180.0)

typedef struct fx_desc {
    int nx, ny, nz, nt;
    int map_proj;                 /* 1, 2, 3, 6 (or anything, to test refusals) */
    double truelat1, truelat2, stand_lon, moad_cen_lat, cen_lat, cen_lon;
    double dx;                    /* DX = DY (m) */
    double dx_attr;               /* written DX attribute; 0 -> dx */
    bool classic;                 /* netCDF-3 classic (64-bit offset) instead of netCDF-4 */
    bool latlon_time;             /* XLAT/XLONG with a Time dimension */
    const char *strlen_name;      /* name of the time-string dimension; NULL -> "DateStrLen" */
    bool thompson;                /* QICE, QSNOW, QGRAUP, QNICE, QNRAIN as well (else WSM3) */
    int start_hour;               /* hour of Times[0] on 2020-06-21 */
    int step_h;                   /* hours between times (0 -> 3) */
    bool omit_ph;                 /* leave out PH (not WRF output) */
    bool bad_qcloud_shape;        /* QCLOUD without west_east */
    float poke_qcloud;            /* when != 0: QCLOUD[t=0,k=1,j=1,i=1] = poke value */
    int cldfra;                   /* CLDFRA: 0 none, 1 a fraction (fx_cf), 2 a 0/1 flag (fx_cf01) */
    float poke_cldfra;            /* when != 0: CLDFRA[t=0,k=1,j=1,i=1] = poke value */
} fx_desc;

/* ---- projections (Snyder, sphere of radius FX_R) ------------------------------------------ */
typedef struct fx_proj {
    int kind;
    double n, F, rho0, lam0, phic, kts;
} fx_proj;

static fx_proj fx_proj_make(const fx_desc *d)
{
    fx_proj p;
    memset(&p, 0, sizeof p);
    p.kind = d->map_proj;
    p.lam0 = d->stand_lon * FX_D2R;
    if (d->map_proj == 1) {
        const double p1 = d->truelat1 * FX_D2R, p2 = d->truelat2 * FX_D2R;
        const double p0 = d->moad_cen_lat * FX_D2R;
        p.n = fabs(p1 - p2) < 1e-12 ? sin(p1)
                                    : log(cos(p1) / cos(p2)) /
                                          log(tan(M_PI / 4 + p2 / 2) / tan(M_PI / 4 + p1 / 2));
        p.F = cos(p1) * pow(tan(M_PI / 4 + p1 / 2), p.n) / p.n;
        p.rho0 = FX_R * p.F / pow(tan(M_PI / 4 + p0 / 2), p.n);
    } else if (d->map_proj == 2) {
        p.phic = d->truelat1 * FX_D2R; /* north-polar aspect */
    } else if (d->map_proj == 3) {
        p.kts = cos(d->truelat1 * FX_D2R);
    }
    return p;
}

static void fx_forward(const fx_proj *p, double lat, double lon, double *x, double *y)
{
    const double phi = lat * FX_D2R;
    double dl = lon * FX_D2R - p->lam0;
    while (dl > M_PI) dl -= 2 * M_PI;
    while (dl < -M_PI) dl += 2 * M_PI;
    if (p->kind == 1) {
        const double rho = FX_R * p->F / pow(tan(M_PI / 4 + phi / 2), p->n);
        *x = rho * sin(p->n * dl);
        *y = p->rho0 - rho * cos(p->n * dl);
    } else if (p->kind == 2) {
        const double rho = FX_R * (1 + sin(p->phic)) * tan(M_PI / 4 - phi / 2);
        *x = rho * sin(dl);
        *y = -rho * cos(dl);
    } else if (p->kind == 3) {
        *x = FX_R * p->kts * dl;
        *y = FX_R * p->kts * log(tan(M_PI / 4 + phi / 2));
    } else {
        *x = FX_R * dl;
        *y = FX_R * phi;
    }
}

static void fx_inverse(const fx_proj *p, double x, double y, double *lat, double *lon)
{
    double phi, lam;
    if (p->kind == 1) {
        const double s = p->n > 0 ? 1.0 : -1.0;
        const double rho = s * hypot(x, p->rho0 - y);
        const double theta = atan2(s * x, s * (p->rho0 - y));
        phi = 2 * atan(pow(FX_R * p->F / rho, 1 / p->n)) - M_PI / 2;
        lam = theta / p->n + p->lam0;
    } else if (p->kind == 2) {
        const double rho = hypot(x, y);
        phi = M_PI / 2 - 2 * atan(rho / (FX_R * (1 + sin(p->phic))));
        lam = p->lam0 + atan2(x, -y);
    } else if (p->kind == 3) {
        phi = 2 * atan(exp(y / (FX_R * p->kts))) - M_PI / 2;
        lam = x / (FX_R * p->kts) + p->lam0;
    } else {
        phi = y / FX_R;
        lam = x / FX_R + p->lam0;
    }
    *lat = phi / FX_D2R;
    *lon = lam / FX_D2R;
    while (*lon > 180) *lon -= 360;
    while (*lon < -180) *lon += 360;
}

/* ---- the analytic fields ------------------------------------------------------------------ */
static double fx_hgt(int t, int j, int i) { return 1000.0 + 10.0 * i + 20.0 * j + 0.0 * t; }
static double fx_phb(int k, int j, int i) { return FX_G * (fx_hgt(0, j, i) + 400.0 * k); }
static double fx_ph(int t, int k, int j, int i) { return FX_G * (2.0 * k * t + 0.25 * k * i + 0 * j); }
static double fx_pb(int k) { return 90000.0 - 2500.0 * k; }
static double fx_p(int t, int k, int j, int i) { return 10.0 * t + i - j + 0.5 * k; }
static double fx_t(int t, int k, int j, int i) { return 5.0 + k + 0.1 * t + 0.01 * (i + j); }
static double fx_qv(int t, int k, int j, int i) { return 0.008 / (1 + k) + 1e-5 * (t + i + j); }
static double fx_qc(int t, int k, int j, int i)
{
    if (k == 0 && j == 0 && i == 0) return -1e-12; /* rounding noise to be clamped */
    return (k == 2 && i >= 1 && j >= 1) ? 1e-3 * (1 + t) : 0.0;
}
static double fx_qr(int t, int k, int j, int i) { return k == 1 ? 1e-5 * (1 + i + t) + 0 * j : 0.0; }
static double fx_qi(int t, int k, int j, int i) { return k == 3 ? 2e-5 * (1 + j) + 0 * (t + i) : 0.0; }
static double fx_qs(int t, int k, int j, int i) { return k == 3 ? 3e-5 + 0 * (t + i + j) : 0.0; }
static double fx_qg(int t, int k, int j, int i) { return 1e-6 * k + 0 * (t + i + j); }
static double fx_qni(int t, int k, int j, int i) { return k == 3 ? 1e5 + 0 * (t + i + j) : 0.0; }
static double fx_cf(int t, int k, int j, int i) { return 0.25 * ((i + j + k + t) % 5); }
static double fx_cf01(int t, int k, int j, int i) { return (double)((i + j + k + t) % 2); }
static double fx_u(int t, int k, int j, int is) { return is + k + t + 0 * j; }
static double fx_v(int t, int k, int js, int i) { return 2.0 * js + 0 * (t + k + i); }
static double fx_w(int t, int ks, int j, int i) { return 0.1 * ks + 0 * (t + j + i); }

typedef double (*fx_fn4)(int, int, int, int);

#define FX_TRY(x)                                                                              \
    do {                                                                                       \
        int st_ = (x);                                                                         \
        if (st_ != NC_NOERR) {                                                                 \
            fprintf(stderr, "fixture %s: %s: %s\n", path, #x, nc_strerror(st_));               \
            return false;                                                                      \
        }                                                                                      \
    } while (0)

/* Defines and writes one variable of dims (time, d0, d1, d2) filled from fn(t, a, b, c). */
static bool fx_put4(const char *path, int ncid, const char *name, const int dims[4], int nt,
                    size_t n0, size_t n1, size_t n2, fx_fn4 fn, int ndims)
{
    int varid;
    FX_TRY(nc_redef(ncid));
    FX_TRY(nc_def_var(ncid, name, NC_FLOAT, ndims, dims, &varid));
    FX_TRY(nc_enddef(ncid));
    static float buf[1 << 20];
    for (int t = 0; t < nt; t++) {
        size_t c = 0;
        for (size_t a = 0; a < n0; a++)
            for (size_t b = 0; b < n1; b++)
                for (size_t e = 0; e < n2; e++)
                    buf[c++] = (float)fn(t, (int)a, (int)b, (int)e);
        size_t start[4] = {(size_t)t, 0, 0, 0}, count[4] = {1, n0, n1, n2};
        if (ndims == 3) {
            count[1] = n1;
            count[2] = n2;
        }
        FX_TRY(nc_put_vara_float(ncid, varid, start, count, buf));
    }
    return true;
}

static double fx_hgt4(int t, int a, int j, int i) { return fx_hgt(t, j, i) + 0 * a; }
static double fx_phb4(int t, int k, int j, int i) { return fx_phb(k, j, i) + 0 * t; }
static double fx_pb4(int t, int k, int j, int i) { return fx_pb(k) + 0 * (t + j + i); }

static fx_desc fx_default(int map_proj)
{
    fx_desc d;
    memset(&d, 0, sizeof d);
    d.nx = 6;
    d.ny = 5;
    d.nz = 4;
    d.nt = 3;
    d.map_proj = map_proj;
    d.dx = 12000.0;
    d.thompson = true;
    d.start_hour = 0;
    switch (map_proj) {
    case 1:
        d.truelat1 = 30, d.truelat2 = 60, d.stand_lon = -98, d.moad_cen_lat = 40;
        d.cen_lat = 41, d.cen_lon = -94; /* east of STAND_LON: grid and true north differ */
        break;
    case 2:
        d.truelat1 = 60, d.truelat2 = 60, d.stand_lon = -150, d.moad_cen_lat = 70;
        d.cen_lat = 70, d.cen_lon = -140;
        break;
    case 3:
        d.truelat1 = 20, d.truelat2 = 0, d.stand_lon = -89, d.moad_cen_lat = 25;
        d.cen_lat = 25.7, d.cen_lon = -87.4;
        break;
    default:
        d.truelat1 = 0, d.truelat2 = 0, d.stand_lon = 10, d.moad_cen_lat = 0;
        d.cen_lat = 47, d.cen_lon = 11;
        d.dx = 0.1 * FX_D2R * FX_R; /* 0.1 degree */
        break;
    }
    return d;
}

static bool fx_put_att(const char *path, int ncid, const char *name, double v, bool as_int)
{
    if (as_int) {
        const int iv = (int)v;
        FX_TRY(nc_put_att_int(ncid, NC_GLOBAL, name, NC_INT, 1, &iv));
    } else {
        const float fv = (float)v;
        FX_TRY(nc_put_att_float(ncid, NC_GLOBAL, name, NC_FLOAT, 1, &fv));
    }
    return true;
}

/* Writes the fixture; true on success (prints the NetCDF error otherwise). */
static bool fx_write(const char *path, const fx_desc *d)
{
    int ncid;
    FX_TRY(nc_create(path, NC_CLOBBER | (d->classic ? NC_64BIT_OFFSET : NC_NETCDF4), &ncid));
    const size_t nx = (size_t)d->nx, ny = (size_t)d->ny, nz = (size_t)d->nz;
    int dt, ds, dwe, dsn, dbt, dwes, dsns, dbts;
    FX_TRY(nc_def_dim(ncid, "Time", NC_UNLIMITED, &dt));
    FX_TRY(nc_def_dim(ncid, d->strlen_name ? d->strlen_name : "DateStrLen", 19, &ds));
    FX_TRY(nc_def_dim(ncid, "west_east", nx, &dwe));
    FX_TRY(nc_def_dim(ncid, "south_north", ny, &dsn));
    FX_TRY(nc_def_dim(ncid, "bottom_top", nz, &dbt));
    FX_TRY(nc_def_dim(ncid, "west_east_stag", nx + 1, &dwes));
    FX_TRY(nc_def_dim(ncid, "south_north_stag", ny + 1, &dsns));
    FX_TRY(nc_def_dim(ncid, "bottom_top_stag", nz + 1, &dbts));
    int vt;
    const int tdims[2] = {dt, ds};
    FX_TRY(nc_def_var(ncid, "Times", NC_CHAR, 2, tdims, &vt));
    const double dxa = d->dx_attr > 0 ? d->dx_attr : d->dx;
    if (!fx_put_att(path, ncid, "MAP_PROJ", d->map_proj, true) ||
        !fx_put_att(path, ncid, "DX", dxa, false) || !fx_put_att(path, ncid, "DY", dxa, false) ||
        !fx_put_att(path, ncid, "TRUELAT1", d->truelat1, false) ||
        !fx_put_att(path, ncid, "TRUELAT2", d->truelat2, false) ||
        !fx_put_att(path, ncid, "STAND_LON", d->stand_lon, false) ||
        !fx_put_att(path, ncid, "MOAD_CEN_LAT", d->moad_cen_lat, false) ||
        !fx_put_att(path, ncid, "CEN_LAT", d->cen_lat, false) ||
        !fx_put_att(path, ncid, "CEN_LON", d->cen_lon, false) ||
        !fx_put_att(path, ncid, "POLE_LAT", 90, false) ||
        !fx_put_att(path, ncid, "POLE_LON", 0, false) ||
        !fx_put_att(path, ncid, "MP_PHYSICS", d->thompson ? 8 : 3, true) ||
        /* the original domain's sizes, unlike the file's (a reader must ignore them) */
        !fx_put_att(path, ncid, "WEST-EAST_GRID_DIMENSION", 97, true) ||
        !fx_put_att(path, ncid, "SOUTH-NORTH_GRID_DIMENSION", 97, true))
        return false;
    FX_TRY(nc_enddef(ncid));
    const int step = d->step_h ? d->step_h : 3;
    for (int t = 0; t < d->nt; t++) {
        char s[32];
        const int h = d->start_hour + step * t;
        snprintf(s, sizeof s, "2020-06-%02d_%02d:00:00", 21 + h / 24, h % 24);
        size_t start[2] = {(size_t)t, 0}, count[2] = {1, 19};
        FX_TRY(nc_put_vara_text(ncid, vt, start, count, s));
    }
    /* coordinates */
    fx_proj p = fx_proj_make(d);
    double xc, yc;
    fx_forward(&p, d->cen_lat, d->cen_lon, &xc, &yc);
    static float lat[4096], lon[4096];
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            double la, lo;
            fx_inverse(&p, xc + ((double)i - 0.5 * (double)(nx - 1)) * d->dx,
                       yc + ((double)j - 0.5 * (double)(ny - 1)) * d->dx, &la, &lo);
            lat[j * nx + i] = (float)la;
            lon[j * nx + i] = (float)lo;
        }
    FX_TRY(nc_redef(ncid));
    int vlat, vlon;
    const int ll3[3] = {dt, dsn, dwe}, ll2[2] = {dsn, dwe};
    FX_TRY(nc_def_var(ncid, "XLAT", NC_FLOAT, d->latlon_time ? 3 : 2,
                      d->latlon_time ? ll3 : ll2, &vlat));
    FX_TRY(nc_def_var(ncid, "XLONG", NC_FLOAT, d->latlon_time ? 3 : 2,
                      d->latlon_time ? ll3 : ll2, &vlon));
    FX_TRY(nc_enddef(ncid));
    for (int t = 0; t < (d->latlon_time ? d->nt : 1); t++) {
        size_t s3[3] = {(size_t)t, 0, 0}, c3[3] = {1, ny, nx}, s2[2] = {0, 0}, c2[2] = {ny, nx};
        FX_TRY(nc_put_vara_float(ncid, vlat, d->latlon_time ? s3 : s2, d->latlon_time ? c3 : c2,
                                 lat));
        FX_TRY(nc_put_vara_float(ncid, vlon, d->latlon_time ? s3 : s2, d->latlon_time ? c3 : c2,
                                 lon));
    }
    const int mass[4] = {dt, dbt, dsn, dwe}, wst[4] = {dt, dbts, dsn, dwe};
    const int ust[4] = {dt, dbt, dsn, dwes}, vst[4] = {dt, dbt, dsns, dwe};
    const int hgt[4] = {dt, dsn, dwe, 0};
    const int bad[4] = {dt, dbt, dsn, 0};
    const int nt = d->nt;
    bool ok = fx_put4(path, ncid, "HGT", hgt, nt, 1, ny, nx, fx_hgt4, 3) &&
              fx_put4(path, ncid, "PHB", wst, nt, nz + 1, ny, nx, fx_phb4, 4) &&
              (d->omit_ph || fx_put4(path, ncid, "PH", wst, nt, nz + 1, ny, nx, fx_ph, 4)) &&
              fx_put4(path, ncid, "P", mass, nt, nz, ny, nx, fx_p, 4) &&
              fx_put4(path, ncid, "PB", mass, nt, nz, ny, nx, fx_pb4, 4) &&
              fx_put4(path, ncid, "T", mass, nt, nz, ny, nx, fx_t, 4) &&
              fx_put4(path, ncid, "QVAPOR", mass, nt, nz, ny, nx, fx_qv, 4) &&
              (d->bad_qcloud_shape
                   ? fx_put4(path, ncid, "QCLOUD", bad, nt, 1, nz, ny, fx_qc, 3)
                   : fx_put4(path, ncid, "QCLOUD", mass, nt, nz, ny, nx, fx_qc, 4)) &&
              fx_put4(path, ncid, "QRAIN", mass, nt, nz, ny, nx, fx_qr, 4) &&
              fx_put4(path, ncid, "U", ust, nt, nz, ny, nx + 1, fx_u, 4) &&
              fx_put4(path, ncid, "V", vst, nt, nz, ny + 1, nx, fx_v, 4) &&
              fx_put4(path, ncid, "W", wst, nt, nz + 1, ny, nx, fx_w, 4);
    if (ok && d->thompson)
        ok = fx_put4(path, ncid, "QICE", mass, nt, nz, ny, nx, fx_qi, 4) &&
             fx_put4(path, ncid, "QSNOW", mass, nt, nz, ny, nx, fx_qs, 4) &&
             fx_put4(path, ncid, "QGRAUP", mass, nt, nz, ny, nx, fx_qg, 4) &&
             fx_put4(path, ncid, "QNICE", mass, nt, nz, ny, nx, fx_qni, 4);
    if (ok && d->cldfra)
        ok = fx_put4(path, ncid, "CLDFRA", mass, nt, nz, ny, nx, d->cldfra == 1 ? fx_cf : fx_cf01, 4);
    if (ok && d->cldfra && d->poke_cldfra != 0.0f) {
        int vc;
        FX_TRY(nc_inq_varid(ncid, "CLDFRA", &vc));
        size_t s[4] = {0, 1, 1, 1};
        FX_TRY(nc_put_var1_float(ncid, vc, s, &d->poke_cldfra));
    }
    if (ok && d->poke_qcloud != 0.0f) {
        int vq;
        FX_TRY(nc_inq_varid(ncid, "QCLOUD", &vq));
        size_t s[4] = {0, 1, 1, 1};
        FX_TRY(nc_put_var1_float(ncid, vq, s, &d->poke_qcloud));
    }
    FX_TRY(nc_close(ncid));
    return ok;
}

#endif
