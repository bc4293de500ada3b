/* cloud.c — extinction of cloud condensate in the geometric-optics limit (SPEC §8, issue 10):
 * beta = 3 C / (2 rho_p r_eff), the one home of the formula (derivation and default radii in
 * include/squall/optics.h); effective radii from number concentrations (gamma size
 * distributions); the extinction-weighted mixture of species; the Rayleigh phase function kept
 * for reproducing S4. */
#include <math.h>

#include "optics_internal.h"

#define PI 3.14159265358979323846
#define REFF_MIN_M 1.0e-6
#define REFF_MAX_M 1.0e-2

static const char *const species_name[SQ_HYDRO_COUNT] = {"cloud", "ice", "snow", "rain",
                                                         "graupel"};

double sq_cloud_extinction(double mass_kg_m3, double particle_density_kg_m3, double r_eff_m)
{
    if (!(mass_kg_m3 > 0.0)) return 0.0;
    return 3.0 * mass_kg_m3 / (2.0 * particle_density_kg_m3 * r_eff_m);
}

sq_result sq_cloud_optics_resolve(const sq_cloud_optics *in, sq_cloud_optics *out)
{
    static const double reff_def[SQ_HYDRO_COUNT] = {
        SQ_CLOUD_DROPLET_R_EFF_M, SQ_CLOUD_ICE_R_EFF_M, SQ_CLOUD_SNOW_R_EFF_M,
        SQ_CLOUD_RAIN_R_EFF_M, SQ_CLOUD_GRAUPEL_R_EFF_M};
    static const double g_def[SQ_HYDRO_COUNT] = {SQ_CLOUD_DROPLET_G, SQ_CLOUD_ICE_G,
                                                 SQ_CLOUD_SNOW_G, SQ_CLOUD_RAIN_G,
                                                 SQ_CLOUD_GRAUPEL_G};
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_cloud_optics_resolve: out is NULL");
    sq_cloud_optics o;
    for (int s = 0; s < SQ_HYDRO_COUNT; s++) {
        o.r_eff_m[s] = in ? in->r_eff_m[s] : 0.0;
        o.g[s] = in ? in->g[s] : 0.0;
        if (o.r_eff_m[s] == 0.0) o.r_eff_m[s] = reff_def[s];
        if (o.g[s] == 0.0) o.g[s] = g_def[s];
        if (!(o.r_eff_m[s] >= REFF_MIN_M && o.r_eff_m[s] <= REFF_MAX_M))
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "r_eff_m[%s] = %g m; must be in [%g, %g] m (0 -> default)",
                                 species_name[s], o.r_eff_m[s], REFF_MIN_M, REFF_MAX_M);
        if (!(o.g[s] > -1.0 && o.g[s] < 1.0))
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "g[%s] = %g; the HG asymmetry must be in (-1, 1) (0 -> default)",
                                 species_name[s], o.g[s]);
    }
    *out = o;
    return SQ_OK;
}

double sq_hydrometeor_density(sq_hydrometeor species)
{
    return species == SQ_HYDRO_CLOUD || species == SQ_HYDRO_RAIN ? SQ_WATER_DENSITY_KG_M3
                                                                 : SQ_ICE_DENSITY_KG_M3;
}

double sq_cloud_effective_radius(double conc_g_m3, double number_per_m3, double density_kg_m3,
                                 double mu)
{
    if (!(conc_g_m3 > 0.0) || !(number_per_m3 > 0.0) || !(density_kg_m3 > 0.0) ||
        !isfinite(conc_g_m3) || !isfinite(number_per_m3) || !(mu > -1.0))
        return 0.0;
    const double w = conc_g_m3 * 1e-3;
    const double r_v = cbrt(3.0 * w / (4.0 * PI * density_kg_m3 * number_per_m3));
    return r_v * (mu + 3.0) / cbrt((mu + 1.0) * (mu + 2.0) * (mu + 3.0));
}

double sq_cloud_mixture(const sq_cloud_optics *o, const float conc_g_m3[SQ_HYDRO_COUNT],
                        const float *r_eff_m, double *g_out)
{
    double beta = 0.0, bg = 0.0;
    for (int s = 0; s < SQ_HYDRO_COUNT; s++) {
        const double r = r_eff_m && r_eff_m[s] > 0.0f ? (double)r_eff_m[s] : o->r_eff_m[s];
        const double b = sq_cloud_extinction((double)conc_g_m3[s] * 1e-3,
                                             sq_hydrometeor_density((sq_hydrometeor)s), r);
        beta += b;
        bg += b * o->g[s];
    }
    if (g_out) *g_out = beta > 0.0 ? bg / beta : 0.0;
    return beta;
}

double sq_rayleigh_phase(double cos_theta)
{
    return 3.0 * (1.0 + cos_theta * cos_theta) / (16.0 * PI);
}
