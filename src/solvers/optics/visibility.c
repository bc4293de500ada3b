/* visibility.c — Koschmieder meteorological visibility (SPEC §2.7, S0 eq. 3.23; Koschmieder
 * 1924): V = ln(1/eps) / beta_ext, eps the contrast threshold (0.05 in S0 and the WMO MOR;
 * 0.02 in the Met Office UM and UPP), beta_ext = C k_ext for a dust mass concentration C and
 * mass extinction k_ext (use beta_ext at 550 nm). */
#include <math.h>

#include "optics_internal.h"

static sq_result resolve_contrast(double *contrast)
{
    if (*contrast == 0.0) *contrast = SQ_VISIBILITY_CONTRAST_DEFAULT;
    if (!(isfinite(*contrast) && *contrast > 0.0 && *contrast < 1.0))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "contrast = %g; the contrast threshold must be in (0, 1) (0 "
                             "selects %g)",
                             *contrast, SQ_VISIBILITY_CONTRAST_DEFAULT);
    return SQ_OK;
}

sq_result sq_visibility_from_extinction(double beta_ext_per_m, double contrast, double *out_m)
{
    if (out_m) *out_m = 0.0;
    sq_result r = sq__optics_check_nonnegative("beta_ext_per_m", beta_ext_per_m);
    if (r == SQ_OK) r = resolve_contrast(&contrast);
    if (r != SQ_OK) return r;
    if (!out_m) return sq__set_error(SQ_ERR_INVALID_ARG, "visibility: out is NULL");
    *out_m = beta_ext_per_m > 0.0 ? -log(contrast) / beta_ext_per_m : HUGE_VAL;
    return SQ_OK;
}

sq_result sq_extinction_for_visibility(double visibility_m, double contrast, double *out_per_m)
{
    if (out_per_m) *out_per_m = 0.0;
    sq_result r = sq__optics_check_positive("visibility_m", visibility_m);
    if (r == SQ_OK) r = resolve_contrast(&contrast);
    if (r != SQ_OK) return r;
    if (!out_per_m) return sq__set_error(SQ_ERR_INVALID_ARG, "extinction: out is NULL");
    *out_per_m = -log(contrast) / visibility_m;
    return SQ_OK;
}

sq_result sq_visibility_from_concentration(double conc_kg_m3, double mass_ext_m2_per_kg,
                                           double contrast, double *out_m)
{
    if (out_m) *out_m = 0.0;
    sq_result r = sq__optics_check_nonnegative("concentration_kg_m3", conc_kg_m3);
    if (r == SQ_OK) r = sq__optics_check_positive("mass_extinction_m2_per_kg", mass_ext_m2_per_kg);
    if (r != SQ_OK) return r;
    return sq_visibility_from_extinction(conc_kg_m3 * mass_ext_m2_per_kg, contrast, out_m);
}

sq_result sq_concentration_for_visibility(double visibility_m, double mass_ext_m2_per_kg,
                                          double contrast, double *out_kg_m3)
{
    if (out_kg_m3) *out_kg_m3 = 0.0;
    sq_result r = sq__optics_check_positive("mass_extinction_m2_per_kg", mass_ext_m2_per_kg);
    if (r != SQ_OK) return r;
    double beta;
    r = sq_extinction_for_visibility(visibility_m, contrast, &beta);
    if (r != SQ_OK) return r;
    if (!out_kg_m3) return sq__set_error(SQ_ERR_INVALID_ARG, "concentration: out is NULL");
    *out_kg_m3 = beta / mass_ext_m2_per_kg;
    return SQ_OK;
}
