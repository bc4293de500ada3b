/* mie.c — exact Lorenz–Mie efficiencies of a homogeneous sphere (SPEC §2.1; Bohren & Huffman
 * 1983 ch. 4, Wiscombe 1980 "Improved Mie scattering algorithms").
 *
 * Series: a_n = [(D_n/m + n/x) psi_n − psi_{n−1}] / [(D_n/m + n/x) xi_n − xi_{n−1}],
 *         b_n = [(m D_n + n/x) psi_n − psi_{n−1}] / [(m D_n + n/x) xi_n − xi_{n−1}],
 * psi_n, chi_n (xi_n = psi_n − i chi_n) by upward recurrence in x (stable up to n ~ x + x^(1/3)),
 * D_n(mx) = psi_n'/psi_n by DOWNWARD recurrence D_{n−1} = n/y − 1/(D_n + n/y) started at
 * N = max(nstop, |mx|) + 16 from the exact value given by Lentz's continued fraction
 * (J_{n−1/2}/J_{n+1/2}), so no start-margin heuristic can bias weakly absorbing large spheres
 * (reference/mie_cases.md pitfall (e)).
 *
 * Memory: the D_n are needed in upward order but produced downward. Instead of an O(nstop)
 * array, the downward pass stores a checkpoint every MIE_CHUNK terms; each chunk is then
 * recomputed downward from its checkpoint into a small buffer (same arithmetic, identical
 * values) and consumed upward. Everything lives on the stack; cost is two D_n recurrences.
 *
 * Sums (Bohren & Huffman 4.61, 4.62; Wiscombe): Qext = 2/x² Σ(2n+1) Re(a_n + b_n),
 * Qsca = 2/x² Σ(2n+1)(|a_n|² + |b_n|²), g Qsca = 4/x² Σ [n(n+2)/(n+1) Re(a_n a*_{n+1} +
 * b_n b*_{n+1}) + (2n+1)/(n(n+1)) Re(a_n b*_n)], Qback = |Σ(2n+1)(−1)^n (a_n − b_n)|² / x². */
#include <complex.h>
#include <math.h>
#include <stdbool.h>

#include "optics_internal.h"

#define MIE_CHUNK 512
#define MIE_MAX_CHUNKS 256 /* nstop <= 131072, enough for x <= 1e5 */

/* Wiscombe's number of terms (his 4.05 branch, used everywhere: a few extra terms are harmless
 * and the small-x branches need fewer). */
static int mie_nstop(double x) { return (int)(x + 4.05 * cbrt(x) + 2.0); }

/* D_n(z) from the continued fraction of J_{n−1/2}(z)/J_{n+1/2}(z) (modified Lentz):
 * D_n = −n/z + b_0 − 1/(b_1 − 1/(b_2 − ...)), b_j = (2n + 2j + 1)/z. Converges in a few tens of
 * terms for n >= |z|, which is where it is used. */
static double complex lentz_dn(int n, double complex z)
{
    const double tiny = 1e-300;
    const double complex zinv = 1.0 / z;
    double complex f = (2.0 * n + 1.0) * zinv;
    if (cabs(f) < tiny) f = tiny;
    double complex c = f, d = 0.0;
    for (int j = 1; j < 10000000; j++) {
        const double complex b = (2.0 * (n + j) + 1.0) * zinv;
        d = b - d;
        if (cabs(d) < tiny) d = tiny;
        c = b - 1.0 / c;
        if (cabs(c) < tiny) c = tiny;
        d = 1.0 / d;
        const double complex delta = c * d;
        f *= delta;
        if (cabs(delta - 1.0) < 1e-16) break;
    }
    return f - n * zinv;
}

/* One downward step D_n -> D_{n−1}. Used by both passes so they agree bit for bit. */
static inline double complex dn_down(int n, double complex zinv, double complex dn)
{
    const double complex nz = n * zinv;
    return nz - 1.0 / (dn + nz);
}

/* psi_1(x) = sin x / x − cos x without cancellation for small x. */
static double psi1_of(double x)
{
    if (x < 0.1) {
        const double x2 = x * x;
        /* x²/3 − x⁴/30 + x⁶/840 − x⁸/45360 + x¹⁰/3991680 */
        return x2 * (1.0 / 3.0 -
                     x2 * (1.0 / 30.0 - x2 * (1.0 / 840.0 - x2 * (1.0 / 45360.0 -
                                                                  x2 / 3991680.0))));
    }
    return sin(x) / x - cos(x);
}

/* The series for a sphere of index m (pec = false) or a perfect conductor (pec = true). */
static void mie_series(double x, double complex m, bool pec, sq_mie_result *out)
{
    const int nstop = mie_nstop(x);
    const int nchunks = (nstop + MIE_CHUNK - 1) / MIE_CHUNK;
    double complex cp[MIE_MAX_CHUNKS];
    double complex buf[MIE_CHUNK];
    const double complex y = m * x;
    const double complex yinv = pec ? 0.0 : 1.0 / y;

    /* Pass 1: downward from the exact start, keeping the checkpoints D_hi(c). */
    if (!pec) {
        const double ay = cabs(y);
        const int nmx = (ay > nstop ? (int)ay : nstop) + 16;
        double complex d = lentz_dn(nmx, y);
        for (int n = nmx; n >= 1; n--) {
            if (n <= nstop && (n % MIE_CHUNK == 0 || n == nstop)) cp[(n - 1) / MIE_CHUNK] = d;
            d = dn_down(n, yinv, d);
        }
    }

    const double xinv = 1.0 / x;
    double psi_m1 = cos(x), psi0 = sin(x); /* psi_{n−2}, psi_{n−1} */
    double chi_m1 = -sin(x), chi0 = cos(x);
    double sext = 0.0, ssca = 0.0, sg = 0.0;
    double complex sback = 0.0, a_prev = 0.0, b_prev = 0.0;

    for (int c = 0; c < nchunks; c++) {
        const int lo = c * MIE_CHUNK + 1;
        const int hi = (c + 1) * MIE_CHUNK < nstop ? (c + 1) * MIE_CHUNK : nstop;
        if (!pec) {
            buf[hi - lo] = cp[c];
            for (int n = hi; n > lo; n--) buf[n - 1 - lo] = dn_down(n, yinv, buf[n - lo]);
        }
        for (int n = lo; n <= hi; n++) {
            const double fn = (double)n;
            double psi, chi;
            if (n == 1) {
                psi = psi1_of(x);
                chi = chi0 * xinv - chi_m1;
            } else {
                psi = (2.0 * fn - 1.0) * xinv * psi0 - psi_m1;
                chi = (2.0 * fn - 1.0) * xinv * chi0 - chi_m1;
            }
            const double complex xi = sq__cmplx(psi, -chi);
            const double complex xi0 = sq__cmplx(psi0, -chi0);
            double complex an, bn;
            if (pec) {
                const double t = fn * xinv;
                an = (t * psi - psi0) / (t * xi - xi0);
                bn = psi / xi;
            } else {
                const double complex dn = buf[n - lo];
                const double complex ta = dn / m + fn * xinv;
                const double complex tb = m * dn + fn * xinv;
                an = (ta * psi - psi0) / (ta * xi - xi0);
                bn = (tb * psi - psi0) / (tb * xi - xi0);
            }
            const double w = 2.0 * fn + 1.0;
            sext += w * (creal(an) + creal(bn));
            ssca += w * (creal(an) * creal(an) + cimag(an) * cimag(an) + creal(bn) * creal(bn) +
                         cimag(bn) * cimag(bn));
            sg += w / (fn * (fn + 1.0)) * creal(an * conj(bn));
            if (n > 1)
                sg += (fn - 1.0) * (fn + 1.0) / fn *
                      creal(a_prev * conj(an) + b_prev * conj(bn));
            sback += (n % 2 ? -w : w) * (an - bn);
            a_prev = an;
            b_prev = bn;
            psi_m1 = psi0;
            psi0 = psi;
            chi_m1 = chi0;
            chi0 = chi;
        }
    }

    const double x2 = x * x;
    out->qext = 2.0 / x2 * sext;
    out->qsca = 2.0 / x2 * ssca;
    out->qabs = out->qext - out->qsca;
    if (out->qabs < 0.0 || cimag(m) == 0.0 || pec) out->qabs = 0.0;
    out->g = out->qsca > 0.0 ? 4.0 / x2 * sg / out->qsca : 0.0;
    out->qback = (creal(sback) * creal(sback) + cimag(sback) * cimag(sback)) / x2;
    out->terms = nstop;
}

static sq_result check_x(double x)
{
    if (!(isfinite(x) && x > 0.0 && x <= SQ_MIE_MAX_SIZE_PARAMETER))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "size parameter x = %g; must be finite, > 0 and <= %g", x,
                             SQ_MIE_MAX_SIZE_PARAMETER);
    return SQ_OK;
}

sq_result sq_mie_sphere(double x, double n_real, double n_imag, sq_mie_result *out)
{
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_mie_sphere: out is NULL");
    *out = (sq_mie_result){0};
    sq_result r = check_x(x);
    if (r == SQ_OK) r = sq__optics_check_index("n_real", "n_imag", n_real, n_imag);
    if (r != SQ_OK) return r;
    mie_series(x, sq__cmplx(n_real, n_imag), false, out);
    return SQ_OK;
}

sq_result sq_mie_sphere_conducting(double x, sq_mie_result *out)
{
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_mie_sphere_conducting: out is NULL");
    *out = (sq_mie_result){0};
    sq_result r = check_x(x);
    if (r != SQ_OK) return r;
    mie_series(x, 1.0, true, out);
    return SQ_OK;
}
