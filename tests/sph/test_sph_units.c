/* test_sph_units.c — SPH solver units (SPEC §7.2–7.4): kernel normalisation and gradient
 * antisymmetry for every kernel on one support radius, the density self term, the rheology
 * models and their limits, desc defaults and validation messages, the memory refusal, and
 * SQ_ERR_UNSTABLE on a runaway particle. */
#include "sq_test.h"
#include "solvers/sph/sph_internal.h"
#include "squall/sph.h"

SQ_LABEL(unit)

/* ∫ W dV = ∫_0^H W(r) 4π r² dr by composite Simpson in double over float kernel values. */
static double radial_integral(const sq__sph_kern *k, sq__sph_kernel_fn fn)
{
    const int n = 20000;
    const double H = k->H, h = H / n;
    double sum = 0.0;
    for (int i = 0; i <= n; i++) {
        const double r = i * h;
        const double w = (double)sq__sph_kernel_w(k, fn, (float)r);
        const double f = 4.0 * 3.14159265358979323846 * r * r * w;
        sum += f * (i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0));
    }
    return sum * h / 3.0;
}

SQ_TEST(kernel_normalisation)
{
    const float supports[3] = {0.05f, 1.0f, 7.5f};
    for (int s = 0; s < 3; s++) {
        sq__sph_kern k;
        sq__sph_kern_init(&k, supports[s], 0);
        SQ_CHECK_NEAR(radial_integral(&k, SQ__SPH_W_POLY6), 1.0, 1e-4);
        SQ_CHECK_NEAR(radial_integral(&k, SQ__SPH_W_SPIKY), 1.0, 1e-4);
        SQ_CHECK_NEAR(radial_integral(&k, SQ__SPH_W_VISC), 1.0, 1e-4);
        SQ_CHECK_NEAR(radial_integral(&k, SQ__SPH_W_CUBIC), 1.0, 1e-4);
    }
}

/* A 3-D Cartesian quadrature (not radial) of the same integrals: catches a wrong angular
 * factor that the radial sum would hide. */
SQ_TEST(kernel_normalisation_cartesian)
{
    sq__sph_kern k;
    sq__sph_kern_init(&k, 1.0f, 0);
    const int n = 80;
    const double h = 2.0 / n;
    double sp = 0.0, ss = 0.0, sc = 0.0;
    for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++)
            for (int c = 0; c < n; c++) {
                const double x = -1.0 + (a + 0.5) * h, y = -1.0 + (b + 0.5) * h,
                             z = -1.0 + (c + 0.5) * h;
                const float r = (float)sqrt(x * x + y * y + z * z);
                sp += sq__sph_kernel_w(&k, SQ__SPH_W_POLY6, r);
                ss += sq__sph_kernel_w(&k, SQ__SPH_W_SPIKY, r);
                sc += sq__sph_kernel_w(&k, SQ__SPH_W_CUBIC, r);
            }
    SQ_CHECK_NEAR(sp * h * h * h, 1.0, 2e-3);
    SQ_CHECK_NEAR(ss * h * h * h, 1.0, 5e-3);
    SQ_CHECK_NEAR(sc * h * h * h, 1.0, 2e-3);
}

/* One support radius: every kernel is zero at and beyond H and positive just inside; the
 * cubic spline's support equals H (its smoothing length is H/2, SPEC §7.3 ⚠). */
SQ_TEST(kernel_support_is_shared)
{
    sq__sph_kern k;
    sq__sph_kern_init(&k, 0.3f, 0);
    const sq__sph_kernel_fn fns[4] = {SQ__SPH_W_POLY6, SQ__SPH_W_SPIKY, SQ__SPH_W_VISC,
                                      SQ__SPH_W_CUBIC};
    for (int f = 0; f < 4; f++) {
        SQ_CHECK(sq__sph_kernel_w(&k, fns[f], 0.3f) == 0.0f);
        SQ_CHECK(sq__sph_kernel_w(&k, fns[f], 0.31f) == 0.0f);
        SQ_CHECK(sq__sph_kernel_w(&k, fns[f], 0.29f) > 0.0f);
    }
    /* W(0) values: poly6 315/(64π H³), cubic 1/(π ℓ³) with ℓ = H/2 */
    const double H3 = 0.3 * 0.3 * 0.3;
    SQ_CHECK_REL(sq__sph_kernel_w(&k, SQ__SPH_W_POLY6, 0.0f), 315.0 / (64.0 * M_PI * H3), 1e-6);
    SQ_CHECK_REL(sq__sph_kernel_w(&k, SQ__SPH_W_CUBIC, 0.0f), 8.0 / (M_PI * H3), 1e-6);
    /* ∇²W_visc = 45/(π H⁶)(H − r) */
    SQ_CHECK_REL(sq__sph_lap_visc(&k, 0.1f), 45.0 / (M_PI * pow(0.3, 6)) * 0.2, 1e-5);
}

/* ∇W(r) = −∇W(−r), the gradient points toward the centre (W decreasing), and it matches a
 * central finite difference of W. */
SQ_TEST(kernel_gradient_antisymmetry)
{
    sq__sph_kern k;
    sq__sph_kern_init(&k, 1.0f, 0);
    const sq__sph_kernel_fn fns[4] = {SQ__SPH_W_POLY6, SQ__SPH_W_SPIKY, SQ__SPH_W_VISC,
                                      SQ__SPH_W_CUBIC};
    const float pts[4][3] = {{0.3f, 0.1f, -0.2f}, {-0.05f, 0.6f, 0.4f}, {0.7f, 0.0f, 0.0f},
                             {0.2f, -0.3f, 0.55f}};
    for (int f = 0; f < 4; f++)
        for (int p = 0; p < 4; p++) {
            float g1[3], g2[3];
            const float d[3] = {pts[p][0], pts[p][1], pts[p][2]};
            const float m[3] = {-d[0], -d[1], -d[2]};
            sq__sph_kernel_grad(&k, fns[f], d, g1);
            sq__sph_kernel_grad(&k, fns[f], m, g2);
            for (int a = 0; a < 3; a++) SQ_CHECK(g1[a] == -g2[a]);
            SQ_CHECK(g1[0] * d[0] + g1[1] * d[1] + g1[2] * d[2] < 0.0f);
            const float r = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            const float e = 1e-3f;
            const double dw = ((double)sq__sph_kernel_w(&k, fns[f], r + e) -
                               (double)sq__sph_kernel_w(&k, fns[f], r - e)) /
                              (2.0 * e);
            const double gr = (g1[0] * d[0] + g1[1] * d[1] + g1[2] * d[2]) / r;
            SQ_CHECK_REL(gr, dw, 2e-3);
        }
    /* no direction at r = 0: zero, not NaN */
    const float z[3] = {0, 0, 0};
    float g[3];
    sq__sph_kernel_grad(&k, SQ__SPH_W_SPIKY, z, g);
    SQ_CHECK(g[0] == 0.0f && g[1] == 0.0f && g[2] == 0.0f);
}

SQ_TEST(cross_limits_and_bounds)
{
    sq_sph_rheology r;
    SQ_CHECK_OK(sq_sph_rheology_preset("s2-avalanche", &r));
    SQ_CHECK(r.kind == SQ_SPH_RHEOLOGY_CROSS);
    SQ_CHECK(r.mu0_pa_s == 100.0 && r.mu_inf_pa_s == 1.0 && r.n == 2.0 && r.k == 3000.0);
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&r, 0.0), 100.0, 1e-12);
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&r, 1e-9), 100.0, 1e-6);
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&r, 1e6), 1.0, 1e-6);
    /* SPEC §7.9 ⚠: already ≈ 1.1 Pa s at |γ̇| = 0.01 1/s: 1 + 99/(1 + 30²) */
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&r, 0.01), 1.0 + 99.0 / 901.0, 1e-12);
    double prev = 1e300;
    for (double g = 1e-8; g < 1e4; g *= 1.7) {
        const double mu = sq_sph_rheology_viscosity(&r, g);
        SQ_CHECK(mu <= 100.0 && mu >= 1.0);
        SQ_CHECK(mu <= prev); /* shear-thinning: monotone */
        prev = mu;
    }
    /* the float kernel agrees with the double reference */
    sq__sph_rheo rf;
    sq__sph_rheo_init(&rf, &r);
    for (double g = 1e-6; g < 1e2; g *= 3.1)
        SQ_CHECK_REL(sq__sph_rheo_mu(&rf, (float)g), sq_sph_rheology_viscosity(&r, g), 1e-5);
    SQ_CHECK_ERR(sq_sph_rheology_preset("nope", &r), SQ_ERR_NOT_FOUND, "s2-avalanche");
}

SQ_TEST(power_law_and_bingham)
{
    sq_sph_rheology r = {.kind = SQ_SPH_RHEOLOGY_POWER_LAW, .k = 1.5, .n = 0.5};
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&r, 4.0), 1.5 * pow(4.0, -0.5), 1e-12);
    /* floor at the default 1e-3 1/s */
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&r, 0.0), 1.5 * pow(1e-3, -0.5), 1e-12);
    r.mu_max_pa_s = 10.0;
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&r, 1e-6), 10.0, 1e-12);
    sq_sph_rheology b = {.kind = SQ_SPH_RHEOLOGY_BINGHAM, .k = 2.0, .yield_stress_pa = 50.0,
                         .bingham_m_s = 100.0};
    /* μ = K + τ_y (1 − e^{−mγ̇})/γ̇ → K + τ_y m at rest, K + τ_y/γ̇ at high shear */
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&b, 0.0), 2.0 + 50.0 * 100.0, 1e-12);
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&b, 10.0), 2.0 + 50.0 * (1.0 - exp(-1000.0)) / 10.0,
                 1e-12);
    /* the stress K γ̇ + τ_y(1 − e^{−mγ̇}) tends to the Bingham law τ_y + K γ̇ */
    const double g = 3.0;
    SQ_CHECK_REL(sq_sph_rheology_viscosity(&b, g) * g, 50.0 + 2.0 * g, 1e-9);
    sq__sph_rheo bf;
    sq__sph_rheo_init(&bf, &b);
    for (double gg = 1e-7; gg < 1e3; gg *= 2.9)
        SQ_CHECK_REL(sq__sph_rheo_mu(&bf, (float)gg), sq_sph_rheology_viscosity(&b, gg), 1e-4);
    sq_sph_rheology nw = {.kind = SQ_SPH_RHEOLOGY_NEWTONIAN, .mu_pa_s = 0.7};
    SQ_CHECK(sq_sph_rheology_viscosity(&nw, 123.0) == 0.7);
}

static sq_sph_desc base_desc(void)
{
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = 0.1;
    d.domain_max_m[0] = d.domain_max_m[1] = d.domain_max_m[2] = 1.0;
    d.max_particles = 100;
    return d;
}

SQ_TEST(desc_defaults)
{
    sq_sph_desc d = base_desc();
    d.gravity_mps2[2] = -9.81;
    const sq_sph_desc r = sq_sph_desc_resolve(&d);
    SQ_CHECK_NEAR(r.support_radius_m, 0.2, 1e-12);
    SQ_CHECK(r.rest_density_kgm3 == 1000.0);
    SQ_CHECK(r.eos == SQ_SPH_EOS_LINEAR && r.kernel == SQ_SPH_KERNEL_CUBIC);
    SQ_CHECK(r.viscous == SQ_SPH_VISCOUS_MORRIS);
    SQ_CHECK(r.gradient == SQ_SPH_GRADIENT_CORRECTED);
    SQ_CHECK(r.rheology.kind == SQ_SPH_RHEOLOGY_NEWTONIAN && r.rheology.mu_pa_s == 0.0);
    SQ_CHECK(r.xsph_epsilon == 0.5);
    SQ_CHECK_REL(r.max_speed_mps, sqrt(2.0 * 9.81 * 1.0), 1e-12);
    SQ_CHECK_REL(r.speed_of_sound_mps, 10.0 * sqrt(2.0 * 9.81), 1e-12);
    SQ_CHECK_NEAR(r.collision_radius_m, 0.05, 1e-12);
    for (int f = 0; f < 6; f++) SQ_CHECK(r.boundary[f] == SQ_SPH_BOUNDARY_NO_SLIP);
    SQ_CHECK(r.neighbour_capacity >= 64);
    d.xsph_off = true;
    SQ_CHECK(sq_sph_desc_resolve(&d).xsph_epsilon == 0.0);
    SQ_CHECK_OK(sq_sph_desc_validate(&d));
}

SQ_TEST(bad_input_named)
{
    sq_sph_desc d = base_desc();
    d.spacing_m = 0.0;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "spacing_m = 0");
    d.spacing_m = -0.1;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "spacing_m = -0.1");
    d = base_desc();
    d.support_radius_m = -1.0;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "support_radius_m = -1");
    d.support_radius_m = 0.11;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "support_radius_m = 0.11");
    d = base_desc();
    d.rheology.kind = SQ_SPH_RHEOLOGY_CROSS;
    d.rheology.mu0_pa_s = 1.0;
    d.rheology.mu_inf_pa_s = 100.0;
    d.rheology.k = 3000.0;
    d.rheology.n = 2.0;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "mu0_pa_s = 1 < mu_inf_pa_s = 100");
    d.rheology.mu0_pa_s = 200.0;
    d.rheology.n = 0.0;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "rheology.n = 0");
    d = base_desc();
    d.rheology.kind = SQ_SPH_RHEOLOGY_POWER_LAW;
    d.rheology.k = 1.0;
    d.rheology.n = -0.5;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "rheology.n = -0.5");
    d.rheology.n = 0.5;
    d.rheology.k = 0.0;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "rheology.k = 0");
    d = base_desc();
    d.rheology.mu_pa_s = -1.0;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "rheology.mu_pa_s = -1");
    d = base_desc();
    d.boundary[SQ_SPH_FACE_XMIN] = SQ_SPH_BOUNDARY_PERIODIC;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "both faces");
    d.boundary[SQ_SPH_FACE_XMAX] = SQ_SPH_BOUNDARY_PERIODIC;
    d.domain_max_m[0] = 0.5;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "3 x support_radius_m");
    d = base_desc();
    d.domain_max_m[2] = -1.0;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "domain z");
    d = base_desc();
    d.max_particles = 0;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "max_particles = 0");
    d = base_desc();
    d.xsph_epsilon = 1.5;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "xsph_epsilon = 1.5");
    d = base_desc();
    d.artificial_viscosity = -0.1;
    SQ_CHECK_ERR(sq_sph_desc_validate(&d), SQ_ERR_INVALID_ARG, "artificial_viscosity");
}

static int log_errors;
static void count_log(void *user, sq_log_level level, const char *module, const char *msg)
{
    (void)user;
    (void)module;
    (void)msg;
    if (level == SQ_LOG_ERROR) log_errors++;
}

/* More particles than memory allows: refused before allocating, naming count and bytes. */
SQ_TEST(memory_refused_before_allocating)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1, .memory_limit_bytes = 64u << 20, .log = count_log};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_sph_desc d = base_desc();
    d.max_particles = 10000000;
    const uint64_t need = sq_sph_memory_bytes(&d, d.max_particles);
    SQ_CHECK(need > (64u << 20));
    SQ_CHECK(sq_sph_memory_bytes(&d, 2000) > sq_sph_memory_bytes(&d, 1000));
    /* per particle: at least the state arrays and a neighbour list */
    SQ_CHECK(sq_sph_memory_bytes(&d, 2000) - sq_sph_memory_bytes(&d, 1000) >= 1000u * 300u);
    char needle[64];
    snprintf(needle, sizeof needle, "sph with 10000000 particles (%llu bytes)",
             (unsigned long long)need);
    sq_sph *s = (sq_sph *)1;
    const uint64_t before = sq_context_bytes_in_use(ctx);
    log_errors = 0;
    SQ_CHECK_ERR(sq_sph_create(ctx, &d, &s), SQ_ERR_TOO_LARGE, needle);
    SQ_CHECK(s == NULL);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == before);
    SQ_CHECK(sq_context_bytes_peak(ctx) == before); /* nothing was allocated */
    SQ_CHECK(log_errors == 1);
    /* the implementation limit on indices */
    d.max_particles = (size_t)1 << 30;
    SQ_CHECK_ERR(sq_sph_create(ctx, &d, &s), SQ_ERR_TOO_LARGE, "max_particles = 1073741824");
    /* adding beyond the capacity */
    d = base_desc();
    d.max_particles = 10;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    const double lo[3] = {0, 0, 0}, hi[3] = {0.3, 0.3, 0.3};
    SQ_CHECK_ERR(sq_sph_add_block(s, lo, hi, NULL, NULL), SQ_ERR_TOO_LARGE,
                 "3x3x3 = 27 particles added to 0 exceeds max_particles = 10");
    const float outside[3] = {0.5f, 0.5f, 1.5f};
    SQ_CHECK_ERR(sq_sph_add_particles(s, 1, outside, NULL), SQ_ERR_INVALID_ARG,
                 "positions_m[0].z = 1.5 is outside the domain");
    sq_sph_destroy(s);
    sq_sph_destroy(NULL);
    sq_context_destroy(ctx);
}

/* SPEC §7.2 ⚠ 1: an isolated particle has ρ = m W(0), not 0. */
SQ_TEST(density_self_term)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    for (int kern = SQ_SPH_KERNEL_MULLER; kern <= SQ_SPH_KERNEL_CUBIC; kern++) {
        sq_sph_desc d = base_desc();
        d.kernel = (sq_sph_kernel)kern;
        sq_sph *s = NULL;
        SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
        const float p[6] = {0.5f, 0.5f, 0.5f, 0.1f, 0.1f, 0.9f}; /* far apart */
        SQ_CHECK_OK(sq_sph_add_particles(s, 2, p, NULL));
        SQ_CHECK(sq_sph_max_stable_dt(s) > 0.0);
        const sq_sph_view v = sq_sph_particles(s);
        const sq_sph_info in = sq_sph_get_info(s);
        SQ_CHECK(v.count == 2);
        sq__sph_kern k;
        sq__sph_kern_init(&k, 0.2f, kern == SQ_SPH_KERNEL_CUBIC);
        const double w0 = sq__sph_kernel_w(&k, kern == SQ_SPH_KERNEL_CUBIC ? SQ__SPH_W_CUBIC
                                                                           : SQ__SPH_W_POLY6,
                                           0.0f);
        for (size_t i = 0; i < v.count; i++) {
            SQ_CHECK_REL(v.density[i], in.particle_mass_kg * w0, 1e-5);
            SQ_CHECK(v.pressure[i] == 0.0f); /* below ρ₀: clamped */
        }
        /* the mass puts a cubic lattice at ρ₀ */
        SQ_CHECK_REL(in.particle_mass_kg, 1000.0 * 0.001, 0.02);
        sq_sph_destroy(s);
    }
    sq_context_destroy(ctx);
}

/* A runaway particle (faster than 3 c_s) is SQ_ERR_UNSTABLE naming step, particle, id. */
SQ_TEST(instability_reported)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1};
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_sph_desc d = base_desc();
    d.speed_of_sound_mps = 10.0;
    d.boundary[SQ_SPH_FACE_ZMAX] = SQ_SPH_BOUNDARY_OPEN;
    sq_sph *s = NULL;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    const float p[6] = {0.5f, 0.5f, 0.5f, 0.2f, 0.2f, 0.2f};
    const float v[6] = {0, 0, 0, 0, 0, 40.0f};
    SQ_CHECK_OK(sq_sph_add_particles(s, 2, p, v));
    SQ_CHECK_ERR(sq_sph_step(s, 1e-3), SQ_ERR_UNSTABLE, "particle");
    SQ_CHECK(strstr(sq_last_error(), "step 0") != NULL);
    SQ_CHECK(strstr(sq_last_error(), "(id 1)") != NULL);
    SQ_CHECK(strstr(sq_last_error(), "runs away") != NULL);
    sq_sph_destroy(s);
    /* a frame that would need more than max_substeps */
    d = base_desc();
    d.max_substeps = 3;
    SQ_CHECK_OK(sq_sph_create(ctx, &d, &s));
    SQ_CHECK_OK(sq_sph_add_particles(s, 1, p, NULL));
    SQ_CHECK_ERR(sq_sph_step(s, 10.0), SQ_ERR_UNSTABLE, "max_substeps = 3");
    SQ_CHECK_ERR(sq_sph_step(s, -1.0), SQ_ERR_INVALID_ARG, "dt_frame_s = -1");
    sq_sph_destroy(s);
    sq_context_destroy(ctx);
}
