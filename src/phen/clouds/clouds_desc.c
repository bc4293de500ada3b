/* clouds_desc.c — defaults and validation of the clouds phenomenon's desc (messages name the
 * layer key, the value and the rule), and its memory estimate. The parameter table in
 * clouds_plugin.c documents every default. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "clouds_internal.h"
#include "world/world_struct.h"

#define MAX_PARTICLES 10000000
#define P "sq_clouds_desc." /* the scene shows it as layers.<name>. */

sq_result sq_clouds_desc_resolve(const sq_clouds_desc *in, sq_clouds_desc *out)
{
    sq_clouds_desc d;
    if (in) d = *in;
    else memset(&d, 0, sizeof d);
    for (int a = 0; a < 3; a++) {
        static const int cells[3] = {48, 48, 24};
        static const double size[3] = {12000.0, 12000.0, 3000.0};
        static const int vox[3] = {128, 128, 48};
        if (d.synthetic_cells[a] == 0) d.synthetic_cells[a] = cells[a];
        if (d.synthetic_size_m[a] == 0.0) d.synthetic_size_m[a] = size[a];
        if (d.volume_cells[a] == 0) d.volume_cells[a] = vox[a];
    }
    if (d.synthetic_base_m == 0.0) d.synthetic_base_m = 800.0;
    if (d.synthetic_lwc_g_m3 == 0.0) d.synthetic_lwc_g_m3 = 0.6;
    if (d.synthetic_clouds == 0) d.synthetic_clouds = 5;
    if (d.reff_droplet_um == 0.0) d.reff_droplet_um = SQ_CLOUD_DROPLET_R_EFF_M * 1e6;
    if (d.reff_ice_um == 0.0) d.reff_ice_um = SQ_CLOUD_ICE_R_EFF_M * 1e6;
    if (d.reff_snow_um == 0.0) d.reff_snow_um = SQ_CLOUD_SNOW_R_EFF_M * 1e6;
    if (d.reff_rain_um == 0.0) d.reff_rain_um = SQ_CLOUD_RAIN_R_EFF_M * 1e6;
    if (d.g_droplet == 0.0) d.g_droplet = SQ_CLOUD_DROPLET_G;
    if (d.g_ice == 0.0) d.g_ice = SQ_CLOUD_ICE_G;
    if (d.threshold_g_m3 == 0.0) d.threshold_g_m3 = 0.01;
    if (d.subgrid_scale_m == 0.0) d.subgrid_scale_m = 6000.0;
    if (d.cloud_fraction == 0.0) d.cloud_fraction = 1.0;
    if (d.particles == 0) d.particles = 15000;
    if (d.lifetime_s == 0.0) d.lifetime_s = 1800.0;
    if (d.eta1 == 0.0) d.eta1 = 0.4;
    if (d.splat_noise == 0.0) d.splat_noise = 0.5;
    if (d.sigma_density == 0.0) d.sigma_density = 0.8;
    if (d.sigma_stage == 0.0) d.sigma_stage = 0.6;
    if (d.sigma_phase == 0.0) d.sigma_phase = 0.5;
    if (d.tau_splat == 0.0) d.tau_splat = 80.0;
    if (d.albedo == 0.0) d.albedo = 0.999;
    if (d.gamma_sr == 0.0) d.gamma_sr = 0.09;
    if (d.light_buffer == 0) d.light_buffer = 512;
    if (d.dist_3d_m == 0.0) d.dist_3d_m = 60000.0;
    if (d.dist_impostor_m == 0.0) d.dist_impostor_m = 90000.0;
    if (d.impostor_angle_deg == 0.0) d.impostor_angle_deg = 2.0;
    if (out) *out = d;
    return SQ_OK;
}

sq_result sq_clouds_validate(sq_context *ctx, const sq_clouds_desc *d, const sq_world *world)
{
    (void)world;
    if (d->source < SQ_CLOUDS_SOURCE_WRF || d->source > SQ_CLOUDS_SOURCE_STRATOCUMULUS)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "clouds",
                        P "source = %d; must be wrf (0), cumulus (1) or stratocumulus (2)",
                        d->source);
    if (d->source == SQ_CLOUDS_SOURCE_WRF && !d->wrf_file[0])
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "clouds",
                        P "wrf.file is empty; source = wrf needs a WRF output (wrfout) file");
    if (!(d->start_s >= 0.0) || !isfinite(d->start_s))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "clouds",
                        P "wrf.start_s = %g s; must be finite and >= 0", d->start_s);
    if (d->particles < 1 || d->particles > MAX_PARTICLES)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "clouds",
                        P "particles.count = %d; must be in 1..%d", d->particles,
                        MAX_PARTICLES);
    if (!(d->dist_impostor_m >= d->dist_3d_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "clouds",
                        P "impostor.dist_m = %g m is below impostor.dist_3d_m = %g m; the "
                        "cross-fade band needs impostor.dist_3d_m <= impostor.dist_m",
                        d->dist_impostor_m, d->dist_3d_m);
    if (d->mode == SQ_CLOUDS_MODE_PARTICLES && d->rayleigh && !d->splat_opacity)
        sq_log(ctx, SQ_LOG_WARN, "clouds",
               P "optics.rayleigh without lighting.splat_opacity mixes S4's phase with "
               "physical opacities (a seed reproduction uses both)");
    const uint64_t bytes = sq_clouds_memory_bytes(d);
    char what[160];
    snprintf(what, sizeof what, P "particles.count = %d: %d particles x %u bytes", d->particles,
             d->particles, SQ__CLOUDS_BYTES_PER_PARTICLE);
    return sq_context_check_memory(ctx, bytes, what);
}

uint64_t sq_clouds_memory_bytes(const sq_clouds_desc *d)
{
    uint64_t bytes = (uint64_t)d->particles * SQ__CLOUDS_BYTES_PER_PARTICLE;
    if (d->source != SQ_CLOUDS_SOURCE_WRF)
        bytes += (uint64_t)d->synthetic_cells[0] * (uint64_t)d->synthetic_cells[1] *
                 (uint64_t)d->synthetic_cells[2] * 120u;
    if (d->mode == SQ_CLOUDS_MODE_VOLUME)
        bytes += (uint64_t)d->volume_cells[0] * (uint64_t)d->volume_cells[1] *
                 (uint64_t)d->volume_cells[2] * sizeof(float);
    return bytes;
}
