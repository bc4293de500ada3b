/* optics_internal.h — helpers shared by the optics solver files (SPEC §2): argument checks that
 * set the error text, the ADA kernel used inside the bulk integral, the normal CDF difference. */
#ifndef SQ_OPTICS_INTERNAL_H
#define SQ_OPTICS_INTERNAL_H

#include <complex.h>
#include <math.h>

#include "core/core_internal.h"
#include "squall/optics.h"

/* Each check returns SQ_OK or SQ_ERR_INVALID_ARG with "what = value; rule". */
sq_result sq__optics_check_positive(const char *what, double v);      /* finite, > 0 */
sq_result sq__optics_check_nonnegative(const char *what, double v);   /* finite, >= 0 */
sq_result sq__optics_check_index(const char *what_real, const char *what_imag, double n_real,
                                 double n_imag);                       /* n > 0, k >= 0 */

/* re + i*im built exactly (no multiplication by I, so infinities and signed zeros survive).
 * C11's CMPLX is missing from glibc's <complex.h> under clang, so it is not used; C11 6.2.5
 * lays a double complex out as double[2] (real part first), which this relies on. */
static inline double complex sq__cmplx(double re, double im)
{
    union {
        double complex z;
        double part[2];
    } u;
    u.part[0] = re;
    u.part[1] = im;
    return u.z;
}

/* ADA efficiencies without argument checks (x > 0, m != 1 assumed). */
void sq__ada_eval(double x, double n_real, double n_imag, double *qext, double *qabs);

/* The ln r trapezoid quadrature shared by sq_lognormal_quadrature and the bulk optics. */
#define SQ__QUADRATURE_MAX_NODES 100000
typedef struct sq__quadrature {
    sq_lognormal dist;
    double a, b, h; /* ln r_min, ln r_max, node spacing in ln r */
    int nodes;
} sq__quadrature;
/* Validates d, the range (both 0 = auto) and the node count. */
sq_result sq__quadrature_setup(const sq_lognormal *d, double r_min_m, double r_max_m, int nodes,
                               sq__quadrature *q);
/* Node i: radius and weight (trapezoid weight x P per unit ln r). */
void sq__quadrature_node(const sq__quadrature *q, int i, double *radius_m, double *weight);

/* Phi(b) − Phi(a) for the standard normal, accurate in both tails (a <= b). */
double sq__normal_cdf_diff(double a, double b);

#endif
