/* optics_common.c — argument checks with messages that name the parameter, its value and the
 * rule, and the two-tailed normal-CDF difference used by the log-normal code (SPEC §2). */
#include <math.h>

#include "optics_internal.h"

sq_result sq__optics_check_positive(const char *what, double v)
{
    if (!(isfinite(v) && v > 0.0))
        return sq__set_error(SQ_ERR_INVALID_ARG, "%s = %g; must be finite and > 0", what, v);
    return SQ_OK;
}

sq_result sq__optics_check_nonnegative(const char *what, double v)
{
    if (!(isfinite(v) && v >= 0.0))
        return sq__set_error(SQ_ERR_INVALID_ARG, "%s = %g; must be finite and >= 0", what, v);
    return SQ_OK;
}

sq_result sq__optics_check_index(const char *what_real, const char *what_imag, double n_real,
                                 double n_imag)
{
    if (!(isfinite(n_real) && n_real > 0.0))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "%s = %g; the real refractive index must be finite and > 0",
                             what_real, n_real);
    if (!isfinite(n_imag))
        return sq__set_error(SQ_ERR_INVALID_ARG, "%s = %g; must be finite", what_imag, n_imag);
    if (n_imag < 0.0)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "%s = %g; must be >= 0 (m = n + ik with k >= 0 for an absorbing "
                             "material; MIEV0's n − ik means k = +|imaginary part|)",
                             what_imag, n_imag);
    return SQ_OK;
}

double sq__normal_cdf_diff(double a, double b)
{
    const double s = 0.70710678118654752440; /* 1/sqrt(2) */
    if (a >= 0.0) return 0.5 * (erfc(a * s) - erfc(b * s));
    if (b <= 0.0) return 0.5 * (erfc(-b * s) - erfc(-a * s));
    return 1.0 - 0.5 * erfc(b * s) - 0.5 * erfc(-a * s);
}
