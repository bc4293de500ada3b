/* ada.c — van de Hulst's anomalous-diffraction approximation (SPEC §2.2, S0 eqs 3.14–3.15;
 * van de Hulst 1957 §11.22) and the default refractive index of mineral dust.
 *
 * With K(w) = 1/2 + e^{−w}/w + (e^{−w} − 1)/w² (van de Hulst's K function):
 *   Q_ext = 4 Re K(w_e),  w_e = 2x(n_i + i(n_r − 1)) = rho (tan beta + i),
 *   Q_abs = 2 K(w_a),     w_a = 4 x n_i,
 * which expand to SPEC eqs 3.14 and 3.15 term by term. For |w| < 0.1 the closed form cancels
 * (it subtracts terms ~1/w² to get a result ~w), so the power series
 *   K(w) = Σ_{j>=1} (−1)^{j+1} (j+1)/(j+2)! w^j
 * is used instead, summed to 18 terms (truncation < 1e-20 relative). In particular Q_abs stays
 * positive for the n_i = 1.96e-9 case that SPEC §2.2 flags. */
#include <complex.h>
#include <math.h>

#include "optics_internal.h"

static double complex ada_k(double complex w)
{
    if (cabs(w) < 0.1) {
        /* Horner on c_j = (−1)^{j+1} (j+1)/(j+2)!, j = 1..18 */
        double c[19];
        double fact = 2.0; /* (j+2)! starting at j = 0 */
        for (int j = 1; j <= 18; j++) {
            fact *= (double)(j + 2);
            c[j] = (j % 2 ? 1.0 : -1.0) * (double)(j + 1) / fact;
        }
        double complex s = c[18];
        for (int j = 17; j >= 1; j--) s = s * w + c[j];
        return s * w;
    }
    const double complex e = cexp(-w);
    return 0.5 + e / w + (e - 1.0) / (w * w);
}

void sq__ada_eval(double x, double n_real, double n_imag, double *qext, double *qabs)
{
    const double complex we = sq__cmplx(2.0 * x * n_imag, 2.0 * x * (n_real - 1.0));
    *qext = 4.0 * creal(ada_k(we));
    *qabs = n_imag > 0.0 ? 2.0 * creal(ada_k(4.0 * x * n_imag)) : 0.0;
    if (*qabs < 0.0) *qabs = 0.0;
}

sq_result sq_ada_sphere(double x, double n_real, double n_imag, sq_mie_result *out)
{
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_ada_sphere: out is NULL");
    *out = (sq_mie_result){0};
    if (!(isfinite(x) && x > 0.0))
        return sq__set_error(SQ_ERR_INVALID_ARG, "size parameter x = %g; must be finite and > 0",
                             x);
    sq_result r = sq__optics_check_index("n_real", "n_imag", n_real, n_imag);
    if (r != SQ_OK) return r;
    if (n_real == 1.0 && n_imag == 0.0)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "n_real = 1, n_imag = 0; ADA needs m != 1 (the particle must differ "
                             "from the medium)");
    double qe, qa;
    sq__ada_eval(x, n_real, n_imag, &qe, &qa);
    out->qext = qe;
    out->qabs = qa;
    out->qsca = qe - qa;
    out->qback = NAN;
    out->g = NAN;
    out->terms = 0;
    return SQ_OK;
}

sq_result sq_dust_refractive_index(double wavelength_m, double *n_real, double *n_imag)
{
    if (n_real) *n_real = 0.0;
    if (n_imag) *n_imag = 0.0;
    sq_result r = sq__optics_check_positive("wavelength_m", wavelength_m);
    if (r != SQ_OK) return r;
    /* Fresh Saharan dust: k(550 nm) = 0.0010 (Fouquart et al. 1987), with the spectral shape of
     * the AERONET desert-dust retrievals (Dubovik et al. 2002: k = 0.0025 at 440 nm, 0.0014 at
     * 670 nm, linear in between, constant outside) scaled to that value. */
    static const double k550 = 0.0010, l0 = 440.0, l1 = 670.0, k0 = 0.0025, k1 = 0.0014;
    double l = wavelength_m * 1e9;
    l = l < l0 ? l0 : (l > l1 ? l1 : l);
    const double shape = k0 + (l - l0) / (l1 - l0) * (k1 - k0);
    const double shape550 = k0 + (550.0 - l0) / (l1 - l0) * (k1 - k0);
    if (n_real) *n_real = 1.53;
    if (n_imag) *n_imag = k550 * shape / shape550;
    return SQ_OK;
}
