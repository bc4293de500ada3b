/* test_sph_units.c — SPH solver units (SPEC §7.2–7.4): the density self term, desc defaults and
 * validation messages, the memory refusal, and SQ_ERR_UNSTABLE on a runaway particle (kernel
 * and rheology checks: test_sph_kernels.c). */
#include "sq_test.h"
#include "solvers/sph/sph_internal.h"
#include "squall/sph.h"

SQ_LABEL(unit)

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
