/* test_sandstorm_mixing.c — the dust's mixing by the ground's turbulence (sandstorm_mixing.c,
 * solver.surface_layer_mixing) against analytic solutions: a Gaussian spreading under a
 * constant diffusivity, Rouse's profile of suspended sediment under the parabolic K of a
 * log-law flow, the bulk-Richardson depth of a uniformly stratified calm column; and in a
 * haboob: the dust budget still closes and the body holds dust above its lowest cells. */
#include <math.h>
#include <string.h>

#include "sq_test.h"
#include "phen/sandstorm/sandstorm_internal.h"
#include "squall/sandstorm.h"

SQ_LABEL(physics)

/* Backward Euler with the 3-point flux form grows a pulse's variance by exactly 2 K dt per step
 * (sum z^2 of the discrete Laplacian is 2 sum c), as the heat equation's Gaussian does:
 * sigma^2(t) = sigma0^2 + 2 K t, peak M / sqrt(2 pi sigma^2). Mass kept to round-off. */
SQ_TEST(kmix_spreads_a_gaussian_like_the_heat_equation)
{
    enum { N = 600 };
    const double h = 1.0, K = 2.0, s0 = 10.0, dt = 1.0;
    const int steps = 100;
    float c[N], kf[N];
    double work[2 * N];
    double m0 = 0.0;
    for (int k = 0; k < N; k++) {
        const double z = (k - N / 2) * h;
        c[k] = (float)exp(-0.5 * z * z / (s0 * s0));
        kf[k] = (float)K;
        m0 += c[k];
    }
    for (int n = 0; n < steps; n++) sq__sand_column_kmix(c, 1, N, kf, h, dt, work);
    double m = 0.0, m2 = 0.0, peak = 0.0;
    for (int k = 0; k < N; k++) {
        const double z = (k - N / 2) * h;
        m += c[k];
        m2 += c[k] * z * z;
        peak = fmax(peak, (double)c[k]);
    }
    const double var = m2 / m, want = s0 * s0 + 2.0 * K * steps * dt;
    printf("  variance %.3f (analytic %.3f), peak %.5f (analytic %.5f), mass %.8f of %.8f\n", var,
           want, peak, m0 / sqrt(2.0 * SQ_PI * want), m, m0);
    SQ_CHECK_REL(m, m0, 1e-5);
    SQ_CHECK_REL(var, want, 1e-3);
    SQ_CHECK_REL(peak, m0 / sqrt(2.0 * SQ_PI * want), 0.01);
}

/* Rouse (1937): in a layer of depth H with K = kappa u* z (1 - z/H) / Sc and grains settling at
 * w_s, the steady column (settling balanced by the upward turbulent flux, w_s c + K dc/dz = 0)
 * holds c(z) / c(a) = ((H - z) / z * a / (H - a))^P, P = w_s Sc / (kappa u*). A column of 800
 * cells of 0.25 m, the ground returning what settles (the emission of an equilibrium), settled
 * (upwind) and mixed until steady (30000 s, ~7 mixing times H^2 / K), for P = 0.5 and P = 1.5,
 * compared between a = 0.1 H and 0.8 H. The error allowed is 1.5 times the first-order upwind
 * settling's: the discrete balance gives c_k+1 / c_k = 1 / (1 + x), x = w_s h / K, for exp(-x),
 * a relative error summing to ~P^2 h / 2 (1 / a + 1 / (H - z)) (0.23 % at P = 0.5, 2.1 % at
 * P = 1.5). */
SQ_TEST(kmix_and_settling_give_rouses_profile)
{
    enum { N = 800 };
    const double h = 0.25, H = N * h, z1 = 0.5 * h, us = 0.5, Sc = 0.74, dt = 0.25;
    const double Ps[2] = {0.5, 1.5};
    for (int p = 0; p < 2; p++) {
        const double ws = Ps[p] * SQ_SAND_KARMAN * us / Sc;
        float c[N], kf[N];
        uint8_t solid[N];
        double work[2 * N];
        memset(solid, 0, sizeof solid);
        for (int k = 0; k < N; k++) c[k] = 1.0f;
        SQ_CHECK(sq__sand_kprofile(kf, N, z1, h, us, H, Sc) == H);
        const double frac = ws * dt / h;
        for (int n = 0; n < 120000; n++) {
            const double dep = sq__sand_column_settle(c, 1, solid, 1, N, frac);
            c[0] += (float)dep;
            sq__sand_column_kmix(c, 1, N, kf, h, dt, work);
        }
        const int ka = (int)(0.1 * H / h); /* reference level a = 0.1 H */
        const double a = z1 + ka * h;
        double worst = 0.0;
        for (int k = ka; z1 + k * h <= 0.8 * H; k++) {
            const double z = z1 + k * h;
            const double want = pow((H - z) / z * a / (H - a), Ps[p]);
            const double got = c[k] / c[ka];
            worst = fmax(worst, fabs(got / want - 1.0));
        }
        printf("  P = %.1f: worst relative error %.4f between 0.1 H and 0.8 H (c(0.5H)/c(a) %.4f, "
               "Rouse %.4f)\n", Ps[p], worst, c[(int)(0.5 * H / h)] / c[ka],
               pow((H - (z1 + (int)(0.5 * H / h) * h)) / (z1 + (int)(0.5 * H / h) * h) * a / (H - a), Ps[p]));
        const double est = Ps[p] * Ps[p] * h / 2.0 * (1.0 / a + 1.0 / (0.2 * H));
        printf("  first-order estimate %.4f\n", est);
        SQ_CHECK(worst < 1.5 * est);
    }
}

/* In calm air (no shear) with theta rising at Gamma K/m, Ri_b(z) = g Gamma (z - z1)^2 /
 * (theta_1 b u*^2) reaches 0.25 at z - z1 = sqrt(0.25 b u*^2 theta_1 / (g Gamma)), b = 100
 * (Vogelezang & Holtslag 1996); Ri_b is quadratic in z, so the depth interpolated linearly
 * between 20 m cells is within a cell of it. With a 3 K step at 450 m over well-mixed air
 * (theta uniform below) the depth stops at the step. */
SQ_TEST(bulk_richardson_depth_is_analytic)
{
    enum { N = 100 };
    const double dz = 20.0, z1 = 10.0, g = 9.81, us = 0.6, G = 0.003;
    float th[N], u[N], v[N];
    for (int k = 0; k < N; k++) {
        th[k] = (float)(300.0 + G * k * dz);
        u[k] = 15.0f;
        v[k] = 0.0f;
    }
    const double d = sq__sand_bulk_ri_depth(th, u, v, N, z1, dz, us, g);
    const double want = z1 + sqrt(0.25 * 100.0 * us * us * 300.0 / (g * G));
    printf("  stratified: depth %.1f m (analytic %.1f m)\n", d, want);
    SQ_CHECK(fabs(d - want) < dz);
    for (int k = 0; k < N; k++) th[k] = z1 + k * dz < 450.0 ? 300.0f : 303.0f;
    const double d2 = sq__sand_bulk_ri_depth(th, u, v, N, z1, dz, us, g);
    printf("  cold pool 450 m deep: depth %.1f m\n", d2);
    SQ_CHECK(d2 > 450.0 - dz && d2 < 450.0 + dz);
}

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
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 3000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    sq_world *w = NULL;
    sq_world_create(ctx, &wd, &w);
    return w;
}

/* In the body (columns more than 300 m behind the front): the dust between 60 and 300 m above
 * the ground (cells 2..9) per dust in the lowest two cells. */
static double body_aloft_ratio(const sq_sandstorm *s, double front_m)
{
    double lo = 0.0, up = 0.0;
    const int iend = (int)((front_m - 300.0) / s->h);
    for (int b = 0; b < s->nbins; b++) {
        sq_field_view c = sq_grid_scalar_view(s->grid, b);
        for (int j = 0; j < s->ny; j++)
            for (int i = 0; i < iend && i < s->nx; i++) {
                const int k0 = s->ground_k[(size_t)j * s->nx + i];
                for (int k = k0; k < k0 + 10 && k < s->nz; k++) {
                    const double v = sq_view_get(&c, i, j, k);
                    if (k < k0 + 2) lo += v;
                    else up += v;
                }
            }
    }
    return lo > 0.0 ? up / lo : 0.0;
}

/* A haboob (10 K, 300 m deep, 30 m cells, a ~10 m/s outflow over desert roughness, 100 s): the mixing
 * conserves the dust (the budget closes to float round-off, every gram emitted) and lifts the
 * dust the body raises above its lowest two cells (without it the resolved closure's K is 0
 * there: uniform wind, slightly stable air). */
SQ_TEST(haboob_body_holds_dust_through_its_depth)
{
    sq_context *ctx = mkctx();
    sq_world *w = flat_world(ctx);
    double ratio[2] = {0, 0};
    for (int mix = 0; mix < 2; mix++) {
        sq_sandstorm_desc d = {0};
        d.cells[0] = 48;
        d.cells[1] = 6;
        d.cells[2] = 24;
        d.cell_size_m = 30.0;
        d.pressure_amp_pa[0] = 0.0f;
        d.pressure_amp_count = 1;
        d.wind_speed_mps = 3.0;
        d.surface_temperature_k = 310.0;
        d.lapse_k_per_m = 0.0085;
        d.buoyancy_gain = 1.0;
        d.coldpool_delta_t_k = 10.0;
        d.coldpool_depth_m = 300.0;
        d.coldpool_length_m = 300.0;
        d.top_boundary = 1;
        d.side_boundary = 1;
        d.log_law_ground = true;
        d.emission_coeff = 1e-3;
        d.surface_layer_mixing = mix;
        sq_sandstorm *s = NULL;
        SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
        if (!s) break;
        for (int n = 0; n < 100; n++) SQ_CHECK_OK(sq_sandstorm_step(s, 1.0));
        sq_sandstorm_stats st;
        sq_sandstorm_get_stats(s, &st);
        sq_sandstorm_budget b;
        sq_sandstorm_get_budget(s, &b);
        const double err =
            fabs(b.initial_kg + b.emitted_kg - b.deposited_kg - b.outflow_kg - b.suspended_kg) / b.emitted_kg;
        ratio[mix] = body_aloft_ratio(s, st.front_m);
        printf("  mixing %s: front %.0f m, emitted %.1f kg, budget error %.2g, body dust 60-300 m / "
               "0-60 m %.3f\n", mix ? "on " : "off", st.front_m, b.emitted_kg, err, ratio[mix]);
        SQ_CHECK(b.emitted_kg > 0.0 && b.inflow_kg == 0.0);
        SQ_CHECK(err < 1e-5);
        sq_sandstorm_destroy(s);
    }
    SQ_CHECK(ratio[1] > 2.0 * ratio[0]);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}
