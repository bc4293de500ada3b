/* test_optics_input.c — bad input to the optics API (SPEC §2): each returns SQ_ERR_INVALID_ARG
 * with a message naming the parameter, its value and the rule, and zeroes the output. */
#include "sq_test.h"
#include "squall/optics.h"

SQ_LABEL(unit)

static sq_lognormal dust(void)
{
    sq_lognormal d = {2e-6, 0.693};
    return d;
}

SQ_TEST(bad_radius)
{
    sq_lognormal d = {1, 1};
    SQ_CHECK_ERR(sq_lognormal_make(NAN, 2.0, &d), SQ_ERR_INVALID_ARG,
                 "median_radius_m = nan; the median radius must be finite and > 0");
    SQ_CHECK(d.median_radius_m == 0 && d.ln_sigma == 0);
    SQ_CHECK_ERR(sq_lognormal_make(INFINITY, 2.0, &d), SQ_ERR_INVALID_ARG,
                 "median_radius_m = inf");
    SQ_CHECK_ERR(sq_lognormal_make(-1e-6, 2.0, &d), SQ_ERR_INVALID_ARG,
                 "median_radius_m = -1e-06; the median radius must be finite and > 0");
    SQ_CHECK_ERR(sq_lognormal_make_ln(0.0, 0.5, &d), SQ_ERR_INVALID_ARG, "median_radius_m = 0");
    /* a hand-filled distribution inside a desc is validated too */
    sq_bulk_optics_desc bd = {.size = {-2e-6, 0.5}, .wavelength_m = 550e-9};
    sq_bulk_optics b;
    b.asymmetry = 1;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG, "median_radius_m = -2e-06");
    SQ_CHECK(b.asymmetry == 0);
    /* bin and quadrature ranges */
    sq_lognormal g = dust();
    sq_size_bin bins[4];
    SQ_CHECK_ERR(sq_lognormal_bins(&g, 4, -1e-6, 1e-5, bins), SQ_ERR_INVALID_ARG,
                 "r_min_m = -1e-06; must be finite and > 0");
    SQ_CHECK_ERR(sq_lognormal_bins(&g, 4, 2e-5, 1e-5, bins), SQ_ERR_INVALID_ARG,
                 "r_max_m = 1e-05; must be > r_min_m = 2e-05");
    SQ_CHECK_ERR(sq_lognormal_bins(&g, 0, 0, 0, bins), SQ_ERR_INVALID_ARG,
                 "count = 0; must be from 1 to 4096");
    double r[8], w[8];
    SQ_CHECK_ERR(sq_lognormal_quadrature(&g, 0, 0, 8, r, w), SQ_ERR_INVALID_ARG,
                 "nodes = 8; the quadrature needs from 16 to 100000 nodes");
    SQ_CHECK_ERR(sq_lognormal_quadrature(&g, NAN, 1e-5, 16, r, w), SQ_ERR_INVALID_ARG,
                 "r_min_m = nan");
}

SQ_TEST(bad_sigma)
{
    sq_lognormal d;
    SQ_CHECK_ERR(sq_lognormal_make(1e-6, 1.0, &d), SQ_ERR_INVALID_ARG,
                 "sigma_g = 1; the geometric standard deviation must be finite and > 1");
    SQ_CHECK_ERR(sq_lognormal_make(1e-6, 0.9, &d), SQ_ERR_INVALID_ARG, "sigma_g = 0.9");
    SQ_CHECK_ERR(sq_lognormal_make(1e-6, NAN, &d), SQ_ERR_INVALID_ARG, "sigma_g = nan");
    SQ_CHECK_ERR(sq_lognormal_make_ln(1e-6, 0.0, &d), SQ_ERR_INVALID_ARG,
                 "ln_sigma = 0; must be finite and > 0 (sigma_g > 1");
    SQ_CHECK_ERR(sq_lognormal_make_ln(1e-6, -0.5, &d), SQ_ERR_INVALID_ARG, "ln_sigma = -0.5");
    sq_lognormal bad = {1e-6, 0.0};
    double lo, hi;
    SQ_CHECK_ERR(sq_lognormal_auto_range(&bad, &lo, &hi), SQ_ERR_INVALID_ARG, "ln_sigma = 0");
    sq_optics_table_desc td = {.size = bad};
    sq_optics_table t;
    SQ_CHECK_ERR(sq_optics_table_build(&td, &t), SQ_ERR_INVALID_ARG, "ln_sigma = 0");
}

SQ_TEST(bad_concentration)
{
    sq_lognormal d = dust();
    double out = 5;
    SQ_CHECK_ERR(sq_lognormal_number_density(&d, -1e-3, 2650, &out), SQ_ERR_INVALID_ARG,
                 "concentration_kg_m3 = -0.001; must be finite and >= 0");
    SQ_CHECK(out == 0);
    SQ_CHECK_ERR(sq_visibility_from_concentration(-1e-3, 100, 0.05, &out), SQ_ERR_INVALID_ARG,
                 "concentration_kg_m3 = -0.001");
    SQ_CHECK_ERR(sq_visibility_from_concentration(NAN, 100, 0.05, &out), SQ_ERR_INVALID_ARG,
                 "concentration_kg_m3 = nan");
    SQ_CHECK_ERR(sq_visibility_from_concentration(1e-3, 0, 0.05, &out), SQ_ERR_INVALID_ARG,
                 "mass_extinction_m2_per_kg = 0; must be finite and > 0");
}

SQ_TEST(bad_density)
{
    sq_lognormal d = dust();
    double out;
    SQ_CHECK_ERR(sq_lognormal_number_density(&d, 1e-3, 0, &out), SQ_ERR_INVALID_ARG,
                 "density_kg_m3 = 0; must be finite and > 0");
    SQ_CHECK_ERR(sq_lognormal_number_density(&d, 1e-3, -2650, &out), SQ_ERR_INVALID_ARG,
                 "density_kg_m3 = -2650");
    /* in a desc 0 selects the default, negative is refused */
    sq_bulk_optics_desc bd = {.size = d, .wavelength_m = 550e-9, .density_kg_m3 = -5};
    sq_bulk_optics b;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG,
                 "density_kg_m3 = -5; the particle density must be finite and > 0");
    sq_optics_table_desc td = {.size = d, .density_kg_m3 = NAN};
    sq_optics_table t;
    SQ_CHECK_ERR(sq_optics_table_build(&td, &t), SQ_ERR_INVALID_ARG, "density_kg_m3 = nan");
}

SQ_TEST(bad_refractive_index)
{
    sq_mie_result r;
    r.qext = 3;
    SQ_CHECK_ERR(sq_mie_sphere(1.0, 1.5, -0.01, &r), SQ_ERR_INVALID_ARG,
                 "n_imag = -0.01; must be >= 0 (m = n + ik with k >= 0 for an absorbing");
    SQ_CHECK(r.qext == 0);
    SQ_CHECK_ERR(sq_ada_sphere(100.0, 1.5, -1e-3, &r), SQ_ERR_INVALID_ARG, "n_imag = -0.001");
    SQ_CHECK_ERR(sq_mie_sphere(1.0, 0.0, 0.01, &r), SQ_ERR_INVALID_ARG,
                 "n_real = 0; the real refractive index must be finite and > 0");
    SQ_CHECK_ERR(sq_mie_sphere(1.0, INFINITY, 0.01, &r), SQ_ERR_INVALID_ARG, "n_real = inf");
    SQ_CHECK_ERR(sq_mie_sphere(1.0, 1.5, NAN, &r), SQ_ERR_INVALID_ARG, "n_imag = nan");
    SQ_CHECK_ERR(sq_ada_sphere(100.0, 1.0, 0.0, &r), SQ_ERR_INVALID_ARG, "ADA needs m != 1");
    sq_bulk_optics_desc bd = {.size = dust(), .wavelength_m = 550e-9, .n_real = 1.53,
                              .n_imag = -0.003};
    sq_bulk_optics b;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG, "n_imag = -0.003");
    sq_optics_table_desc td = {.size = dust()};
    td.n_real[SQ_OPTICS_BLUE] = 1.53;
    td.n_imag[SQ_OPTICS_BLUE] = -0.0057;
    sq_optics_table t;
    SQ_CHECK_ERR(sq_optics_table_build(&td, &t), SQ_ERR_INVALID_ARG, "n_imag[blue] = -0.0057");
}

SQ_TEST(bad_wavelength)
{
    sq_bulk_optics_desc bd = {.size = dust(), .wavelength_m = 0};
    sq_bulk_optics b;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG,
                 "wavelength_m = 0; must be finite and > 0");
    bd.wavelength_m = -550e-9;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG, "wavelength_m = -5.5e-07");
    double n, k;
    SQ_CHECK_ERR(sq_dust_refractive_index(-1, &n, &k), SQ_ERR_INVALID_ARG, "wavelength_m = -1");
    sq_optics_table_desc td = {.size = dust()};
    td.wavelength_m[SQ_OPTICS_RED] = -650e-9;
    sq_optics_table t;
    SQ_CHECK_ERR(sq_optics_table_build(&td, &t), SQ_ERR_INVALID_ARG,
                 "wavelength_m[red] = -6.5e-07");
}

SQ_TEST(bad_size_parameter)
{
    sq_mie_result r;
    SQ_CHECK_ERR(sq_mie_sphere(0.0, 1.5, 0.0, &r), SQ_ERR_INVALID_ARG,
                 "size parameter x = 0; must be finite, > 0 and <= 100000");
    SQ_CHECK_ERR(sq_mie_sphere(2e5, 1.5, 0.0, &r), SQ_ERR_INVALID_ARG, "x = 200000");
    SQ_CHECK_ERR(sq_mie_sphere_conducting(NAN, &r), SQ_ERR_INVALID_ARG, "x = nan");
    SQ_CHECK_ERR(sq_ada_sphere(-3.0, 1.5, 0.0, &r), SQ_ERR_INVALID_ARG, "x = -3");
}

SQ_TEST(bad_desc_fields)
{
    sq_bulk_optics_desc bd = {.size = dust(), .wavelength_m = 550e-9, .nodes = 3};
    sq_bulk_optics b;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG, "nodes = 3");
    bd.nodes = 0;
    bd.method = (sq_optics_method)7;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG, "method = 7");
    bd.method = SQ_OPTICS_ADA;
    bd.ada_asymmetry = 1.0;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG,
                 "ada_asymmetry = 1; must be in (-1, 1)");
    bd.ada_asymmetry = 0;
    bd.r_min_m = 1e-6;
    bd.r_max_m = 1e-7;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG, "r_max_m = 1e-07");
    /* a range holding no particles at all (the density underflows to 0) */
    bd.r_min_m = 1e10;
    bd.r_max_m = 2e10;
    SQ_CHECK_ERR(sq_bulk_optics_compute(&bd, &b), SQ_ERR_INVALID_ARG, "hold no particles");
    SQ_CHECK_ERR(sq_bulk_optics_compute(NULL, &b), SQ_ERR_INVALID_ARG, "NULL");
    /* resolve fills the defaults and is idempotent */
    sq_bulk_optics_desc in = {.size = dust(), .wavelength_m = 450e-9}, r1, r2;
    SQ_CHECK_OK(sq_bulk_optics_desc_resolve(&in, &r1));
    SQ_CHECK_OK(sq_bulk_optics_desc_resolve(&r1, &r2));
    double n450, k450;
    SQ_CHECK_OK(sq_dust_refractive_index(450e-9, &n450, &k450));
    SQ_CHECK(r1.n_real == 1.53 && r1.n_imag == k450 && r1.density_kg_m3 == 2650);
    SQ_CHECK(r1.method == SQ_OPTICS_MIE && r1.nodes >= 400 && r1.ada_asymmetry == 0.7);
    SQ_CHECK(r1.r_min_m > 0 && r1.r_max_m > r1.r_min_m);
    SQ_CHECK(r2.nodes == r1.nodes);
    SQ_CHECK_REL(r2.r_min_m, r1.r_min_m, 1e-14);
}

SQ_TEST(bad_visibility_inputs)
{
    double v = 7;
    SQ_CHECK_ERR(sq_visibility_from_extinction(1e-3, 1.5, &v), SQ_ERR_INVALID_ARG,
                 "contrast = 1.5; the contrast threshold must be in (0, 1)");
    SQ_CHECK(v == 0);
    SQ_CHECK_ERR(sq_visibility_from_extinction(1e-3, -0.05, &v), SQ_ERR_INVALID_ARG,
                 "contrast = -0.05");
    SQ_CHECK_ERR(sq_visibility_from_extinction(-1e-3, 0.05, &v), SQ_ERR_INVALID_ARG,
                 "beta_ext_per_m = -0.001; must be finite and >= 0");
    SQ_CHECK_ERR(sq_extinction_for_visibility(0, 0.05, &v), SQ_ERR_INVALID_ARG,
                 "visibility_m = 0; must be finite and > 0");
    SQ_CHECK_ERR(sq_concentration_for_visibility(-600, 700, 0.05, &v), SQ_ERR_INVALID_ARG,
                 "visibility_m = -600");
    SQ_CHECK_ERR(sq_concentration_for_visibility(600, -700, 0.05, &v), SQ_ERR_INVALID_ARG,
                 "mass_extinction_m2_per_kg = -700");
}
