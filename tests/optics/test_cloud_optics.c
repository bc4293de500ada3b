/* test_cloud_optics.c — cloud hydrometeor optics (SPEC §8, issue 10): the geometric-optics
 * extinction beta = 3 W / (2 rho r_eff) against exact Lorenz–Mie for a droplet population, the
 * textbook optical depth of a liquid-water path, the published Stoelinga–Warner (NCEP UPP)
 * extinction, effective radii from number concentrations against quadrature of the gamma size
 * distribution, the mixture weighting and the Rayleigh normalisation. */
#include "sq_test.h"
#include "squall/optics.h"

SQ_LABEL(physics)

#define PI 3.14159265358979323846

/* The formula itself: 0.3 g/m³ of 10 µm droplets -> 3 * 3e-4 / (2 * 1000 * 1e-5) = 0.045 1/m;
 * linear in the concentration, inverse in r_eff, zero for no or bad water. */
SQ_TEST(extinction_formula)
{
    SQ_CHECK_REL(sq_cloud_extinction(0.3 * 1e-3, 1000.0, 10e-6), 0.045, 1e-14);
    SQ_CHECK_REL(sq_cloud_extinction(0.6 * 1e-3, 1000.0, 10e-6), 0.090, 1e-14);
    SQ_CHECK_REL(sq_cloud_extinction(0.3 * 1e-3, 1000.0, 20e-6), 0.0225, 1e-14);
    SQ_CHECK(sq_cloud_extinction(0.0 * 1e-3, 1000.0, 10e-6) == 0.0);
    SQ_CHECK(sq_cloud_extinction(-1e-9 * 1e-3, 1000.0, 10e-6) == 0.0);
    SQ_CHECK(sq_cloud_extinction(NAN * 1e-3, 1000.0, 10e-6) == 0.0);
}

/* Stephens (1978): tau = 3 LWP / (2 rho_w r_e); LWP = 100 g/m² of 10 µm droplets gives tau = 15.
 * Integrating our extinction over a 500 m layer of 0.2 g/m³ reproduces it. */
SQ_TEST(optical_depth_of_liquid_water_path)
{
    double tau = 0.0;
    const int n = 50;
    for (int k = 0; k < n; k++)
        tau += sq_cloud_extinction(0.2 * 1e-3, 1000.0, 10e-6) * (500.0 / n);
    SQ_CHECK_REL(tau, 15.0, 1e-12);
}

/* Exact Mie for a log-normal droplet population (sigma_g = 1.35, r_eff = 10 µm, water n = 1.333
 * with negligible absorption at 550 nm) gives a mass extinction within 6 % of 3 / (2 rho r_eff),
 * and above it: Q_ext approaches 2 from above at these size parameters (x ~ 100), so the
 * geometric formula is a slight underestimate. */
SQ_TEST(extinction_matches_mie_for_droplets)
{
    const double sg = 1.35, reff = 10e-6;
    const double l2 = log(sg) * log(sg);
    const double rm = reff / exp(2.5 * l2); /* r_eff = <r³>/<r²> = r_m exp(5/2 ln² sigma) */
    sq_bulk_optics_desc d = {0};
    SQ_CHECK_OK(sq_lognormal_make(rm, sg, &d.size));
    d.wavelength_m = 550e-9;
    d.n_real = 1.333;
    d.n_imag = 1e-9;
    d.density_kg_m3 = 1000.0;
    sq_bulk_optics b;
    SQ_CHECK_OK(sq_bulk_optics_compute(&d, &b));
    SQ_CHECK_REL(b.effective_radius_m, reff, 1e-3);
    const double geometric = sq_cloud_extinction(1000.0 * 1e-3, 1000.0, reff); /* 1 kg/m³: m²/kg */
    const double mie = b.mass_extinction_m2_per_kg;
    printf("mass extinction: Mie %.2f m2/kg, geometric %.2f m2/kg (ratio %.4f), g = %.4f\n", mie,
           geometric, mie / geometric, b.asymmetry);
    SQ_CHECK(mie > geometric);
    SQ_CHECK_REL(mie, geometric, 0.06);
    /* and the droplet asymmetry default agrees with Mie to 0.02 */
    SQ_CHECK_NEAR(b.asymmetry, SQ_CLOUD_DROPLET_G, 0.02);
}

/* The published Stoelinga–Warner cloud-liquid extinction of NCEP UPP (reference/wrf_format.md):
 * beta = 144.7 C^0.88 1/km. Our 10 µm default is within 30 % of it from 0.05 to 1 g/m³ (a power
 * fit to observations against a fixed size; they cross near 0.8 g/m³). */
SQ_TEST(extinction_vs_stoelinga_warner)
{
    const double c[] = {0.05, 0.1, 0.2, 0.3, 0.5, 0.8, 1.0};
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        const double ours =
            sq_cloud_extinction(c[i] * 1e-3, 1000.0, SQ_CLOUD_DROPLET_R_EFF_M) * 1e3;
        const double sw = 144.7 * pow(c[i], 0.88);
        SQ_CHECK_MSG(ours / sw > 0.7 && ours / sw < 1.3, "C = %g g/m3: ours %.2f /km, UPP %.2f /km",
                     c[i], ours, sw);
    }
}

/* r_eff from mass and number against quadrature of n(D) = D^mu exp(-lambda D) with lambda set so
 * that the mass matches, for mu = 0 (Thompson ice and rain) and mu = 2. */
SQ_TEST(effective_radius_from_number)
{
    const double mus[] = {0.0, 2.0};
    for (int m = 0; m < 2; m++) {
        const double mu = mus[m], rho = 917.0, w_g = 0.02, n = 1e5;
        const double reff = sq_cloud_effective_radius(w_g, n, rho, mu);
        /* quadrature in D for a trial lambda: moments M_k = int D^(mu+k) exp(-lambda D) dD */
        double lo = 1e2, hi = 1e7;
        double lambda = 0.0;
        for (int it = 0; it < 200; it++) { /* bisection on the mass per particle */
            lambda = sqrt(lo * hi);
            double m0 = 0, m3 = 0;
            const double dmax = 60.0 / lambda, h = dmax / 20000.0;
            for (int i = 0; i < 20000; i++) {
                const double dd = (i + 0.5) * h, f = pow(dd, mu) * exp(-lambda * dd);
                m0 += f * h;
                m3 += f * dd * dd * dd * h;
            }
            const double mass = rho * PI / 6.0 * m3 / m0 * n; /* kg/m³ */
            if (mass > w_g * 1e-3) lo = lambda;
            else hi = lambda;
        }
        double m2 = 0, m3 = 0;
        const double dmax = 60.0 / lambda, h = dmax / 20000.0;
        for (int i = 0; i < 20000; i++) {
            const double dd = (i + 0.5) * h, f = pow(dd, mu) * exp(-lambda * dd);
            m2 += f * dd * dd * h;
            m3 += f * dd * dd * dd * h;
        }
        SQ_CHECK_REL(reff, 0.5 * m3 / m2, 1e-4);
    }
    SQ_CHECK(sq_cloud_effective_radius(0.0, 1e5, 917.0, 0.0) == 0.0);
    SQ_CHECK(sq_cloud_effective_radius(0.1, 0.0, 917.0, 0.0) == 0.0);
}

/* Mixture: extinctions add, g is the extinction-weighted mean; liquid only gives 0.85. */
SQ_TEST(mixture_weights)
{
    sq_cloud_optics o;
    SQ_CHECK_OK(sq_cloud_optics_resolve(NULL, &o));
    float c[SQ_HYDRO_COUNT] = {0.3f, 0.0f, 0.0f, 0.0f, 0.0f};
    double g = 0;
    const double b1 = sq_cloud_mixture(&o, c, NULL, &g);
    SQ_CHECK_REL(b1, 0.045, 1e-6);
    SQ_CHECK_NEAR(g, 0.85, 1e-12);
    c[1] = 0.05f;
    const double bi = sq_cloud_extinction((double)0.05f * 1e-3, 917.0, SQ_CLOUD_ICE_R_EFF_M);
    const double b2 = sq_cloud_mixture(&o, c, NULL, &g);
    SQ_CHECK_REL(b2, sq_cloud_extinction((double)0.3f * 1e-3, 1000.0, 10e-6) + bi, 1e-12);
    SQ_CHECK_NEAR(g, (sq_cloud_extinction((double)0.3f * 1e-3, 1000.0, 10e-6) * 0.85 + bi * 0.75) / b2, 1e-12);
    /* a per-cell effective radius overrides the default for that species only */
    const float r[SQ_HYDRO_COUNT] = {20e-6f, 0.0f, 0.0f, 0.0f, 0.0f};
    SQ_CHECK_REL(sq_cloud_mixture(&o, c, r, NULL), sq_cloud_extinction((double)0.3f * 1e-3, 1000.0, (double)20e-6f) + bi,
                 1e-6);
    const float none[SQ_HYDRO_COUNT] = {0, 0, 0, 0, 0};
    SQ_CHECK(sq_cloud_mixture(&o, none, NULL, &g) == 0.0 && g == 0.0);
}

SQ_TEST(resolve_defaults_and_errors)
{
    sq_cloud_optics o = {{0, 0, 0, 0, 0}, {0, 0, 0, 0, 0}};
    SQ_CHECK_OK(sq_cloud_optics_resolve(&o, &o));
    SQ_CHECK(o.r_eff_m[SQ_HYDRO_CLOUD] == SQ_CLOUD_DROPLET_R_EFF_M);
    SQ_CHECK(o.g[SQ_HYDRO_ICE] == SQ_CLOUD_ICE_G);
    o.r_eff_m[SQ_HYDRO_SNOW] = 1e-9;
    SQ_CHECK(sq_cloud_optics_resolve(&o, &o) == SQ_ERR_INVALID_ARG);
    SQ_CHECK(strstr(sq_last_error(), "r_eff_m[snow]") != NULL);
    o.r_eff_m[SQ_HYDRO_SNOW] = 0;
    o.g[SQ_HYDRO_RAIN] = 1.0;
    SQ_CHECK(sq_cloud_optics_resolve(&o, &o) == SQ_ERR_INVALID_ARG);
    SQ_CHECK(strstr(sq_last_error(), "g[rain]") != NULL);
    SQ_CHECK(sq_hydrometeor_density(SQ_HYDRO_SNOW) == 917.0);
    SQ_CHECK(sq_hydrometeor_density(SQ_HYDRO_RAIN) == 1000.0);
    SQ_CHECK(sq_hydrometeor_density(SQ_HYDRO_GRAUPEL) == 917.0);
}

/* Rayleigh: integrates to 1 over the sphere, 3/(8 pi) forward, 3/(16 pi) at 90 degrees. */
SQ_TEST(rayleigh_phase_normalised)
{
    double s = 0;
    const int n = 20000;
    for (int i = 0; i < n; i++) {
        const double mu = -1.0 + (i + 0.5) * 2.0 / n;
        s += sq_rayleigh_phase(mu) * 2.0 * PI * (2.0 / n);
    }
    SQ_CHECK_NEAR(s, 1.0, 1e-8);
    SQ_CHECK_REL(sq_rayleigh_phase(1.0), 3.0 / (8.0 * PI), 1e-14);
    SQ_CHECK_REL(sq_rayleigh_phase(0.0), 3.0 / (16.0 * PI), 1e-14);
}
