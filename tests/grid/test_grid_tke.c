/* test_grid_tke.c — Deardorff's (1980) 1.5-order subgrid closure (grid_tke.c, closure =
 * SQ_SGS_TKE) against analytic answers: decaying turbulence at rest follows the closed form of
 * de/dt = -C_eps e^(3/2) / l; the stable length 0.76 sqrt(e) / N and K_m = C_k l sqrt(e); the
 * buoyancy sink K_h N^2 with K_h = (1 + 2 l / h) K_m; the local equilibrium of shear production
 * and dissipation in a uniform shear; e never negative nor NaN; e carried by the scalar
 * advection with its sum conserved; bad descs refused. */
#include "sq_test.h"
#include "squall/grid.h"

SQ_LABEL(physics)

#define CK 0.10   /* Deardorff 1980; Moeng 1984 */
#define GRAV 9.81

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1};
    if (sq_context_create(&cd, &ctx) != SQ_OK) return NULL;
    return ctx;
}

/* n x n x nz cells of h, periodic in x and y; z ends free-slip walls (or open with open_z);
 * scalar 0 = e, scalar 1 = theta. */
static sq_grid *make_box(sq_context *ctx, int n, int nz, double h, bool open_z)
{
    sq_grid_desc d = {.cells = {n, n, nz}, .cell_size_m = h, .scalar_count = 2};
    for (int f = 0; f < 4; f++) d.boundary[f] = SQ_BOUNDARY_PERIODIC;
    d.boundary[SQ_FACE_ZMIN] = open_z ? SQ_BOUNDARY_OPEN : SQ_BOUNDARY_FREE_SLIP;
    d.boundary[SQ_FACE_ZMAX] = open_z ? SQ_BOUNDARY_OPEN : SQ_BOUNDARY_FREE_SLIP;
    d.scalar_nonnegative = 1u;
    sq_grid *g = NULL;
    if (sq_grid_create(ctx, &d, &g) != SQ_OK) fprintf(stderr, "sq_grid_create: %s\n", sq_last_error());
    return g;
}

/* e = e0 everywhere, theta = th0 + gamma z */
static void fill(sq_grid *g, double e0, double th0, double gamma, double h)
{
    sq_field3 *e = sq_grid_scalar_field(g, 0), *t = sq_grid_scalar_field(g, 1);
    for (int k = 0; k < e->n.nz; k++)
        for (int j = 0; j < e->n.ny; j++)
            for (int i = 0; i < e->n.nx; i++) {
                *sq_field3_at(e, i, j, k) = (float)e0;
                *sq_field3_at(t, i, j, k) = (float)(th0 + gamma * (k + 0.5) * h);
            }
    sq_grid_apply_boundary(g);
}

static sq_grid_sgs_desc tke_desc(bool stratified)
{
    sq_grid_sgs_desc d = {.closure = SQ_SGS_TKE, .tke_idx = 0, .stratified = stratified,
                          .theta_idx = 1, .gravity_mps2 = GRAV};
    return d;
}

/* Isotropic turbulence at rest in neutral air: no production, l = h, C_eps = 0.19 + 0.51 =
 * 0.70, so de/dt = -C_eps e^(3/2) / h, whose solution is e(t) = (e0^(-1/2) + C_eps t /
 * (2 h))^(-2) (Deardorff 1980 eq. 11). Uniform e does not diffuse. Checked at every step. */
SQ_TEST(decay_at_rest_follows_the_closed_form)
{
    sq_context *ctx = make_ctx();
    const double h = 20.0, e0 = 2.0, dt = 4.0, ceps = 0.70;
    sq_grid *g = make_box(ctx, 8, 8, h, false);
    SQ_CHECK(g != NULL);
    fill(g, e0, 300.0, 0.0, h);
    const sq_grid_sgs_desc sd = tke_desc(false);
    double worst = 0.0;
    for (int s = 1; s <= 50; s++) {
        SQ_CHECK_OK(sq_grid_diffuse_sgs(g, &sd, dt));
        const double t = s * dt, exact = pow(1.0 / sqrt(e0) + ceps * t / (2.0 * h), -2.0);
        sq_field_view v = sq_grid_scalar_view(g, 0);
        for (int k = 0; k < 8; k += 7)
            for (int i = 0; i < 8; i += 3) {
                const double r = fabs(sq_view_get(&v, i, 2, k) / exact - 1.0);
                worst = r > worst ? r : worst;
            }
    }
    const double exact = pow(1.0 / sqrt(e0) + ceps * 200.0 / (2.0 * h), -2.0);
    sq_field_view v = sq_grid_scalar_view(g, 0);
    printf("e(200 s) = %.7f (closed form %.7f; e0 = %g), worst relative error %.2e\n",
           (double)sq_view_get(&v, 3, 3, 3), exact, e0, worst);
    SQ_CHECK(exact < 0.2 * e0); /* it did decay */
    SQ_CHECK(worst < 1e-5);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* K_m = C_k l sqrt(e) with l = min(h, 0.76 sqrt(e) / N) (Deardorff 1980 eq. 10): at rest in
 * air with theta = 300 K + 0.01 K/m z, N^2 = g Gamma / theta; e = 0.25 m^2/s^2 gives l = 21 m
 * < h = 50 m, e = 4 gives l = 84 m, cut to h; neutral air l = h. */
SQ_TEST(stable_length_scale)
{
    sq_context *ctx = make_ctx();
    const double h = 50.0, gamma = 0.01, th0 = 300.0;
    const int n = 6, nz = 10;
    float nu[6 * 6 * 10];
    const double es[3] = {0.25, 4.0, 0.25};
    const double gs[3] = {gamma, gamma, 0.0};
    for (int c = 0; c < 3; c++) {
        sq_grid *g = make_box(ctx, n, nz, h, false);
        SQ_CHECK(g != NULL);
        fill(g, es[c], th0, gs[c], h);
        const sq_grid_sgs_desc sd = tke_desc(true);
        SQ_CHECK_OK(sq_grid_sgs_viscosity(g, &sd, nu));
        double worst = 0.0, lmid = 0.0;
        for (int k = 0; k < nz; k++) {
            const double th = (double)(float)(th0 + gs[c] * (k + 0.5) * h);
            const double n2 = GRAV * gs[c] / th;
            const double ls = n2 > 0.0 ? 0.76 * sqrt(es[c] / n2) : 1e30;
            const double l = ls < h ? ls : h;
            const double km = CK * l * sqrt(es[c]);
            const double r = fabs(nu[(k * n + 2) * n + 3] / km - 1.0);
            worst = r > worst ? r : worst;
            if (k == nz / 2) lmid = l;
        }
        printf("e = %g, Gamma = %g K/m: l = %.3f m at mid-height, K_m %.5f m2/s; worst "
               "relative error %.2e\n", es[c], gs[c], lmid, (double)nu[((nz / 2) * n + 2) * n + 3],
               worst);
        SQ_CHECK(worst < 2e-4);
        if (c == 0) SQ_CHECK(lmid < 0.5 * h); /* the stable length applies */
        if (c >= 1) SQ_CHECK(lmid == h);
        sq_grid_destroy(g);
    }
    sq_context_destroy(ctx);
}

/* Turbulence at rest in stable air loses energy to the buoyancy and to dissipation:
 * de/dt = -K_h N^2 - C_eps e^(3/2) / l, K_h = (1 + 2 l / h) K_m, C_eps = 0.19 + 0.51 l / h,
 * with the stable l (here 0.42 h). One short step (0.1 s) against the rate at e0; without the
 * buoyancy term the loss would be 21 % smaller. */
SQ_TEST(buoyancy_sink_uses_k_h)
{
    sq_context *ctx = make_ctx();
    const double h = 50.0, gamma = 0.01, th0 = 300.0, e0 = 0.25, dt = 0.1;
    sq_grid *g = make_box(ctx, 6, 10, h, false);
    SQ_CHECK(g != NULL);
    fill(g, e0, th0, gamma, h);
    const sq_grid_sgs_desc sd = tke_desc(true);
    SQ_CHECK_OK(sq_grid_diffuse_sgs(g, &sd, dt));
    sq_field_view v = sq_grid_scalar_view(g, 0);
    double worst = 0.0, share = 0.0;
    for (int k = 1; k < 9; k++) {
        const double th = (double)(float)(th0 + gamma * (k + 0.5) * h);
        const double n2 = GRAV * gamma / th, l = 0.76 * sqrt(e0 / n2);
        const double km = CK * l * sqrt(e0), kh = (1.0 + 2.0 * l / h) * km;
        const double eps = (0.19 + 0.51 * l / h) * pow(e0, 1.5) / l;
        const double rate = -kh * n2 - eps;
        const double got = ((double)sq_view_get(&v, 2, 3, k) - e0) / dt;
        const double r = fabs(got / rate - 1.0);
        worst = r > worst ? r : worst;
        share = kh * n2 / -rate;
    }
    printf("de/dt at rest in stable air: worst relative error %.2e (buoyancy %.0f %% of the "
           "loss)\n", worst, 100.0 * share);
    SQ_CHECK(share > 0.15);
    SQ_CHECK(worst < 5e-3);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* In a uniform shear u = S z (restored every step) in neutral air, e settles where shear
 * production balances dissipation: C_k h sqrt(e) S^2 = C_eps e^(3/2) / h, i.e.
 * e = C_k h^2 S^2 / C_eps with C_eps = 0.70 (l = h). The split step's fixed point differs by
 * O(dt) (1.0 % at 1 s, 0.5 % at 0.5 s). From the floor (1e-6) it grows there by itself. */
SQ_TEST(shear_production_balances_dissipation)
{
    sq_context *ctx = make_ctx();
    const double h = 10.0, S = 0.05, dt = 0.5;
    const int n = 6, nz = 24;
    sq_grid *g = make_box(ctx, n, nz, h, true);
    SQ_CHECK(g != NULL);
    fill(g, 0.0, 300.0, 0.0, h);
    const sq_grid_sgs_desc sd = tke_desc(false);
    sq_field3 *u = sq_grid_velocity_field(g, 0);
    for (int s = 0; s < 1600; s++) { /* 800 s: ~10 relaxation times */
        for (int k = 0; k < u->n.nz; k++)
            for (int j = 0; j < u->n.ny; j++)
                for (int i = 0; i < u->n.nx; i++)
                    *sq_field3_at(u, i, j, k) = (float)(S * ((k + 0.5) * h - 0.5 * nz * h));
        sq_grid_apply_boundary(g);
        SQ_CHECK_OK(sq_grid_diffuse_sgs(g, &sd, dt));
    }
    const double expect = CK * h * h * S * S / 0.70;
    sq_field_view v = sq_grid_scalar_view(g, 0);
    double worst = 0.0;
    for (int k = 6; k < nz - 6; k++) {
        const double r = fabs(sq_view_get(&v, 1, 4, k) / expect - 1.0);
        worst = r > worst ? r : worst;
    }
    printf("equilibrium e %.6f (analytic %.6f), worst relative error %.2e over the middle\n",
           (double)sq_view_get(&v, 1, 4, nz / 2), expect, worst);
    SQ_CHECK(worst < 1e-2);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* e is never negative nor NaN: strongly stable air (N^2 = 1.6e-3 1/s^2), a random wind, e from
 * 0 to 10 m^2/s^2 (and a negative value a caller wrote), long steps: after each, every e is
 * finite and at least the floor (1e-6). */
SQ_TEST(tke_stays_non_negative)
{
    sq_context *ctx = make_ctx();
    const double h = 10.0;
    const int n = 8;
    sq_grid *g = make_box(ctx, n, n, h, false);
    SQ_CHECK(g != NULL);
    fill(g, 0.0, 300.0, 0.05, h);
    sq_field3 *e = sq_grid_scalar_field(g, 0);
    uint64_t r = 12345;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                r = r * 6364136223846793005ull + 1442695040888963407ull;
                const double x = (double)(r >> 11) / 9007199254740992.0;
                *sq_field3_at(e, i, j, k) = (float)(x < 0.3 ? 0.0 : 10.0 * x);
            }
    *sq_field3_at(e, 1, 1, 1) = -1.0f;
    for (int c = 0; c < 3; c++) {
        sq_field3 *vf = sq_grid_velocity_field(g, c);
        for (int k = 0; k < vf->n.nz; k++)
            for (int j = 0; j < vf->n.ny; j++)
                for (int i = 0; i < vf->n.nx; i++)
                    *sq_field3_at(vf, i, j, k) = (float)(3.0 * sin(1.7 * i + 0.9 * j + c) *
                                                         cos(1.1 * k - 0.3 * c));
    }
    sq_grid_apply_boundary(g);
    const sq_grid_sgs_desc sd = tke_desc(true);
    int bad = 0;
    double lo = 1e30;
    for (int s = 0; s < 10; s++) {
        SQ_CHECK_OK(sq_grid_diffuse_sgs(g, &sd, 30.0));
        sq_field_view v = sq_grid_scalar_view(g, 0);
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    const double x = sq_view_get(&v, i, j, k);
                    if (!isfinite(x) || x < 1e-6 * (1.0 - 1e-6)) bad++;
                    lo = x < lo ? x : lo;
                }
    }
    printf("bad samples %d, smallest e %g\n", bad, lo);
    SQ_CHECK(bad == 0);
    SQ_CHECK_OK(sq_grid_check_finite(g, 10));
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* e is a scalar of the grid: the scalar advection carries it. A blob of e in a uniform wind
 * through a periodic box, advection alone (the closure's sources are not called): its sum is
 * conserved and its centroid moves with the wind. */
SQ_TEST(tke_is_carried_by_the_advection)
{
    sq_context *ctx = make_ctx();
    const double h = 10.0, U[3] = {2.0, -1.5, 1.0}, dt = 2.0;
    const int n = 32, steps = 12; /* the blob stays 4.5 sigma from the box's faces */
    sq_grid_desc d = {.cells = {n, n, n}, .cell_size_m = h, .scalar_count = 2,
                      .scalar_nonnegative = 1u};
    for (int f = 0; f < 6; f++) d.boundary[f] = SQ_BOUNDARY_PERIODIC;
    sq_grid *g = NULL;
    SQ_CHECK_OK(sq_grid_create(ctx, &d, &g));
    for (int c = 0; c < 3; c++) {
        sq_field3 *vf = sq_grid_velocity_field(g, c);
        for (size_t q = 0; q < vf->count; q++) vf->base[q] = (float)U[c];
    }
    sq_field3 *e = sq_grid_scalar_field(g, 0);
    const double c0 = 0.5 * n * h;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                const double x = (i + 0.5) * h - c0, y = (j + 0.5) * h - c0, z = (k + 0.5) * h - c0;
                *sq_field3_at(e, i, j, k) = (float)(3.0 * exp(-(x * x + y * y + z * z) / (2.0 * 30.0 * 30.0)));
            }
    sq_grid_apply_boundary(g);
    double m[2], cen[2][3];
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1)
            for (int s = 0; s < steps; s++) SQ_CHECK_OK(sq_grid_advect_scalars(g, dt));
        sq_field_view v = sq_grid_scalar_view(g, 0);
        m[pass] = 0.0;
        for (int a = 0; a < 3; a++) cen[pass][a] = 0.0;
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    const double x = sq_view_get(&v, i, j, k);
                    m[pass] += x;
                    cen[pass][0] += x * (i + 0.5) * h;
                    cen[pass][1] += x * (j + 0.5) * h;
                    cen[pass][2] += x * (k + 0.5) * h;
                }
        for (int a = 0; a < 3; a++) cen[pass][a] /= m[pass];
    }
    printf("sum ratio %.7f; centroid moved (%.3f, %.3f, %.3f) m, wind x t = (%g, %g, %g) m\n",
           m[1] / m[0], cen[1][0] - cen[0][0], cen[1][1] - cen[0][1], cen[1][2] - cen[0][2],
           U[0] * steps * dt, U[1] * steps * dt, U[2] * steps * dt);
    SQ_CHECK(fabs(m[1] / m[0] - 1.0) < 1e-3);
    for (int a = 0; a < 3; a++) SQ_CHECK_NEAR(cen[1][a] - cen[0][a], U[a] * steps * dt, 0.05 * h);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

SQ_TEST(tke_bad_input_is_refused)
{
    sq_context *ctx = make_ctx();
    sq_grid *g = make_box(ctx, 4, 4, 10.0, false);
    SQ_CHECK(g != NULL);
    sq_grid_sgs_desc sd = tke_desc(true);
    sd.closure = (sq_grid_sgs_closure)7;
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "closure = 7");
    sd = tke_desc(true);
    sd.tke_idx = 2;
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "tke_idx = 2");
    sd.tke_idx = 1; /* theta */
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "tke_idx = 1");
    sd = tke_desc(true);
    sd.tke_ck = 1.5;
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "tke_ck = 1.5");
    sd = tke_desc(true);
    sd.tke_min_m2ps2 = -1.0;
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "tke_min_m2ps2 = -1");
    sd = tke_desc(true);
    SQ_CHECK_OK(sq_grid_diffuse_sgs(g, &sd, 1.0));
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}
