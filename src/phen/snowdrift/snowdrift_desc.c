/* snowdrift_desc.c — defaults and validation of the snowdrift desc (SPEC §5). Messages name the
 * scene key (layers.snowdrift.<key>), the value and the rule. */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "snowdrift_internal.h"
#include "world/world_struct.h"

#define DEF(f, v)                                                                              \
    do {                                                                                       \
        if ((f) == 0) (f) = (v);                                                               \
    } while (0)

sq_result sq_snowdrift_desc_resolve(const sq_snowdrift_desc *in, sq_snowdrift_desc *out)
{
    sq_snowdrift_desc d;
    memset(&d, 0, sizeof d);
    if (in) d = *in;
    DEF(d.cells[0], 128);
    DEF(d.cells[1], 64);
    DEF(d.cells[2], 48);
    DEF(d.cell_size_m, 1.0);
    DEF(d.gust_period_s, 3.0);
    DEF(d.ref_height_m, 10.0);
    DEF(d.roughness_m, 0.005);
    DEF(d.eddy_viscosity_m2s, 0.01);
    DEF(d.smagorinsky_c, 0.16);
    DEF(d.speedup, 1.0);
    DEF(d.fall_speed_mps, 1.0);
    DEF(d.threshold, 10);
    DEF(d.snow_density_kgm3, 150.0);
    DEF(d.ustar_threshold_mps, 0.25);
    DEF(d.erosion_efficiency, 1.0);
    DEF(d.saturation_time_s, 1.0);
    DEF(d.saltation_kgm3, 0.05);
    DEF(d.snow_cfl, 0.5);
    DEF(d.flake_radius_m, 0.03);
    DEF(d.flake_min_mrad, 2.5);
    if (out) *out = d;
    return SQ_OK;
}

#define BAD(...) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift", __VA_ARGS__)

static bool pos(double v) { return isfinite(v) && v > 0; }

/* The lattice's own rules (sq_lbm_desc_validate: τ > 1/2, Mach) on the lattice this desc makes,
 * its message turned into this desc's keys: the rules live in the solver only. */
static sq_result lattice_rules(sq_context *ctx, const sq_snowdrift_desc *d, const char *P)
{
    sq_lbm_desc l;
    sq__snowdrift_lbm_desc(d, &l);
    const sq_result r = sq_lbm_desc_validate(NULL, &l);
    if (r == SQ_OK) return SQ_OK;
    static const char *const names[][2] = {{"tau", "wind.tau"},
                                           {"viscosity_m2s", "wind.eddy_viscosity_m2s"},
                                           {"cell_size_m", "domain.cell_size_m"},
                                           {"cells", "domain.cells"},
                                           {"dt_s", "domain.dt_s"}};
    char msg[1024], out[1536];
    snprintf(msg, sizeof msg, "%s", sq_last_error());
    size_t len = 0;
    for (const char *p = msg; *p && len + 64 < sizeof out;) {
        const bool word_start = p == msg || !(p[-1] == '_' || p[-1] == '.' || isalnum((unsigned char)p[-1]));
        bool hit = false;
        for (size_t k = 0; word_start && k < sizeof names / sizeof names[0] && !hit; k++) {
            const size_t n = strlen(names[k][0]);
            /* plain words ("tau", "cells") only where they name a value: "tau = 0.5" */
            const bool named = strchr(names[k][0], '_') || strncmp(p + n, " =", 2) == 0;
            if (named && strncmp(p, names[k][0], n) == 0 &&
                !(p[n] == '_' || isalnum((unsigned char)p[n]))) {
                len += (size_t)snprintf(out + len, sizeof out - len, "%s", names[k][1]);
                p += n;
                hit = true;
            }
        }
        if (!hit) out[len++] = *p++;
    }
    out[len] = '\0';
    return sq__fail(ctx, r, "snowdrift", "%s%s", P, out);
}

sq_result sq_snowdrift_validate(sq_context *ctx, const sq_snowdrift_desc *in, const sq_world *w)
{
    sq_snowdrift_desc d;
    sq_snowdrift_desc_resolve(in, &d);
    const char *P = "sq_snowdrift_desc."; /* the scene shows it as layers.<name>. */
    for (int a = 0; a < 3; a++)
        if (d.cells[a] < 4 || d.cells[a] > 2048)
            BAD("%sdomain.nx x ny x nz = %dx%dx%d; every axis needs 4..2048 cells", P, d.cells[0],
                d.cells[1], d.cells[2]);
    if (!pos(d.cell_size_m)) BAD("%sdomain.cell_size_m = %g; must be > 0 m", P, d.cell_size_m);
    if (!(isfinite(d.center_m[0]) && isfinite(d.center_m[1])))
        BAD("%sdomain.center is not finite", P);
    if (!(isfinite(d.wind_speed_mps) && d.wind_speed_mps >= 0 && d.wind_speed_mps <= 80))
        BAD("%swind.speed_mps = %g; must be in [0, 80] m/s", P, d.wind_speed_mps);
    if (!isfinite(d.wind_dir_deg)) BAD("%swind.dir_deg = %g; must be finite", P, d.wind_dir_deg);
    if (!(isfinite(d.beaufort) && d.beaufort >= 0 && d.beaufort <= 12))
        BAD("%swind.beaufort = %g; must be in [0, 12]", P, d.beaufort);
    if (!pos(d.gust_period_s)) BAD("%swind.gust_period_s = %g; must be > 0 s", P, d.gust_period_s);
    if (!(isfinite(d.wind_ramp_mps2) && d.wind_ramp_mps2 >= 0))
        BAD("%swind.ramp_mps2 = %g; must be >= 0 (0 = instantaneous)", P, d.wind_ramp_mps2);
    if (!pos(d.ref_height_m)) BAD("%swind.ref_height_m = %g; must be > 0 m", P, d.ref_height_m);
    if (!pos(d.roughness_m) || d.roughness_m >= d.ref_height_m)
        BAD("%swind.roughness_m = %g; must be > 0 and below wind.ref_height_m = %g", P,
            d.roughness_m, d.ref_height_m);
    if (d.boundary != SQ_SNOWDRIFT_RECYCLE && d.boundary != SQ_SNOWDRIFT_INFLOW)
        BAD("%swind.boundary = %d; must be recycle (0) or inflow (1)", P, d.boundary);
    if (!pos(d.eddy_viscosity_m2s))
        BAD("%swind.eddy_viscosity_m2s = %g; must be > 0 (tau must exceed 1/2)", P,
            d.eddy_viscosity_m2s);
    if (!(pos(d.smagorinsky_c) && d.smagorinsky_c <= 1))
        BAD("%swind.smagorinsky_c = %g; must be in (0, 1]", P, d.smagorinsky_c);
    if (!(isfinite(d.snowfall_mmh) && d.snowfall_mmh >= 0 && d.snowfall_mmh <= 1000))
        BAD("%ssnow.snowfall_mmh = %g; must be in [0, 1000] mm/h water equivalent", P,
            d.snowfall_mmh);
    if (!(pos(d.speedup) && d.speedup <= 1e9))
        BAD("%ssnow.speedup = %g; must be in (0, 1e9]", P, d.speedup);
    if (!(pos(d.fall_speed_mps) && d.fall_speed_mps <= 10))
        BAD("%ssnow.fall_speed_mps = %g; must be in (0, 10] m/s (flakes: 0.5-1.5)", P,
            d.fall_speed_mps);
    if (d.threshold < 1 || d.threshold > 1000000)
        BAD("%ssnow.threshold = %d; must be in 1..1000000 flakes", P, d.threshold);
    if (!(pos(d.snow_density_kgm3) && d.snow_density_kgm3 <= 917))
        BAD("%ssnow.density_kgm3 = %g; must be in (0, 917] (ice)", P, d.snow_density_kgm3);
    if (!pos(d.ustar_threshold_mps))
        BAD("%ssnow.ustar_threshold_mps = %g; must be > 0 m/s", P, d.ustar_threshold_mps);
    if (!(pos(d.erosion_efficiency) && d.erosion_efficiency <= 1))
        BAD("%ssnow.erosion_efficiency = %g; must be in (0, 1]", P, d.erosion_efficiency);
    if (!pos(d.saturation_time_s))
        BAD("%ssnow.saturation_time_s = %g; must be > 0 s", P, d.saturation_time_s);
    if (!(pos(d.saltation_kgm3) && d.saltation_kgm3 <= 1000))
        BAD("%ssnow.saltation_kgm3 = %g; must be in (0, 1000] kg/m3", P, d.saltation_kgm3);
    if (!(pos(d.snow_cfl) && d.snow_cfl <= 1))
        BAD("%ssnow.cfl = %g; must be in (0, 1] cells per snow step", P, d.snow_cfl);
    if (!(isfinite(d.dt_s) && d.dt_s >= 0 && d.dt_s <= 100))
        BAD("%sdomain.dt_s = %g; must be in [0, 100] s (0 = automatic)", P, d.dt_s);
    if (!(isfinite(d.tau) && d.tau >= 0) || d.tau > 100) /* > 1/2: the lattice's rule below */
        BAD("%swind.tau = %g; must be <= 100 (and > 0.5), or 0 = from wind.eddy_viscosity_m2s",
            P, d.tau);
    if (!(pos(d.flake_min_mrad) && d.flake_min_mrad <= 100))
        BAD("%sdraw.flake_min_mrad = %g; must be in (0, 100] mrad", P, d.flake_min_mrad);
    /* the wind lattice: relaxation time and Mach number (SPEC §5.3), checked by the lattice */
    sq_result lr = lattice_rules(ctx, &d, P);
    if (lr != SQ_OK) return lr;
    if (w) {
        /* obstacles must lie inside the lattice: outside it the wind and the snow never see
         * them, and one cut by the edge would be half a house */
        const double x0 = d.center_m[0] - 0.5 * d.cells[0] * d.cell_size_m;
        const double y0 = d.center_m[1] - 0.5 * d.cells[1] * d.cell_size_m;
        const double x1 = x0 + d.cells[0] * d.cell_size_m, y1 = y0 + d.cells[1] * d.cell_size_m;
        for (int o = 0; o < w->obstacle_count; o++) {
            const sq_obstacle *ob = &w->obstacles[o];
            const double yaw = (double)ob->yaw_deg * 3.14159265358979323846 / 180.0;
            const double hx = 0.5 * (fabs(cos(yaw)) * (double)ob->size_m.x +
                                     fabs(sin(yaw)) * (double)ob->size_m.y);
            const double hy = 0.5 * (fabs(sin(yaw)) * (double)ob->size_m.x +
                                     fabs(cos(yaw)) * (double)ob->size_m.y);
            const double cx = (double)ob->center_m.x, cy = (double)ob->center_m.y;
            if (cx - hx < x0 || cx + hx > x1 || cy - hy < y0 || cy + hy > y1)
                BAD("world.obstacles[%d] (footprint x %.4g..%.4g m, y %.4g..%.4g m) is not "
                    "inside the snowdrift lattice (x %.4g..%.4g m, y %.4g..%.4g m); move it, or "
                    "move/enlarge the lattice with %sdomain.center_x_m/center_y_m, nx/ny or "
                    "%sdomain.cell_size_m",
                    o, cx - hx, cx + hx, cy - hy, cy + hy, x0, x1, y0, y1, P, P);
        }
    }
    if (d.visual_flakes < 0 || d.visual_flakes > 2000000)
        BAD("%sdraw.flakes = %d; must be in 0..2000000", P, d.visual_flakes);
    if (!(pos(d.flake_radius_m) && d.flake_radius_m <= 1))
        BAD("%sdraw.flake_radius_m = %g; must be in (0, 1] m", P, d.flake_radius_m);
    return SQ_OK;
}
