/* test_clouds_light.c — the CPU side of the cloud pass (SPEC 8.4–8.5): the splat falloff with
 * the SPEC's |t| and clamp, the Harris multiple-forward-scattering sweep (processing order by
 * distance from the sun, the recursion I_k = g_{k-1} + T_{k-1} I_{k-1} with the causal index,
 * self-shadowing, independence of the input order, the splat's conserved cross-section, the
 * shadow map) and the impostor cross-fade weight. */
#include "render/clouds_light.h"
#include "sq_test.h"
#include "squall/rng.h"

SQ_LABEL(unit)

static sq_context *ctx_new(void)
{
    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

static sq_clouds_view view_default(void)
{
    sq_clouds_view v;
    memset(&v, 0, sizeof v);
    v.g_default = 0.85f;
    v.albedo = 0.9f;
    v.eta1 = 0.4f;
    v.tau_splat = 80.0f;
    v.gamma_sr = 0.09f;
    v.light_buffer = 256;
    return v;
}

/* eta(t)/eta_1 = 2|t|³ - 3t² + 1: 1 at the centre, 0 at the rim, 1/2 at t = 1/2, symmetric in t
 * (S4's cubic gives -4 eta_1 at t = -1), 0 beyond the rim, monotone decreasing in |t|. */
SQ_TEST(splat_falloff)
{
    SQ_CHECK(sq__cloud_splat(0.0f) == 1.0f);
    SQ_CHECK_NEAR(sq__cloud_splat(1.0f), 0.0f, 1e-7);
    SQ_CHECK_NEAR(sq__cloud_splat(0.5f), 0.5f, 1e-7);
    SQ_CHECK_NEAR(sq__cloud_splat(0.25f), 2 * 0.015625 - 3 * 0.0625 + 1, 1e-7);
    for (int i = 0; i <= 100; i++) {
        const float t = (float)i / 100.0f;
        SQ_CHECK(sq__cloud_splat(-t) == sq__cloud_splat(t));
        SQ_CHECK(sq__cloud_splat(t) >= 0.0f);
        if (i > 0) SQ_CHECK(sq__cloud_splat(t) <= sq__cloud_splat(t - 0.01f));
    }
    SQ_CHECK(sq__cloud_splat(-1.0f) == 0.0f);
    SQ_CHECK(sq__cloud_splat(1.5f) == 0.0f && sq__cloud_splat(-7.0f) == 0.0f);
    SQ_CHECK(sq__cloud_splat(NAN) == 0.0f);
    /* opacities: S4's splat alpha peaks at (1 - e^-80) eta_1 = 0.4 (not e^-80: never opaque);
     * the physical opacity is 1 - e^-tau at the centre */
    sq_clouds_view v = view_default();
    v.splat_opacity = true;
    SQ_CHECK_NEAR(sq__cloud_alpha(&v, 5.0f, 0.0f), 0.4f, 1e-6);
    SQ_CHECK_NEAR(sq__cloud_alpha(&v, 5.0f, 0.5f), 0.2f, 1e-6);
    v.splat_opacity = false;
    SQ_CHECK_NEAR(sq__cloud_alpha(&v, 2.0f, 0.0f), 1.0f - expf(-2.0f), 1e-6);
    SQ_CHECK_NEAR(sq__cloud_alpha(&v, 2.0f, 0.5f), 1.0f - expf(-1.0f), 1e-6);
    SQ_CHECK(sq__cloud_alpha(&v, 2.0f, 1.2f) == 0.0f);
}

/* Phase: HG normalised, forward peak (1+g)/(4 pi (1-g)^2); Rayleigh 3/(8 pi) forward; the
 * forward fraction F = p(0) gamma is Harris's a tau p gamma / 4 pi factor (1.5 x 0.09 / 4 pi for
 * Rayleigh normalised to 4 pi), capped at 1. */
SQ_TEST(phase_and_forward_fraction)
{
    sq_clouds_view v = view_default();
    double s = 0;
    for (int i = 0; i < 20000; i++) {
        const float mu = -1.0f + ((float)i + 0.5f) * 2.0f / 20000.0f;
        s += (double)sq__cloud_phase(&v, 0.85f, mu) * 2.0 * 3.14159265358979 * (2.0 / 20000.0);
    }
    SQ_CHECK_NEAR(s, 1.0, 2e-3);
    SQ_CHECK_REL(sq__cloud_phase(&v, 0.85f, 1.0f), 1.85 / (4 * 3.14159265 * 0.0225), 1e-4);
    SQ_CHECK_REL(sq__cloud_forward_fraction(&v, 0.85f), 1.85 / (4 * 3.14159265 * 0.0225) * 0.09,
                 1e-4);
    v.rayleigh = true;
    SQ_CHECK_REL(sq__cloud_forward_fraction(&v, 0.85f), 1.5 * 0.09 / (4 * 3.14159265), 1e-5);
    v.rayleigh = false;
    v.gamma_sr = 1.0f;
    SQ_CHECK(sq__cloud_forward_fraction(&v, 0.85f) == 1.0f);
}

/* A column of particles along the sun's rays, given in scrambled order: the sweep processes them
 * by distance from the sun, and the light at the centres follows eq. (4) with the causal index,
 * I_1 = 1, I_k = g_{k-1} + T_{k-1} I_{k-1}, g = a alpha F I, T = 1 - alpha. The printed
 * g_{k+1} would need a particle not yet reached; its values differ by more than 10 %. Radii of
 * 100 texels make the splat flat at the centre (eta = 1 - 3t², t < 0.01). */
SQ_TEST(mfs_recursion_causal_index)
{
    sq_context *ctx = ctx_new();
    const int n = 6;
    const float tau[6] = {0.3f, 2.0f, 0.1f, 1.2f, 0.6f, 3.0f}; /* by distance from the sun */
    const int slot[6] = {3, 0, 5, 1, 4, 2};                    /* input index of each */
    float pos[18], rad[6], tt[6];
    const sq_vec3 sun = sq_v3_norm(sq_v3(0.3f, -0.2f, 0.9f));
    for (int k = 0; k < n; k++) {
        const int i = slot[k];
        const float d = 1000.0f - 150.0f * (float)k; /* k = 0 nearest the sun */
        pos[3 * i + 0] = sun.x * d;
        pos[3 * i + 1] = sun.y * d;
        pos[3 * i + 2] = sun.z * d;
        rad[i] = 100.0f;
        tt[i] = tau[k];
    }
    sq_clouds_view v = view_default();
    v.count = n;
    v.position = pos;
    v.radius_m = rad;
    v.tau = tt;
    v.light_buffer = 200; /* 200 m extent: 1 m texels, radius = 100 texels */
    v.light_texels_per_radius = 100.0f;
    sq__cloud_light L;
    memset(&L, 0, sizeof L);
    SQ_CHECK_OK(sq__cloud_light_compute(ctx, &L, &v, sun));
    const float F = sq__cloud_forward_fraction(&v, 0.85f);
    float I = 1.0f, wrong = 1.0f;
    for (int k = 0; k < n; k++) {
        const int i = slot[k];
        SQ_CHECK_MSG(fabsf(L.sun[i] - I) <= 2e-3f * I + 1e-6f, "particle %d: I = %.6f, eq. 4 %.6f",
                     k, (double)L.sun[i], (double)I);
        const float a = 1.0f - expf(-tau[k]);
        const float g = v.albedo * a * F * I;
        if (k > 0) SQ_CHECK(fabsf(L.sun[i] - wrong) > 0.1f * wrong);
        const float an = k + 1 < n ? 1.0f - expf(-tau[k + 1]) : 0.0f; /* S4's g_{k+1} */
        wrong = v.albedo * an * F * I + (1.0f - a) * I;
        I = g + (1.0f - a) * I;
    }
    SQ_CHECK(L.sun[slot[n - 1]] < 0.3f);
    sq__cloud_light_free(ctx, &L);
    sq_context_destroy(ctx);
}

/* Self-shadowing: of two overlapping particles the one farther from the sun gets less light, a
 * particle off to the side gets all of it; the Beer transmittance is below the MFS light (the
 * forward in-scatter refills the beam). The shadow map is darkest under the pair. */
SQ_TEST(mfs_self_shadowing)
{
    sq_context *ctx = ctx_new();
    float pos[9] = {0, 0, 500, 0, 0, 300, 2000, 0, 300};
    float rad[3] = {150, 150, 150}, tt[3] = {3, 3, 3};
    sq_clouds_view v = view_default();
    v.count = 3;
    v.position = pos;
    v.radius_m = rad;
    v.tau = tt;
    v.multiple_scattering = true;
    v.light_texels_per_radius = 40.0f; /* fine texels: centre values against the analytic ones */
    sq__cloud_light L;
    memset(&L, 0, sizeof L);
    SQ_CHECK_OK(sq__cloud_light_compute(ctx, &L, &v, sq_v3(0, 0, 1)));
    SQ_CHECK_NEAR(L.sun[0], 1.0f, 1e-5);
    SQ_CHECK_NEAR(L.sun[2], 1.0f, 1e-5);
    /* I = 1 - (1 - a F) (1 - e^-3): the beam loses what is scattered out of the forward cone */
    const float F = sq__cloud_forward_fraction(&v, 0.85f), a = 1.0f - expf(-3.0f);
    const float I1 = 1.0f - (1.0f - v.albedo * F) * a;
    SQ_CHECK_NEAR(L.sun[1], I1, 0.01);
    SQ_CHECK(L.direct[1] < L.sun[1]);
    SQ_CHECK_NEAR(L.direct[1], expf(-3.0f), 0.01);
    SQ_CHECK(L.diffuse[0] > L.diffuse[1] && L.diffuse[1] > 0.0f); /* lit face brighter */
    SQ_CHECK(L.sky[1] < L.sky[0]);
    /* shadow map below particle 1 vs beside everything */
    const float *m = L.shadow_matrix.m;
    const float p_under[3] = {0, 0, 0}, p_clear[3] = {1000, 0, 0};
    float su[2], sc[2];
    for (int c = 0; c < 2; c++) {
        su[c] = m[c] * p_under[0] + m[4 + c] * p_under[1] + m[8 + c] * p_under[2] + m[12 + c];
        sc[c] = m[c] * p_clear[0] + m[4 + c] * p_clear[1] + m[8 + c] * p_clear[2] + m[12 + c];
    }
    const int xu = (int)(su[0] * L.nx), yu = (int)(su[1] * L.ny);
    const int xc = (int)(sc[0] * L.nx), yc = (int)(sc[1] * L.ny);
    SQ_CHECK(xu >= 0 && xu < L.nx && yu >= 0 && yu < L.ny);
    SQ_CHECK_NEAR(L.shadow[yu * L.nx + xu], I1 * I1, 0.01);
    SQ_CHECK_NEAR(L.shadow[yc * L.nx + xc], 1.0f, 1e-6);
    sq__cloud_light_free(ctx, &L);
    sq_context_destroy(ctx);
}

/* The result does not depend on the order the particles come in (only on their distance from
 * the sun): a random field and its shuffle give identical light per particle. */
SQ_TEST(mfs_order_independent_of_input)
{
    sq_context *ctx = ctx_new();
    const int n = 3000;
    float *pos = malloc(sizeof(float) * 3 * n), *rad = malloc(sizeof(float) * n);
    float *tt = malloc(sizeof(float) * n);
    float *pos2 = malloc(sizeof(float) * 3 * n), *rad2 = malloc(sizeof(float) * n);
    float *tt2 = malloc(sizeof(float) * n);
    int *perm = malloc(sizeof(int) * n);
    for (int i = 0; i < n; i++) {
        float u[4];
        sq_rng_uniform4(5, 0, (uint64_t)i, u);
        pos[3 * i] = 4000 * u[0];
        pos[3 * i + 1] = 4000 * u[1];
        pos[3 * i + 2] = 1000 + 800 * u[2];
        rad[i] = 120 + 80 * u[3];
        tt[i] = 0.5f + u[0] * u[1] * 4;
        perm[i] = i;
    }
    for (int i = n - 1; i > 0; i--) {
        const int j = (int)(sq_rng_uniform(6, 0, (uint64_t)i) * (float)(i + 1)) % (i + 1);
        const int t = perm[i];
        perm[i] = perm[j];
        perm[j] = t;
    }
    for (int i = 0; i < n; i++) {
        const int j = perm[i];
        memcpy(pos2 + 3 * i, pos + 3 * j, 3 * sizeof(float));
        rad2[i] = rad[j];
        tt2[i] = tt[j];
    }
    sq_clouds_view a = view_default(), b = view_default();
    a.count = b.count = n;
    a.position = pos;
    a.radius_m = rad;
    a.tau = tt;
    b.position = pos2;
    b.radius_m = rad2;
    b.tau = tt2;
    a.multiple_scattering = b.multiple_scattering = true;
    sq__cloud_light La, Lb;
    memset(&La, 0, sizeof La);
    memset(&Lb, 0, sizeof Lb);
    const sq_vec3 sun = sq_v3_norm(sq_v3(-0.4f, 0.5f, 0.6f));
    SQ_CHECK_OK(sq__cloud_light_compute(ctx, &La, &a, sun));
    SQ_CHECK_OK(sq__cloud_light_compute(ctx, &Lb, &b, sun));
    int diff = 0;
    float lo = 1.0f;
    for (int i = 0; i < n; i++) {
        const int j = perm[i];
        diff += Lb.sun[i] != La.sun[j] || Lb.sky[i] != La.sky[j] || Lb.diffuse[i] != La.diffuse[j];
        lo = fminf(lo, La.sun[j]);
    }
    SQ_CHECK_MSG(diff == 0, "%d particles lit differently after a shuffle", diff);
    SQ_CHECK(lo < 0.5f); /* the field does shadow itself */
    sq__cloud_light_free(ctx, &La);
    sq__cloud_light_free(ctx, &Lb);
    free(pos);
    free(rad);
    free(tt);
    free(pos2);
    free(rad2);
    free(tt2);
    free(perm);
    sq_context_destroy(ctx);
}

/* A thin particle's splat removes its cross-section from the light whatever the buffer's
 * resolution: the mean transmittance loss over the buffer times its area equals
 * integral(1 - e^{-tau eta}) dA ~ tau 0.3 pi r² for small tau, also when the particle is smaller
 * than a texel. */
SQ_TEST(splat_conserves_cross_section)
{
    sq_context *ctx = ctx_new();
    const int sizes[3] = {512, 64, 8};
    for (int s = 0; s < 3; s++) {
        /* one tiny thin particle and two far corner particles (tau 0) setting the extent */
        float pos[9] = {37.0f, 11.0f, 0, -1000, -1000, 0, 1000, 1000, 0};
        float rad[3] = {20.0f, 1.0f, 1.0f}, tt[3] = {0.01f, 0.0f, 0.0f};
        sq_clouds_view v = view_default();
        v.count = 3;
        v.position = pos;
        v.radius_m = rad;
        v.tau = tt;
        v.albedo = 0.0f; /* no in-scatter: the buffer is the transmittance */
        v.light_buffer = sizes[s];
        v.light_texels_per_radius = 1000.0f; /* the buffer's size alone sets the texel */
        sq__cloud_light L;
        memset(&L, 0, sizeof L);
        SQ_CHECK_OK(sq__cloud_light_compute(ctx, &L, &v, sq_v3(0, 0, 1)));
        double loss = 0;
        for (int c = 0; c < L.nx * L.ny; c++) loss += 1.0 - (double)L.shadow[c];
        loss *= (double)L.texel_m * (double)L.texel_m;
        const double want = 0.01 * 0.3 * 3.14159265358979 * 20.0 * 20.0;
        printf("buffer %d (texel %.1f m): removed %.4f m2, expected %.4f m2\n", sizes[s],
               (double)L.texel_m, loss, want);
        SQ_CHECK_REL(loss, want, 0.01);
        sq__cloud_light_free(ctx, &L);
    }
    sq_context_destroy(ctx);
}

/* Impostor weight: 0 (particles) up to dist_3d, 1 (impostor) from dist_impostor, continuous and
 * monotone between with zero slope at both ends (no pop); a degenerate band switches at it. */
SQ_TEST(impostor_crossfade_weight)
{
    const float d3 = 60e3f, di = 90e3f;
    SQ_CHECK(sq__cloud_impostor_weight(0.0f, d3, di) == 0.0f);
    SQ_CHECK(sq__cloud_impostor_weight(d3, d3, di) == 0.0f);
    SQ_CHECK(sq__cloud_impostor_weight(di, d3, di) == 1.0f);
    SQ_CHECK(sq__cloud_impostor_weight(1e6f, d3, di) == 1.0f);
    SQ_CHECK_NEAR(sq__cloud_impostor_weight(75e3f, d3, di), 0.5f, 1e-6);
    float prev = 0.0f, max_step = 0.0f;
    for (int i = 0; i <= 1000; i++) {
        const float d = d3 - 1000.0f + (di - d3 + 2000.0f) * (float)i / 1000.0f;
        const float w = sq__cloud_impostor_weight(d, d3, di);
        SQ_CHECK(w >= prev);
        max_step = fmaxf(max_step, w - prev);
        prev = w;
    }
    /* 1000 steps of 32 m over a 30 km band: the largest step is 1.5 x the mean (smoothstep) */
    SQ_CHECK(max_step < 1.6f * 32.0f / 30000.0f);
    SQ_CHECK(sq__cloud_impostor_weight(59e3f, 60e3f, 60e3f) == 0.0f);
    SQ_CHECK(sq__cloud_impostor_weight(60e3f, 60e3f, 60e3f) == 1.0f);
}
