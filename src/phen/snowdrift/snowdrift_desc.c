/* snowdrift_desc.c — defaults and validation of the snowdrift desc (SPEC §5). Messages name the
 * scene key (layers.snowdrift.<key>), the value and the rule. */
#include <math.h>
#include <string.h>

#include "snowdrift_internal.h"

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
    DEF(d.visual_flakes, 20000);
    DEF(d.flake_radius_m, 0.03);
    DEF(d.flake_min_mrad, 2.5);
    if (out) *out = d;
    return SQ_OK;
}

#define BAD(...) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift", __VA_ARGS__)

static bool pos(double v) { return isfinite(v) && v > 0; }

sq_result sq_snowdrift_validate(sq_context *ctx, const sq_snowdrift_desc *in, const sq_world *w)
{
    sq_snowdrift_desc d;
    sq_snowdrift_desc_resolve(in, &d);
    const char *P = "layers.snowdrift.";
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
    if (!(isfinite(d.tau) && (d.tau == 0 || d.tau > 0.5)) || d.tau > 100)
        BAD("%swind.tau = %g; must be > 0.5 (the lattice viscosity (tau - 1/2)/3 must be "
            "positive: BGK is unstable at zero viscosity) and <= 100, or 0 = from "
            "wind.eddy_viscosity_m2s",
            P, d.tau);
    if (!(pos(d.flake_min_mrad) && d.flake_min_mrad <= 100))
        BAD("%sdraw.flake_min_mrad = %g; must be in (0, 100] mrad", P, d.flake_min_mrad);
    /* the wind lattice: relaxation time and Mach number (SPEC §5.3) */
    {
        sq_lbm_desc l;
        sq__snowdrift_lbm_desc(&d, &l);
        const double dt = sq_lbm_time_step_s(&l), h = d.cell_size_m;
        if (d.tau == 0) {
            const double tau = 0.5 + 3.0 * d.eddy_viscosity_m2s * dt / (h * h);
            if (!(tau > 0.5))
                BAD("%swind.eddy_viscosity_m2s = %g m2/s with domain.cell_size_m = %g m and a "
                    "wind step of %g s gives tau = 1/2 + 3 nu dt/dx^2 = %.17g; must be > 0.5 "
                    "(raise the viscosity or the step, or set wind.tau)",
                    P, d.eddy_viscosity_m2s, h, dt, tau);
        }
        const double umax = sq_lbm_max_wind_mps(&l);
        const double ulu = umax * dt / h, mach = ulu * sqrt(3.0), lim = sq_lbm_mach_limit();
        if (mach > lim)
            BAD("%sdomain.dt_s = %g s: the wind with gusts at the top of the domain, %.3g m/s, "
                "moves %.3g cells per step (Mach %.2f > %.1f); lower domain.dt_s to at most %.3g "
                "s (0 = automatic), raise domain.cell_size_m to at least %.3g m, or lower "
                "wind.speed_mps or wind.beaufort",
                P, d.dt_s, umax, ulu, mach, lim, 0.1 * h / umax, umax * dt / 0.1);
    }
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
