/* test_sandstorm.c — physics of the sandstorm phenomenon: settling (Stokes and the drag law),
 * emission threshold and the u*^3 law, the dust budget, Koschmieder visibility planes, urban
 * severities, bad input and blow-up detection. */
#include <string.h>

#include "sq_test.h"
#include "phen/sandstorm/sandstorm_internal.h"
#include "squall/sandstorm.h"

SQ_LABEL(physics)

static sq_context *mkctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {.threads = 2};
    sq_context_create(&d, &ctx);
    return ctx;
}

static sq_world *flat_world(sq_context *ctx)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 2000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    sq_world *w = NULL;
    sq_world_create(ctx, &wd, &w);
    return w;
}

/* A 1.2 km x 200 m x 400 m haboob on 25 m cells: a 10 K, 150 m deep cold pool 200 m long at the
 * west face, no synoptic wind wave, emission on. */
static sq_sandstorm_desc small_haboob_desc(void)
{
    sq_sandstorm_desc d = {0};
    d.cells[0] = 48;
    d.cells[1] = 8;
    d.cells[2] = 16;
    d.cell_size_m = 25.0;
    d.pressure_amp_pa[0] = 0.0f;
    d.pressure_amp_count = 1;
    d.wind_speed_mps = 1.0;
    d.surface_temperature_k = 305.0;
    d.lapse_k_per_m = 0.0065;
    d.buoyancy_gain = 1.0;
    d.coldpool_delta_t_k = 10.0;
    d.coldpool_depth_m = 150.0;
    d.coldpool_length_m = 200.0;
    d.emission_coeff = 1e-2;
    return d;
}

static sq_sandstorm_desc small_desc(void)
{
    sq_sandstorm_desc d = {0};
    d.cells[0] = 24;
    d.cells[1] = 16;
    d.cells[2] = 12;
    d.cell_size_m = 40.0;
    d.pressure_amp_pa[0] = 1.0f;
    d.pressure_amp_count = 1;
    return d;
}

SQ_TEST(stokes_settling_low_re)
{
    const double rho_p = 2650, rho = SQ_SAND_AIR_DENSITY, mu = SQ_SAND_AIR_VISCOSITY, g = 9.81;
    const double radii[] = {0.5e-6, 1e-6, 5e-6, 10e-6};
    for (int i = 0; i < 4; i++) {
        double r = radii[i];
        double stokes = 2.0 * r * r * g * (rho_p - rho) / (9.0 * mu);
        double w = sq_dust_terminal_speed(r, rho_p, rho, mu);
        double re = rho * w * 2 * r / mu;
        SQ_CHECK(re < 0.1);
        SQ_CHECK_REL(w, stokes, 0.02); /* the 2 % */
        SQ_CHECK(w <= stokes);         /* extra drag beyond Stokes only slows grains */
    }
    /* SPEC §1.8 table: 10 um diameter -> 8.0e-3 m/s */
    SQ_CHECK_REL(sq_dust_terminal_speed(5e-6, rho_p, rho, mu), 8.0e-3, 0.02);
}

SQ_TEST(drag_law_higher_re)
{
    const double rho_p = 2650, rho = SQ_SAND_AIR_DENSITY, mu = SQ_SAND_AIR_VISCOSITY, g = 9.81;
    const double radii[] = {50e-6, 100e-6, 250e-6};
    for (int i = 0; i < 3; i++) {
        double r = radii[i], d = 2 * r;
        double w = sq_dust_terminal_speed(r, rho_p, rho, mu);
        double re = rho * w * d / mu;
        /* force balance with White's C_D: weight - buoyancy = drag */
        double cd = sq_drag_coefficient(re);
        SQ_CHECK_REL(w * w, 4.0 * d * g * (rho_p - rho) / (3.0 * rho * cd), 1e-9);
        double stokes = 2.0 * r * r * g * (rho_p - rho) / (9.0 * mu);
        SQ_CHECK(w < 0.9 * stokes); /* inertial drag matters here */
    }
    /* 0.5 mm sand (r = 250 um): Re ~ 100 */
    double w = sq_dust_terminal_speed(250e-6, rho_p, rho, mu);
    SQ_CHECK(rho * w * 500e-6 / mu > 50.0);
    SQ_CHECK_NEAR(sq_drag_coefficient(1.0), 24.0 + 3.0 + 0.4, 1e-12);
}

SQ_TEST(emission_threshold_and_cubic_law)
{
    SQ_CHECK(sq_dust_emission_flux(0.2, 0.25, 1e-4) == 0.0);
    SQ_CHECK(sq_dust_emission_flux(0.25, 0.25, 1e-4) == 0.0);
    SQ_CHECK(sq_dust_emission_flux(0.26, 0.25, 1e-4) > 0.0);
    /* far above the threshold the flux scales as u*^3 */
    double f1 = sq_dust_emission_flux(1.0, 0.01, 2e-4), f2 = sq_dust_emission_flux(2.0, 0.01, 2e-4);
    SQ_CHECK_REL(f2 / f1, 8.0, 1e-3);
    SQ_CHECK_REL(f1, 2e-4, 1e-3);
    /* log law */
    SQ_CHECK_NEAR(sq_friction_velocity(10.0, 10.0, 1e-3), 0.4 * 10.0 / log(1e4), 1e-12);
}

/* Emitted mass in the first step of a uniform storm with wind speed set through C_B. */
static double first_step_emission(sq_context *ctx, sq_world *w, double bernoulli, double coeff)
{
    sq_sandstorm_desc d = small_desc();
    d.wind_speed_mps = sqrt(2.0 * bernoulli / SQ_SAND_AIR_DENSITY); /* C_B = rho U^2 / 2 */
    d.emission_coeff = coeff;
    d.u_star_t0_mps = 0.05;
    sq_sandstorm *s = NULL;
    if (sq_sandstorm_create(ctx, &d, w, &s) != SQ_OK) return -1.0;
    sq_sandstorm_step(s, 0.5);
    sq_sandstorm_budget b;
    sq_sandstorm_get_budget(s, &b);
    sq_sandstorm_destroy(s);
    return b.emitted_kg;
}

SQ_TEST(emission_in_the_storm_scales_with_ustar_cubed)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    /* speed ~ sqrt(C_B): C_B x 2.25 -> speed x 1.5 -> u*^3 x 3.375 (threshold 0.05 << u*) */
    double e1 = first_step_emission(ctx, w, 60.0, 1e-4);
    double e2 = first_step_emission(ctx, w, 135.0, 1e-4);
    SQ_CHECK(e1 > 0.0);
    SQ_CHECK_REL(e2 / e1, 3.375, 0.05);
    /* below the threshold nothing is emitted */
    sq_sandstorm_desc d = small_desc();
    d.wind_speed_mps = 1.29; /* C_B = 1 Pa */
    d.emission_coeff = 1e-3;
    d.u_star_t0_mps = 0.5;
    sq_sandstorm *s = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    for (int i = 0; i < 5; i++) SQ_CHECK_OK(sq_sandstorm_step(s, 1.0));
    sq_sandstorm_budget b;
    sq_sandstorm_get_budget(s, &b);
    SQ_CHECK(b.emitted_kg == 0.0);
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

static double budget_error(const sq_sandstorm_budget *b)
{
    return b->suspended_kg - (b->initial_kg + b->emitted_kg + b->inflow_kg - b->deposited_kg - b->outflow_kg);
}

SQ_TEST(dust_budget_closes)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    for (int fix = 0; fix < 2; fix++) {
        sq_sandstorm_desc d = small_desc();
        d.wind_speed_mps = 15.81; /* C_B = 150 Pa */
        d.emission_coeff = 2e-4;
        d.inflow_dust_kg_m3 = 2e-4;
        d.no_mass_fix = !fix;
        sq_sandstorm *s = NULL;
        SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
        for (int i = 0; i < 40; i++) SQ_CHECK_OK(sq_sandstorm_step(s, 2.0));
        sq_sandstorm_budget b;
        sq_sandstorm_get_budget(s, &b);
        SQ_CHECK(b.emitted_kg > 0 && b.inflow_kg > 0 && b.deposited_kg > 0 && b.outflow_kg > 0);
        double scale = b.emitted_kg + b.inflow_kg;
        double err = fabs(budget_error(&b)) / scale;
        printf("mass fix %s: budget error %.3g of the dust supplied (correction %.3g kg)\n",
               fix ? "on" : "off", err, b.advection_correction_kg);
        if (fix)
            SQ_CHECK(err < 1e-5); /* closes to float round-off */
        else
            SQ_CHECK(err < 0.15); /* documented: MacCormack transport is not conservative */
        sq_sandstorm_destroy(s);
    }
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(settling_in_still_air_deposits_at_stokes_rate)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm_desc d = small_desc();
    d.wind_speed_mps = 1.3e-3; /* still air */
    d.bins = 1;
    d.sigma_g = 1.05;
    d.median_radius_m = 20e-6;
    sq_sandstorm *s = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    /* fill the bottom fluid layer with 1e-3 kg/m3 */
    sq_field3 *c = sq_grid_scalar_field(s->grid, 0);
    int k0 = s->ground_k[0];
    for (int j = 0; j < s->ny; j++)
        for (int i = 0; i < s->nx; i++) *sq_field3_at(c, i, j, k0) = 1e-3f;
    double dt = 0.5;
    SQ_CHECK_OK(sq_sandstorm_step(s, dt));
    sq_sandstorm_budget b;
    sq_sandstorm_get_budget(s, &b);
    double area = s->nx * s->ny * s->h * s->h;
    double expected = 1e-3 * s->w_settle[0] * dt * area; /* flux c w_s through the ground */
    SQ_CHECK_REL(b.deposited_kg, expected, 0.02);
    /* Re ~ 0.3 here: the drag law settles ~5 % slower than Stokes */
    double stokes = 2.0 * pow(s->bins[0].radius_m, 2) * 9.81 * (2650 - 1.2) / (9 * 1.81e-5);
    SQ_CHECK(s->w_settle[0] < stokes && s->w_settle[0] > 0.9 * stokes);
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Largest |w_a - w_b| (m/s) over the interior w faces (b NULL: |w_a|). */
static double max_w_diff(sq_sandstorm *a, sq_sandstorm *b)
{
    sq_field_view wa = sq_grid_velocity_view(a->grid, 2), wb;
    if (b) wb = sq_grid_velocity_view(b->grid, 2);
    double m = 0.0;
    for (int k = 1; k < a->nz; k++)
        for (int j = 0; j < a->ny; j++)
            for (int i = 0; i < a->nx; i++) {
                double v = sq_view_get(&wa, i, j, k) - (b ? sq_view_get(&wb, i, j, k) : 0.0f);
                m = fmax(m, fabs(v));
            }
    return m;
}

/* Largest |theta - theta_bar(z)| (K) over the fluid cells. */
static double max_theta_anomaly(sq_sandstorm *s)
{
    sq_field_view t = sq_grid_scalar_view(s->grid, s->temp_idx);
    double m = 0.0;
    for (int k = 0; k < s->nz; k++)
        for (int j = 0; j < s->ny; j++)
            for (int i = 0; i < s->nx; i++)
                if (!sq_grid_is_solid(s->grid, i, j, k))
                    m = fmax(m, fabs((double)sq_view_get(&t, i, j, k) - (double)s->theta_ref[k]));
    return m;
}

/* Issue 12: the inflow face carries the same temperature profile as the interior, so an
 * atmosphere with no temperature wave and no surface heating makes no updraft of its own
 * (bounds as docs/phen/sandstorm.md states, over 10 simulated minutes, flat ground):
 *   - calm, stable (0.0065 K/m): |w| < 1e-3 m/s;
 *   - 10 m/s wind, neutral (dry adiabatic): the buoyancy changes w by < 1e-4 m/s (the same run
 *     with buoyancy off as the reference);
 *   - 10 m/s wind, stable: |theta - theta_bar(z)| < 0.5 K everywhere (what the ~0.7 m/s w of
 *     the inflow's log profile adjusting to the ground stress lifts; the buoyancy answering it
 *     is the stable air's restoring force, physics).
 * The old constant-temperature inflow was 2.6 K (stable) or 3.9 K (neutral) too warm 400 m
 * up: a buoyancy of ~0.1 m/s^2 there, an updraft of metres per second. */
static void atmosphere_at_rest(int turbulence)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    const double speed[4] = {1e-3, 10.0, 10.0, 10.0}, lapse[4] = {0.0065, 0.0098, 0.0098, 0.0065};
    const double gain[4] = {1.0, 1.0, 0.0, 1.0};
    sq_sandstorm *s[4] = {NULL, NULL, NULL, NULL};
    for (int c = 0; c < 4; c++) {
        sq_sandstorm_desc d = small_desc();
        d.wind_speed_mps = speed[c];
        d.lapse_k_per_m = lapse[c];
        d.buoyancy_gain = gain[c];
        d.turbulence = turbulence;
        SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s[c]));
    }
    double calm = 0.0, diff = 0.0, anomaly = 0.0;
    for (int n = 0; n < 120; n++) { /* 600 s */
        for (int c = 0; c < 4; c++) SQ_CHECK_OK(sq_sandstorm_step(s[c], 5.0));
        calm = fmax(calm, max_w_diff(s[0], NULL));
        diff = fmax(diff, max_w_diff(s[1], s[2]));
        anomaly = fmax(anomaly, max_theta_anomaly(s[3]));
    }
    printf("  10 min: calm max |w| = %.3g m/s; neutral, wind: buoyancy changes w by %.3g m/s; "
           "stable, wind: max |theta - theta_bar| = %.3g K\n", calm, diff, anomaly);
    SQ_CHECK_MSG(calm < 1e-3, "calm air: max |w| %g m/s over 10 min (bound 1e-3)", calm);
    SQ_CHECK_MSG(diff < 1e-4, "neutral wind: buoyancy changed w by %g m/s (bound 1e-4)", diff);
    SQ_CHECK_MSG(anomaly < 0.5, "stable wind: temperature anomaly %g K (bound 0.5)", anomaly);
    for (int c = 0; c < 4; c++) sq_sandstorm_destroy(s[c]);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(stratified_atmosphere_stays_at_rest) { atmosphere_at_rest(0); }

/* The same bounds with the Smagorinsky-Lilly subgrid closure (solver.turbulence = smagorinsky):
 * its strain-rate viscosity, the log-law wall stress and the 3D heat flux must not make an
 * updraft of their own either. */
SQ_TEST(stratified_atmosphere_stays_at_rest_with_the_subgrid_closure) { atmosphere_at_rest(1); }

/* And with Deardorff's TKE closure (solver.turbulence = tke): its subgrid energy, produced by
 * the inflow's shear and carried through the domain, must not make an updraft either. */
SQ_TEST(stratified_atmosphere_stays_at_rest_with_the_tke_closure) { atmosphere_at_rest(2); }

/* The stated non-spherical asymmetry parameter reaches the drawable, inside the SPEC §2.6
 * band for mineral dust (0.65-0.75) and below what Mie spheres of the same sizes give. */
SQ_TEST(dust_asymmetry_is_non_spherical)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm_desc d = small_desc();
    sq_sandstorm *s = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    sq_drawable dr[2];
    SQ_CHECK(sq__sandstorm_drawables(s, dr, 2) >= 1);
    for (int c = 0; c < 3; c++) {
        const float g = dr[0].u.volume.g[c];
        SQ_CHECK(g >= 0.65f && g <= 0.75f);
    }
    SQ_CHECK(dr[0].u.volume.g[2] > dr[0].u.volume.g[0]); /* blue scatters more forward here */
    /* Mie spheres of the emitted distribution at 550 nm */
    sq_lognormal ln;
    SQ_CHECK_OK(sq_lognormal_make(s->d.median_radius_m, s->d.sigma_g, &ln));
    sq_bulk_optics_desc od = {0};
    od.size = ln;
    od.wavelength_m = 550e-9;
    od.density_kg_m3 = 2650;
    od.r_min_m = s->bins[0].r_lo_m;
    od.r_max_m = s->bins[s->nbins - 1].r_hi_m;
    od.nodes = 200;
    sq_bulk_optics bo;
    SQ_CHECK_OK(sq_bulk_optics_compute(&od, &bo));
    printf("  g(550): sphere Mie %.3f, non-spherical reference %.3f\n", bo.asymmetry,
           (double)dr[0].u.volume.g[1]);
    SQ_CHECK(bo.asymmetry > dr[0].u.volume.g[1]);
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(visibility_plane_is_koschmieder)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm_desc d = small_desc();
    d.wind_speed_mps = 1.3e-3;
    sq_sandstorm *s = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    const double conc = 5e-5;
    for (int b = 0; b < s->nbins; b++) {
        sq_field3 *c = sq_grid_scalar_field(s->grid, b);
        for (int k = 0; k < s->nz; k++)
            for (int j = 0; j < s->ny; j++)
                for (int i = 0; i < s->nx; i++)
                    *sq_field3_at(c, i, j, k) = (float)(conc * s->bins[b].mass_fraction);
    }
    s->derived_dirty = true;
    int nx, ny;
    const float *v = sq__sandstorm_visibility_plane(s, 0, &nx, &ny);
    SQ_CHECK(v != NULL);
    double beta = conc * s->k_ext_total_550 + SQ_SAND_BETA_AIR_550;
    SQ_CHECK_REL(v[nx * ny / 2 + 3], log(20.0) / beta, 1e-4);
    /* the per-bin optics add up to the whole distribution's mass extinction */
    sq_optics_table_desc td = {0};
    sq_lognormal_make(d.median_radius_m ? d.median_radius_m : 5e-6, 2.0, &td.size);
    sq_optics_table t;
    SQ_CHECK_OK(sq_optics_table_build(&td, &t));
    SQ_CHECK_REL(s->k_ext_total_550, t.channel[SQ_OPTICS_VIS].mass_extinction_m2_per_kg, 0.03);
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(urban_severities)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm_desc d = {0};
    d.mode = SQ_SANDSTORM_URBAN;
    d.median_radius_m = 0.29e-6;
    d.sigma_g = 2.0;
    d.urban_stage_s = 1.0;
    const double vis[3] = {600, 450, 200};
    sq_sandstorm *probe = NULL;
    d.urban_conc_kg_m3[0] = 1e-5f;
    d.urban_conc_count = 1;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &probe));
    double k = probe->k_ext_total_550;
    sq_sandstorm_destroy(probe);
    for (int i = 0; i < 3; i++) {
        double c;
        SQ_CHECK_OK(sq_concentration_for_visibility(vis[i], k, 0.05, &c));
        d.urban_conc_kg_m3[i] = (float)c;
    }
    d.urban_conc_count = 3;
    sq_sandstorm *s = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    for (int stage = 0; stage < 3; stage++) {
        sq_metric m[16];
        int n = sq__sandstorm_metrics(s, m, 16);
        SQ_CHECK(n >= 1 && strstr(m[0].name, "visibility"));
        /* clean-air Rayleigh extinction makes it slightly shorter than the dust-only value */
        SQ_CHECK_REL(m[0].value, vis[stage], 0.01);
        SQ_CHECK_OK(sq_sandstorm_step(s, 1.0));
    }
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Issue 12, the haboob: a cold pool (dT = 10 K, H = 150 m) entering through the west face runs
 * along the ground as a density current at a speed of the order of sqrt(g' H) = 6.9 m/s
 * (g' = g dT / T_s; a current fed by inflow runs at 0.5-1.2 of it: Benjamin's 1/2 for the lock
 * release, ~1 for a deep ambient; the 6 cells over H here run it ~15 % slow, cf. the lock-exchange
 * convergence in docs/validation.md, so the band is 0.4-1.2), lifts dust where its wind exceeds the emission threshold
 * (the 1 m/s ambient wind ahead of it cannot: u* = 0.04 m/s < 0.25 m/s), and every airborne
 * grain was emitted: no inflow, suspended <= emitted, the metrics' share 1. */
SQ_TEST(haboob_cold_pool_lifts_its_own_dust)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm_desc d = small_haboob_desc();
    sq_sandstorm *s = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    if (!s) return;
    for (int n = 0; n < 60; n++) SQ_CHECK_OK(sq_sandstorm_step(s, 1.0));
    sq_sandstorm_stats st;
    sq_sandstorm_get_stats(s, &st);
    const double c = sqrt(9.81 * 10.0 / 305.0 * 150.0);
    printf("  front %.0f m after 60 s, speed %.2f m/s = %.2f sqrt(g'H)\n", st.front_m,
           st.front_speed_mps, st.front_speed_mps / c);
    SQ_CHECK(st.front_m > 200.0 + 0.5 * c * 30.0);
    SQ_CHECK(st.front_speed_mps > 0.4 * c && st.front_speed_mps < 1.2 * c);
    sq_sandstorm_budget b;
    sq_sandstorm_get_budget(s, &b);
    SQ_CHECK(b.emitted_kg > 0.0 && b.inflow_kg == 0.0);
    SQ_CHECK(b.suspended_kg <= b.emitted_kg * (1.0 + 1e-6));
    sq_metric m[40];
    int nm = sq__sandstorm_metrics(s, m, 40);
    int found = 0;
    for (int i = 0; i < nm; i++) {
        if (strcmp(m[i].name, "dust_emitted_share") == 0) {
            SQ_CHECK(m[i].value == 1.0);
            found |= 1;
        }
        if (strcmp(m[i].name, "front_m") == 0) found |= 2;
        if (strcmp(m[i].name, "visibility_observer_m") == 0) found |= 4;
        if (strcmp(m[i].name, "wall_height_m") == 0) found |= 8;
    }
    SQ_CHECK(found == 15);
    /* the ground ahead of the front emitted nothing: its first cells hold no dust */
    sq_field_view c0 = sq_grid_scalar_view(s->grid, 0);
    const int i_ahead = (int)((st.front_m + 150.0) / s->h);
    double ahead = 0.0;
    for (int i = i_ahead; i < s->nx; i++)
        for (int j = 0; j < s->ny; j++) ahead = fmax(ahead, (double)sq_view_get(&c0, i, j, s->ground_k[0]));
    SQ_CHECK(i_ahead < s->nx && ahead < 1e-9);
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* The station's wind (wind_10m_observer_mps, max_wind_10m_mps): what an anemometer 10 m above
 * the ground would measure. A wind of U = 12 m/s with the log profile below 100 m over desert
 * roughness (z0 = 5e-4 m), flat ground, no pressure wave: at every height z below 100 m the air
 * moves at U ln(z/z0) / ln(100/z0), so 10 m above the ground at U ln(10/z0) / ln(100/z0) =
 * 0.8114 U (9.74 m/s), whatever the cells' size, everywhere (the 3-D maximum, max_wind_mps, is
 * the wind at the top of the log layer and above, U). */
SQ_TEST(station_wind_is_the_log_law_at_10_m)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm_desc d = small_desc();
    d.wind_speed_mps = 12.0;
    d.roughness_m = 5e-4;
    d.log_layer_m = 100.0;
    sq_sandstorm *s = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    if (!s) return;
    const double want = 12.0 * log(10.0 / 5e-4) / log(100.0 / 5e-4);
    sq_metric m[40];
    const int nm = sq__sandstorm_metrics(s, m, 40);
    double at = -1.0, mx = -1.0, m3 = -1.0;
    for (int i = 0; i < nm; i++) {
        if (strcmp(m[i].name, "wind_10m_observer_mps") == 0) at = m[i].value;
        if (strcmp(m[i].name, "max_wind_10m_mps") == 0) mx = m[i].value;
        if (strcmp(m[i].name, "max_wind_mps") == 0) m3 = m[i].value;
    }
    printf("  10 m wind: observer %.4f, largest %.4f m/s (log law %.4f); 3-D maximum %.3f m/s\n",
           at, mx, want, m3);
    SQ_CHECK_REL(at, want, 1e-3);
    SQ_CHECK_REL(mx, want, 1e-3);
    SQ_CHECK_REL(m3, 12.0, 1e-3);
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* The haboob under a lid (domain.top: free-slip): the cold pool of the test above under a
 * top 400 m up (H/D = 0.375). Under the open top its slumping draws air in through the top
 * face (|w| > 0 there); under the lid no air crosses it (w = 0 on every top face), and the
 * front still runs at 0.4-1.2 sqrt(g'H) (a lid at H/D = 0.375 slows it by at most ~20 %:
 * Benjamin 1968's energy-conserving current, Fr_h from 1.41 at H/D -> 0 to 1.12 at 0.375). */
SQ_TEST(haboob_lid_keeps_the_air_in)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    double wtop[2] = {0.0, 0.0}, speed[2] = {0.0, 0.0};
    for (int lid = 0; lid < 2; lid++) {
        sq_sandstorm_desc d = small_haboob_desc();
        d.top_boundary = lid;
        sq_sandstorm *s = NULL;
        SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
        if (!s) break;
        for (int n = 0; n < 60; n++) SQ_CHECK_OK(sq_sandstorm_step(s, 1.0));
        sq_field_view wv = sq_grid_velocity_view(s->grid, 2);
        for (int j = 0; j < s->ny; j++)
            for (int i = 0; i < s->nx; i++)
                wtop[lid] = fmax(wtop[lid], fabs((double)sq_view_get(&wv, i, j, s->nz)));
        sq_sandstorm_stats st;
        sq_sandstorm_get_stats(s, &st);
        speed[lid] = st.front_speed_mps;
        sq_sandstorm_destroy(s);
    }
    const double c = sqrt(9.81 * 10.0 / 305.0 * 150.0);
    printf("  top face max |w|: open %.3g m/s, lid %.3g m/s; front speed %.2f / %.2f sqrt(g'H)\n",
           wtop[0], wtop[1], speed[0] / c, speed[1] / c);
    SQ_CHECK(wtop[0] > 1e-3);  /* the open top lets air through */
    SQ_CHECK(wtop[1] == 0.0);  /* the lid does not */
    SQ_CHECK(speed[1] > 0.4 * c && speed[1] < 1.2 * c);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* domain.sides = periodic: dust blown out through the north face comes back in through the
 * south face. A slab of dust near the north face in a 5 m/s southerly (from the south) over
 * 50 s (250 m, 0.4 of the domain's width; a lid on top): with open sides most of it leaves
 * (outflow > 0); with periodic sides nothing leaves (outflow 0 to round-off), the airborne and
 * deposited dust add up to the slab (the mass fix on), and most of it is now in the southern
 * half. */
SQ_TEST(periodic_sides_keep_the_dust_in)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    double out[2] = {0, 0}, kept[2] = {0, 0}, south[2] = {0, 0}, m0 = 0.0;
    for (int per = 0; per < 2; per++) {
        sq_sandstorm_desc d = small_desc();
        d.wind_speed_mps = 5.0;
        d.prevailing_dir_deg = 90.0;
        d.side_boundary = per;
        d.top_boundary = 1;
        sq_sandstorm *s = NULL;
        SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
        if (!s) break;
        sq_field3 *c = sq_grid_scalar_field(s->grid, 0);
        m0 = 0.0;
        for (int k = 2; k < 6; k++)
            for (int j = 11; j < 15; j++)
                for (int i = 4; i < 20; i++) {
                    *sq_field3_at(c, i, j, k) = 1e-3f;
                    m0 += 1e-3 * s->h * s->h * s->h;
                }
        for (int n = 0; n < 10; n++) SQ_CHECK_OK(sq_sandstorm_step(s, 5.0));
        sq_sandstorm_budget b;
        sq_sandstorm_get_budget(s, &b);
        out[per] = b.outflow_kg;
        kept[per] = (b.suspended_kg + b.deposited_kg) / m0;
        sq_field_view v = sq_grid_scalar_view(s->grid, 0);
        double all = 0.0, lo = 0.0;
        for (int k = 0; k < s->nz; k++)
            for (int j = 0; j < s->ny; j++)
                for (int i = 0; i < s->nx; i++) {
                    all += sq_view_get(&v, i, j, k);
                    if (j < s->ny / 2) lo += sq_view_get(&v, i, j, k);
                }
        south[per] = all > 0.0 ? lo / all : 0.0;
        sq_sandstorm_destroy(s);
    }
    printf("  open sides: outflow %.4g kg, kept %.4f; periodic: outflow %.4g kg, kept %.7f, "
           "southern half holds %.2f of the dust\n", out[0], kept[0], out[1], kept[1], south[1]);
    SQ_CHECK(out[0] > 0.2 * m0 && kept[0] < 0.8);
    SQ_CHECK(out[1] < 1e-9 * m0);
    SQ_CHECK(fabs(kept[1] - 1.0) < 1e-5);
    SQ_CHECK(south[1] > 0.5);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* coldpool.return_flow in a channel (periodic sides, a lid): the cold inflow's volume beyond
 * the ambient wind's leaves through the west face above the cold pool, so that the air ahead of
 * the front keeps the ambient wind. By continuity the flux through any section ahead of the
 * front is the west face's net flux: with the return flow the ambient's, a depth mean of
 * U (1 - (100 m / D) / ln(100 m / z0)) = 0.980 m/s for U = 1 m/s over D = 400 m with the log
 * layer's 100 m; without it that plus the cold pool's extra flux over the depth,
 * (1/D) int f(z) (u_c - U) lp(z) dz (f the tanh step of the cold pool, 6.9 m/s inflow over
 * 150 m), ~2.3 m/s more. The front runs either way. */
SQ_TEST(haboob_return_flow_keeps_the_ambient_wind_ahead)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    const double U = 1.0, D = 400.0, z0 = 5e-4, H = 150.0, c = sqrt(9.81 * 10.0 / 305.0 * H);
    double excess = 0.0; /* int f (u_c - U) lp dz, 0.1 m steps */
    for (double z = 0.05; z < D; z += 0.1) {
        const double f = 0.5 * (1.0 - tanh((z - H) / (0.1 * H)));
        const double lp = fmin(1.0, log(z / z0) / log(100.0 / z0));
        excess += f * (c - U) * lp * 0.1;
    }
    const double ambient = U * (1.0 - (100.0 / D) / log(100.0 / z0));
    double ahead[2] = {0, 0}, front[2] = {0, 0};
    for (int ret = 0; ret < 2; ret++) {
        sq_sandstorm_desc d = small_haboob_desc();
        d.side_boundary = 1;
        d.top_boundary = 1;
        d.coldpool_return_flow = ret == 1;
        sq_sandstorm *s = NULL;
        SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
        if (!s) break;
        for (int n = 0; n < 60; n++) SQ_CHECK_OK(sq_sandstorm_step(s, 1.0));
        sq_sandstorm_stats st;
        sq_sandstorm_get_stats(s, &st);
        front[ret] = st.front_speed_mps;
        printf("  front at %.0f m\n", st.front_m);
        /* the depth mean of u over the fluid faces of the section 1 km from the west face */
        sq_field_view u = sq_grid_velocity_view(s->grid, 0);
        const int i = 40;
        double sum = 0.0;
        int n = 0;
        for (int j = 0; j < s->ny; j++)
            for (int k = s->ground_k[(size_t)j * s->nx + i]; k < s->nz; k++, n++)
                sum += sq_view_get(&u, i, j, k);
        ahead[ret] = n ? sum / n : 0.0;
        sq_sandstorm_destroy(s);
    }
    printf("  1 km from the west face: without the return flow %.3f m/s (%.3f + %.3f), with it "
           "%.3f m/s (ambient %.3f); front %.2f / %.2f sqrt(g'H)\n", ahead[0], ambient,
           excess / D, ahead[1], ambient, front[0] / c, front[1] / c);
    SQ_CHECK(fabs(ahead[1] - ambient) < 0.05);
    SQ_CHECK(fabs(ahead[0] - (ambient + excess / D)) < 0.1 * excess / D);
    SQ_CHECK(front[1] > 0.4 * c && front[1] < 1.2 * c);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Issue 12's bad input: a cold pool warmer than the air, colder by more than 20 K or outside
 * the domain, an unstable lapse rate, a step more than 100x the CFL sub-step limit. */
SQ_TEST(haboob_bad_input_named)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm *s = NULL;
    sq_sandstorm_desc d = small_desc();
    d.coldpool_delta_t_k = -2.0;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "coldpool.delta_t_k = -2 K");
    d.coldpool_delta_t_k = 25.0;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "coldpool.delta_t_k = 25 K");
    d.coldpool_delta_t_k = 8.0;
    d.coldpool_depth_m = 1000.0; /* domain 12 x 40 m = 480 m high */
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "coldpool.depth_m = 1000 m");
    d.coldpool_depth_m = 200.0;
    d.coldpool_length_m = 5000.0;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "coldpool.length_m = 5000 m");
    d = small_desc();
    d.lapse_k_per_m = 0.012;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "statically unstable");
    d = small_desc();
    d.top_boundary = 2;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "domain.top = 2; must be open (0) or free-slip (1)");
    d = small_desc();
    d.side_boundary = 2;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG,
                 "domain.sides = 2; must be open (0) or periodic (1)");
    d = small_desc();
    d.turbulence = 3;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG,
                 "solver.turbulence = 3; must be mixing-length (0), smagorinsky (1) or tke (2)");
    d = small_desc();
    d.wind_speed_mps = 40.0;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    if (s) {
        /* 40 m/s, 40 m cells, CFL 2: 2 s per sub-step; a 1000 s step needs 500 */
        SQ_CHECK_ERR(sq_sandstorm_step(s, 1000.0), SQ_ERR_INVALID_ARG, "more than 100");
        SQ_CHECK_OK(sq_sandstorm_step(s, 100.0)); /* 50 sub-steps are allowed */
        sq_sandstorm_destroy(s);
    }
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* coldpool.spanwise_variation: the deficit varies along y as dT (1 + a xi(y)), xi a sum of M
 * Fourier modes of the domain's width with equal amplitudes and seeded phases, rms 1. On the
 * grid's rows every mode has whole periods, so over the rows the variation's mean is exactly 0
 * and its rms exactly a dT (cos^2 averages to 1/2): read in the initial cold pool's first cell
 * (f = 1 there), against the same pool without the variation. The same seed gives the same
 * field, another seed another; the median front after 60 s stays within 5 % of the uniform
 * pool's (the speed goes as sqrt(dT): a^2/8 ~ 0.1 % slower on average); a variation whose
 * modes could add up to a deficit <= 0 is refused, naming the key. */
static double deficit_rows(const sq_sandstorm *u, const sq_sandstorm *v, double *rms)
{
    sq_field_view tu = sq_grid_scalar_view(u->grid, u->temp_idx), tv = sq_grid_scalar_view(v->grid, v->temp_idx);
    double m = 0.0, m2 = 0.0;
    for (int j = 0; j < u->ny; j++) {
        const double d = (double)sq_view_get(&tu, 0, j, u->ground_k[0]) - (double)sq_view_get(&tv, 0, j, v->ground_k[0]);
        m += d;
        m2 += d * d;
    }
    m /= u->ny;
    *rms = sqrt(m2 / u->ny - m * m);
    return m;
}

SQ_TEST(haboob_spanwise_variation_has_its_rms_and_mean)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm_desc d = small_haboob_desc();
    d.cells[1] = 32; /* 4 modes: 800, 400, 267, 200 m */
    d.side_boundary = 1;
    sq_sandstorm *u = NULL, *v = NULL, *v2 = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &u));
    d.coldpool_spanwise = 0.1;
    d.seed = 7;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &v));
    d.seed = 8;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &v2));
    if (!u || !v || !v2) return;
    double rms = 0.0, rms2 = 0.0;
    const double mean = deficit_rows(u, v, &rms);
    deficit_rows(u, v2, &rms2);
    double diff = 0.0;
    sq_field_view t1 = sq_grid_scalar_view(v->grid, v->temp_idx), t2 = sq_grid_scalar_view(v2->grid, v2->temp_idx);
    for (int j = 0; j < v->ny; j++)
        diff = fmax(diff, fabs((double)sq_view_get(&t1, 0, j, v->ground_k[0]) - (double)sq_view_get(&t2, 0, j, v->ground_k[0])));
    printf("  deficit's variation over the rows: mean %.2e K, rms %.5f K (a dT = %.5f K); seeds 7/8 "
           "differ by up to %.3f K\n", mean, rms, 0.1 * d.coldpool_delta_t_k, diff);
    SQ_CHECK(fabs(mean) < 1e-4);
    SQ_CHECK_REL(rms, 0.1 * d.coldpool_delta_t_k, 1e-3);
    SQ_CHECK_REL(rms2, 0.1 * d.coldpool_delta_t_k, 1e-3);
    SQ_CHECK(diff > 0.1);
    for (int n = 0; n < 60; n++) {
        SQ_CHECK_OK(sq_sandstorm_step(u, 1.0));
        SQ_CHECK_OK(sq_sandstorm_step(v, 1.0));
    }
    sq_sandstorm_stats su, sv;
    sq_sandstorm_get_stats(u, &su);
    sq_sandstorm_get_stats(v, &sv);
    printf("  median front after 60 s: uniform %.0f m, varied %.0f m\n", su.front_m, sv.front_m);
    SQ_CHECK(fabs(sv.front_m - su.front_m) < 0.05 * su.front_m);
    sq_sandstorm_destroy(u);
    sq_sandstorm_destroy(v);
    sq_sandstorm_destroy(v2);
    sq_sandstorm *s = NULL;
    d.coldpool_spanwise = 0.4; /* sqrt(8) x 0.4 = 1.13: a deficit < 0 where the modes add up */
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "coldpool.spanwise_variation = 0.4");
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* The haboob preset's cold pool, scaled down: 15 K on 310 K, 15 cells over its depth H = 600 m
 * under a lid at D = 2000 m (the preset's H/D = 0.3 and cells per depth), periodic sides, the
 * storm's return flow aloft, the log-law ground, no vorticity confinement (the preset's solver),
 * uniform across (a 4-cell slab), no dust; 3.2 km x 160 m on 40 m cells over flat ground.
 * Theory: Benjamin's (1968) current in a channel, c^2 = g' h (D - h)(2D - h) / (D (D + h)),
 * g' = g dT / theta: 0.957 sqrt(g'H) = 16.15 m/s in still air for h = H (within 1 % for a body
 * 0.9-1.1 H deep: c is near its largest there), an upper bound: energy-conserving but for the
 * loss Benjamin's h/D < 1/2 requires, no mixing, no drag. Laboratory and atmospheric currents
 * run at Fr = U / sqrt(g'H) of 0.7 to 1 (mixing at the head, the floor's drag); a following
 * ambient wind U adds 0.62 U over a rough floor (Simpson & Britter 1979), U itself for an
 * inviscid current. Asserted: the front fitted over 1-2.5 km in still air between 0.7 sqrt(g'H)
 * and c, and a 3 m/s following wind adding 0.5-1.0 of itself. */
static double reduced_haboob_front_speed(sq_context *ctx, double U)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 5000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    sq_sandstorm_desc d = small_haboob_desc();
    d.cells[0] = 80;
    d.cells[1] = 4;
    d.cells[2] = 50;
    d.cell_size_m = 40.0;
    d.wind_speed_mps = U;
    d.roughness_m = 5e-4;
    d.surface_temperature_k = 310.0;
    d.lapse_k_per_m = 0.0085;
    d.coldpool_delta_t_k = 15.0;
    d.coldpool_depth_m = 600.0;
    d.coldpool_length_m = 400.0;
    d.coldpool_return_flow = true;
    d.side_boundary = 1;
    d.top_boundary = 1;
    d.log_law_ground = true;
    d.emission_coeff = 0.0;
    sq_sandstorm *s = NULL;
    if (w) SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (int step = 0; s && step < 300; step++) {
        SQ_CHECK_OK(sq_sandstorm_step(s, 1.0));
        sq_sandstorm_stats st;
        sq_sandstorm_get_stats(s, &st);
        if (st.front_m > 2500.0) break;
        if (st.front_m >= 1000.0) {
            const double t = s->time_s;
            sx += t;
            sy += st.front_m;
            sxx += t * t;
            sxy += t * st.front_m;
            n++;
        }
    }
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    SQ_CHECK(n >= 20);
    return n >= 2 ? (n * sxy - sx * sy) / (n * sxx - sx * sx) : 0.0;
}

SQ_TEST(haboob_front_runs_at_the_density_currents_speed)
{
    /* one thread: 16 000 cells are too few to share, and two threads' barriers spin on a
     * loaded machine */
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    const double gp = 9.81 * 15.0 / 310.0, H = 600.0, D = 2000.0, c0 = sqrt(gp * H);
    const double cb = sqrt(gp * H * (D - H) * (2.0 * D - H) / (D * (D + H)));
    const double still = reduced_haboob_front_speed(ctx, 0.01);
    const double with3 = reduced_haboob_front_speed(ctx, 3.0);
    printf("  Benjamin's channel current %.2f m/s (%.3f sqrt(g'H)); front in still air %.2f m/s "
           "(%.3f sqrt(g'H), %.3f of Benjamin's), with a 3 m/s following wind %.2f m/s (+%.2f = "
           "%.2f of the wind)\n", cb, cb / c0, still, still / c0, still / cb, with3, with3 - still,
           (with3 - still) / 3.0);
    SQ_CHECK(still > 0.7 * c0 && still < cb);
    SQ_CHECK(with3 - still > 0.5 * 3.0 && with3 - still < 1.0 * 3.0);
    sq_context_destroy(ctx);
}

SQ_TEST(bad_input_named)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm *s = NULL;
    sq_sandstorm_desc d = small_desc();
    d.median_radius_m = -1e-6;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "dust.median_radius_m = -1e-06");
    d = small_desc();
    d.median_radius_m = NAN;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "median_radius_m = nan");
    d = small_desc();
    d.sigma_g = 0.9;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "sigma_g = 0.9; the geometric standard deviation must be > 1");
    d = small_desc();
    d.grain_density_kg_m3 = -5;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "density_kg_m3 = -5");
    d = small_desc();
    d.n_real = 1.5;
    d.n_imag = -0.01;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "n_imag = -0.01");
    d = small_desc();
    d.inflow_dust_kg_m3 = -1e-3;
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "a concentration must be >= 0");
    d = small_desc();
    d.kx_per_m = 0.05; /* wavelength 126 m < 4 cells of 40 m */
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "would alias on the grid");
    d = small_desc();
    d.cells[0] = d.cells[1] = d.cells[2] = 1000;
    d.cell_size_m = 1.0;
    sq_context *small = NULL;
    sq_context_desc cd = {.memory_limit_bytes = 64u << 20};
    sq_context_create(&cd, &small);
    SQ_CHECK_ERR(sq_sandstorm_create(small, &d, w, &s), SQ_ERR_TOO_LARGE, "sandstorm grid 1000x1000x1000 needs");
    SQ_CHECK(sq_context_bytes_peak(small) == 0);
    sq_context_destroy(small);
    d = small_desc();
    d.cells[0] = 100; /* 4 km domain on a 2 km terrain */
    SQ_CHECK_ERR(sq_sandstorm_create(ctx, &d, w, &s), SQ_ERR_INVALID_ARG, "reaches outside the terrain");
    SQ_CHECK(s == NULL);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(blow_up_is_an_error_not_a_crash)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    sq_sandstorm_desc d = small_desc();
    sq_sandstorm *s = NULL;
    SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
    *sq_field3_at(sq_grid_scalar_field(s->grid, 1), 5, 5, 5) = NAN;
    SQ_CHECK_ERR(sq_sandstorm_step(s, 0.5), SQ_ERR_UNSTABLE, "step");
    sq_sandstorm_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* ---- flow-following detail of the drawable (sandstorm_detail.c) ---------------------------- */
/* A grid whose face velocities are set by hand (no solver step): u = (u0 + shear z, v0, w0). */
static sq_grid *detail_grid(sq_context *ctx, int n[3], double h, const double uvw[3],
                            double shear)
{
    sq_grid_desc gd = {0};
    gd.cells = (sq_dims){n[0], n[1], n[2]};
    gd.cell_size_m = h;
    sq_grid *g = NULL;
    SQ_CHECK_OK(sq_grid_create(ctx, &gd, &g));
    if (!g) return NULL;
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = sq_grid_velocity_field(g, c);
        for (int k = -f->ghost; k < f->n.nz + f->ghost; k++)
            for (int j = -f->ghost; j < f->n.ny + f->ghost; j++)
                for (int i = -f->ghost; i < f->n.nx + f->ghost; i++)
                    *sq_field3_at(f, i, j, k) =
                        (float)(uvw[c] + (c == 0 ? shear * (k + 0.5) * h : 0.0));
    }
    return g;
}

/* What is checked. In a uniform wind u the advected noise coordinates of both phases are
 * X(x, t) = x - u t / h (cells) in every cell, those entering through the faces included, within
 * 1e-4 cells after 10 steps; the wind has no vorticity, so the amplitude is 0 and the drawable is
 * returned unchanged (bit for bit). With the amplitude held at 1.5 cells and the blend weights
 * held, the detailed pattern of a dust blob carried by the same wind for 10 s (a shift of
 * (2, 1, 1) cells) equals the pattern at t = 0 shifted by u t (within 1e-5 of the blob's peak):
 * the detail moves with the air, it is not fixed in space (a static noise, or coordinates that
 * are not advected, fails this by up to the blob's full contrast). */
SQ_TEST(detail_is_advected_by_the_wind)
{
    sq_context *ctx = mkctx();
    int n[3] = {24, 16, 12};
    const double h = 50.0, uvw[3] = {10.0, 5.0, 5.0};
    sq_grid *g = detail_grid(ctx, n, h, uvw, 0.0);
    sq__sand_detail d;
    SQ_CHECK_OK(sq__sand_detail_init(&d, ctx, n[0], n[1], n[2], h, 75.0, 200.0, 1000.0, 3));
    const size_t nc = (size_t)n[0] * n[1] * n[2];
    float *in0 = malloc(nc * sizeof(float)), *in1 = malloc(nc * sizeof(float));
    float *out0 = malloc(nc * sizeof(float)), *out1 = malloc(nc * sizeof(float));
    if (!g || !in0 || !in1 || !out0 || !out1) goto done;
    for (int k = 0; k < n[2]; k++)
        for (int j = 0; j < n[1]; j++)
            for (int i = 0; i < n[0]; i++) {
                const size_t id = ((size_t)k * n[1] + j) * n[0] + i;
                const double r0 = (i - 9.0) * (i - 9.0) + (j - 7.0) * (j - 7.0) + (k - 5.0) * (k - 5.0);
                const double r1 = (i - 11.0) * (i - 11.0) + (j - 8.0) * (j - 8.0) + (k - 6.0) * (k - 6.0);
                in0[id] = (float)exp(-r0 / 6.0); /* the blob at t = 0 ... */
                in1[id] = (float)exp(-r1 / 6.0); /* ... and carried by u t = (2, 1, 1) cells */
            }
    /* no vorticity: no detail at all */
    sq__sand_detail_advect(&d, g, 1.0, 1);
    sq__sand_detail_apply(&d, in0, out0, 1);
    SQ_CHECK(memcmp(in0, out0, nc * sizeof(float)) == 0);
    sq__sand_detail_reseed(&d, 0);
    sq__sand_detail_reseed(&d, 1);
    const double age[2] = {250.0, 750.0};
    memcpy(d.age, age, sizeof age);
    for (size_t c = 0; c < nc; c++) d.amp[c] = 1.5f;
    sq__sand_detail_apply(&d, in0, out0, 1);
    double changed = 0.0;
    for (size_t c = 0; c < nc; c++) changed = fmax(changed, fabs((double)out0[c] - in0[c]));
    SQ_CHECK_MSG(changed > 0.1, "the detail changes the blob by only %g", changed);
    for (int s = 0; s < 10; s++) sq__sand_detail_advect(&d, g, 1.0, 1);
    double worst_x = 0.0;
    for (int ph = 0; ph < 2; ph++)
        for (int k = 0; k < n[2]; k++)
            for (int j = 0; j < n[1]; j++)
                for (int i = 0; i < n[0]; i++) {
                    const float *X = d.coord[ph] + 3 * (((size_t)k * n[1] + j) * n[0] + i);
                    const double e[3] = {i - 2.0, j - 1.0, k - 1.0};
                    for (int c = 0; c < 3; c++) worst_x = fmax(worst_x, fabs(X[c] - e[c]));
                }
    printf("detail coordinates after 10 s of (10, 5, 5) m/s: worst error %.2e cells\n", worst_x);
    SQ_CHECK(worst_x < 1e-4);
    memcpy(d.age, age, sizeof age);
    for (size_t c = 0; c < nc; c++) d.amp[c] = 1.5f;
    sq__sand_detail_apply(&d, in1, out1, 1);
    double worst = 0.0, worst_static = 0.0;
    int cells = 0;
    for (int k = 4; k < n[2] - 3; k++)
        for (int j = 4; j < n[1] - 3; j++)
            for (int i = 5; i < n[0] - 3; i++) {
                const size_t a = ((size_t)k * n[1] + j) * n[0] + i;
                const size_t b = ((size_t)(k - 1) * n[1] + (j - 1)) * n[0] + (i - 2);
                worst = fmax(worst, fabs((double)out1[a] - out0[b]));
                worst_static = fmax(worst_static, fabs((double)out1[a] - out0[a]));
                cells++;
            }
    printf("detail pattern carried by the wind: %d cells, worst difference %.2e (to the unshifted "
           "pattern %.3f)\n", cells, worst, worst_static);
    SQ_CHECK(cells > 500);
    SQ_CHECK(worst < 1e-5);
    SQ_CHECK(worst_static > 0.1);
done:
    free(in0);
    free(in1);
    free(out0);
    free(out1);
    sq__sand_detail_free(&d, ctx);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* What is checked. The amplitude follows the resolved vorticity: in a uniform shear
 * u = S z (S = 0.1 1/s, |omega| = S) it is A (1 - exp(-S / 0.1 1/s)) = A (1 - 1/e) at every
 * cell, within 1e-4 relative (the central difference of a linear profile is exact; one-sided at
 * the ground and top). The blend weights: 0 when a phase is re-seeded, 1 half a period later,
 * and the two phases, half a period apart, always sum to 1. A phase is re-seeded (its
 * coordinates back to the cell positions) once its age reaches the period. No NaN: the detail of
 * a finite field stays finite, non-negative and at most twice the field's maximum. */
SQ_TEST(detail_amplitude_follows_the_shear)
{
    sq_context *ctx = mkctx();
    int n[3] = {16, 12, 10};
    const double h = 40.0, uvw[3] = {2.0, 0.0, 0.0}, A = 60.0;
    sq_grid *g = detail_grid(ctx, n, h, uvw, 0.1);
    sq__sand_detail d;
    SQ_CHECK_OK(sq__sand_detail_init(&d, ctx, n[0], n[1], n[2], h, A, 160.0, 4.0, 9));
    const size_t nc = (size_t)n[0] * n[1] * n[2];
    float *in = malloc(nc * sizeof(float)), *out = malloc(nc * sizeof(float));
    if (!g || !in || !out) goto done;
    sq__sand_detail_advect(&d, g, 1.0, 1);
    const double expect = A / h * (1.0 - exp(-1.0));
    double worst = 0.0;
    for (size_t c = 0; c < nc; c++) worst = fmax(worst, fabs(d.amp[c] - expect) / expect);
    printf("detail amplitude in a 0.1 1/s shear: expected %.5f cells, worst rel error %.2e\n",
           expect, worst);
    SQ_CHECK(worst < 1e-4);
    for (int s = 0; s < 10; s++) {
        const double a0 = 0.4 * s, a1 = fmod(a0 + 2.0, 4.0);
        SQ_CHECK_NEAR(sq__sand_detail_weight(a0, 4.0) + sq__sand_detail_weight(a1, 4.0), 1.0, 1e-12);
    }
    SQ_CHECK_NEAR(sq__sand_detail_weight(0.0, 4.0), 0.0, 1e-12);
    SQ_CHECK_NEAR(sq__sand_detail_weight(2.0, 4.0), 1.0, 1e-12);
    /* phase 0 starts at age 0, phase 1 at 2 s: after 3 steps of 1 s phase 1 was re-seeded at
     * t = 2 s and advected for 1 s since, phase 0 (age 3) not */
    sq__sand_detail_advect(&d, g, 1.0, 1);
    sq__sand_detail_advect(&d, g, 1.0, 1);
    SQ_CHECK_NEAR(d.age[0], 3.0, 1e-12);
    SQ_CHECK_NEAR(d.age[1], 1.0, 1e-12);
    sq__sand_detail_advect(&d, g, 1.0, 1);
    SQ_CHECK_NEAR(d.age[0], 0.0, 1e-12); /* re-seeded at 4 s */
    SQ_CHECK_NEAR(d.coord[0][3 * 5 + 0], 5.0, 0.0);
    for (int i = 0; i < 3; i++) sq__sand_detail_advect(&d, g, 1.0, 1);
    for (size_t c = 0; c < nc; c++) in[c] = (float)(c % 7) * 0.01f;
    sq__sand_detail_apply(&d, in, out, 1);
    bool finite = true, inside = true;
    for (size_t c = 0; c < nc; c++) {
        finite = finite && isfinite(out[c]);
        /* trilinear lookup (within the field's range) times the modulation 1 + 0.7 m with
         * |m| <= sqrt(2) (two phases, normalised weights): at most 2x the maximum, never < 0 */
        inside = inside && out[c] >= 0.0f && out[c] <= 2.0f * 0.06f + 1e-6f;
    }
    SQ_CHECK(finite);
    SQ_CHECK(inside);
done:
    free(in);
    free(out);
    sq__sand_detail_free(&d, ctx);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* The wall's top seen from ahead: in 3 of 5 rows a block of dust 4 cells long (beta 0.1 1/m,
 * optical depth 4 along x at h = 10 m) up to level 3 under a thinner layer (beta 0.05: depth 2,
 * below ln(1/0.05) = 3.0) at levels 4-5: the top is level 3's, 3.5 h + z1 above the ground;
 * one dense column higher up in one row (depth 1) and the two empty rows do not move the
 * median; with contrast 0.2 (ln 5 = 1.6) the thinner layer counts. */
SQ_TEST(wall_seen_is_where_the_dust_hides_the_sky)
{
    enum { NX = 10, NY = 5, NZ = 8 };
    static float beta[NZ * NY * NX];
    int gk[NY * NX];
    float z1[NY * NX];
    double rows[NY];
    for (int c = 0; c < NY * NX; c++) {
        gk[c] = 0;
        z1[c] = 5.0f;
    }
    for (int j = 1; j < 4; j++)
        for (int k = 0; k < 6; k++)
            for (int i = 2; i < 6; i++) beta[(k * NY + j) * NX + i] = k <= 3 ? 0.1f : 0.05f;
    beta[(7 * NY + 2) * NX + 5] = 0.1f;
    const double top = sq__sand_wall_seen(beta, NX, NY, NZ, gk, z1, 10.0f, 0.05, rows);
    const double top2 = sq__sand_wall_seen(beta, NX, NY, NZ, gk, z1, 10.0f, 0.2, rows);
    printf("  wall seen: %.1f m (expected 40), with contrast 0.2 %.1f m (expected 60)\n", top, top2);
    SQ_CHECK_NEAR(top, 40.0, 1e-9);
    SQ_CHECK_NEAR(top2, 60.0, 1e-9);
}
