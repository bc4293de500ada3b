/* test_sph_kernels.c — SPH kernels and rheology against their analytic properties (SPEC §7.2–7.4):
 * normalisation ∫W dV = 1 and gradient antisymmetry for every kernel on one support radius, and
 * the Cross / power-law / Bingham viscosities against their limits (issue 6 item 6, physics). */
#include "sq_test.h"
#include "solvers/sph/sph_internal.h"
#include "squall/sph.h"

SQ_LABEL(physics)

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
