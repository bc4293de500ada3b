/* sandstorm_desc.c — defaults and validation of the sandstorm desc. Messages name the scene
 * key (layers.sandstorm.<key>), the value and the rule. */
#include <math.h>
#include <string.h>

#include "sandstorm_internal.h"

#define DEF(f, v)                                                                              \
    do {                                                                                       \
        if ((f) == 0) (f) = (v);                                                               \
    } while (0)

sq_result sq_sandstorm_desc_resolve(const sq_sandstorm_desc *in, sq_sandstorm_desc *out)
{
    sq_sandstorm_desc d;
    memset(&d, 0, sizeof d);
    if (in) d = *in;
    DEF(d.cells[0], 64);
    DEF(d.cells[1], 64);
    DEF(d.cells[2], 32);
    DEF(d.cell_size_m, 40.0);
    if (d.pressure_amp_count == 0) {
        d.pressure_amp_pa[0] = 400.0f;
        d.pressure_amp_pa[1] = 300.0f;
        d.pressure_amp_pa[2] = 150.0f;
        d.pressure_amp_count = 3;
    }
    DEF(d.wind_speed_mps, 18.0);
    DEF(d.roughness_m, 5e-4);
    DEF(d.log_layer_m, 100.0);
    DEF(d.surface_temperature_k, 305.0);
    DEF(d.jacobi_iterations, 40);
    DEF(d.pressure_tolerance, 1e-3);
    DEF(d.cfl, 2.0);
    DEF(d.smagorinsky_c, 0.18);
    DEF(d.median_radius_m, 5e-6);
    DEF(d.sigma_g, 2.0);
    DEF(d.grain_density_kg_m3, 2650.0);
    DEF(d.bins, 4);
    DEF(d.inflow_dust_height_m, 300.0);
    DEF(d.u_star_t0_mps, 0.25);
    DEF(d.coldpool_depth_m, 1000.0);
    DEF(d.roughness_factor, 1.0);
    DEF(d.moisture_factor, 1.0);
    DEF(d.compactness_factor, 1.0);
    if (d.vis_height_count == 0) {
        d.vis_heights_m[0] = 2.0f;
        d.vis_heights_m[1] = 10.0f;
        d.vis_height_count = 2;
    }
    DEF(d.contrast, 0.05);
    if (d.urban_conc_count == 0) {
        d.urban_conc_kg_m3[0] = 5e-3f;
        d.urban_conc_count = 1;
    }
    DEF(d.urban_stage_s, 4.0);
    DEF(d.urban_height_m, 400.0);
    DEF(d.near_particles, 4000);
    DEF(d.near_radius_m, 80.0);
    DEF(d.near_particle_radius_m, 4.0);
    DEF(d.near_fraction, 0.3);
    DEF(d.detail_scale_m, 4.0 * d.cell_size_m);
    DEF(d.detail_period_s, 20.0);
    if (out) *out = d;
    return SQ_OK;
}

#define BAD(...) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "sandstorm", __VA_ARGS__)

sq_result sq_sandstorm_validate(sq_context *ctx, const sq_sandstorm_desc *in, const sq_world *w)
{
    sq_sandstorm_desc d;
    sq_sandstorm_desc_resolve(in, &d);
    const char *P = "sq_sandstorm_desc."; /* the scene shows it as layers.<name>. */
    if (d.mode != SQ_SANDSTORM_DESERT && d.mode != SQ_SANDSTORM_URBAN)
        BAD("%smode = %d; must be desert (0) or urban (1)", P, d.mode);
    for (int a = 0; a < 3; a++)
        if (d.cells[a] < 4 || d.cells[a] > 1024)
            BAD("%sdomain.nx x ny x nz = %dx%dx%d; every axis needs 4..1024 cells", P, d.cells[0],
                d.cells[1], d.cells[2]);
    if (!(d.cell_size_m > 0.0) || !isfinite(d.cell_size_m))
        BAD("%sdomain.cell_size_m = %g; must be > 0 m", P, (double)d.cell_size_m);
    /* wave numbers that alias: a wavelength must span at least 4 cells (|k| h <= pi/2) */
    double kh = sqrt((double)d.kx_per_m * d.kx_per_m + (double)d.ky_per_m * d.ky_per_m) * d.cell_size_m;
    if (kh > SQ_PI / 2.0)
        BAD("%swave.kx_per_m, %swave.ky_per_m = (%g, %g) 1/m: wavelength %.1f m is shorter than 4 "
            "cells of %g m and would alias on the grid; use |k| <= %.3g 1/m or a smaller cell size",
            P, P, (double)d.kx_per_m, (double)d.ky_per_m, 2.0 * SQ_PI / (kh / d.cell_size_m),
            (double)d.cell_size_m, SQ_PI / 2.0 / d.cell_size_m);
    if (!(d.wind_speed_mps >= 0.0) || !isfinite(d.wind_speed_mps))
        BAD("%swind.speed_mps = %g; must be a finite speed >= 0 m/s", P, (double)d.wind_speed_mps);
    if (d.lapse_k_per_m > SQ_SAND_DRY_LAPSE)
        BAD("%stemperature.lapse_k_per_m = %g K/m; above the dry adiabatic %g K/m the air is "
            "statically unstable (potential temperature falls with height)", P,
            (double)d.lapse_k_per_m, SQ_SAND_DRY_LAPSE);
    if (d.coldpool_delta_t_k < 0.0 || d.coldpool_delta_t_k > 20.0 || !isfinite(d.coldpool_delta_t_k))
        BAD("%scoldpool.delta_t_k = %g K; a cold pool is colder than the air it enters (> 0; 0 = "
            "none) by at most 20 K (observed outflows 2-15 K; beyond, dT/theta > 7 %% and the "
            "Boussinesq buoyancy no longer holds)", P, (double)d.coldpool_delta_t_k);
    if (d.coldpool_delta_t_k > 0.0) {
        const double top = d.cells[2] * (double)d.cell_size_m, len = d.cells[0] * (double)d.cell_size_m;
        if (!(d.coldpool_depth_m >= 2.0 * d.cell_size_m && d.coldpool_depth_m <= 0.8 * top))
            BAD("%scoldpool.depth_m = %g m; the cold pool must lie inside the domain: at least 2 "
                "cells (%g m) and at most 0.8 of its height (%g m; domain.nz x domain.cell_size_m)",
                P, (double)d.coldpool_depth_m, 2.0 * d.cell_size_m, 0.8 * top);
        /* the spanwise variation's modes (sandstorm.c, coldpool_spanwise) can add up to
         * sqrt(2 M) times their rms: the deficit must stay > 0 and <= 20 K there */
        int modes = d.cells[1] / 8;
        modes = modes < 1 ? 1 : modes > 64 ? 64 : modes;
        const double peak = d.coldpool_spanwise * sqrt(2.0 * modes);
        if (!(d.coldpool_spanwise >= 0.0 && peak < 1.0 && d.coldpool_delta_t_k * (1.0 + peak) <= 20.0))
            BAD("%scoldpool.spanwise_variation = %g; its %d mode%s can add up to %.3g x that, so "
                "the deficit %g K x (1 +- %.3g) must stay > 0 and <= 20 K (at most %.3g here)", P,
                (double)d.coldpool_spanwise, modes, modes == 1 ? "" : "s", sqrt(2.0 * modes),
                (double)d.coldpool_delta_t_k,
                peak, fmin(1.0, 20.0 / d.coldpool_delta_t_k - 1.0) / sqrt(2.0 * modes));
        if (d.coldpool_length_m < 0.0 || d.coldpool_length_m >= len)
            BAD("%scoldpool.length_m = %g m; the initial outflow must start inside the domain "
                "(0 <= length < %g m)", P, (double)d.coldpool_length_m, len);
    }
    if (d.turbulence < 0 || d.turbulence > 2)
        BAD("%ssolver.turbulence = %d; must be mixing-length (0), smagorinsky (1) or tke (2)", P,
            d.turbulence);
    if (d.side_boundary != 0 && d.side_boundary != 1)
        BAD("%sdomain.sides = %d; must be open (0) or periodic (1)", P, d.side_boundary);
    if (d.top_boundary != 0 && d.top_boundary != 1)
        BAD("%sdomain.top = %d; must be open (0) or free-slip (1)", P, d.top_boundary);
    if (d.surface_heat_flux_w_m2 < -200.0 || d.surface_heat_flux_w_m2 > 1000.0)
        BAD("%ssurface.heat_flux_w_m2 = %g W/m2; desert sensible heat fluxes are -200..1000 W/m2",
            P, (double)d.surface_heat_flux_w_m2);
    if (!(d.median_radius_m > 0.0) || !isfinite(d.median_radius_m))
        BAD("%sdust.median_radius_m = %g; must be a finite radius > 0 m", P, (double)d.median_radius_m);
    if (!(d.sigma_g > 1.0) || !isfinite(d.sigma_g))
        BAD("%sdust.sigma_g = %g; the geometric standard deviation must be > 1", P, (double)d.sigma_g);
    if (!(d.grain_density_kg_m3 > 0.0))
        BAD("%sdust.density_kg_m3 = %g; must be > 0 kg/m3", P, (double)d.grain_density_kg_m3);
    if (d.n_imag < 0.0)
        BAD("%sdust.n_imag = %g; the imaginary part of the refractive index must be >= 0 "
            "(m = n + ik, k >= 0 absorbs)", P, (double)d.n_imag);
    if (d.bins < 1 || d.bins > SQ_SANDSTORM_MAX_BINS)
        BAD("%sdust.bins = %d; must be 1..%d", P, d.bins, SQ_SANDSTORM_MAX_BINS);
    if (d.detail_amplitude_m < 0.0 || !isfinite(d.detail_amplitude_m))
        BAD("%sdetail.amplitude_m = %g; a displacement must be >= 0 m (0 = off)", P,
            (double)d.detail_amplitude_m);
    if (!(d.detail_scale_m > 0.0) || !isfinite(d.detail_scale_m))
        BAD("%sdetail.scale_m = %g; the noise feature size must be > 0 m", P,
            (double)d.detail_scale_m);
    if (!(d.detail_period_s > 0.0) || !isfinite(d.detail_period_s))
        BAD("%sdetail.period_s = %g; the re-seeding period must be > 0 s", P,
            (double)d.detail_period_s);
    if (d.detail_mirror_sides_m < 0.0 || !isfinite(d.detail_mirror_sides_m))
        BAD("%sdetail.mirror_sides_m = %g; a distance must be >= 0 m (0 = the domain only)", P,
            (double)d.detail_mirror_sides_m);
    if (d.inflow_dust_kg_m3 < 0.0)
        BAD("%sdust.inflow_kg_m3 = %g; a concentration must be >= 0", P, (double)d.inflow_dust_kg_m3);
    for (int i = 0; i < d.urban_conc_count; i++)
        if (d.urban_conc_kg_m3[i] < 0.0f || !isfinite(d.urban_conc_kg_m3[i]))
            BAD("%surban.concentration_kg_m3[%d] = %g; a concentration must be >= 0", P, i,
                (double)d.urban_conc_kg_m3[i]);
    if (d.roughness_factor < 1.0 || d.moisture_factor < 1.0 || d.compactness_factor < 1.0)
        BAD("%ssurface factors (roughness %g, moisture %g, compactness %g) must be >= 1: they raise "
            "the threshold of a dry, loose, smooth surface", P, (double)d.roughness_factor,
            (double)d.moisture_factor, (double)d.compactness_factor);
    if (!(d.contrast > 0.0 && d.contrast < 1.0))
        BAD("%svisibility.contrast = %g; must be in (0, 1)", P, (double)d.contrast);
    if (d.mode == SQ_SANDSTORM_DESERT && w) {
        double ex = d.cells[0] * (double)d.cell_size_m, ey = d.cells[1] * (double)d.cell_size_m;
        sq_vec3 lo, hi;
        sq_world_bounds(w, &lo, &hi);
        if (d.center_m[0] - ex / 2 < (double)lo.x - 1e-3 || d.center_m[0] + ex / 2 > (double)hi.x + 1e-3 ||
            d.center_m[1] - ey / 2 < (double)lo.y - 1e-3 || d.center_m[1] + ey / 2 > (double)hi.y + 1e-3)
            BAD("%sdomain: %.0f x %.0f m centred at (%g, %g) reaches outside the terrain "
                "[%g, %g] x [%g, %g] m", P, ex, ey, (double)d.center_m[0], (double)d.center_m[1],
                (double)lo.x, (double)hi.x, (double)lo.y, (double)hi.y);
    }
    return SQ_OK;
}

uint64_t sq_sandstorm_memory_bytes(const sq_sandstorm_desc *in)
{
    sq_sandstorm_desc d;
    sq_sandstorm_desc_resolve(in, &d);
    if (d.mode == SQ_SANDSTORM_URBAN) return 4096 + (uint64_t)d.near_particles * 40u;
    sq_grid_desc g = {0};
    g.cells = (sq_dims){d.cells[0], d.cells[1], d.cells[2]};
    g.cell_size_m = d.cell_size_m;
    g.scalar_count = d.bins + 1 + (d.turbulence == 2 ? 1 : 0); /* dust, theta, TKE's e */
    uint64_t n = (uint64_t)d.cells[0] * d.cells[1] * d.cells[2];
    uint64_t cols = (uint64_t)d.cells[0] * d.cells[1];
    /* accel_z, density, 6 export buffers; ground_k, ground_z1, keep; row and plane sums */
    /* theta_ref per level; the temperature inflow values of the west face */
    return sq_grid_memory_bytes(&g) + n * 4u * (2u + 6u) + cols * 12u + (uint64_t)d.cells[2] * 4u +
           (uint64_t)d.cells[1] * d.cells[2] * 4u +
           cols * 4u * (uint64_t)d.vis_height_count + (uint64_t)d.near_particles * 40u +
           (uint64_t)d.cells[1] * 32u + (uint64_t)d.cells[2] * 8u * SQ_SANDSTORM_MAX_BINS +
           /* detail: two coordinate fields, scratch, cell velocity (3 each), amplitude, output */
           (d.detail_amplitude_m > 0.0 ? n * 4u * 14u : 0u);
}
