/* test_wrf.c — the WRF reader (include/squall/wrf.h): the real sample file against the reference
 * numbers of ../shared/reference/wrf_format.md (computed with the formulas wrf-python matches),
 * synthetic files (tests/io/wrf_fixture.h: netCDF-3 and netCDF-4, every projection, Thompson and
 * WSM3 species, Time on XLAT or not, the time-string dimension under another name) against the
 * formulas computed here independently, time interpolation, series of several files, and
 * refusals. Each case writes its fixtures in a fresh directory under /tmp (or $TMPDIR). */
#include <errno.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sq_config.h"
#include "sq_test.h"
#include "squall/io.h"
#include "squall/optics.h"
#include "squall/scene.h"
#include "squall/wrf.h"

#if SQ_HAVE_NETCDF && SQ_HAVE_PROJ
#include "io/wrf_fixture.h"
#endif

SQ_LABEL(unit)

static inline sq_world_light light_of(const sq_world *w)
{
    sq_world_light l;
    sq_world_get_light(w, &l);
    return l;
}

static inline sq_world_terrain terrain_of(const sq_world *w)
{
    sq_world_terrain t;
    sq_world_get_terrain(w, &t);
    return t;
}

#define SAMPLE SQ_TEST_SOURCE_DIR "/data/wrf/wrf_d01_allvars_cropped.nc"

static sq_context *mkctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {0};
    d.threads = 2;
    sq_context_create(&d, &ctx);
    return ctx;
}

static char g_dir[512];

static const char *tmp_path(const char *name)
{
    static char buf[4][600];
    static int next;
    if (!g_dir[0]) {
        const char *base = getenv("TMPDIR");
        snprintf(g_dir, sizeof g_dir, "%s/sq_wrf_XXXXXX", base && *base ? base : "/tmp");
        if (!mkdtemp(g_dir)) SQ_FAIL_AT("mkdtemp: %s", strerror(errno));
    }
    char *b = buf[next++ % 4];
    snprintf(b, 600, "%s/%s", g_dir, name);
    return b;
}

static void cleanup(void)
{
    if (!g_dir[0]) return;
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    if (system(cmd) != 0) fprintf(stderr, "cannot remove %s\n", g_dir);
    g_dir[0] = 0;
}

static sq_wrf *open1(sq_context *ctx, const char *path)
{
    sq_wrf *w = NULL;
    const char *p[1] = {path};
    SQ_CHECK_OK(sq_wrf_open(ctx, p, 1, &w));
    return w;
}

#if SQ_HAVE_NETCDF && SQ_HAVE_PROJ

/* ---- the real sample --------------------------------------------------------------------- */

SQ_TEST(sample_info)
{
    sq_context *ctx = mkctx();
    sq_wrf *w = open1(ctx, SAMPLE);
    if (!w) return;
    sq_wrf_info in;
    sq_wrf_get_info(w, &in);
    /* sizes from the dimensions (the *_GRID_DIMENSION attributes say otherwise) */
    SQ_CHECK(in.nx == 10 && in.ny == 8 && in.nz == 27);
    SQ_CHECK(in.projection == SQ_WRF_PROJ_LAMBERT && in.map_proj == 1);
    SQ_CHECK_NEAR(in.dx_m, 30000.0, 0.0);
    SQ_CHECK_NEAR(in.truelat1_deg, 30.0, 0.0);
    SQ_CHECK_NEAR(in.truelat2_deg, 35.0, 0.0);
    SQ_CHECK_NEAR(in.stand_lon_deg, 87.0, 0.0);
    SQ_CHECK(strstr(in.proj_string, "+proj=lcc") && strstr(in.proj_string, "+R=6370000"));
    SQ_CHECK(strstr(in.crs_wkt, "Lambert Conic Conformal") != NULL);
    /* 4 times (the string dimension is called string19 here), 3 h apart */
    SQ_CHECK(in.time_count == 4);
    if (in.time_count == 4) {
        SQ_CHECK(strcmp(in.time_strings[0], "2005-09-21_00:00:00") == 0);
        SQ_CHECK(strcmp(in.time_strings[3], "2005-09-21_09:00:00") == 0);
        SQ_CHECK_NEAR(in.times_s[1], 10800.0, 0.0);
        SQ_CHECK_NEAR(in.duration_s, 32400.0, 0.0);
    }
    SQ_CHECK_NEAR(in.start_unix_s, 1127260800.0, 0.0);
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) SQ_CHECK(in.has_species[s]);
    SQ_CHECK(in.has_ice_number && in.has_rain_number);
    SQ_CHECK(in.mp_physics == 8);
    SQ_CHECK(in.has_cloud_fraction);
    /* the centre of the mass grid; XLAT/XLONG have no Time dimension in this file */
    SQ_CHECK_NEAR(in.center_lat_deg, 30.0, 0.01);
    SQ_CHECK_NEAR(in.center_lon_deg, 87.0, 0.01);
    SQ_CHECK_NEAR(in.x0_m, -4.5 * 30000.0, 1e-6);
    SQ_CHECK_NEAR(in.y0_m, -3.5 * 30000.0, 1e-6);
    sq_wrf_close(w);
    sq_context_destroy(ctx);
}

SQ_TEST(sample_reference_numbers)
{
    sq_context *ctx = mkctx();
    sq_wrf *w = open1(ctx, SAMPLE);
    if (!w) return;
    sq_wrf_info in;
    sq_wrf_get_info(w, &in);
    sq_wrf_state s;
    SQ_CHECK_OK(sq_wrf_read_index(w, 0, &s));
    if (!s.z_m) return;
    const size_t plane = (size_t)in.nx * (size_t)in.ny, n = plane * (size_t)in.nz;
    /* wrf_format.md, time index 0: z[0,0,0] = 4824.1283 m */
    SQ_CHECK_NEAR(s.z_m[0], 4824.1283, 0.01);
    /* HGT 4484.35..5499.41 m, equal to zstag at k = 0 to float precision */
    double hmin = 1e9, hmax = -1e9, dz0 = 0, top_min = 1e9, top_max = -1e9;
    double rmin = 1e9, rmax = -1e9;
    for (size_t c = 0; c < plane; c++) {
        hmin = fmin(hmin, s.terrain_m[c]);
        hmax = fmax(hmax, s.terrain_m[c]);
        dz0 = fmax(dz0, fabs((double)s.z_w_m[c] - (double)s.terrain_m[c]));
        top_min = fmin(top_min, s.z_w_m[plane * (size_t)in.nz + c]);
        top_max = fmax(top_max, s.z_w_m[plane * (size_t)in.nz + c]);
        rmin = fmin(rmin, s.rho_kg_m3[c]);
        rmax = fmax(rmax, s.rho_kg_m3[c]);
    }
    SQ_CHECK_NEAR(hmin, 4484.35, 0.005);
    SQ_CHECK_NEAR(hmax, 5499.41, 0.005);
    SQ_CHECK(dz0 < 0.01);
    /* model top zstag ~ 20797-20813 m */
    SQ_CHECK_NEAR(top_min, 20797.5, 0.5);
    SQ_CHECK_NEAR(top_max, 20813.2, 0.5);
    /* surface moist density 0.6835..0.7552 kg m-3 */
    SQ_CHECK_NEAR(rmin, 0.6835, 5e-5);
    SQ_CHECK_NEAR(rmax, 0.7552, 5e-5);
    /* height above ground of the first level: half the first layer, tens of metres */
    SQ_CHECK(s.height_agl_m[0] > 5.0f && s.height_agl_m[0] < 100.0f);
    for (size_t c = 0; c < n; c++)
        if (!(s.z_m[c] > s.terrain_m[c % plane])) {
            SQ_FAIL_AT("z below the terrain at %zu", c);
            break;
        }

    /* Mixing ratio maxima over the four times (QCLOUD 8.824e-4, QICE 8.15e-6, QSNOW 7.55e-5,
     * QRAIN 1.13e-6, QGRAUP 7.9e-9) and QCLOUD > 1e-8 in 1.2 % of the cells: recovered from the
     * concentrations by inverting C = 1000 q / V, V = (1 + qv)/rho + sum q_s / rho_s. */
    double qmax[SQ_WRF_SPECIES_COUNT] = {0};
    size_t above = 0;
    const double rho_s[SQ_WRF_SPECIES_COUNT] = {1000, 917, 917, 1000, 917};
    for (int t = 0; t < in.time_count; t++) {
        SQ_CHECK_OK(sq_wrf_read_index(w, t, &s));
        if (!s.z_m) return;
        for (size_t c = 0; c < n; c++) {
            double frac = 0;
            for (int k = 0; k < SQ_WRF_SPECIES_COUNT; k++)
                frac += (double)s.q_g_m3[k][c] / (1000.0 * rho_s[k]);
            const double v = (1.0 + (double)s.qv_kg_kg[c]) / (double)s.rho_kg_m3[c] / (1.0 - frac);
            for (int k = 0; k < SQ_WRF_SPECIES_COUNT; k++)
                qmax[k] = fmax(qmax[k], (double)s.q_g_m3[k][c] * v / 1000.0);
            above += (double)s.q_g_m3[SQ_WRF_CLOUD][c] * v / 1000.0 > 1e-8;
        }
    }
    SQ_CHECK_NEAR(qmax[SQ_WRF_CLOUD], 8.824e-4, 0.0006e-4);
    SQ_CHECK_NEAR(qmax[SQ_WRF_ICE], 8.15e-6, 0.006e-6);
    SQ_CHECK_NEAR(qmax[SQ_WRF_SNOW], 7.55e-5, 0.006e-5);
    SQ_CHECK_NEAR(qmax[SQ_WRF_RAIN], 1.13e-6, 0.006e-6);
    SQ_CHECK_NEAR(qmax[SQ_WRF_GRAUPEL], 7.9e-9, 0.06e-9);
    SQ_CHECK_NEAR((double)above / ((double)n * in.time_count), 0.012, 0.0005);
    sq_wrf_close(w);
    sq_context_destroy(ctx);
}

SQ_TEST(sample_scan_ranges_and_world)
{
    sq_context *ctx = mkctx();
    sq_wrf *w = open1(ctx, SAMPLE);
    if (!w) return;
    sq_wrf_ranges g;
    SQ_CHECK_OK(sq_wrf_scan(w, &g));
    SQ_CHECK_NEAR(g.terrain_m.min, 4484.35, 0.005);
    SQ_CHECK_NEAR(g.terrain_m.max, 5499.41, 0.005);
    SQ_CHECK(g.p_pa.max < 60000.0 && g.p_pa.min > 4000.0); /* plateau: ~570 hPa at the ground */
    SQ_CHECK(g.t_k.min > 180.0 && g.t_k.max < 300.0);
    SQ_CHECK(g.q_g_m3[SQ_WRF_CLOUD].max > 0.1 && g.q_g_m3[SQ_WRF_CLOUD].min == 0.0);
    SQ_CHECK(g.lat_deg.min > 25.0 && g.lat_deg.max < 35.0);
    /* this run's CLDFRA is a cloud flag: 8521 zeros and 119 ones over its 4 x 27 x 8 x 10
     * values (ncdump) */
    SQ_CHECK(g.cloud_fraction_is_flag);
    SQ_CHECK(g.cloud_fraction.min == 0.0 && g.cloud_fraction.max == 1.0);
    int ones = 0, others = 0;
    for (int t = 0; t < 4; t++) {
        sq_wrf_state st;
        SQ_CHECK_OK(sq_wrf_read_index(w, t, &st));
        for (int c = 0; st.cloud_fraction && c < 10 * 8 * 27; c++) {
            ones += st.cloud_fraction[c] == 1.0f;
            others += st.cloud_fraction[c] != 0.0f && st.cloud_fraction[c] != 1.0f;
        }
    }
    SQ_CHECK(ones == 119 && others == 0);

    /* the world from the file: terrain heights at the grid points equal HGT, georeferenced */
    sq_wrf_info in;
    sq_wrf_get_info(w, &in);
    sq_world_desc wd = {0};
    SQ_CHECK_OK(sq_wrf_world_desc(w, 3 * 3600.0, &wd));
    sq_world *world = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &world));
    sq_wrf_state s;
    SQ_CHECK_OK(sq_wrf_read_index(w, 0, &s));
    if (world && s.terrain_m) {
        SQ_CHECK(terrain_of(world).nx == in.nx && terrain_of(world).ny == in.ny);
        for (int j = 0; j < in.ny; j++)
            for (int i = 0; i < in.nx; i++)
                SQ_CHECK_NEAR(sq_world_height_at(world, s.x_m[i], s.y_m[j]),
                              s.terrain_m[j * in.nx + i], 1e-3);
        SQ_CHECK(sq_world_crs(world, NULL) && strstr(sq_world_crs(world, NULL), "Lambert"));
        double off[2];
        sq_world_crs(world, off);
        SQ_CHECK_NEAR(off[0], in.crs_offset_m[0], 0.0);
        /* 03 UTC at 87 E is about 08:55 true solar time: the sun is up in the east-south-east */
        SQ_CHECK(light_of(world).sun_dir.z > 0.5f && light_of(world).sun_dir.x > 0.5f);
        /* the projected coordinates of a grid point's lat/lon give back its world position */
        double x, y;
        SQ_CHECK_OK(sq_wrf_to_world(w, s.lon_deg[3 * in.nx + 7], s.lat_deg[3 * in.nx + 7], &x, &y));
        SQ_CHECK_NEAR(x, s.x_m[7], 2.0);
        SQ_CHECK_NEAR(y, s.y_m[3], 2.0);
        double lon, lat;
        SQ_CHECK_OK(sq_wrf_from_world(w, 0.0, 0.0, &lon, &lat));
        SQ_CHECK_NEAR(lon, in.center_lon_deg, 1e-9);
        SQ_CHECK_NEAR(lat, in.center_lat_deg, 1e-9);
    }
    sq_world_destroy(ctx, world);
    sq_wrf_close(w);
    sq_context_destroy(ctx);
}

SQ_TEST(sample_sun_through_the_morning)
{
    sq_context *ctx = mkctx();
    sq_wrf *w = open1(ctx, SAMPLE);
    if (!w) return;
    sq_wrf_info in;
    sq_wrf_get_info(w, &in);
    double el[4] = {0};
    for (int t = 0; t < in.time_count && t < 4; t++) {
        sq_sun_position p;
        sq_vec3 d;
        SQ_CHECK_OK(sq_wrf_sun(w, in.times_s[t], &p, &d));
        /* the same as the world-layer function at the centre */
        sq_sun_position q = sq_sun_position_at(in.start_unix_s + in.times_s[t],
                                               in.center_lat_deg, in.center_lon_deg);
        SQ_CHECK_NEAR(p.elevation_deg, q.elevation_deg, 1e-12);
        el[t] = p.elevation_deg;
        SQ_CHECK_NEAR(asin((double)d.z) * 180.0 / M_PI, p.elevation_deg, 1e-4);
    }
    /* 00, 03, 06, 09 UTC at 87 E are about 05:55, 08:55, 11:55, 14:55 true solar time: sunrise,
     * morning, noon (elevation 90 - (30 - declination) at the equinox), afternoon */
    SQ_CHECK(el[0] < el[1] && el[1] < el[2] && el[3] < el[2] && el[3] > el[1]);
    SQ_CHECK_NEAR(el[2], 60.0, 1.0);
    /* 2005-09-21 00 UTC at 87 E: 5.8 h + 6.8 min equation of time = 05:55 solar, sunrise */
    sq_sun_position p0;
    sq_wrf_sun(w, 0.0, &p0, NULL);
    SQ_CHECK_NEAR(p0.true_solar_time_h, 87.0 / 15.0 + p0.equation_of_time_min / 60.0, 1e-6);
    SQ_CHECK_NEAR(p0.equation_of_time_min, 6.9, 0.3);
    SQ_CHECK(fabs(p0.elevation_deg) < 3.0);
    sq_wrf_close(w);
    sq_context_destroy(ctx);
}

SQ_TEST(scene_terrain_from_wrf_with_moving_sun)
{
    /* world.terrain.kind = wrf through the io layer's loader: HGT x exaggeration on the model grid,
     * the sun from the file's first time over the domain centre, moving with the scene clock */
    sq_context *ctx = mkctx();
    char text[1024];
    snprintf(text, sizeof text,
             "world:\n  terrain: {kind: wrf, wrf: %s, vertical_exaggeration: 3}\n"
             "  sun: {clock_scale: 1800}\n"
             "output: {width: 64, height: 48, frames: 2}\n",
             SAMPLE);
    sq_cfg *cfg = NULL;
    SQ_CHECK_OK(sq_cfg_parse(ctx, text, strlen(text), "wrf.yaml", &cfg));
    sq_scene_desc d = {.cfg = cfg, .load_wrf_world = sq_scene_wrf_world_loader};
    sq_scene *s = NULL;
    SQ_CHECK_OK(sq_scene_create(ctx, &d, &s));
    sq_wrf *w = open1(ctx, SAMPLE);
    sq_wrf_state st;
    if (s && w && sq_wrf_read_index(w, 0, &st) == SQ_OK) {
        const sq_world *world = sq_scene_world(s);
        sq_wrf_info in;
        sq_wrf_get_info(w, &in);
        SQ_CHECK(terrain_of(world).nx == in.nx && terrain_of(world).ny == in.ny && terrain_of(world).dx == 30000.0f);
        for (int j = 0; j < in.ny; j++)
            for (int i = 0; i < in.nx; i++)
                SQ_CHECK_NEAR(sq_world_height_at(world, st.x_m[i], st.y_m[j]),
                              3.0 * st.terrain_m[j * in.nx + i], 3e-3);
        SQ_CHECK(sq_world_crs(world, NULL) && strstr(sq_world_crs(world, NULL), "Lambert"));
        /* sunrise at scene time 0; after 6 scene seconds = 3 h of sun time, the 03 UTC sun */
        sq_sun_position p;
        sq_vec3 dir;
        SQ_CHECK_OK(sq_wrf_sun(w, 0.0, &p, &dir));
        SQ_CHECK_NEAR(light_of(world).sun_dir.z, dir.z, 1e-5);
        for (int k = 0; k < 6; k++) SQ_CHECK_OK(sq_scene_step(s, 1.0));
        SQ_CHECK_OK(sq_wrf_sun(w, 3 * 3600.0, &p, &dir));
        SQ_CHECK_NEAR(light_of(world).sun_dir.x, dir.x, 1e-5);
        SQ_CHECK_NEAR(light_of(world).sun_dir.z, dir.z, 1e-5);
        SQ_CHECK(p.elevation_deg > 30.0);
    }
    sq_wrf_close(w);
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    /* without a path, and without a loader: refused with the key */
    const char *t2 = "world:\n  terrain: {kind: wrf}\n";
    SQ_CHECK_OK(sq_cfg_parse(ctx, t2, strlen(t2), "nopath.yaml", &cfg));
    d.cfg = cfg;
    SQ_CHECK_ERR(sq_scene_create(ctx, &d, &s), SQ_ERR_INVALID_ARG, "needs world.terrain.wrf");
    sq_cfg_destroy(cfg);
    SQ_CHECK_OK(sq_cfg_parse(ctx, text, strlen(text), "wrf.yaml", &cfg));
    d.cfg = cfg;
    d.load_wrf_world = NULL;
    SQ_CHECK_ERR(sq_scene_create(ctx, &d, &s), SQ_ERR_UNSUPPORTED, "needs a WRF loader");
    sq_cfg_destroy(cfg);
    /* a bad date */
    const char *t3 = "world:\n  sun: {date: '2005-13-01 00:00:00'}\n";
    SQ_CHECK_OK(sq_cfg_parse(ctx, t3, strlen(t3), "date.yaml", &cfg));
    d.cfg = cfg;
    SQ_CHECK_ERR(sq_scene_create(ctx, &d, &s), SQ_ERR_INVALID_ARG, "world.sun.date = '2005-13-01");
    sq_cfg_destroy(cfg);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
}

/* ---- synthetic files ------------------------------------------------------------------------ */

/* Expected derived values at (t, k, j, i) from the formulas of wrf_format.md, on the values as
 * stored (float). */
typedef struct fx_expect {
    double z, zw0, p, theta, tk, rho, qv, u, v, w, c[SQ_WRF_SPECIES_COUNT], ni;
} fx_expect;

static double f32(double v) { return (double)(float)v; }

static fx_expect fx_expected(const fx_desc *d, int t, int k, int j, int i)
{
    fx_expect e;
    const double zb = (f32(fx_ph(t, k, j, i)) + f32(fx_phb(k, j, i))) / 9.81;
    const double zt = (f32(fx_ph(t, k + 1, j, i)) + f32(fx_phb(k + 1, j, i))) / 9.81;
    e.zw0 = zb;
    e.z = 0.5 * (zb + zt);
    e.p = f32(fx_p(t, k, j, i)) + f32(fx_pb(k));
    e.theta = f32(fx_t(t, k, j, i)) + 300.0;
    e.tk = e.theta * pow(e.p / 1e5, 287.0 / 1004.5);
    e.qv = f32(fx_qv(t, k, j, i));
    e.rho = e.p / (287.0 * e.tk * (1.0 + 0.608 * e.qv));
    e.u = 0.5 * (f32(fx_u(t, k, j, i)) + f32(fx_u(t, k, j, i + 1)));
    e.v = 0.5 * (f32(fx_v(t, k, j, i)) + f32(fx_v(t, k, j + 1, i)));
    e.w = 0.5 * (f32(fx_w(t, k, j, i)) + f32(fx_w(t, k + 1, j, i)));
    double q[SQ_WRF_SPECIES_COUNT] = {fmax(0.0, f32(fx_qc(t, k, j, i))), 0, 0,
                                      f32(fx_qr(t, k, j, i)), 0};
    if (d->thompson) {
        q[SQ_WRF_ICE] = f32(fx_qi(t, k, j, i));
        q[SQ_WRF_SNOW] = f32(fx_qs(t, k, j, i));
        q[SQ_WRF_GRAUPEL] = f32(fx_qg(t, k, j, i));
    }
    const double vol = (1 + e.qv) / e.rho + (q[0] + q[3]) / 1000.0 + (q[1] + q[2] + q[4]) / 917.0;
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) e.c[s] = q[s] / vol * 1000.0;
    e.ni = d->thompson ? f32(fx_qni(t, k, j, i)) / vol : 0.0;
    return e;
}

/* Compares every derived field of state s (at stored time t, or halfway to t + 1) with the
 * independent formulas; returns the number of mismatches. */
static int fx_compare(const fx_desc *d, const sq_wrf_state *s, int t, bool halfway)
{
    int bad = 0;
    const int nx = d->nx, ny = d->ny;
    for (int k = 0; k < d->nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const size_t c = ((size_t)k * ny + j) * nx + i;
                fx_expect e = fx_expected(d, t, k, j, i);
                if (halfway) {
                    fx_expect b = fx_expected(d, t + 1, k, j, i);
                    e.z = 0.5 * (e.z + b.z), e.p = 0.5 * (e.p + b.p);
                    e.theta = 0.5 * (e.theta + b.theta), e.tk = 0.5 * (e.tk + b.tk);
                    e.rho = 0.5 * (e.rho + b.rho), e.u = 0.5 * (e.u + b.u);
                    for (int q = 0; q < SQ_WRF_SPECIES_COUNT; q++) e.c[q] = 0.5 * (e.c[q] + b.c[q]);
                }
                const double hgt = f32(fx_hgt(t, j, i));
                const double ptol = halfway ? 0.01 : 0.0; /* p exact at a stored time */
                bool ok = fabs(s->z_m[c] - e.z) <= 1e-3 &&
                          fabs(s->height_agl_m[c] - (e.z - hgt)) <= 1e-3 &&
                          fabs(s->p_pa[c] - (halfway ? e.p : f32(e.p))) <= ptol &&
                          fabs(s->theta_k[c] - e.theta) <= 1e-4 &&
                          fabs(s->t_k[c] - e.tk) <= 1e-4 &&
                          fabs(s->rho_kg_m3[c] - e.rho) <= 1e-6 * e.rho &&
                          fabs(s->u_mps[c] - e.u) <= 1e-5;
                if (!halfway)
                    ok = ok && fabs(s->v_mps[c] - e.v) <= 1e-5 && fabs(s->w_mps[c] - e.w) <= 1e-6 &&
                         fabs(s->qv_kg_kg[c] - e.qv) <= 1e-9;
                for (int q = 0; q < SQ_WRF_SPECIES_COUNT; q++) {
                    if (!s->q_g_m3[q]) continue;
                    ok = ok && fabs(s->q_g_m3[q][c] - e.c[q]) <= 1e-6 * e.c[q] + 1e-12;
                }
                if (!halfway && s->ice_number_m3)
                    ok = ok && fabs(s->ice_number_m3[c] - e.ni) <= 1e-6 * e.ni;
                if (!ok && bad++ < 3)
                    fprintf(stderr,
                            "t %d k %d j %d i %d: z %.4f/%.4f p %.3f/%.3f T %.5f/%.5f rho "
                            "%.6f/%.6f u %.4f/%.4f qc %.6g/%.6g\n",
                            t, k, j, i, (double)s->z_m[c], e.z, (double)s->p_pa[c], e.p,
                            (double)s->t_k[c], e.tk, (double)s->rho_kg_m3[c], e.rho,
                            (double)s->u_mps[c], e.u,
                            s->q_g_m3[0] ? (double)s->q_g_m3[0][c] : 0.0, e.c[0]);
            }
    return bad;
}

/* Opens a fixture and checks its projection: every XLAT/XLONG (from Snyder's formulas) projects
 * through the reader's PROJ set-up onto its grid point, the centre is the fixture's centre. */
static void check_projection(const fx_desc *d, const char *name, double north_rotation)
{
    sq_context *ctx = mkctx();
    const char *path = tmp_path(name);
    SQ_CHECK(fx_write(path, d));
    sq_wrf *w = open1(ctx, path);
    if (!w) {
        sq_context_destroy(ctx);
        return;
    }
    sq_wrf_info in;
    sq_wrf_get_info(w, &in);
    SQ_CHECK((int)in.projection == d->map_proj);
    SQ_CHECK_NEAR(in.center_lat_deg, d->cen_lat, 1e-4);
    SQ_CHECK_NEAR(in.center_lon_deg, d->cen_lon, 1e-4);
    SQ_CHECK_NEAR(in.north_rotation_deg, north_rotation, 1e-3);
    sq_wrf_state s;
    SQ_CHECK_OK(sq_wrf_read_index(w, 0, &s));
    double worst = 0;
    for (int j = 0; j < d->ny && s.lat_deg; j++)
        for (int i = 0; i < d->nx; i++) {
            double x, y;
            SQ_CHECK_OK(sq_wrf_to_world(w, s.lon_deg[j * d->nx + i], s.lat_deg[j * d->nx + i], &x,
                                        &y));
            worst = fmax(worst, hypot(x - s.x_m[i], y - s.y_m[j]));
        }
    /* float32 lat/lon: ~1e-5 degree ~ 1 m */
    SQ_CHECK_MSG(worst < 2.0, "%s: grid points off by %.2f m", name, worst);
    /* true north in the grid: the sun's world direction is its azimuth turned by the rotation */
    sq_sun_position p;
    sq_vec3 dir;
    SQ_CHECK_OK(sq_wrf_sun(w, 0.0, &p, &dir));
    const double az_world = atan2((double)dir.x, (double)dir.y) * 180.0 / M_PI;
    double diff = fmod(az_world - (p.azimuth_deg + north_rotation) + 720.0, 360.0);
    if (diff > 180.0) diff -= 360.0;
    SQ_CHECK_NEAR(diff, 0.0, 1e-3);
    sq_wrf_close(w);
    sq_context_destroy(ctx);
}

SQ_TEST(projection_lambert)
{
    fx_desc d = fx_default(1);
    /* grid convergence of the Lambert cone: gamma = -n (lon - lon0), n from the true latitudes */
    const double p1 = 30 * FX_D2R, p2 = 60 * FX_D2R;
    const double n = log(cos(p1) / cos(p2)) / log(tan(M_PI / 4 + p2 / 2) / tan(M_PI / 4 + p1 / 2));
    check_projection(&d, "lcc.nc", -n * (d.cen_lon - d.stand_lon));
    cleanup();
}

SQ_TEST(projection_polar_stereographic)
{
    fx_desc d = fx_default(2);
    check_projection(&d, "polar.nc", -(d.cen_lon - d.stand_lon));
    cleanup();
}

SQ_TEST(projection_mercator)
{
    fx_desc d = fx_default(3);
    check_projection(&d, "merc.nc", 0.0);
    cleanup();
}

SQ_TEST(projection_latlon)
{
    fx_desc d = fx_default(6);
    check_projection(&d, "latlon.nc", 0.0);
    cleanup();
}

SQ_TEST(derived_fields_netcdf3_thompson)
{
    /* netCDF-3 (64-bit offset), DateStrLen, XLAT/XLONG with Time, all species */
    fx_desc d = fx_default(1);
    d.classic = true;
    d.latlon_time = true;
    const char *path = tmp_path("classic.nc");
    SQ_CHECK(fx_write(path, &d));
    sq_context *ctx = mkctx();
    sq_wrf *w = open1(ctx, path);
    if (w) {
        sq_wrf_info in;
        sq_wrf_get_info(w, &in);
        SQ_CHECK(in.nx == d.nx && in.ny == d.ny && in.nz == d.nz && in.time_count == d.nt);
        SQ_CHECK(in.has_species[SQ_WRF_ICE] && in.has_species[SQ_WRF_GRAUPEL]);
        SQ_CHECK(in.has_ice_number && !in.has_rain_number);
        for (int t = 0; t < d.nt; t++) {
            sq_wrf_state s;
            SQ_CHECK_OK(sq_wrf_read_index(w, t, &s));
            if (s.z_m) SQ_CHECK_MSG(fx_compare(&d, &s, t, false) == 0, "time %d differs", t);
            /* the rounding-noise QCLOUD of -1e-12 at the first cell is clamped to 0 */
            if (s.z_m) SQ_CHECK(s.q_g_m3[SQ_WRF_CLOUD][0] == 0.0f);
            /* w-levels: the ground is HGT */
            if (s.z_m) SQ_CHECK_NEAR(s.z_w_m[7], fx_hgt(t, 1, 1), 1e-3);
        }
        sq_wrf_ranges g;
        SQ_CHECK_OK(sq_wrf_scan(w, &g));
        SQ_CHECK(g.clamped_negative == d.nt);
        sq_wrf_close(w);
    }
    sq_context_destroy(ctx);
    cleanup();
}

SQ_TEST(derived_fields_netcdf4_wsm3_subset)
{
    /* netCDF-4, time strings under another dimension name, WSM3: no QICE/QSNOW/QGRAUP */
    fx_desc d = fx_default(3);
    d.thompson = false;
    d.strlen_name = "string19";
    const char *path = tmp_path("wsm3.nc");
    SQ_CHECK(fx_write(path, &d));
    sq_context *ctx = mkctx();
    sq_wrf *w = open1(ctx, path);
    if (w) {
        sq_wrf_info in;
        sq_wrf_get_info(w, &in);
        SQ_CHECK(in.has_species[SQ_WRF_CLOUD] && in.has_species[SQ_WRF_RAIN]);
        SQ_CHECK(!in.has_species[SQ_WRF_ICE] && !in.has_species[SQ_WRF_SNOW] &&
                 !in.has_species[SQ_WRF_GRAUPEL] && !in.has_ice_number);
        SQ_CHECK(in.mp_physics == 3);
        sq_wrf_state s;
        SQ_CHECK_OK(sq_wrf_read_index(w, 2, &s));
        if (s.z_m) {
            SQ_CHECK(!s.q_g_m3[SQ_WRF_ICE] && !s.q_g_m3[SQ_WRF_SNOW] && !s.q_g_m3[SQ_WRF_GRAUPEL]);
            SQ_CHECK(!s.ice_number_m3 && !s.rain_number_m3);
            SQ_CHECK(fx_compare(&d, &s, 2, false) == 0);
        }
        sq_wrf_close(w);
    }
    sq_context_destroy(ctx);
    cleanup();
}

SQ_TEST(time_interpolation_between_stored_times)
{
    fx_desc d = fx_default(1);
    const char *path = tmp_path("interp.nc");
    SQ_CHECK(fx_write(path, &d));
    sq_context *ctx = mkctx();
    sq_wrf *w = open1(ctx, path);
    if (w) {
        sq_wrf_state s;
        /* halfway between stored times 1 and 2 (3 h apart): the mean of the two */
        SQ_CHECK_OK(sq_wrf_read(w, 1.5 * 3 * 3600.0, &s));
        SQ_CHECK(s.index0 == 1 && s.index1 == 2);
        SQ_CHECK_NEAR(s.weight1, 0.5, 1e-12);
        if (s.z_m) SQ_CHECK(fx_compare(&d, &s, 1, true) == 0);
        /* a quarter of the way: linear */
        SQ_CHECK_OK(sq_wrf_read(w, 0.25 * 3 * 3600.0, &s));
        fx_expect a = fx_expected(&d, 0, 2, 1, 1), b = fx_expected(&d, 1, 2, 1, 1);
        const size_t c = ((size_t)2 * d.ny + 1) * d.nx + 1;
        if (s.z_m) {
            SQ_CHECK_NEAR(s.z_m[c], 0.75 * a.z + 0.25 * b.z, 1e-3);
            SQ_CHECK_NEAR(s.q_g_m3[0][c], 0.75 * a.c[0] + 0.25 * b.c[0], 1e-6 * a.c[0]);
        }
        /* exactly at a stored time: that time's fields, index0 == index1 */
        SQ_CHECK_OK(sq_wrf_read(w, 2 * 3 * 3600.0, &s));
        SQ_CHECK(s.index0 == 2 && s.index1 == 2);
        if (s.z_m) SQ_CHECK(fx_compare(&d, &s, 2, false) == 0);
        /* the end points, and outside the series */
        SQ_CHECK_OK(sq_wrf_read(w, 0.0, &s));
        SQ_CHECK_ERR(sq_wrf_read(w, -1.0, &s), SQ_ERR_INVALID_ARG, "outside the series");
        SQ_CHECK_ERR(sq_wrf_read(w, 6 * 3600.0 + 1.0, &s), SQ_ERR_INVALID_ARG,
                     "2020-06-21_00:00:00 to 2020-06-21_06:00:00");
        SQ_CHECK_ERR(sq_wrf_read(w, NAN, &s), SQ_ERR_INVALID_ARG, "outside");
        SQ_CHECK_ERR(sq_wrf_read_index(w, 3, &s), SQ_ERR_INVALID_ARG, "time index 3");
        SQ_CHECK(s.z_m == NULL);
        sq_wrf_close(w);
    }
    sq_context_destroy(ctx);
    cleanup();
}

/* CLDFRA: read as written (a fraction), interpolated between stored times, known as a 0/1 flag
 * when a scheme writes only those, refused beyond [0, 1] (rounding noise clamped), absent
 * without it. */
SQ_TEST(cloud_fraction_read_flag_and_refused)
{
    sq_context *ctx = mkctx();
    for (int mode = 0; mode < 3; mode++) {
        fx_desc d = fx_default(1);
        d.cldfra = mode;
        char name[32];
        snprintf(name, sizeof name, "cldfra%d.nc", mode);
        const char *path = tmp_path(name);
        SQ_CHECK(fx_write(path, &d));
        sq_wrf *w = open1(ctx, path);
        if (!w) continue;
        sq_wrf_info in;
        sq_wrf_get_info(w, &in);
        SQ_CHECK(in.has_cloud_fraction == (mode != 0));
        sq_wrf_state s;
        SQ_CHECK_OK(sq_wrf_read_index(w, 1, &s));
        if (mode == 0) SQ_CHECK(s.cloud_fraction == NULL);
        if (mode != 0 && s.cloud_fraction) {
            int bad = 0;
            for (int k = 0; k < d.nz; k++)
                for (int j = 0; j < d.ny; j++)
                    for (int i = 0; i < d.nx; i++) {
                        const double want = mode == 1 ? fx_cf(1, k, j, i) : fx_cf01(1, k, j, i);
                        bad += s.cloud_fraction[((size_t)k * d.ny + j) * d.nx + i] != (float)want;
                    }
            SQ_CHECK(bad == 0);
            SQ_CHECK(s.cloud_fraction_is_flag == (mode == 2));
            /* halfway between stored times 1 and 2: the mean; a flag stays a flag */
            SQ_CHECK_OK(sq_wrf_read(w, 1.5 * 3 * 3600.0, &s));
            const size_t c = ((size_t)2 * d.ny + 1) * d.nx + 3;
            const double a = mode == 1 ? fx_cf(1, 2, 1, 3) : fx_cf01(1, 2, 1, 3);
            const double b = mode == 1 ? fx_cf(2, 2, 1, 3) : fx_cf01(2, 2, 1, 3);
            SQ_CHECK_NEAR(s.cloud_fraction[c], 0.5 * (a + b), 1e-6);
            SQ_CHECK(s.cloud_fraction_is_flag == (mode == 2));
            sq_wrf_ranges g;
            SQ_CHECK_OK(sq_wrf_scan(w, &g));
            SQ_CHECK(g.cloud_fraction_is_flag == (mode == 2));
            SQ_CHECK_NEAR(g.cloud_fraction.max, 1.0, 0.0);
        }
        sq_wrf_close(w);
    }
    /* beyond [0, 1]: refused with the variable, value and index; 1.004 is rounding noise */
    const float pokes[2] = {1.5f, 1.004f};
    for (int q = 0; q < 2; q++) {
        fx_desc d = fx_default(1);
        d.cldfra = 1;
        d.poke_cldfra = pokes[q];
        const char *path = tmp_path(q == 0 ? "cldfra_bad.nc" : "cldfra_noise.nc");
        SQ_CHECK(fx_write(path, &d));
        sq_wrf *w = open1(ctx, path);
        if (!w) continue;
        sq_wrf_state s;
        if (q == 0) {
            SQ_CHECK_ERR(sq_wrf_read_index(w, 0, &s), SQ_ERR_INVALID_ARG, "'CLDFRA' = 1.5");
            SQ_CHECK(strstr(sq_last_error(), "bottom_top 1, south_north 1, west_east 1") != NULL);
        } else {
            SQ_CHECK_OK(sq_wrf_read_index(w, 0, &s));
            if (s.cloud_fraction)
                SQ_CHECK(s.cloud_fraction[((size_t)1 * d.ny + 1) * d.nx + 1] == 1.0f);
        }
        sq_wrf_close(w);
    }
    sq_context_destroy(ctx);
    cleanup();
}

SQ_TEST(series_of_files_in_time_order)
{
    /* three files of three 3-hourly times each, given out of order, form one 9-time series */
    fx_desc d = fx_default(1);
    const char *names[3] = {"s_b.nc", "s_a.nc", "s_c.nc"};
    const int hours[3] = {9, 0, 18};
    char paths[3][600];
    for (int f = 0; f < 3; f++) {
        d.start_hour = hours[f];
        snprintf(paths[f], sizeof paths[f], "%s", tmp_path(names[f]));
        SQ_CHECK(fx_write(paths[f], &d));
    }
    sq_context *ctx = mkctx();
    const char *p[3] = {paths[0], paths[1], paths[2]};
    sq_wrf *w = NULL;
    SQ_CHECK_OK(sq_wrf_open(ctx, p, 3, &w));
    if (w) {
        sq_wrf_info in;
        sq_wrf_get_info(w, &in);
        SQ_CHECK(in.time_count == 9 && in.file_count == 3);
        for (int t = 0; t < in.time_count; t++) SQ_CHECK_NEAR(in.times_s[t], t * 10800.0, 0.0);
        SQ_CHECK(strcmp(in.time_strings[8], "2020-06-22_00:00:00") == 0);
        /* stored time 4 is the second time of the file that starts at 09 h: its local t = 1 */
        sq_wrf_state s;
        SQ_CHECK_OK(sq_wrf_read_index(w, 4, &s));
        if (s.z_m) SQ_CHECK(fx_compare(&d, &s, 1, false) == 0);
        /* across a file boundary (between stored times 2 and 3) the interpolation still works */
        SQ_CHECK_OK(sq_wrf_read(w, 2.5 * 10800.0, &s));
        SQ_CHECK(s.index0 == 2 && s.index1 == 3);
        sq_wrf_close(w);
    }
    /* the same time twice is refused */
    const char *dup[2] = {paths[1], paths[1]};
    SQ_CHECK_ERR(sq_wrf_open(ctx, dup, 2, &w), SQ_ERR_INVALID_ARG, "is also in");
    /* a file with another grid is refused */
    fx_desc other = fx_default(1);
    other.nx = 7;
    const char *op = tmp_path("other.nc");
    SQ_CHECK(fx_write(op, &other));
    const char *mix[2] = {paths[1], op};
    SQ_CHECK_ERR(sq_wrf_open(ctx, mix, 2, &w), SQ_ERR_INVALID_ARG, "differs from 6 x 5 x 4");
    SQ_CHECK(w == NULL);
    sq_context_destroy(ctx);
    cleanup();
}

SQ_TEST(refusals_name_file_and_variable)
{
    sq_context *ctx = mkctx();
    sq_wrf *w = NULL;
    /* not WRF output: PH missing */
    fx_desc d = fx_default(1);
    d.omit_ph = true;
    const char *a = tmp_path("noph.nc");
    SQ_CHECK(fx_write(a, &d));
    const char *pa[1] = {a};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pa, 1, &w), SQ_ERR_PARSE, "noph.nc: not WRF output: variable 'PH'");
    /* a variable of the wrong shape */
    d = fx_default(1);
    d.bad_qcloud_shape = true;
    const char *b = tmp_path("shape.nc");
    SQ_CHECK(fx_write(b, &d));
    const char *pb[1] = {b};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pb, 1, &w), SQ_ERR_PARSE,
                 "variable 'QCLOUD' has the shape (Time=3, bottom_top=4, south_north=5)");
    /* an unknown projection code */
    d = fx_default(1);
    d.map_proj = 5;
    const char *c = tmp_path("proj5.nc");
    SQ_CHECK(fx_write(c, &d));
    const char *pc[1] = {c};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pc, 1, &w), SQ_ERR_PARSE, "MAP_PROJ = 5: unknown map projection");
    /* DX that does not match XLAT/XLONG */
    d = fx_default(1);
    d.dx_attr = 13000.0;
    const char *e = tmp_path("dx.nc");
    SQ_CHECK(fx_write(e, &d));
    const char *pe[1] = {e};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pe, 1, &w), SQ_ERR_PARSE, "XLAT/XLONG do not match MAP_PROJ = 1");
    /* NaN and strongly negative mixing ratios: found when the time is read */
    d = fx_default(1);
    d.poke_qcloud = NAN;
    const char *f = tmp_path("nan.nc");
    SQ_CHECK(fx_write(f, &d));
    sq_wrf *wf = open1(ctx, f);
    sq_wrf_state s;
    if (wf) {
        SQ_CHECK_ERR(sq_wrf_read_index(wf, 0, &s), SQ_ERR_INVALID_ARG,
                     "nan.nc: variable 'QCLOUD' is NaN at [Time 0, bottom_top 1, south_north 1, "
                     "west_east 1]");
        SQ_CHECK_OK(sq_wrf_read_index(wf, 1, &s));
        sq_wrf_ranges g;
        SQ_CHECK_ERR(sq_wrf_scan(wf, &g), SQ_ERR_INVALID_ARG, "NaN");
        sq_wrf_close(wf);
    }
    d.poke_qcloud = -0.01f;
    const char *g = tmp_path("neg.nc");
    SQ_CHECK(fx_write(g, &d));
    sq_wrf *wg = open1(ctx, g);
    if (wg) {
        SQ_CHECK_ERR(sq_wrf_read_index(wg, 0, &s), SQ_ERR_INVALID_ARG,
                     "variable 'QCLOUD' = -0.01 kg/kg");
        sq_wrf_close(wg);
    }
    /* not NetCDF, missing, a directory, a FIFO */
    const char *h = tmp_path("text.nc");
    FILE *fp = fopen(h, "w");
    if (fp) {
        fputs("not a netcdf file\n", fp);
        fclose(fp);
    }
    const char *ph[1] = {h};
    SQ_CHECK_ERR(sq_wrf_open(ctx, ph, 1, &w), SQ_ERR_PARSE, "text.nc: not a NetCDF file");
    const char *pm[1] = {tmp_path("missing.nc")};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pm, 1, &w), SQ_ERR_IO, "No such file");
    const char *pd[1] = {g_dir};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pd, 1, &w), SQ_ERR_IO, "is a directory");
    const char *fifo = tmp_path("fifo.nc");
    if (mkfifo(fifo, 0600) == 0) {
        const char *pf[1] = {fifo};
        SQ_CHECK_ERR(sq_wrf_open(ctx, pf, 1, &w), SQ_ERR_IO, "is a FIFO");
    }
    SQ_CHECK(w == NULL);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    cleanup();
}

/* Copies src to dst with the 4-byte big-endian word at offset set to value (value < 0: the file
 * is cut to offset bytes instead); false when src cannot be read. */
static bool poke_be32(const char *src, const char *dst, long offset, long long value)
{
    FILE *in = fopen(src, "rb");
    if (!in) return false;
    unsigned char buf[1 << 16];
    const size_t n = fread(buf, 1, sizeof buf, in);
    fclose(in);
    if (n < (size_t)offset + 4) return false;
    size_t len = n;
    if (value >= 0)
        for (int b = 0; b < 4; b++) buf[offset + b] = (unsigned char)(value >> (24 - 8 * b));
    else
        len = (size_t)offset;
    FILE *out = fopen(dst, "wb");
    if (!out) return false;
    const bool ok = fwrite(buf, 1, len, out) == len;
    return fclose(out) == 0 && ok;
}

/* libnetcdf allocates what a netCDF-3 header declares; the reader walks the header first and
 * refuses counts that do not fit in the file (tests/fuzz/regress/wrf/ has the fuzzer's find). */
SQ_TEST(netcdf3_header_counts_bounded_by_the_file)
{
    sq_context *ctx = mkctx();
    sq_wrf *w = NULL;
    fx_desc d = fx_default(1);
    d.classic = true;
    char good[600]; /* tmp_path() reuses 4 buffers */
    snprintf(good, sizeof good, "%s", tmp_path("classic.nc"));
    SQ_CHECK(fx_write(good, &d));
    sq_wrf *wg = open1(ctx, good); /* the walk accepts a real classic file */
    if (wg) sq_wrf_close(wg);
    /* magic, numrecs, NC_DIMENSION, ndims: the first dimension's name length is at byte 16 */
    const char *name = tmp_path("name.nc");
    SQ_CHECK(poke_be32(good, name, 16, 0x7ffffff0LL));
    const char *pn[1] = {name};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pn, 1, &w), SQ_ERR_PARSE,
                 "name.nc: truncated or corrupt netCDF-3 file: its header declares a dimension "
                 "that does not fit");
    /* a dimension count of two billion */
    const char *count = tmp_path("count.nc");
    SQ_CHECK(poke_be32(good, count, 12, 0x7fffffffLL));
    const char *pc[1] = {count};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pc, 1, &w), SQ_ERR_PARSE, "dimension list that does not fit");
    /* an unknown list tag where the dimensions start */
    const char *tag = tmp_path("tag.nc");
    SQ_CHECK(poke_be32(good, tag, 8, 0x0d));
    const char *pt[1] = {tag};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pt, 1, &w), SQ_ERR_PARSE,
                 "tag.nc: corrupt netCDF-3 file: invalid dimension list in the header");
    /* the header cut short */
    const char *cut = tmp_path("cut.nc");
    SQ_CHECK(poke_be32(good, cut, 40, -1));
    const char *pk[1] = {cut};
    SQ_CHECK_ERR(sq_wrf_open(ctx, pk, 1, &w), SQ_ERR_PARSE, "cut.nc: truncated or corrupt netCDF-3");
    SQ_CHECK(w == NULL);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    cleanup();
}

SQ_TEST(memory_limit_refuses_before_allocating)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {0};
    cd.memory_limit_bytes = 300000; /* the sample's caches need ~605 kB */
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_wrf *w = open1(ctx, SAMPLE);
    if (w) {
        SQ_CHECK(sq_wrf_memory_bytes(w) > 600000 && sq_wrf_memory_bytes(w) < 700000);
        sq_wrf_state s;
        SQ_CHECK_ERR(sq_wrf_read_index(w, 0, &s), SQ_ERR_TOO_LARGE,
                     "WRF fields of 10 x 8 x 27 points (raw + 3 derived sets) needs");
        SQ_CHECK_ERR(sq_wrf_read_index(w, 1, &s), SQ_ERR_TOO_LARGE, "memory limit");
        sq_wrf_close(w);
    }
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
}

SQ_TEST(cloud_optical_depth_is_the_column_sum)
{
    fx_desc d = fx_default(1);
    const char *path = tmp_path("tau.nc");
    SQ_CHECK(fx_write(path, &d));
    sq_context *ctx = mkctx();
    sq_wrf *w = open1(ctx, path);
    if (w) {
        sq_wrf_info in;
        sq_wrf_get_info(w, &in);
        sq_wrf_state s;
        SQ_CHECK_OK(sq_wrf_read_index(w, 1, &s));
        float tau[64];
        if (s.z_m) {
            sq_wrf_cloud_optical_depth(&in, &s, tau);
            /* cell (i 2, j 3): cloud water only at k = 2, ice only at k = 3 */
            const int i = 2, j = 3, t = 1;
            fx_expect e2 = fx_expected(&d, t, 2, j, i), e3 = fx_expected(&d, t, 3, j, i);
            const double dz2 = fx_expected(&d, t, 3, j, i).zw0 - e2.zw0;
            const double dz3 = (f32(fx_ph(t, 4, j, i)) + f32(fx_phb(4, j, i))) / 9.81 - e3.zw0;
            /* beta = 3 C / (2 rho r): 10 um droplets, 25 um ice */
            const double want = 3.0 * e2.c[0] * 1e-3 / (2.0 * 1000.0 * 10e-6) * dz2 +
                                3.0 * e3.c[1] * 1e-3 / (2.0 * 917.0 * 25e-6) * dz3;
            SQ_CHECK_NEAR(tau[j * d.nx + i], want, 1e-5 * want);
            /* cloud water of 1e-3 * 2 kg/kg over a 400 m layer: tau of order 100 */
            SQ_CHECK(want > 50.0 && want < 200.0);
            /* column i = 0 has no cloud water, and ice only */
            fx_expect f3 = fx_expected(&d, t, 3, j, 0);
            const double dz30 = (f32(fx_ph(t, 4, j, 0)) + f32(fx_phb(4, j, 0))) / 9.81 - f3.zw0;
            SQ_CHECK_NEAR(tau[j * d.nx], 3.0 * f3.c[1] * 1e-3 / (2 * 917.0 * 25e-6) * dz30,
                          1e-4);
        }
        sq_wrf_close(w);
    }
    sq_context_destroy(ctx);
    cleanup();
}

#endif

SQ_TEST(cloud_extinction_geometric_limit_matches_mie)
{
    /* beta = 3 C / (2 rho r): 0.3 g m-3 of 10 um droplets -> 45 km-1 */
    SQ_CHECK_NEAR(sq_cloud_extinction(0.3e-3, 1000.0, 10e-6), 0.045, 1e-12);
    SQ_CHECK(sq_cloud_extinction(0.0, 1000.0, 10e-6) == 0.0);
    SQ_CHECK(sq_cloud_extinction(-1.0, 1000.0, 10e-6) == 0.0);
    SQ_CHECK(sq_cloud_extinction(NAN, 1000.0, 10e-6) == 0.0);
    /* exact Mie for a 10 um water droplet at 550 nm (m = 1.333): Q_ext close to 2, so the
     * geometric formula is within a few per cent of beta = Q_ext pi r^2 N */
    sq_mie_result m;
    SQ_CHECK_OK(sq_mie_sphere(2.0 * M_PI * 10e-6 / 550e-9, 1.333, 0.0, &m));
    const double r = 10e-6, c = 0.3e-3;
    const double n = c / (1000.0 * 4.0 / 3.0 * M_PI * r * r * r);
    const double beta_mie = m.qext * M_PI * r * r * n;
    SQ_CHECK_REL(sq_cloud_extinction(c, 1000.0, r), beta_mie, 0.05);
    /* the asymmetry of a cloud droplet: strongly forward (g ~ 0.85, SPEC §8.4) */
    SQ_CHECK(m.g > 0.8 && m.g < 0.9);
}
