/* size_dist.c — number-weighted log-normal size distribution of dust radii (SPEC §2.4):
 * P(r) dr = exp(−(ln r − ln r_m)² / (2 s²)) / (s sqrt(2 pi)) dr / r, s = ln sigma_g.
 * Analytic moments <r^k> = r_m^k exp(k² s² / 2), partial moments through the normal CDF, the
 * ln r quadrature the bulk optics integrate with, and the K-bin discretisation the sandstorm
 * solver transports. */
#include <math.h>

#include "optics_internal.h"

sq_result sq_lognormal_validate(const sq_lognormal *d)
{
    if (!d) return sq__set_error(SQ_ERR_INVALID_ARG, "size distribution is NULL");
    if (!(isfinite(d->median_radius_m) && d->median_radius_m > 0.0))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "median_radius_m = %g; the median radius must be finite and > 0",
                             d->median_radius_m);
    if (!(isfinite(d->ln_sigma) && d->ln_sigma > 0.0))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "ln_sigma = %g; must be finite and > 0 (sigma_g > 1; use a narrow "
                             "width such as 0.01 for nearly equal sizes)",
                             d->ln_sigma);
    return SQ_OK;
}

sq_result sq_lognormal_make_ln(double median_radius_m, double ln_sigma, sq_lognormal *out)
{
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lognormal_make_ln: out is NULL");
    *out = (sq_lognormal){0};
    const sq_lognormal d = {median_radius_m, ln_sigma};
    sq_result r = sq_lognormal_validate(&d);
    if (r != SQ_OK) return r;
    *out = d;
    return SQ_OK;
}

sq_result sq_lognormal_make(double median_radius_m, double sigma_g, sq_lognormal *out)
{
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lognormal_make: out is NULL");
    *out = (sq_lognormal){0};
    if (!(isfinite(sigma_g) && sigma_g > 1.0))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "sigma_g = %g; the geometric standard deviation must be finite and "
                             "> 1 (it is exp of the std of ln r)",
                             sigma_g);
    return sq_lognormal_make_ln(median_radius_m, log(sigma_g), out);
}

double sq_lognormal_moment(const sq_lognormal *d, double k)
{
    const double s = d->ln_sigma;
    return pow(d->median_radius_m, k) * exp(0.5 * k * k * s * s);
}

double sq_lognormal_partial_moment(const sq_lognormal *d, double k, double r_lo_m,
                                   double r_hi_m)
{
    if (!(r_hi_m > r_lo_m)) return 0.0;
    const double s = d->ln_sigma, mu = log(d->median_radius_m);
    const double zlo = r_lo_m > 0.0 ? (log(r_lo_m) - mu) / s - k * s : -HUGE_VAL;
    const double zhi = isfinite(r_hi_m) ? (log(r_hi_m) - mu) / s - k * s : HUGE_VAL;
    return sq_lognormal_moment(d, k) * sq__normal_cdf_diff(zlo, zhi);
}

double sq_lognormal_pdf_ln(const sq_lognormal *d, double radius_m)
{
    if (!(radius_m > 0.0)) return 0.0;
    const double s = d->ln_sigma;
    const double z = (log(radius_m) - log(d->median_radius_m)) / s;
    return exp(-0.5 * z * z) / (s * 2.50662827463100050242); /* sqrt(2 pi) */
}

sq_result sq_lognormal_auto_range(const sq_lognormal *d, double *r_min_m, double *r_max_m)
{
    sq_result r = sq_lognormal_validate(d);
    if (r != SQ_OK) return r;
    const double s = d->ln_sigma;
    if (r_min_m) *r_min_m = d->median_radius_m * exp(-6.0 * s);
    if (r_max_m) *r_max_m = d->median_radius_m * exp(3.0 * s * s + 6.0 * s);
    return SQ_OK;
}

/* Resolves and checks a radius range; zeros select the default given by lo_def/hi_def. */
static sq_result resolve_range(double r_min, double r_max, double lo_def, double hi_def,
                               double *lo, double *hi)
{
    if (r_min == 0.0 && r_max == 0.0) {
        *lo = lo_def;
        *hi = hi_def;
        return SQ_OK;
    }
    sq_result r = sq__optics_check_positive("r_min_m", r_min);
    if (r == SQ_OK) r = sq__optics_check_positive("r_max_m", r_max);
    if (r != SQ_OK) return r;
    if (!(r_max > r_min))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "r_max_m = %g; must be > r_min_m = %g (or set both to 0 for the "
                             "automatic range)",
                             r_max, r_min);
    *lo = r_min;
    *hi = r_max;
    return SQ_OK;
}

sq_result sq__quadrature_setup(const sq_lognormal *d, double r_min_m, double r_max_m, int nodes,
                               sq__quadrature *q)
{
    double lo_def, hi_def, lo = 0.0, hi = 0.0;
    sq_result r = sq_lognormal_auto_range(d, &lo_def, &hi_def);
    if (r != SQ_OK) return r;
    r = resolve_range(r_min_m, r_max_m, lo_def, hi_def, &lo, &hi);
    if (r != SQ_OK) return r;
    if (nodes < 16 || nodes > SQ__QUADRATURE_MAX_NODES)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "nodes = %d; the quadrature needs from 16 to %d nodes", nodes,
                             SQ__QUADRATURE_MAX_NODES);
    q->dist = *d;
    q->a = log(lo);
    q->b = log(hi);
    q->h = (q->b - q->a) / (double)(nodes - 1);
    q->nodes = nodes;
    return SQ_OK;
}

void sq__quadrature_node(const sq__quadrature *q, int i, double *radius_m, double *weight)
{
    const double y = i == q->nodes - 1 ? q->b : q->a + q->h * (double)i;
    *radius_m = exp(y);
    const double w = (i == 0 || i == q->nodes - 1) ? 0.5 * q->h : q->h;
    *weight = w * sq_lognormal_pdf_ln(&q->dist, *radius_m);
}

sq_result sq_lognormal_quadrature(const sq_lognormal *d, double r_min_m, double r_max_m,
                                  int nodes, double *radius_m, double *weight)
{
    sq__quadrature q;
    sq_result r = sq__quadrature_setup(d, r_min_m, r_max_m, nodes, &q);
    if (r != SQ_OK) return r;
    if (!radius_m || !weight)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lognormal_quadrature: NULL output array");
    for (int i = 0; i < nodes; i++) sq__quadrature_node(&q, i, &radius_m[i], &weight[i]);
    return SQ_OK;
}

sq_result sq_lognormal_bins(const sq_lognormal *d, int count, double r_min_m, double r_max_m,
                            sq_size_bin *bins)
{
    sq_result r = sq_lognormal_validate(d);
    if (r != SQ_OK) return r;
    if (count < 1 || count > 4096)
        return sq__set_error(SQ_ERR_INVALID_ARG, "count = %d; must be from 1 to 4096 bins",
                             count);
    if (!bins) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lognormal_bins: bins is NULL");
    const double s = d->ln_sigma;
    double lo = 0.0, hi = 0.0;
    r = resolve_range(r_min_m, r_max_m, d->median_radius_m * exp(-3.0 * s),
                      d->median_radius_m * exp(3.0 * s * s + 3.0 * s), &lo, &hi);
    if (r != SQ_OK) return r;
    const double n_tot = sq_lognormal_partial_moment(d, 0.0, lo, hi);
    const double m_tot = sq_lognormal_partial_moment(d, 3.0, lo, hi);
    const double a = log(lo), step = (log(hi) - a) / (double)count;
    for (int i = 0; i < count; i++) {
        sq_size_bin *bn = &bins[i];
        bn->r_lo_m = i == 0 ? lo : exp(a + step * (double)i);
        bn->r_hi_m = i == count - 1 ? hi : exp(a + step * (double)(i + 1));
        const double n = sq_lognormal_partial_moment(d, 0.0, bn->r_lo_m, bn->r_hi_m);
        const double m3 = sq_lognormal_partial_moment(d, 3.0, bn->r_lo_m, bn->r_hi_m);
        bn->number_fraction = n_tot > 0.0 ? n / n_tot : 0.0;
        bn->mass_fraction = m_tot > 0.0 ? m3 / m_tot : 0.0;
        /* mean r³ of the bin; the geometric centre where the bin holds no particles (underflow) */
        const double rep = n > 0.0 ? cbrt(m3 / n) : sqrt(bn->r_lo_m * bn->r_hi_m);
        bn->radius_m = fmin(fmax(rep, bn->r_lo_m), bn->r_hi_m);
    }
    return SQ_OK;
}

sq_result sq_lognormal_number_density(const sq_lognormal *d, double conc_kg_m3,
                                      double density_kg_m3, double *out_per_m3)
{
    if (out_per_m3) *out_per_m3 = 0.0;
    sq_result r = sq_lognormal_validate(d);
    if (r == SQ_OK) r = sq__optics_check_nonnegative("concentration_kg_m3", conc_kg_m3);
    if (r == SQ_OK) r = sq__optics_check_positive("density_kg_m3", density_kg_m3);
    if (r != SQ_OK) return r;
    if (!out_per_m3)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lognormal_number_density: out is NULL");
    const double mass = density_kg_m3 * (4.0 / 3.0) * 3.14159265358979323846 *
                        sq_lognormal_moment(d, 3.0);
    *out_per_m3 = conc_kg_m3 / mass;
    return SQ_OK;
}
