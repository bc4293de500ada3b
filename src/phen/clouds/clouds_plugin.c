/* clouds_plugin.c — the clouds phenomenon's parameter table (scene keys, units, defaults, ranges,
 * docs) and its plug-in vtable. Defaults S4 does not give are chosen and justified here and in
 * docs/phen/clouds.md. */
#include <stddef.h>

#include "clouds_internal.h"
#include "squall/plugin.h"

#define S sq_clouds_desc
#include "phen/plugin_glue.h"

#define PATH(key, field, deftext, doc)                                                         \
    {key, SQ_PARAM_STRING, "", offsetof(S, field), 0, 0, 0, deftext, NULL, 0, 0, SQ_PARAM_PATH, doc}

/* a bool that applies live (drawing and lighting settings) */
#define BL(key, field, doc)                                                                        \
    {key, SQ_PARAM_BOOL, "", offsetof(S, field), 0, 0, 1, NULL, NULL, 0, 0, L, doc}

static const sq_param params[] = {
    E("source", source, "wrf|cumulus|stratocumulus",
      "Where the clouds come from: a WRF output file (wrf.file), or an analytic field of fair-"
      "weather cumuli or a broken stratocumulus deck over the world's terrain (tests, benchmarks)."),
    PATH("wrf.file", wrf_file, "",
         "WRF output (wrfout, netCDF-3 or netCDF-4) read through the WRF reader; a relative path "
         "is taken against the scene file's folder (a preset's: the source tree)."),
    D("wrf.start_s", start_s, "s", 0, 0, 1e9, Z,
      "File time at simulation time 0, seconds after the first stored time; fields between "
      "stored times are interpolated, after the last one it is held."),
    {"seed", SQ_PARAM_U64, "", offsetof(S, seed), 0, 0, 0, NULL, NULL, 0, 0, Z,
     "Seed of the particles, the sub-grid pattern and the leader order (0 is a valid seed)."},
    I("synthetic.nx", synthetic_cells[0], "1", 48, 4, 1024, "Analytic field: cells along x."),
    I("synthetic.ny", synthetic_cells[1], "1", 48, 4, 1024, "Analytic field: cells along y."),
    I("synthetic.nz", synthetic_cells[2], "1", 24, 4, 512, "Analytic field: levels."),
    D("synthetic.size_x_m", synthetic_size_m[0], "m", 12000, 100, 1e7, 0,
      "Analytic field: extent along x, centred on the world origin."),
    D("synthetic.size_y_m", synthetic_size_m[1], "m", 12000, 100, 1e7, 0,
      "Analytic field: extent along y."),
    D("synthetic.depth_m", synthetic_size_m[2], "m", 3000, 50, 2e4, 0,
      "Analytic field: cloud layer depth above the base (cumulus tops reach 45-90 % of it)."),
    D("synthetic.base_m", synthetic_base_m, "m", 800, 10, 2e4, 0,
      "Analytic field: cloud base above the terrain (fair-weather cumulus ~ 0.5-1.5 km)."),
    D("synthetic.lwc_g_m3", synthetic_lwc_g_m3, "g/m3", 0.6, 1e-4, 10, 0,
      "Analytic field: peak liquid water content (cumulus 0.2-1 g/m3)."),
    I("synthetic.clouds", synthetic_clouds, "1", 5, 1, 64, "Analytic cumulus field: towers."),
    D("optics.reff_droplet_um", reff_droplet_um, "um", 10, 1, 100, 0,
      "Effective radius of cloud droplets (ISCCP: continental 8.5, marine 11.8 um)."),
    D("optics.reff_ice_um", reff_ice_um, "um", 25, 1, 1000, 0,
      "Effective radius of cloud ice (mid-latitude cirrus 20-40 um)."),
    D("optics.reff_snow_um", reff_snow_um, "um", 100, 1, 10000, 0,
      "Effective radius of snow (what UPP's Stoelinga-Warner snow extinction implies)."),
    D("optics.reff_rain_um", reff_rain_um, "um", 500, 10, 10000, 0,
      "Effective radius of rain (what UPP's Stoelinga-Warner rain extinction implies)."),
    D("optics.g_droplet", g_droplet, "1", 0.85, -0.99, 0.99, 0,
      "Henyey-Greenstein asymmetry of droplets (Mie: 0.85-0.87 in the visible). S4's Rayleigh "
      "is wrong for droplets (SPEC 8.4)."),
    D("optics.g_ice", g_ice, "1", 0.75, -0.99, 0.99, 0,
      "Henyey-Greenstein asymmetry of ice crystals (roughened/aggregates ~0.75)."),
    B("optics.reff_fixed", reff_fixed,
      "Use the fixed effective radii everywhere; false: ice and rain radii from the number "
      "concentrations QNICE/QNRAIN where the file has them (exponential size distributions)."),
    B("optics.rayleigh", rayleigh,
      "S4's Rayleigh phase function instead of Henyey-Greenstein: for reproducing the seed only."),
    D("cloud.threshold_g_m3", threshold_g_m3, "g/m3", 0.01, 1e-6, 10, 0,
      "A cell is cloud when cloud water + ice + snow reach this (0.01 g/m3, a common in-situ "
      "cloud-edge threshold); clouds are the 6-connected sets of such cells."),
    B("cloud.no_subgrid", no_subgrid,
      "No sub-grid structure; false: the cloud fraction of a cell is covered by an fBm pattern that keeps "
      "the cell's mean extinction (for coarse grids such as the 30 km sample)."),
    D("cloud.subgrid_scale_m", subgrid_scale_m, "m", 6000, 10, 1e6, 0,
      "Horizontal size of the sub-grid cloud cells (a quarter of it vertically)."),
    D("cloud.fraction", cloud_fraction, "1", 1, 0.01, 1, 0,
      "Cloud fraction of cloudy cells where the source gives none: no CLDFRA, a CLDFRA of only "
      "0 and 1 (a cloud flag), or CLDFRA 0 in a cell with condensate; < 1 breaks decks into "
      "cells."),
    I("particles.count", particles, "1", 15000, 1, 10000000,
      "Particles filling the clouds (S4: 2000-15000). Memory: 200 bytes each."),
    D("particles.per_km3", particles_per_km3, "1/km3", 0, 0, 1e12, Z,
      "If > 0: the particle count is this density times the clouds' volume (in-cloud, at time "
      "0) instead of particles.count; refused before allocating beyond the memory limit."),
    D("particles.radius_m", radius_m, "m", 0, 0, 1e6, Z,
      "Billboard radius; 0 = 1.3 x the mean particle spacing of the cloud volume."),
    D("particles.lifetime_s", lifetime_s, "s", 1800, 1, 1e7, 0,
      "Particle life (+-25 %); at its end a particle is re-initialised from the current field "
      "(S4 §2.2 step 4)."),
    B("plain", plain,
      "Draw every particle (the plain particle system) instead of the structured particles, the "
      "leader clusters of similar particles (S4 §2.1-2.2)."),
    D("cluster.radius_m", cluster_radius_m, "m", 0, 0, 1e6, Z,
      "Position thresholds sigma = 1 - radius / (max - min) per axis; 0 = the particle radius."),
    D("cluster.sigma_density", sigma_density, "1", 0.8, 1e-3, 1, 0,
      "Threshold of the density attribute (local extinction / maximum, measure (1))."),
    D("cluster.sigma_stage", sigma_stage, "1", 0.6, 1e-3, 1, 0,
      "Threshold of the life-stage attribute (4 stages, measure (2)): 0.6 allows neighbours."),
    D("cluster.sigma_phase", sigma_phase, "1", 0.5, 1e-3, 1, 0,
      "Threshold of the phase attribute (liquid/mixed/ice, measure (3) over the clouds)."),
    E("cluster.symbolic", symbolic, "s4|vdm",
      "Measure (3): as S4 prints it (clamped to [0, 1]) or the value-difference metric."),
    E("mode", mode, "particles|volume",
      "particles: MFS-lit billboards and impostors (S4); volume: the same extinction field drawn "
      "by half-angle slicing (for comparison)."),
    BL("lighting.splat_opacity", splat_opacity,
      "Harris/S4 opacity from the splat alpha, (1 - e^-tau_splat) eta(t) with tau = 80, instead "
      "of the physical 1 - exp(-tau eta(t)) (seed reproduction)."),
    D("lighting.eta1", eta1, "1", 0.4, 0.01, 1, L, "Splat peak eta_1 (S4 eq. 5: 0.4)."),
    D("lighting.tau_splat", tau_splat, "1", 80, 0.01, 1e3, L,
      "S4's particle optical depth tau_k = 80 (Harris's SkyWorks extinction); only with "
      "splat_opacity."),
    D("lighting.splat_noise", splat_noise, "1", 0.5, 1e-3, 1, L,
      "Texture of the splat: its radius scaled by a mean-one value noise of this amplitude fixed "
      "to each particle, so overlapping opaque splats do not read as discs."),
    BL("lighting.smooth_splat", smooth_splat,
      "S4's smooth splat (no texture noise), for reproducing the seed."),
    D("lighting.albedo", albedo, "1", 0.999, 0, 1, L,
      "Single-scattering albedo (cloud droplets ~0.9999 in the visible; Harris used 0.9)."),
    D("lighting.gamma_sr", gamma_sr, "sr", 0.09, 1e-4, 12.57, L,
      "Forward solid angle kept in the light (Harris's 0.09 sr read-back)."),
    I("lighting.buffer", light_buffer, "1", 512, 8, 4096, "Light-buffer texels per side."),
    BL("lighting.harris_only", harris_only,
      "Harris's forward-scattered light only; false: the diffuse light of a two-stream slab is "
      "added (clouds stay bright away from the sun)."),
    BL("lighting.no_shadows", no_shadows, "The clouds do not shadow the terrain."),
    D("impostor.dist_3d_m", dist_3d_m, "m", 60000, 1, 1e8, L,
      "Clouds nearer than this are drawn as particles (S4's dist_3D)."),
    D("impostor.dist_m", dist_impostor_m, "m", 90000, 1, 1e8, L,
      "Clouds farther than this are drawn as impostors (S4's dist_impostor); between the two "
      "both, cross-faded."),
    D("impostor.angle_deg", impostor_angle_deg, "deg", 2, 0.01, 90, L,
      "An impostor is re-rendered when the view direction to its cloud turns by more."),
    BL("impostor.off", no_impostors, "No impostors: particles at every distance."),
    I("volume.nx", volume_cells[0], "1", 128, 4, 1024, "Volume mode: voxels along x."),
    I("volume.ny", volume_cells[1], "1", 128, 4, 1024, "Volume mode: voxels along y."),
    I("volume.nz", volume_cells[2], "1", 48, 4, 1024, "Volume mode: voxels along z."),
};

#undef SQ__PHEN_STATE_SAVE
#define SQ__PHEN_STATE_SAVE sq__clouds_save_state
#undef SQ__PHEN_STATE_LOAD
#define SQ__PHEN_STATE_LOAD sq__clouds_load_state

/* Live changes: the live entries of desc (lighting and impostor settings) onto the running
 * clouds (clouds.c). */
static sq_result clouds_apply_live(void *self, const void *desc)
{
    return sq__clouds_apply_live((sq_clouds *)self, params, sizeof params / sizeof params[0],
                                 (const sq_clouds_desc *)desc);
}

#undef SQ__PHEN_APPLY_LIVE
#define SQ__PHEN_APPLY_LIVE clouds_apply_live
SQ__PHEN_PLUGIN(clouds, "clouds from WRF output: structured particles, MFS lighting, impostors (S4)",
                0);
