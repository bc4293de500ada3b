/* cloud.c — extinction of cloud condensate in the geometric-optics limit (SPEC §8, issue 10):
 * beta = 3 C / (2 rho_p r_eff). The derivation and the default radii are in
 * include/squall/optics.h and docs/wrf.md. */
#include "optics_internal.h"

double sq_cloud_extinction(double mass_kg_m3, double particle_density_kg_m3, double r_eff_m)
{
    if (!(mass_kg_m3 > 0.0)) return 0.0;
    return 3.0 * mass_kg_m3 / (2.0 * particle_density_kg_m3 * r_eff_m);
}
