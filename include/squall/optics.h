/* squall/optics.h — dust optics and visibility (SPEC §2): exact Lorenz–Mie efficiencies of a
 * homogeneous sphere, van de Hulst's anomalous-diffraction approximation (ADA), log-normal size
 * distributions (moments, quadrature, size bins), bulk optics of a distribution and the
 * per-channel table the renderer uses, the Henyey–Greenstein phase function and Koschmieder
 * visibility.
 *
 * Refractive-index sign convention: m = n_real + i n_imag with n_imag >= 0 for an absorbing
 * material (time dependence e^{-i omega t}, as in Bohren & Huffman). MIEV0 (Wiscombe) writes the
 * same material as n − ik and SPEC §2.1 as n_r − i n_i: pass n_imag = k = n_i (a positive
 * number). A negative n_imag is an input error (SQ_ERR_INVALID_ARG), never silently flipped.
 *
 * Units: SI everywhere (metres, kg, m², m⁻¹); efficiencies Q and the asymmetry g are
 * dimensionless. Pure functions: no context, no allocation, no global state; failures set
 * sq_last_error() with the parameter, its value and the rule. */
#ifndef SQ_OPTICS_H
#define SQ_OPTICS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- single spheres ------------------------------------------------------------------------ */

/* Largest size parameter x = 2 pi r / lambda the exact Mie series accepts. */
#define SQ_MIE_MAX_SIZE_PARAMETER 1.0e5

typedef struct sq_mie_result {
    double qext;  /* extinction efficiency C_ext / (pi r²) */
    double qsca;  /* scattering efficiency */
    double qabs;  /* absorption efficiency qext − qsca (>= 0) */
    double qback; /* backscattering efficiency (Bohren & Huffman definition); NaN from ADA */
    double g;     /* asymmetry parameter <cos theta> (g > 0: forward); NaN from ADA */
    int terms;    /* number of series terms summed (0 for ADA) */
} sq_mie_result;

/* Exact Lorenz–Mie efficiencies for a homogeneous sphere of size parameter x (0 < x <= 1e5) and
 * refractive index n_real + i n_imag (n_real > 0, n_imag >= 0) relative to the medium.
 * Downward logarithmic-derivative recurrence started from Lentz's continued fraction (exact
 * start value, no start-margin heuristic), Wiscombe's term count x + 4.05 x^(1/3) + 2, double
 * precision. Validated against Wiscombe's MIEV0 test set, BHMIE and scattnlay
 * (tests/optics/test_optics_mie.c). */
SQ_API sq_result sq_mie_sphere(double x, double n_real, double n_imag, sq_mie_result *out);

/* Exact Mie efficiencies of a perfectly conducting sphere (the m -> infinity limit). */
SQ_API sq_result sq_mie_sphere_conducting(double x, sq_mie_result *out);

/* Van de Hulst's anomalous-diffraction approximation (SPEC §2.2, eqs 3.14–3.15):
 *   Q_ext = 4 Re K(2x(n_imag + i(n_real − 1))),  Q_abs = 2 K(4 x n_imag),
 *   K(w) = 1/2 + e^{−w}/w + (e^{−w} − 1)/w²,
 * with the power series K(w) = sum_j (−1)^{j+1} (j+1)/(j+2)! w^j for |w| < 0.1 (the closed form
 * cancels catastrophically for small w), so Q_abs never goes negative. Meant for |m − 1| small
 * and x >> 1; needs m != 1. qback and g are NaN, terms = 0. */
SQ_API sq_result sq_ada_sphere(double x, double n_real, double n_imag, sq_mie_result *out);

/* Default refractive index of fresh mineral (Saharan) dust at a wavelength
 * (reference/dust_optics.md, docs/phen/sandstorm-optics.md):
 * n_real = 1.53 (Fouquart et al. 1987; Woodward 2001);
 * n_imag = 0.0010 at 550 nm (Fouquart et al. 1987, Saharan dust; within the 0.0007–0.0035 at
 *   520 nm that Di Biagio et al. 2019 measured for 19 dust samples), following the spectral
 *   shape of the AERONET desert-dust retrievals of Dubovik et al. 2002 (0.0025 at 440 nm,
 *   0.0014 at 670 nm, linear in wavelength between, held constant outside 440–670 nm) scaled
 *   to that value: 0.00124 at 450 nm, 0.00100 at 550 nm, 0.00076 at 650 nm (the blue absorbs
 *   most: yellow-brown tint). */
SQ_API sq_result sq_dust_refractive_index(double wavelength_m, double *n_real, double *n_imag);

/* ---- log-normal size distribution ----------------------------------------------------------- */

/* Number-weighted log-normal: ln r is normal with mean ln(median_radius_m) and standard
 * deviation ln_sigma = ln(sigma_g). Build with one of the two constructors below. */
typedef struct sq_lognormal {
    double median_radius_m; /* number median radius r_m, > 0 */
    double ln_sigma;        /* ln of the geometric standard deviation, > 0 */
} sq_lognormal;

/* From the geometric standard deviation sigma_g (> 1). */
SQ_API sq_result sq_lognormal_make(double median_radius_m, double sigma_g, sq_lognormal *out);
/* From ln(sigma_g) (> 0), the "std" of SPEC §2.4–2.7 (eta). */
SQ_API sq_result sq_lognormal_make_ln(double median_radius_m, double ln_sigma, sq_lognormal *out);
/* Checks a distribution filled in by hand (messages name median_radius_m / ln_sigma). */
SQ_API sq_result sq_lognormal_validate(const sq_lognormal *d);

/* Analytic moment <r^k> = r_m^k exp(k² ln²sigma_g / 2) (m^k). */
SQ_API double sq_lognormal_moment(const sq_lognormal *d, double k);
/* Partial moment: integral of r^k P(r) dr over [r_lo, r_hi] (P normalised to 1 over (0, inf));
 * = <r^k> [Phi(z_hi − k ln sigma) − Phi(z_lo − k ln sigma)], z = (ln r − ln r_m)/ln sigma. */
SQ_API double sq_lognormal_partial_moment(const sq_lognormal *d, double k, double r_lo_m,
                                          double r_hi_m);
/* Probability density per unit ln r, dN/dln r / N (dimensionless). */
SQ_API double sq_lognormal_pdf_ln(const sq_lognormal *d, double radius_m);

/* Default integration range in radius for bulk optics: ln r from ln r_m − 6 ln sigma (the
 * number tail) to ln r_m + 3 ln² sigma + 6 ln sigma (6 sigma beyond the mass median), so the
 * neglected tails of the number, area and mass integrals are each below 1e-9. */
SQ_API sq_result sq_lognormal_auto_range(const sq_lognormal *d, double *r_min_m,
                                         double *r_max_m);

/* Quadrature in ln r: `nodes` equally spaced nodes from ln r_min to ln r_max (trapezoid rule,
 * which converges spectrally for these smooth, rapidly decaying integrands). Fills radius_m[i]
 * and weight[i] so that sum_i weight[i] f(radius_m[i]) approximates the integral of f(r) P(r) dr
 * over [r_min, r_max] (weights are NOT renormalised; their sum is the number fraction inside
 * the range). r_min_m = r_max_m = 0 selects sq_lognormal_auto_range; 16 <= nodes <= 100000. */
SQ_API sq_result sq_lognormal_quadrature(const sq_lognormal *d, double r_min_m, double r_max_m,
                                         int nodes, double *radius_m, double *weight);

/* One size class of a discretised distribution. Fractions are shares of the particles (or
 * mass) inside [r_min, r_max], so each sums to 1 over the bins. */
typedef struct sq_size_bin {
    double r_lo_m, r_hi_m;  /* bin edges (log-spaced) */
    double radius_m;        /* representative radius: cube root of the bin's mean r³ (conserves
                               mass when all particles of the bin get this radius) */
    double number_fraction; /* share of the number */
    double mass_fraction;   /* share of the mass (volume) */
} sq_size_bin;

/* Splits [r_min, r_max] into `count` log-spaced bins (1 <= count <= 4096). r_min_m = r_max_m =
 * 0 selects ln r_m − 3 ln sigma .. ln r_m + 3 ln² sigma + 3 ln sigma (the central 99.7 % of the
 * number and of the mass). All values are analytic (error functions). */
SQ_API sq_result sq_lognormal_bins(const sq_lognormal *d, int count, double r_min_m,
                                   double r_max_m, sq_size_bin *bins);

/* Number density of particles (m⁻³) for a dust mass concentration (kg/m³, 0 is physical):
 * rho_n = C / (rho_d <4/3 pi r³>) with the analytic third moment. density_kg_m3 > 0. */
SQ_API sq_result sq_lognormal_number_density(const sq_lognormal *d, double conc_kg_m3,
                                             double density_kg_m3, double *out_per_m3);

/* ---- bulk optics of a distribution -------------------------------------------------------- */

typedef enum sq_optics_method {
    SQ_OPTICS_DEFAULT = 0, /* = SQ_OPTICS_MIE */
    SQ_OPTICS_MIE = 1,     /* exact Lorenz–Mie per node */
    SQ_OPTICS_ADA = 2      /* anomalous diffraction, the thesis's method (S0 §3.3) */
} sq_optics_method;

#define SQ_DUST_DENSITY_DEFAULT 2650.0   /* kg/m³, quartz / Met Office UM value */
/* Default quadrature: node spacing <= 0.0125 in ln r and at least 400 nodes (800 for the
 * automatic range of sigma_g = 2). Mie ripple makes the integrand rough at x ~ 1–100; measured
 * against 6400 nodes this keeps k_ext, albedo and g within ~1e-4 for sigma_g <= 2.2. */
#define SQ_OPTICS_NODE_SPACING 0.0125
#define SQ_OPTICS_NODES_MIN 400
#define SQ_OPTICS_ADA_ASYMMETRY_DEFAULT 0.7 /* SPEC §2.6 default g (ADA has no angular data) */
/* Above this size parameter the bulk integral does not evaluate the Mie series (cost O(x)):
 * Q_ext continues as 2 + (Q_ext(x_cap) − 2)(x/x_cap)^(−2/3) (the edge term), Q_abs as
 * Q_abs(x_cap) + Q_abs,ADA(x) − Q_abs,ADA(x_cap), g is held at its x_cap value. Measured against
 * exact Mie for dust (m = 1.53 + 0.003i) at x = 1.5e4–6e4: Q_ext within 1e-6, Q_abs within 1e-3,
 * g within 1e-4; for nearly transparent spheres (n_imag ~ 1e-5) Q_abs and g drift by up to ~7 %
 * (absorption is still growing there). */
#define SQ_OPTICS_MIE_X_CAP 1.0e4

typedef struct sq_bulk_optics_desc {
    sq_lognormal size;       /* required: build with sq_lognormal_make / _make_ln */
    double wavelength_m;     /* required, > 0 */
    double n_real;           /* 0 = dust default at wavelength_m (sq_dust_refractive_index),
                                n_imag is then ignored; otherwise > 0 */
    double n_imag;           /* >= 0, 0 is physical (non-absorbing) when n_real is set */
    double density_kg_m3;    /* particle material density; 0 = 2650 */
    sq_optics_method method; /* 0 = exact Mie */
    double r_min_m, r_max_m; /* integration range; both 0 = sq_lognormal_auto_range */
    int nodes;               /* quadrature nodes in ln r, 16..100000; 0 = automatic (above) */
    double ada_asymmetry;    /* g reported by the ADA method; 0 = 0.7; in (−1, 1) */
} sq_bulk_optics_desc;

/* Bulk optical properties per particle and per unit mass. Averages are over the particles in
 * [r_min, r_max] (the quadrature weights are renormalised to that range). */
typedef struct sq_bulk_optics {
    double wavelength_m, n_real, n_imag; /* resolved inputs */
    double ext_cross_section_m2;   /* <C_ext> per particle; beta_ext = rho_n <C_ext> */
    double sca_cross_section_m2;   /* <C_sca> */
    double abs_cross_section_m2;   /* <C_abs> */
    double particle_mass_kg;       /* rho_d <4/3 pi r³> */
    double mass_extinction_m2_per_kg; /* k_ext = <C_ext> / (rho_d <4/3 pi r³>) */
    double mass_scattering_m2_per_kg;
    double single_scattering_albedo;  /* <C_sca> / <C_ext> */
    double asymmetry;              /* scattering-weighted g: <C_sca g> / <C_sca> */
    double effective_radius_m;     /* <r³> / <r²> */
} sq_bulk_optics;

/* Fills defaults (zeros) and validates; out receives the resolved copy. */
SQ_API sq_result sq_bulk_optics_desc_resolve(const sq_bulk_optics_desc *desc,
                                             sq_bulk_optics_desc *out);
SQ_API sq_result sq_bulk_optics_compute(const sq_bulk_optics_desc *desc, sq_bulk_optics *out);

/* ---- the per-channel table the renderer and the sandstorm use ----------------------------- */

typedef enum sq_optics_channel {
    SQ_OPTICS_RED = 0,   /* default 650 nm */
    SQ_OPTICS_GREEN = 1, /* default 550 nm */
    SQ_OPTICS_BLUE = 2,  /* default 450 nm */
    SQ_OPTICS_VIS = 3,   /* 550 nm reference for visibility (SPEC §2.7) */
    SQ_OPTICS_CHANNELS = 4
} sq_optics_channel;

typedef struct sq_optics_table_desc {
    sq_lognormal size;                          /* required */
    double density_kg_m3;                       /* 0 = 2650 */
    sq_optics_method method;                    /* 0 = exact Mie */
    double wavelength_m[SQ_OPTICS_CHANNELS];    /* 0 = 650, 550, 450, 550 nm */
    double n_real[SQ_OPTICS_CHANNELS];          /* 0 = dust default at that wavelength */
    double n_imag[SQ_OPTICS_CHANNELS];          /* used where n_real is set; 0 is physical */
    double r_min_m, r_max_m;                    /* 0 = auto range */
    int nodes;                                  /* 0 = automatic */
    double ada_asymmetry;                       /* 0 = 0.7 */
} sq_optics_table_desc;

typedef struct sq_optics_table {
    sq_bulk_optics channel[SQ_OPTICS_CHANNELS];
    sq_lognormal size;
    double density_kg_m3;
    sq_optics_method method;
} sq_optics_table;

/* Copies desc to out with zero fields replaced by their defaults and checks the ranges:
 * SQ_ERR_INVALID_ARG naming sq_optics_table_desc.<field>. */
SQ_API sq_result sq_optics_table_desc_resolve(const sq_optics_table_desc *desc,
                                              sq_optics_table_desc *out);
/* Builds the table once (scene creation): four bulk-optics evaluations. */
SQ_API sq_result sq_optics_table_build(const sq_optics_table_desc *desc, sq_optics_table *out);

/* ---- phase function --------------------------------------------------------------------- */

/* Henyey–Greenstein phase function (1/sr), normalised to 1 over 4 pi:
 * p = (1 − g²) / (4 pi (1 + g² − 2 g cos_theta)^{3/2}), cos_theta = dot of the propagation
 * directions of the incident and scattered light, so g > 0 is forward scattering (SPEC §2.6).
 * |g| < 1. */
SQ_API double sq_hg_phase(double cos_theta, double g);
/* Inverse CDF: cos_theta distributed as p for a uniform u in [0, 1]; monotone increasing
 * (u = 0 gives −1, u = 1 gives +1). */
SQ_API double sq_hg_sample_cos(double g, double u);
/* Scattered propagation direction for incident unit direction dir_in: cos_theta from u1,
 * azimuth 2 pi u2 around dir_in. dir_out is a unit vector; dir_in and dir_out may alias. */
SQ_API void sq_hg_sample_direction(const double dir_in[3], double g, double u1, double u2,
                                   double dir_out[3]);

/* ---- cloud condensate (SPEC §8, issue 10; src/solvers/optics/cloud.c) ---------------------- */
/* The one home of the cloud extinction formula: the WRF export, the clouds phenomenon and the
 * renderer all call this. Droplets and ice crystals are much larger than visible wavelengths, so
 * the extinction efficiency is Q_ext ~ 2 (the extinction paradox) and a population with mass
 * concentration C, particle density rho_p and effective radius r_eff = <r^3>/<r^2> has
 *     beta = Q_ext pi <r^2> N = 3 C / (2 rho_p r_eff)        [m^-1]
 * (Stephens 1978, J. Atmos. Sci. 35, 2123; Hansen & Travis 1974). For ice, r_eff is the radius of
 * the ice-volume-equivalent population in this formula; Fu (1996, J. Climate 9, 2058) gives
 * beta ~ 2.52 IWC / D_ge (g m-3, um, m^-1), i.e. r_eff ~ 0.65 D_ge. Exact Mie for a log-normal
 * droplet population with r_eff = 10 um is 4 % above the formula (tests/optics). */
#define SQ_WATER_DENSITY_KG_M3 1000.0
#define SQ_ICE_DENSITY_KG_M3 917.0
/* Default effective radii: 10 um for liquid cloud droplets (Stephens 1978; Miles et al. 2000,
 * J. Atmos. Sci. 57, 295: continental ~ 8-10 um, marine ~ 12 um), 25 um for cloud ice
 * (Fu 1996: D_ge ~ 40 um of mid-latitude cirrus). Snow 100 um and rain 500 um are the sizes the
 * Stoelinga–Warner extinctions of NCEP UPP imply (snow 10.36 C^0.7776 km-1 at 0.01-0.1 g m-3:
 * 56-95 um; rain 2.24 C^0.75 km-1 at 0.1-1 g m-3: 375-670 um; reference/wrf_format.md); graupel
 * 1 mm (millimetre-sized rimed particles). */
#define SQ_CLOUD_DROPLET_R_EFF_M 10.0e-6
#define SQ_CLOUD_ICE_R_EFF_M 25.0e-6
#define SQ_CLOUD_SNOW_R_EFF_M 100.0e-6
#define SQ_CLOUD_RAIN_R_EFF_M 500.0e-6
#define SQ_CLOUD_GRAUPEL_R_EFF_M 1.0e-3
/* Henyey–Greenstein asymmetry at visible wavelengths: droplets 0.85 (Hansen & Travis 1974:
 * 0.84-0.87 for water clouds at 0.55 um; Mie gives 0.866 for the default population), ice 0.75
 * (roughened and aggregate crystals: Fu 1996; Yang et al. 2013), snow 0.80 (aggregates, between
 * ice and drops), rain and graupel 0.88 (large particles, geometric optics plus diffraction). */
#define SQ_CLOUD_DROPLET_G 0.85
#define SQ_CLOUD_ICE_G 0.75
#define SQ_CLOUD_SNOW_G 0.80
#define SQ_CLOUD_RAIN_G 0.88
#define SQ_CLOUD_GRAUPEL_G 0.88

/* beta = 3 C / (2 rho_p r_eff) in m^-1 for a mass concentration C in kg m^-3 (values <= 0 and
 * NaN give 0), a particle density in kg m^-3 and an effective radius in m (both > 0: the
 * caller validates its parameters). */
SQ_API double sq_cloud_extinction(double mass_kg_m3, double particle_density_kg_m3,
                                  double r_eff_m);

/* Hydrometeor species in the order of sq_wrf_species (include/squall/wrf.h). */
typedef enum sq_hydrometeor {
    SQ_HYDRO_CLOUD = 0,   /* cloud liquid water (QCLOUD) */
    SQ_HYDRO_ICE = 1,     /* cloud ice (QICE) */
    SQ_HYDRO_SNOW = 2,    /* snow (QSNOW) */
    SQ_HYDRO_RAIN = 3,    /* rain (QRAIN) */
    SQ_HYDRO_GRAUPEL = 4, /* graupel (QGRAUP) */
    SQ_HYDRO_COUNT = 5
} sq_hydrometeor;

/* Effective radii and asymmetries per species; zeros take the defaults above. */
typedef struct sq_cloud_optics {
    double r_eff_m[SQ_HYDRO_COUNT]; /* > 0 after resolve */
    double g[SQ_HYDRO_COUNT];       /* in (-1, 1) after resolve; 0 -> default */
} sq_cloud_optics;

/* Fills zeros with the defaults and checks the rest (r_eff in [1 um, 10 mm], |g| < 1); messages
 * name r_eff_m[species] or g[species]. in may be NULL (all defaults); in and out may alias. */
SQ_API sq_result sq_cloud_optics_resolve(const sq_cloud_optics *in, sq_cloud_optics *out);

/* Particle density (kg/m³) used in the formula for a species: water for droplets and rain, solid
 * ice for ice, snow and graupel (ice-volume-equivalent spheres, as UPP's CALVIS does). */
SQ_API double sq_hydrometeor_density(sq_hydrometeor species);

/* Effective radius (m) from the mass (g/m³) and number (1/m³) concentrations of a gamma size
 * distribution n(D) ~ D^mu exp(-lambda D) of spheres of the given density (mu = 0: the
 * exponential of Thompson's ice and rain):
 *   r_v = (3 W / (4 pi rho N))^(1/3),  r_eff = r_v (mu + 3) / ((mu + 1)(mu + 2)(mu + 3))^(1/3).
 * Returns 0 when a concentration is <= 0 or not finite (the caller keeps its default). */
SQ_API double sq_cloud_effective_radius(double conc_g_m3, double number_per_m3,
                                        double density_kg_m3, double mu);

/* Extinction (1/m) of a mixture of species and its scattering-weighted asymmetry (the single-
 * scattering albedo of every species is ~1 in the visible, so the weights are the extinctions):
 *   beta = sum_s beta_s,  g = sum_s beta_s g_s / beta  (g = 0 where beta = 0).
 * conc_g_m3[s]: mass concentration per species (0 for one the file lacks); r_eff_m may be NULL
 * (o's radii) or hold per-species radii for this cell (entries <= 0 fall back to o). */
SQ_API double sq_cloud_mixture(const sq_cloud_optics *o, const float conc_g_m3[SQ_HYDRO_COUNT],
                               const float *r_eff_m, double *g_out);

/* Rayleigh phase function (1/sr), normalised to 1 over 4 pi: 3 (1 + cos²theta) / (16 pi). Kept
 * only for reproducing S4, which applied it to cloud droplets (SPEC 8.4 ⚠: droplets are Mie
 * scatterers; use Henyey–Greenstein with g ~ 0.85). */
SQ_API double sq_rayleigh_phase(double cos_theta);

/* ---- visibility (Koschmieder, SPEC §2.7) --------------------------------------------------- */

#define SQ_VISIBILITY_CONTRAST_DEFAULT 0.05 /* S0 and WMO MOR; the UM and UPP use 0.02 */

/* V = ln(1/contrast) / beta_ext. beta_ext >= 0 (0 gives +infinity); contrast in (0, 1), 0 =
 * 0.05. */
SQ_API sq_result sq_visibility_from_extinction(double beta_ext_per_m, double contrast,
                                               double *out_m);
/* beta_ext = ln(1/contrast) / V for a visibility V > 0. */
SQ_API sq_result sq_extinction_for_visibility(double visibility_m, double contrast,
                                              double *out_per_m);
/* V for a dust mass concentration (kg/m³, >= 0) and mass extinction k_ext (m²/kg, > 0). */
SQ_API sq_result sq_visibility_from_concentration(double conc_kg_m3, double mass_ext_m2_per_kg,
                                                  double contrast, double *out_m);
/* The dust mass concentration (kg/m³) that gives visibility V (m, > 0). */
SQ_API sq_result sq_concentration_for_visibility(double visibility_m, double mass_ext_m2_per_kg,
                                                 double contrast, double *out_kg_m3);

#ifdef __cplusplus
}
#endif
#endif
