/* test_grid_sgs.c — the Smagorinsky–Lilly subgrid closure (grid_sgs.c, SPEC §1.5) against
 * analytic solutions: a Gaussian puff in a uniform shear spreads as the exact solution of
 * diffusion with K = (C_s h)^2 S / Pr_t; the closure vanishes in uniform flow and above the
 * critical Richardson number and follows Lilly's sqrt(1 - Ri/Pr_t) between; the wall stress
 * is the log law's; scalar mass is conserved and no new extrema appear. */
#include "sq_test.h"
#include "squall/grid.h"

SQ_LABEL(physics)

#define PI 3.14159265358979323846

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1};
    if (sq_context_create(&cd, &ctx) != SQ_OK) return NULL;
    return ctx;
}

static sq_grid *make_grid(sq_context *ctx, sq_grid_desc *d)
{
    sq_grid *g = NULL;
    if (sq_grid_create(ctx, d, &g) != SQ_OK) fprintf(stderr, "sq_grid_create: %s\n", sq_last_error());
    return g;
}

/* u = shear (z - zc) on every x face */
static void set_shear(sq_grid *g, double shear, double h, double zc)
{
    sq_field3 *u = sq_grid_velocity_field(g, 0);
    for (int k = 0; k < u->n.nz; k++)
        for (int j = 0; j < u->n.ny; j++)
            for (int i = 0; i < u->n.nx; i++)
                *sq_field3_at(u, i, j, k) = (float)(shear * ((k + 0.5) * h - zc));
    sq_grid_apply_boundary(g);
}

/* A Gaussian puff (sigma0 30 m) in the uniform shear u = S z (restored every step, so nu_t is
 * uniform away from the domain's ends): nu_t = (C_s h)^2 S exactly (|S| = du/dz), K = nu_t /
 * Pr_t, and the exact solution is a Gaussian with sigma^2 = sigma0^2 + 2 K t along each axis
 * and the peak M / ((2 pi)^3/2 sigma^3). The conservative three-point operator reproduces the
 * variance growth 2 K t exactly (moment identity), the profile to the scheme's truncation
 * error (second order: ~(h / sigma)^2 / 12). */
SQ_TEST(gaussian_puff_spreads_with_the_smagorinsky_diffusivity)
{
    sq_context *ctx = make_ctx();
    const int n = 32, nz = 48;
    const double h = 10.0, dt = 10.0, S = 0.05, cs = 0.18, pr = 0.74, s0 = 30.0;
    sq_grid_desc d = {.cells = {n, n, nz}, .cell_size_m = h, .scalar_count = 1};
    for (int f = 0; f < 4; f++) d.boundary[f] = SQ_BOUNDARY_PERIODIC;
    d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_OPEN; /* no ground: l = C_s h everywhere */
    d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
    sq_grid *g = make_grid(ctx, &d);
    SQ_CHECK(g != NULL);
    sq_field3 *c = sq_grid_scalar_field(g, 0);
    const double xc = 0.5 * n * h, zc = 0.5 * nz * h;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                const double x = (i + 0.5) * h - xc, y = (j + 0.5) * h - xc, z = (k + 0.5) * h - zc;
                *sq_field3_at(c, i, j, k) = (float)exp(-0.5 * (x * x + y * y + z * z) / (s0 * s0));
            }
    double m0 = 0.0;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) m0 += *sq_field3_at(c, i, j, k);
    const sq_grid_sgs_desc sd = {.smagorinsky_c = cs, .prandtl_t = pr};
    const int steps = 100;
    for (int t = 0; t < steps; t++) {
        set_shear(g, S, h, zc);
        SQ_CHECK_OK(sq_grid_diffuse_sgs(g, &sd, dt));
    }
    const double t_s = steps * dt, K = cs * h * cs * h * S / pr;
    const double s2 = s0 * s0 + 2.0 * K * t_s;
    /* the exact solution's amplitude, from the discrete mass: M h^3 / ((2 pi)^3/2 sigma^3) */
    const double amp = m0 * h * h * h / (pow(2.0 * PI, 1.5) * pow(s2, 1.5));
    double m = 0.0, var[3] = {0, 0, 0}, e2 = 0.0, a2 = 0.0;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                const double a = *sq_field3_at(c, i, j, k);
                const double x = (i + 0.5) * h - xc, y = (j + 0.5) * h - xc, z = (k + 0.5) * h - zc;
                const double ex = amp * exp(-0.5 * (x * x + y * y + z * z) / s2);
                m += a;
                var[0] += a * x * x;
                var[1] += a * y * y;
                var[2] += a * z * z;
                e2 += (a - ex) * (a - ex);
                a2 += ex * ex;
            }
    /* the discrete initial variance is s0^2 to ~1e-6 (a well-resolved Gaussian) */
    for (int a = 0; a < 3; a++) {
        const double km = (var[a] / m - s0 * s0) / (2.0 * t_s);
        printf("axis %d: K = %.5f m2/s, analytic (C_s h)^2 S / Pr_t = %.5f\n", a, km, K);
        SQ_CHECK_REL(km, K, 0.01);
    }
    printf("profile vs the exact solution: relative L2 error %.5f; mass ratio %.8f\n",
           sqrt(e2 / a2), m / m0);
    SQ_CHECK(sqrt(e2 / a2) < 0.01);
    SQ_CHECK(fabs(m / m0 - 1.0) < 1e-5);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* nu_t of one uniform shear S with a potential-temperature gradient dth/dz (no ground) at the
 * centre cell. */
static double nu_centre(double S, double dthdz, double u0)
{
    sq_context *ctx = make_ctx();
    const int n = 8;
    const double h = 10.0, zc = 40.0, th0 = 300.0;
    sq_grid_desc d = {.cells = {n, n, n}, .cell_size_m = h, .scalar_count = 1};
    for (int f = 0; f < 4; f++) d.boundary[f] = SQ_BOUNDARY_PERIODIC;
    d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_OPEN;
    d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
    sq_grid *g = make_grid(ctx, &d);
    sq_field3 *th = sq_grid_scalar_field(g, 0);
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++)
                *sq_field3_at(th, i, j, k) = (float)(th0 + dthdz * ((k + 0.5) * h - zc));
    set_shear(g, S, h, zc);
    sq_field3 *u = sq_grid_velocity_field(g, 0);
    for (size_t q = 0; q < u->count; q++) u->base[q] += (float)u0;
    sq_grid_apply_boundary(g);
    const sq_grid_sgs_desc sd = {.stratified = true, .theta_idx = 0, .gravity_mps2 = 9.81};
    float nu[8 * 8 * 8];
    SQ_CHECK_OK(sq_grid_sgs_viscosity(g, &sd, nu));
    const double v = nu[(4 * n + 4) * n + 4];
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
    return v;
}

/* The closure vanishes where nothing is to be mixed: uniform flow (any speed), uniform flow in
 * stable air, and shear above the critical Richardson number Ri = Pr_t; between, Lilly's
 * nu_t = (C_s h)^2 S sqrt(1 - Ri/Pr_t); statically unstable air mixes without shear (free
 * convection, (C_s h)^2 sqrt(-N^2/Pr_t)). And a diffusion step of uniform flow changes
 * nothing, bit for bit. */
SQ_TEST(closure_vanishes_in_uniform_flow_and_stable_air)
{
    const double S = 0.05, l = 0.18 * 10.0, pr = 0.74, g = 9.81, th0 = 300.0;
    const double uniform = nu_centre(0.0, 0.0, 12.0);
    const double stable_uniform = nu_centre(0.0, 0.01, 12.0);
    const double neutral = nu_centre(S, 0.0, 0.0);
    const double half = nu_centre(S, 0.5 * pr * S * S * th0 / g, 0.0);
    const double over = nu_centre(S, 2.0 * pr * S * S * th0 / g, 0.0);
    const double convective = nu_centre(0.0, -pr * S * S * th0 / g, 0.0);
    printf("uniform %g, stable uniform %g, neutral shear %.6f (analytic %.6f), Ri = Pr_t/2 "
           "%.6f (analytic %.6f), Ri = 2 Pr_t %g, free convection %.6f (analytic %.6f)\n",
           uniform, stable_uniform, neutral, l * l * S, half, l * l * S * sqrt(0.5), over,
           convective, l * l * S);
    SQ_CHECK(uniform == 0.0);
    SQ_CHECK(stable_uniform == 0.0);
    SQ_CHECK(over == 0.0);
    SQ_CHECK_REL(neutral, l * l * S, 1e-5);
    /* theta is a float near 300 K: N^2 to ~1e-5 relative at these gradients */
    SQ_CHECK_REL(half, l * l * S * sqrt(0.5), 2e-3);
    SQ_CHECK_REL(convective, l * l * S, 2e-3);

    /* uniform flow through a domain with a ground, an inflow and solids: unchanged bit for bit */
    sq_context *ctx = make_ctx();
    sq_grid_desc d = {.cells = {16, 8, 8}, .cell_size_m = 10.0, .scalar_count = 1};
    d.boundary[SQ_FACE_XMIN] = SQ_BOUNDARY_PERIODIC;
    d.boundary[SQ_FACE_XMAX] = SQ_BOUNDARY_PERIODIC;
    d.boundary[SQ_FACE_YMIN] = SQ_BOUNDARY_FREE_SLIP;
    d.boundary[SQ_FACE_YMAX] = SQ_BOUNDARY_FREE_SLIP;
    d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_FREE_SLIP;
    d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
    sq_grid *gr = make_grid(ctx, &d);
    sq_field3 *u = sq_grid_velocity_field(gr, 0), *t = sq_grid_scalar_field(gr, 0);
    for (size_t q = 0; q < u->count; q++) u->base[q] = 7.25f;
    for (size_t q = 0; q < t->count; q++) t->base[q] = 301.3f;
    sq_grid_apply_boundary(gr);
    const sq_grid_sgs_desc sd = {.stratified = true, .theta_idx = 0, .gravity_mps2 = 9.81,
                                 .roughness_m = 0.0};
    for (int s = 0; s < 5; s++) SQ_CHECK_OK(sq_grid_diffuse_sgs(gr, &sd, 2.0));
    int changed = 0;
    for (int k = 0; k < 8; k++)
        for (int j = 0; j < 8; j++)
            for (int i = 0; i < 16; i++)
                changed += *sq_field3_at(u, i, j, k) != 7.25f || *sq_field3_at(t, i, j, k) != 301.3f;
    printf("uniform flow: %d samples changed\n", changed);
    SQ_CHECK(changed == 0);
    sq_grid_destroy(gr);
    sq_context_destroy(ctx);
}

/* The ground's stress is the log law's: uniform wind U over a no-slip ground; one step changes
 * only the first layer, by the implicit drag u / (1 + dt C_d U / h), C_d = (kappa /
 * ln(z1/z0))^2, z1 = h/2, i.e. a surface stress u*^2 = (kappa U / ln(z1/z0))^2 for a short
 * step; the layers above keep U (no shear: nu_t = 0). */
SQ_TEST(wall_stress_is_the_log_law)
{
    sq_context *ctx = make_ctx();
    const double h = 40.0, z0 = 5e-4, U = 15.0, dt = 0.5, kappa = 0.4;
    sq_grid_desc d = {.cells = {8, 8, 8}, .cell_size_m = h};
    for (int f = 0; f < 4; f++) d.boundary[f] = SQ_BOUNDARY_PERIODIC;
    d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_NO_SLIP;
    d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
    sq_grid *g = make_grid(ctx, &d);
    sq_field3 *u = sq_grid_velocity_field(g, 0);
    for (size_t q = 0; q < u->count; q++) u->base[q] = (float)U;
    sq_grid_apply_boundary(g);
    const sq_grid_sgs_desc sd = {.roughness_m = z0};
    SQ_CHECK_OK(sq_grid_diffuse_sgs(g, &sd, dt));
    const double cd = pow(kappa / log(0.5 * h / z0), 2.0);
    const double expect = U / (1.0 + dt * cd * U / h);
    const double u0 = *sq_field3_at(u, 3, 3, 0), u1 = *sq_field3_at(u, 3, 3, 1);
    const double ustar2 = (U - u0) * h / dt, ustar_law = kappa * U / log(0.5 * h / z0);
    printf("first layer %.7f (implicit log-law drag %.7f), above %.7f; u*^2 %.5f vs log law "
           "%.5f\n", u0, expect, u1, ustar2, ustar_law * ustar_law);
    SQ_CHECK_REL(u0, expect, 1e-6);
    SQ_CHECK(u1 == (float)U);
    SQ_CHECK_REL(ustar2, ustar_law * ustar_law, 2e-3);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* In a swirling flow over a ground with a solid block, the scalar's sum is conserved (no flux
 * through the ground, the solid or the domain's faces) and no new extrema appear (every update
 * is a convex combination). */
SQ_TEST(scalar_mass_conserved_and_bounded)
{
    sq_context *ctx = make_ctx();
    const int n = 16;
    const double h = 20.0;
    sq_grid_desc d = {.cells = {n, n, n}, .cell_size_m = h, .scalar_count = 1};
    d.boundary[SQ_FACE_XMIN] = SQ_BOUNDARY_INFLOW;
    d.boundary[SQ_FACE_XMAX] = SQ_BOUNDARY_OUTFLOW;
    d.boundary[SQ_FACE_YMIN] = SQ_BOUNDARY_OPEN;
    d.boundary[SQ_FACE_YMAX] = SQ_BOUNDARY_OPEN;
    d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_NO_SLIP;
    d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
    sq_grid *g = make_grid(ctx, &d);
    uint8_t solid[16 * 16 * 16] = {0};
    for (int k = 0; k < 4; k++)
        for (int j = 6; j < 10; j++)
            for (int i = 6; i < 10; i++) solid[(k * n + j) * n + i] = 1;
    SQ_CHECK_OK(sq_grid_set_solid_mask(g, solid));
    for (int c = 0; c < 3; c++) {
        sq_field3 *v = sq_grid_velocity_field(g, c);
        for (int k = 0; k < v->n.nz; k++)
            for (int j = 0; j < v->n.ny; j++)
                for (int i = 0; i < v->n.nx; i++)
                    *sq_field3_at(v, i, j, k) =
                        (float)(8.0 * sin(0.7 * i + 1.3 * c) * cos(0.5 * j - 0.4 * k + c) +
                                (c == 0 ? 0.8 * k : 0.0));
    }
    sq_grid_apply_boundary(g);
    sq_field3 *s = sq_grid_scalar_field(g, 0);
    double m0 = 0.0, hi0 = 0.0;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                const float a = solid[(k * n + j) * n + i] ? 0.0f
                                : (float)(((i * 7 + j * 3 + k * 5) % 11) * 0.1);
                *sq_field3_at(s, i, j, k) = a;
                m0 += a;
                hi0 = a > hi0 ? a : hi0;
            }
    const sq_grid_sgs_desc sd = {.roughness_m = 0.01, .smagorinsky_c = 0.3};
    for (int t = 0; t < 20; t++) SQ_CHECK_OK(sq_grid_diffuse_sgs(g, &sd, 2.0));
    double m1 = 0.0, lo = 1e30, hi = -1e30;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                if (solid[(k * n + j) * n + i]) continue;
                const double a = *sq_field3_at(s, i, j, k);
                m1 += a;
                lo = a < lo ? a : lo;
                hi = a > hi ? a : hi;
            }
    sq_grid_stats st;
    sq_grid_get_stats(g, &st);
    printf("mass ratio %.9f, range [%g, %g] (was [0, %g]); last diffusion number %.4f\n",
           m1 / m0, lo, hi, hi0, st.last_diffusion_number);
    SQ_CHECK(st.last_diffusion_number > 1e-3); /* it did mix */
    SQ_CHECK(fabs(m1 / m0 - 1.0) < 1e-6);
    SQ_CHECK(lo >= 0.0 && hi <= hi0);
    SQ_CHECK(hi < hi0 - 0.05); /* and the peaks were smoothed */
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

SQ_TEST(bad_input_is_refused)
{
    sq_context *ctx = make_ctx();
    sq_grid_desc d = {.cells = {4, 4, 4}, .cell_size_m = 10.0, .scalar_count = 1};
    sq_grid *g = make_grid(ctx, &d);
    sq_grid_sgs_desc sd = {.smagorinsky_c = 1.5};
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "smagorinsky_c = 1.5");
    sd = (sq_grid_sgs_desc){.prandtl_t = 20.0};
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "prandtl_t = 20");
    sd = (sq_grid_sgs_desc){.roughness_m = 6.0};
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "roughness_m = 6");
    sd = (sq_grid_sgs_desc){.stratified = true, .theta_idx = 1, .gravity_mps2 = 9.81};
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "theta_idx = 1");
    sd = (sq_grid_sgs_desc){.stratified = true, .theta_idx = 0};
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, &sd, 1.0), SQ_ERR_INVALID_ARG, "gravity_mps2 = 0");
    SQ_CHECK_ERR(sq_grid_diffuse_sgs(g, NULL, -1.0), SQ_ERR_INVALID_ARG, "dt = -1");
    SQ_CHECK_OK(sq_grid_diffuse_sgs(g, NULL, 1.0));
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
}

/* The mixing-length closure with sq_grid_desc.wall_roughness_m: the ground's stress is the same
 * log law (the layer above keeps U: no shear), where S0's no-slip wall half a cell below takes
 * (kappa U)^2, ln(z1/z0)^2 times more. */
SQ_TEST(mixing_length_ground_stress_is_the_log_law)
{
    sq_context *ctx = make_ctx();
    const double h = 40.0, z0 = 5e-4, U = 15.0, dt = 0.5, kappa = 0.4;
    double first[2];
    for (int c = 0; c < 2; c++) {
        sq_grid_desc d = {.cells = {8, 8, 8}, .cell_size_m = h, .wall_roughness_m = c ? z0 : 0.0,
                          .mixing_length_max_m = 100.0};
        for (int f = 0; f < 4; f++) d.boundary[f] = SQ_BOUNDARY_PERIODIC;
        d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_NO_SLIP;
        d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
        sq_grid *g = make_grid(ctx, &d);
        sq_field3 *u = sq_grid_velocity_field(g, 0);
        for (size_t q = 0; q < u->count; q++) u->base[q] = (float)U;
        sq_grid_apply_boundary(g);
        SQ_CHECK_OK(sq_grid_diffuse_eddy(g, 0.0, kappa, dt));
        first[c] = *sq_field3_at(u, 3, 3, 0);
        if (c) SQ_CHECK_REL(*sq_field3_at(u, 3, 3, 2), U, 1e-6);
        sq_grid_destroy(g);
    }
    const double ln = log(0.5 * h / z0), expect = U / (1.0 + dt * pow(kappa / ln, 2.0) * U / h);
    const double us_law = (U - first[1]) * h / dt, us_noslip = (U - first[0]) * h / dt;
    printf("first layer: log law %.7f (expected %.7f), no-slip %.5f; stress %.4f vs %.3f "
           "(ratio %.0f, ln(z1/z0)^2 = %.0f)\n", first[1], expect, first[0], us_law, us_noslip,
           us_noslip / us_law, ln * ln);
    SQ_CHECK_REL(first[1], expect, 1e-5);
    SQ_CHECK(us_noslip > 30.0 * us_law);
    sq_context_destroy(ctx);
}
