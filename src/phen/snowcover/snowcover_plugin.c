/* snowcover_plugin.c — the snow cover's parameter table (scene keys, units, defaults, ranges,
 * docs) and its plug-in vtable. Values S2 does not give (SPEC §6.1a: map resolution, D_snow,
 * snow depth, A/B/C, K, Q, r(n)) are chosen here and justified in docs/phen/snow-cover.md. */
#include <stddef.h>

#include "snowcover_internal.h"
#include "squall/plugin.h"

#define S sq_snowcover_desc
#include "phen/plugin_glue.h"

static const sq_param params[] = {
    {"seed", SQ_PARAM_U64, "", offsetof(S, seed), 0, 0, 0, NULL, NULL, 0, 0, Z,
     "Seed of the flakes' birth positions, spin and velocity noise."},
    E("snowfall.level", level, "custom|none|light|medium|heavy",
      "custom: snowfall.rate_mmh and prior_h as given; none/light/medium/heavy (S2 Figs "
      "2.11-2.14) set them: 0, 1 mm/h x 2 h, 2.5 mm/h x 4 h, 5 mm/h x 6 h (2, 10 and 30 cm at "
      "100 kg/m3)."),
    D("snowfall.rate_mmh", snowfall_mmh, "mm/h", 0, 0, 1000, Z | L,
      "Snowfall rate as water equivalent (1 mm/h = 1 kg m-2 h-1; moderate snowfall 1-2.5)."),
    D("snowfall.density_kgm3", density_kgm3, "kg/m3", 100, 10, 917, 0,
      "Density of the lying snow: depth = water x 1000 / density (fresh snow 50-150 kg/m3)."),
    D("snowfall.prior_h", prior_h, "h", 0, 0, 1e4, Z,
      "Hours of snowfall at the rate before t = 0 (snow already lying at the start)."),
    D("snowfall.speedup", speedup, "1", 1, 1e-6, 1e9, 0,
      "Time-lapse factor of the accumulation (the flakes still fall in real time)."),
    D("snowfall.cell_m", cell_m, "m", 0, 0, 1e4, Z | A,
      "Cell of the top-down accumulation grid; 0 = the world's extent / 512, at least 1 m."),
    D("occlusion.detail_m", detail_m, "m", 250, 1, 1e5, L,
      "Snow-detail distance D_snow: the frustum is clipped here for the occlusion map; beyond, "
      "the far-field texture blend (S2 2.4.2). Not given by S2."),
    I("occlusion.map_size", map_size, "1", 1024, 64, 8192,
      "Occlusion map texels per side (the texel is the smallest power of two in metres that "
      "covers the footprint). Not given by S2."),
    I("occlusion.taps", taps, "1", 4, 1, 9,
      "Samples M of the exposure (S2 eq 2.2): 1, 4 (S2's four neighbours), 5 or 9."),
    D("occlusion.tap_radius", tap_radius, "texel", 1, 0, 16, Z | L,
      "Distance of the taps from the point, in map texels."),
    D("occlusion.bias_m", bias_m, "m", 0.05, 0, 100, Z | L,
      "Depth bias b: exposed when D_occ - D_act >= -b (plus the slope-scaled part)."),
    D("look.noise", noise, "1", 0.3, 0.01, 1, L,
      "Amplitude of the multi-octave 3D noise on the inclination f_inc and the normal (S2)."),
    D("look.noise_scale_m", noise_scale_m, "m", 2, 0.01, 1e4, L,
      "Wavelength of the noise's first octave."),
    D("look.shell_blend", shell_blend, "1", 0.5, 0.01, 1, L,
      "Direction of the snow shell: toward 0 along the smoothed normal, 1 straight up (SPEC "
      "6.3's crack-free displacement)."),
    E("look.brdf", brdf, "physical|blinn-phong",
      "physical: high albedo, forward-scattering lobe, sparkle, bluish subsurface tint; "
      "blinn-phong: S2 eqs 2.7-2.8."),
    D("look.albedo", albedo, "1", 0.9, 0.01, 1, L, "Snow albedo (fresh snow 0.8-0.95)."),
    D("look.sparkle", sparkle, "1", 0.5, 0.01, 1, L, "Strength of the glints (physical BRDF)."),
    D("look.shininess", shininess, "1", 24, 1, 1e4, L, "Blinn-Phong exponent n (S2 eq 2.7)."),
    {"flakes.count", SQ_PARAM_INT, "1", offsetof(S, flakes), 0, 0, 4000000, NULL, NULL, 0, 0, Z,
     "Falling-snow pool (S2: > 50 000; the snowy presets: 100 000); 0 = none."},
    I("flakes.layers", layers, "1", 4, 3, 5, "Depth layers of the sizing (S2: 3-5)."),
    D("flakes.near_m", near_m, "m", 1.5, 0.01, 1e4, 0,
      "The first layer starts here; nearer flakes are hidden (S2)."),
    D("flakes.reach_m", reach_m, "m", 80, 1, 1e4, 0,
      "Depth of the emitter ahead of the camera and of the last layer."),
    D("flakes.size_mrad", size_mrad, "mrad", 6, 0.01, 1000, L,
      "Base angular radius S of the first layer at D = 1 m."),
    D("flakes.layer_growth", layer_growth, "1", 1.3, 0.1, 10, L,
      "Base size ratio of successive layers (farther layers larger, so they stay visible)."),
    {"flakes.attenuation", SQ_PARAM_VEC3, "", offsetof(S, atten), 0, 0, 1e6, "0 1 0", NULL, 0, 0,
     L, "A, B, C of S2 eq 2.4: angular size S sqrt(1 / (A + B D + C D^2)); 0 0 1 is the "
        "physical 1/D."},
    D("flakes.fall_speed_mps", fall_speed_mps, "m/s", 1, 0.1, 5, 0,
      "Terminal fall speed v_t (SPEC 6.6: 0.5-1.5 m/s); drag rate k = g / v_t."),
    D("flakes.turbulence_mps", turbulence_mps, "m/s", 0, 0, 10, Z,
      "Standard deviation of the velocity noise (collisions, S2's r(n)); increments scale "
      "with sqrt(dt)."),
    D("flakes.spin_rad_s", spin_rad_s, "rad/s", 0, 0, 100, Z,
      "Largest flake spin (the snowy presets: 3); 0 = none."),
    D("wind.speed_mps", wind_speed_mps, "m/s", 0, 0, 80, Z | L,
      "Wind the flakes relax toward (drag)."),
    D("wind.dir_deg", wind_dir_deg, "deg", 0, -360, 360, Z | L,
      "Direction the wind blows toward, counter-clockwise from east."),
};

#undef SQ__PHEN_STATE_SAVE
#define SQ__PHEN_STATE_SAVE sq__snowcover_save_state
#undef SQ__PHEN_STATE_LOAD
#define SQ__PHEN_STATE_LOAD sq__snowcover_load_state
SQ__PHEN_PLUGIN_OBSERVING(snowcover,
    "snow lying on every surface (adaptive occlusion map, shell, snow BRDF, depth accumulated "
    "over time) and layered falling snow around the camera (S2 chapter 2)",
    1, sq_snowcover_observe);
