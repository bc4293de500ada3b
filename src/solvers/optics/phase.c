/* phase.c — Henyey–Greenstein phase function and its exact inverse-CDF sampling (SPEC §2.6,
 * S0 eq. 3.18; Henyey & Greenstein 1941). cos_theta is the dot product of the PROPAGATION
 * directions of incident and scattered light, so g > 0 means forward scattering (SPEC §0.3). */
#include <math.h>

#include "optics_internal.h"

#define PI 3.14159265358979323846

double sq_hg_phase(double cos_theta, double g)
{
    const double den = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * PI * den * sqrt(den));
}

/* CDF from cos_theta = −1: u(mu) = (1 − g²)/(2g) [1/sqrt(1 + g² − 2g mu) − 1/(1 + g)], inverted:
 * mu = (1 + g² − ((1 − g²)/(1 − g + 2 g u))²) / (2g); u = 0 gives −1, u = 1 gives +1. For
 * |g| < 1e-6 the formula cancels (relative error ~ 1e-16/|g|) and the isotropic 2u − 1 is within
 * 1e-6 of it. */
double sq_hg_sample_cos(double g, double u)
{
    if (u < 0.0) u = 0.0;
    if (u > 1.0) u = 1.0;
    if (fabs(g) < 1e-6) return 2.0 * u - 1.0;
    const double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    double mu = (1.0 + g * g - s * s) / (2.0 * g);
    if (mu > 1.0) mu = 1.0;
    if (mu < -1.0) mu = -1.0;
    return mu;
}

void sq_hg_sample_direction(const double dir_in[3], double g, double u1, double u2,
                            double dir_out[3])
{
    const double mu = sq_hg_sample_cos(g, u1);
    const double st = sqrt(fmax(0.0, 1.0 - mu * mu));
    const double phi = 2.0 * PI * u2;
    const double w[3] = {dir_in[0], dir_in[1], dir_in[2]};
    /* orthonormal basis (t, b, w) around the incident direction (Frisvad-style branch) */
    double t[3];
    if (fabs(w[0]) > 0.9) {
        t[0] = -w[1];
        t[1] = w[0];
        t[2] = 0.0;
    } else {
        t[0] = 0.0;
        t[1] = -w[2];
        t[2] = w[1];
    }
    const double tn = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    t[0] /= tn;
    t[1] /= tn;
    t[2] /= tn;
    const double b[3] = {w[1] * t[2] - w[2] * t[1], w[2] * t[0] - w[0] * t[2],
                         w[0] * t[1] - w[1] * t[0]};
    const double cp = cos(phi) * st, sp = sin(phi) * st;
    double o[3];
    for (int i = 0; i < 3; i++) o[i] = mu * w[i] + cp * t[i] + sp * b[i];
    const double on = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    for (int i = 0; i < 3; i++) dir_out[i] = o[i] / on;
}
