/* bulk.c — bulk optical properties of a log-normal dust population (SPEC §2.4, S0 eqs
 * 3.16–3.17) and the R/G/B/550 nm table built once per scene.
 *
 *   <C_ext> = ∫ P(r) pi r² Q_ext(2 pi r / lambda) dr / ∫ P(r) dr      (per particle, m²)
 *   k_ext   = <C_ext> / (rho_d <4/3 pi r³>)                           (m²/kg)
 *   omega   = <C_sca> / <C_ext>,   g = <C_sca g> / <C_sca>
 * all integrals over the same [r_min, r_max] with the ln r trapezoid rule of size_dist.c, so the
 * normalisation cancels in k_ext and the mass <-> number conversion rho_n = C / (rho_d
 * <4/3 pi r³>) is consistent with the cross-sections. */
#include <math.h>
#include <string.h>

#include "optics_internal.h"

#define PI 3.14159265358979323846

static sq_result resolve_common(const sq_lognormal *size, double *density, sq_optics_method *method,
                                double *r_min, double *r_max, int *nodes, double *ada_g)
{
    sq_result r = sq_lognormal_validate(size);
    if (r != SQ_OK) return r;
    if (*density == 0.0) *density = SQ_DUST_DENSITY_DEFAULT;
    if (!(isfinite(*density) && *density > 0.0))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "density_kg_m3 = %g; the particle density must be finite and > 0 "
                             "(0 selects %g)",
                             *density, SQ_DUST_DENSITY_DEFAULT);
    if (*method == SQ_OPTICS_DEFAULT) *method = SQ_OPTICS_MIE;
    if (*method != SQ_OPTICS_MIE && *method != SQ_OPTICS_ADA)
        return sq__set_error(SQ_ERR_INVALID_ARG, "method = %d; must be SQ_OPTICS_MIE (1) or "
                                                 "SQ_OPTICS_ADA (2)",
                             (int)*method);
    sq__quadrature q;
    r = sq__quadrature_setup(size, *r_min, *r_max, *nodes == 0 ? 16 : *nodes, &q);
    if (r != SQ_OK) return r;
    *r_min = exp(q.a);
    *r_max = exp(q.b);
    if (*nodes == 0) {
        /* spacing <= SQ_OPTICS_NODE_SPACING in ln r, at least SQ_OPTICS_NODES_MIN nodes */
        const double n = ceil((q.b - q.a) / SQ_OPTICS_NODE_SPACING) + 1.0;
        *nodes = n < SQ_OPTICS_NODES_MIN ? SQ_OPTICS_NODES_MIN
                 : n > SQ__QUADRATURE_MAX_NODES ? SQ__QUADRATURE_MAX_NODES
                                                : (int)n;
    }
    if (*ada_g == 0.0) *ada_g = SQ_OPTICS_ADA_ASYMMETRY_DEFAULT;
    if (!(isfinite(*ada_g) && *ada_g > -1.0 && *ada_g < 1.0))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "ada_asymmetry = %g; must be in (-1, 1) (0 selects %g)", *ada_g,
                             SQ_OPTICS_ADA_ASYMMETRY_DEFAULT);
    return SQ_OK;
}

static sq_result resolve_index(const char *wl_name, const char *nr_name, const char *ni_name,
                               double wavelength_m, double *n_real, double *n_imag)
{
    sq_result r = sq__optics_check_positive(wl_name, wavelength_m);
    if (r != SQ_OK) return r;
    if (*n_real == 0.0) return sq_dust_refractive_index(wavelength_m, n_real, n_imag);
    return sq__optics_check_index(nr_name, ni_name, *n_real, *n_imag);
}

sq_result sq_bulk_optics_desc_resolve(const sq_bulk_optics_desc *desc, sq_bulk_optics_desc *out)
{
    if (!desc || !out)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_bulk_optics_desc_resolve: NULL argument");
    sq_bulk_optics_desc d = *desc;
    memset(out, 0, sizeof *out);
    sq_result r = resolve_index("wavelength_m", "n_real", "n_imag", d.wavelength_m, &d.n_real,
                                &d.n_imag);
    if (r == SQ_OK)
        r = resolve_common(&d.size, &d.density_kg_m3, &d.method, &d.r_min_m, &d.r_max_m,
                           &d.nodes, &d.ada_asymmetry);
    if (r != SQ_OK) return r;
    if (d.method == SQ_OPTICS_ADA && d.n_real == 1.0 && d.n_imag == 0.0)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "n_real = 1, n_imag = 0; the ADA method needs m != 1");
    *out = d;
    return SQ_OK;
}

/* Efficiencies and g at size parameter x for a resolved desc. Above SQ_OPTICS_MIE_X_CAP the Mie
 * values at the cap are continued (see optics.h): Q_ext with its x^(−2/3) approach to 2, Q_abs
 * with the ADA increment, g held. */
typedef struct eff_ctx {
    const sq_bulk_optics_desc *d;
    bool cap_ready;
    sq_mie_result cap_mie;
    double cap_ada_ext, cap_ada_abs;
} eff_ctx;

static void efficiencies(eff_ctx *c, double x, double *qext, double *qsca, double *g)
{
    const sq_bulk_optics_desc *d = c->d;
    if (d->method == SQ_OPTICS_ADA) {
        double qe, qa;
        sq__ada_eval(x, d->n_real, d->n_imag, &qe, &qa);
        *qext = qe;
        *qsca = qe - qa;
        *g = d->ada_asymmetry;
        return;
    }
    if (x <= SQ_OPTICS_MIE_X_CAP) {
        sq_mie_result m;
        (void)sq_mie_sphere(x, d->n_real, d->n_imag, &m); /* inputs validated by resolve */
        *qext = m.qext;
        *qsca = m.qsca;
        *g = m.g;
        return;
    }
    if (!c->cap_ready) {
        (void)sq_mie_sphere(SQ_OPTICS_MIE_X_CAP, d->n_real, d->n_imag, &c->cap_mie);
        sq__ada_eval(SQ_OPTICS_MIE_X_CAP, d->n_real, d->n_imag, &c->cap_ada_ext,
                     &c->cap_ada_abs);
        c->cap_ready = true;
    }
    double qe, qa;
    sq__ada_eval(x, d->n_real, d->n_imag, &qe, &qa);
    (void)qe;
    /* edge (glory/surface-wave) term of Q_ext decays as x^(−2/3) (Nussenzveig & Wiscombe 1980) */
    const double ext = 2.0 + (c->cap_mie.qext - 2.0) * pow(x / SQ_OPTICS_MIE_X_CAP, -2.0 / 3.0);
    double abs = c->cap_mie.qabs + (qa - c->cap_ada_abs);
    if (abs < 0.0) abs = 0.0;
    if (abs > ext) abs = ext;
    *qext = ext;
    *qsca = ext - abs;
    *g = c->cap_mie.g;
}

sq_result sq_bulk_optics_compute(const sq_bulk_optics_desc *desc, sq_bulk_optics *out)
{
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_bulk_optics_compute: out is NULL");
    memset(out, 0, sizeof *out);
    sq_bulk_optics_desc d;
    sq_result r = sq_bulk_optics_desc_resolve(desc, &d);
    if (r != SQ_OK) return r;
    sq__quadrature q;
    r = sq__quadrature_setup(&d.size, d.r_min_m, d.r_max_m, d.nodes, &q);
    if (r != SQ_OK) return r;

    eff_ctx c = {.d = &d};
    const double k = 2.0 * PI / d.wavelength_m;
    double sw = 0.0, sext = 0.0, ssca = 0.0, sgs = 0.0, s2 = 0.0, s3 = 0.0;
    for (int i = 0; i < q.nodes; i++) {
        double rad, w, qext, qsca, g;
        sq__quadrature_node(&q, i, &rad, &w);
        if (w == 0.0) continue; /* underflowed tail: nothing to add, skip the Mie series */
        efficiencies(&c, k * rad, &qext, &qsca, &g);
        const double area = PI * rad * rad;
        sw += w;
        sext += w * area * qext;
        ssca += w * area * qsca;
        sgs += w * area * qsca * g;
        s2 += w * rad * rad;
        s3 += w * rad * rad * rad;
    }
    if (!(sw > 0.0))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "r_min_m = %g, r_max_m = %g hold no particles of the distribution "
                             "(median %g m, ln_sigma %g)",
                             d.r_min_m, d.r_max_m, d.size.median_radius_m, d.size.ln_sigma);
    out->wavelength_m = d.wavelength_m;
    out->n_real = d.n_real;
    out->n_imag = d.n_imag;
    out->ext_cross_section_m2 = sext / sw;
    out->sca_cross_section_m2 = ssca / sw;
    out->abs_cross_section_m2 = (sext - ssca) / sw;
    out->particle_mass_kg = d.density_kg_m3 * (4.0 / 3.0) * PI * s3 / sw;
    out->mass_extinction_m2_per_kg = out->ext_cross_section_m2 / out->particle_mass_kg;
    out->mass_scattering_m2_per_kg = out->sca_cross_section_m2 / out->particle_mass_kg;
    out->single_scattering_albedo = sext > 0.0 ? ssca / sext : 1.0;
    out->asymmetry = ssca > 0.0 ? sgs / ssca : 0.0;
    out->effective_radius_m = s3 / s2;
    return SQ_OK;
}

static const double table_default_wl[SQ_OPTICS_CHANNELS] = {650e-9, 550e-9, 450e-9, 550e-9};

sq_result sq_optics_table_desc_resolve(const sq_optics_table_desc *desc, sq_optics_table_desc *out)
{
    if (!desc || !out)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_optics_table_desc_resolve: NULL argument");
    sq_optics_table_desc d = *desc;
    memset(out, 0, sizeof *out);
    static const char *const wl_names[SQ_OPTICS_CHANNELS] = {
        "wavelength_m[red]", "wavelength_m[green]", "wavelength_m[blue]", "wavelength_m[vis]"};
    static const char *const nr_names[SQ_OPTICS_CHANNELS] = {
        "n_real[red]", "n_real[green]", "n_real[blue]", "n_real[vis]"};
    static const char *const ni_names[SQ_OPTICS_CHANNELS] = {
        "n_imag[red]", "n_imag[green]", "n_imag[blue]", "n_imag[vis]"};
    sq_result r = SQ_OK;
    for (int ch = 0; ch < SQ_OPTICS_CHANNELS && r == SQ_OK; ch++) {
        if (d.wavelength_m[ch] == 0.0) d.wavelength_m[ch] = table_default_wl[ch];
        r = resolve_index(wl_names[ch], nr_names[ch], ni_names[ch], d.wavelength_m[ch],
                          &d.n_real[ch], &d.n_imag[ch]);
    }
    if (r == SQ_OK)
        r = resolve_common(&d.size, &d.density_kg_m3, &d.method, &d.r_min_m, &d.r_max_m,
                           &d.nodes, &d.ada_asymmetry);
    if (r != SQ_OK) return r;
    *out = d;
    return SQ_OK;
}

sq_result sq_optics_table_build(const sq_optics_table_desc *desc, sq_optics_table *out)
{
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_optics_table_build: out is NULL");
    memset(out, 0, sizeof *out);
    sq_optics_table_desc d;
    sq_result r = sq_optics_table_desc_resolve(desc, &d);
    if (r != SQ_OK) return r;
    sq_optics_table t;
    memset(&t, 0, sizeof t);
    for (int ch = 0; ch < SQ_OPTICS_CHANNELS; ch++) {
        /* A channel identical to an earlier one (G and VIS by default) is copied. */
        int same = -1;
        for (int e = 0; e < ch && same < 0; e++)
            if (d.wavelength_m[e] == d.wavelength_m[ch] && d.n_real[e] == d.n_real[ch] &&
                d.n_imag[e] == d.n_imag[ch])
                same = e;
        if (same >= 0) {
            t.channel[ch] = t.channel[same];
            continue;
        }
        const sq_bulk_optics_desc bd = {
            .size = d.size,
            .wavelength_m = d.wavelength_m[ch],
            .n_real = d.n_real[ch],
            .n_imag = d.n_imag[ch],
            .density_kg_m3 = d.density_kg_m3,
            .method = d.method,
            .r_min_m = d.r_min_m,
            .r_max_m = d.r_max_m,
            .nodes = d.nodes,
            .ada_asymmetry = d.ada_asymmetry,
        };
        r = sq_bulk_optics_compute(&bd, &t.channel[ch]);
        if (r != SQ_OK) return r;
    }
    t.size = d.size;
    t.density_kg_m3 = d.density_kg_m3;
    t.method = d.method;
    *out = t;
    return SQ_OK;
}
