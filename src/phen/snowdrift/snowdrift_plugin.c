/* snowdrift_plugin.c — the snowdrift's parameter table (scene keys, units, defaults, ranges,
 * docs) and its plug-in vtable. Defaults not given by S1 are chosen and justified here and in
 * docs/phen/snowdrift.md. */
#include <stddef.h>

#include "snowdrift_internal.h"
#include "squall/plugin.h"

#define S sq_snowdrift_desc
#include "phen/plugin_glue.h"

static const sq_param params[] = {
    {"seed", SQ_PARAM_U64, "", offsetof(S, seed), 0, 0, 0, NULL, NULL, 0, 0, Z,
     "Seed of the stochastic snow transport, gusts and visual flakes."},
    I("domain.nx", cells[0], "1", 128, 4, 2048, "Lattice cells along x (east)."),
    I("domain.ny", cells[1], "1", 64, 4, 2048, "Lattice cells along y (north)."),
    I("domain.nz", cells[2], "1", 48, 4, 2048, "Lattice cells along z (up)."),
    D("domain.cell_size_m", cell_size_m, "m", 1, 0.01, 100, 0,
      "Cubic cell edge of the wind and snow lattice. Chosen: 1 m resolves houses and drifts."),
    D("domain.center_x_m", center_m[0], "m", 0, -1e7, 1e7, Z, "Domain centre, x."),
    D("domain.center_y_m", center_m[1], "m", 0, -1e7, 1e7, Z, "Domain centre, y."),
    D("domain.dt_s", dt_s, "s", 0, 0, 100, Z,
      "Lattice (wind) time step; 0 = automatic: the fastest wind (with gusts, at the top of "
      "its profile) moves 0.08 cells per step (Mach 0.14; SPEC 5.3 asks for < 0.1-0.17). "
      "Refused above Mach 0.3."),
    D("wind.speed_mps", wind_speed_mps, "m/s", 0, 0, 80, Z | L,
      "Mean wind at wind.ref_height_m (S1 demo: Beaufort 4.5, about 7 m/s); 0 = calm."),
    D("wind.dir_deg", wind_dir_deg, "deg", 0, -360, 360, Z | L,
      "Direction the wind blows toward, counter-clockwise from east."),
    D("wind.beaufort", beaufort, "1", 0, 0, 12, Z,
      "Gust level n_B: gusts v = mu_g v_mean sin(alpha), mu_g = n_B/20, alpha uniform in "
      "[0, 2 pi) (S1 eq 14 with SPEC 5.5's zero-mean fix); 0 = steady wind."),
    D("wind.gust_period_s", gust_period_s, "s", 3, 0.01, 1e4, 0,
      "The gust phase is redrawn this often and blended smoothly (SPEC 5.5)."),
    D("wind.ramp_mps2", wind_ramp_mps2, "m/s2", 0, 0, 100, Z,
      "Progressive set-up: the wind speed changes at most this fast; 0 = instantaneous "
      "(one-shot mass-conserving injection, SPEC 5.5)."),
    D("wind.ref_height_m", ref_height_m, "m", 10, 0.1, 1e4, 0,
      "Height above the ground at which wind.speed_mps applies (log-law profile below/above)."),
    D("wind.roughness_m", roughness_m, "m", 0.005, 1e-6, 10, 0,
      "Aerodynamic roughness z0 of the surface (snow 1e-4..1e-2 m) for the log law and u*."),
    E("wind.boundary", boundary, "recycle|inflow",
      "recycle: S1's recirculation (periodic sides, wind held by a controlled body force); "
      "inflow: log-law inflow on the upwind x face, outflow on the other."),
    D("wind.eddy_viscosity_m2s", eddy_viscosity_m2s, "m2/s", 0.01, 1e-7, 100, 0,
      "Background viscosity of the lattice air, tau = 1/2 + 3 nu dt/dx^2 (SPEC 5.3); the "
      "Smagorinsky model adds the resolved-strain part."),
    D("wind.smagorinsky_c", smagorinsky_c, "1", 0.16, 0.01, 1, 0,
      "Smagorinsky constant of the sub-grid eddy viscosity (SPEC 5.3)."),
    D("wind.tau", tau, "1", 0, 0, 100, Z,
      "Lattice relaxation time; must exceed 1/2 (S1's 0.5 is zero viscosity, unstable: SPEC "
      "5.3); 0 = from wind.eddy_viscosity_m2s."),
    D("snow.snowfall_mmh", snowfall_mmh, "mm/h", 0, 0, 1000, Z | L,
      "Snowfall rate as water equivalent (1 mm/h = 1 kg m-2 h-1); 0 = no snowfall."),
    D("snow.speedup", speedup, "1", 1, 1e-6, 1e9, 0,
      "Time-lapse factor on snowfall and erosion: drifts build this many times faster than "
      "real time while the wind stays real-time (one flake is 15 kg on 1 m cells)."),
    D("snow.fall_speed_mps", fall_speed_mps, "m/s", 1, 0.01, 10, 0,
      "Settling speed u_g of flakes (SPEC 5.6: 0.5-1.5 m/s)."),
    I("snow.threshold", threshold, "1", 10, 1, 1000000,
      "Flakes that fill a cell: a cell holding more turns solid and blocks the wind (S1: 10). "
      "One flake is 1/threshold of a cell of deposited snow."),
    D("snow.density_kgm3", snow_density_kgm3, "kg/m3", 150, 1, 917, 0,
      "Density of deposited snow; with the threshold it fixes the flake mass."),
    B("snow.no_erosion", no_erosion, "Deposited snow never lifts (erosion off)."),
    D("snow.ustar_threshold_mps", ustar_threshold_mps, "m/s", 0.25, 0.001, 10, 0,
      "Threshold friction velocity for erosion (dry fresh snow 0.15-0.35 m/s, Li & Pomeroy "
      "1997; S1 quotes a wind speed of 4 instead)."),
    D("snow.erosion_efficiency", erosion_efficiency, "1", 1, 1e-6, 1, 0,
      "Transport efficiency eff in C_sat = eff (1 - u*_t^2/u*^2) (S1 eq 13)."),
    D("snow.saturation_time_s", saturation_time_s, "s", 1, 1e-4, 1e6, 0,
      "Saturation time t_sat of the saltation layer (S1 eq 12)."),
    D("snow.saltation_kgm3", saltation_kgm3, "kg/m3", 0.05, 1e-6, 1000, 0,
      "Airborne snow in a surface cell at saturation, C_salt = 1 (saltation layers carry "
      "0.1-1 kg/m3 in their lowest 10 cm; averaged over a metre cell, a few 0.01)."),
    D("snow.cfl", snow_cfl, "1", 0.5, 0.01, 1, 0,
      "Largest flake displacement per snow step, in cells; sets how many wind steps a snow "
      "step spans."),
    {"draw.flakes", SQ_PARAM_INT, "1", offsetof(S, visual_flakes), 0, 0, 2000000, NULL, NULL, 0,
     0, Z, "Falling-snow particles drawn (carried by the lattice wind) while it snows; 0 = none "
     "(a snowcover layer draws the falling snow around the camera)."},
    D("draw.flake_radius_m", flake_radius_m, "m", 0.03, 0.001, 1, L,
      "Radius of a drawn flake (S1: flakes up to 10 mm; larger reads better on screen)."),
    D("draw.flake_min_mrad", flake_min_mrad, "mrad", 2.5, 0.01, 100, L,
      "Smallest angular radius a flake is drawn with: farther flakes are enlarged to it and "
      "made fainter by (true/drawn radius)^2, keeping projected area x opacity. Chosen: "
      "2.5 mrad is a radius of 0.9 px at 360 px of height and 1.7 px at 720 px (55 deg field "
      "of view): distant flakes stay visible as soft dots."),
};

/* Live changes: the live entries of desc onto the running desc (snowdrift.c applies them). */
static sq_result snowdrift_apply_live(void *self, const void *desc)
{
    sq_snowdrift *s = (sq_snowdrift *)self;
    sq_snowdrift_desc d = s->d;
    sq_params_copy_live(params, sizeof params / sizeof params[0], &d, desc);
    return sq__snowdrift_apply_live(s, &d);
}

#undef SQ__PHEN_APPLY_LIVE
#define SQ__PHEN_APPLY_LIVE snowdrift_apply_live
#undef SQ__PHEN_STATE_SAVE
#define SQ__PHEN_STATE_SAVE sq__snowdrift_save_state
#undef SQ__PHEN_STATE_LOAD
#define SQ__PHEN_STATE_LOAD sq__snowdrift_load_state
#undef SQ__PHEN_FRAME_SYNC
#define SQ__PHEN_FRAME_SYNC sq__snowdrift_frame_sync
SQ__PHEN_PLUGIN_OBSERVING(snowdrift,
    "wind-driven snowfall and drifts: D3Q15 lattice-Boltzmann wind, snow on the lattice with "
    "deposition and erosion (S1)",
    0, sq__snowdrift_observe);

