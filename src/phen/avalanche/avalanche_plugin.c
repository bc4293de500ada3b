/* avalanche_plugin.c — the snow avalanche's parameter table (scene keys, units, defaults,
 * ranges, docs) and its plug-in vtable. Values S2 leaves open are chosen and justified here and
 * in docs/phen/avalanche.md. */
#include <stddef.h>

#include "avalanche_internal.h"
#include "squall/plugin.h"

#define S sq_avalanche_desc
#include "phen/plugin_glue.h"

_Static_assert(sizeof(((sq_avalanche_desc *)0)->release_area) == SQ_PARAM_STRING_MAX,
               "string fields of a desc hold SQ_PARAM_STRING_MAX bytes");

static const sq_param params[] = {
    D("particles.spacing_m", spacing_m, "m", 1.0, 1e-3, 100, 0,
      "Initial particle spacing dx; the particle count is the release volume / dx^3 (S2 leaves "
      "the resolution open; chosen: 1 m resolves a slab a few metres thick)."),
    D("particles.support_radius_m", support_radius_m, "m", 0, 0, 400, Z,
      "Kernel support H of every kernel and cell of the neighbour grid (SPEC §7.3 ⚠: one "
      "support for all kernels); 0 = 2 x spacing (about 33 neighbours)."),
    D("snow.density_kgm3", density_kgm3, "kg/m3", 300, 10, 1000, 0,
      "Rest density rho0 of the flowing snow. Chosen: 300, inside S2's 150-500 kg/m3 for "
      "wet/dense flowing snow."),
    B("snow.cohesion", cohesion,
      "Keep negative SPH pressure as cohesion (SPEC §7.2 ⚠ 2). Off by default: a slab a few "
      "particles thick has a 20-70 % kernel deficit at its surfaces, and c_s^2 (rho - rho0) then "
      "pulls it together violently (measured: particles thrown at 18 m/s within 0.5 s)."),
    D("release.x_m", release_x_m, "m", 0, -1e7, 1e7, Z,
      "World x of the centre of the release rectangle."),
    D("release.y_m", release_y_m, "m", 0, -1e7, 1e7, Z,
      "World y of the centre of the release rectangle."),
    D("release.length_m", release_length_m, "m", 40, 1e-3, 1e5, 0,
      "Horizontal extent of the release rectangle along x."),
    D("release.width_m", release_width_m, "m", 30, 1e-3, 1e5, 0,
      "Horizontal extent of the release rectangle along y."),
    D("release.depth_m", release_depth_m, "m", 2, 1e-3, 1e3, 0,
      "Slab thickness measured normal to the slope (typical slab fracture depths 0.5-3 m); "
      "the release volume is sum(dx^2 depth / n_z) over the columns."),
    STR("release.area", release_area, "",
        "Name of a world area (world.areas: polygons from GeoJSON/Shapefile or a raster mask) "
        "that is the release; its polygons' thickness attribute (m, slope-normal) overrides "
        "release.depth_m. Empty = the rectangle release.x_m/y_m/length_m/width_m."),
    B("release.slope_dependent", release_slope_dependent,
      "Slope-dependent thickness of the Swiss guidelines (Salm et al. 1990; RAMMS, AvaFrame): "
      "d = d0 * 0.291 / (sin psi - 0.202 cos psi), d0 at psi = 28 deg and thinner on steeper "
      "slopes (d0 below 28 deg)."),
    D("release.gradient_m", release_gradient_m, "m", 0, -10, 10, Z,
      "Thickness added per 100 m of altitude above release.reference_altitude_m (Swiss "
      "practice: +0.05 m per 100 m); 0 = none."),
    D("release.reference_altitude_m", release_reference_altitude_m, "m", 2000, -1e4, 1e4, 0,
      "Altitude at which the release thickness is d0 (for release.gradient_m)."),
    E("rheology.model", rheology, "cross|newtonian|power-law|bingham",
      "Effective viscosity model (S2 eqs 3.26-3.29): cross (S2's avalanche), newtonian, "
      "power-law (Ostwald-de Waele) or bingham (Papanastasiou-regularised)."),
    D("rheology.mu0_pa_s", mu0_pa_s, "Pa s", 100, 1e-9, 1e9, 0,
      "Cross zero-shear viscosity mu0 >= mu_inf (S2 Fig. 3.20: 100; SPEC §7.4 ⚠ on the bound)."),
    D("rheology.mu_inf_pa_s", mu_inf_pa_s, "Pa s", 1, 1e-9, 1e9, 0,
      "Cross infinite-shear viscosity mu_inf (S2 Fig. 3.20: 1)."),
    D("rheology.cross_k_s", cross_k_s, "s", 3000, 1e-9, 1e9, 0,
      "Cross time constant K (S2 Fig. 3.20: 3000, units unstated, read as s; SPEC §7.9 ⚠: "
      "mu is within 10 % of mu_inf above |shear rate| = 0.01 1/s)."),
    D("rheology.cross_n", cross_n, "1", 2, 1e-6, 20, 0, "Cross exponent n > 0 (S2 Fig. 3.20: 2)."),
    D("rheology.mu_pa_s", mu_pa_s, "Pa s", 1, 1e-9, 1e9, 0,
      "Newtonian dynamic viscosity (water at 0 C: 1.79e-3, S2 §3.2)."),
    D("rheology.power_k", power_k, "Pa s^n", 1.5, 1e-9, 1e9, 0,
      "Power-law consistency K (S2 Fig. 3.7: 1.5)."),
    D("rheology.power_n", power_n, "1", 0.5, 1e-6, 20, 0,
      "Power-law flow index n > 0: < 1 shear-thinning (S2 Fig. 3.7: 0.5, 1, 1.5)."),
    D("rheology.bingham_mu_pa_s", bingham_mu_pa_s, "Pa s", 1.5, 1e-9, 1e9, 0,
      "Bingham plastic viscosity K (S2 Fig. 3.8: 1.5)."),
    D("rheology.yield_stress_pa", yield_stress_pa, "Pa", 0, 0, 1e7, Z,
      "Bingham yield stress tau_y (0 = Newtonian with the plastic viscosity)."),
    D("rheology.mu_max_pa_s", mu_max_pa_s, "Pa s", 0, 0, 1e9, Z | A,
      "Cap on the effective viscosity (bounds the viscous time-step limit); 0 = none."),
    D("terrain.friction", friction, "1", 0.2, 1e-6, 5, 0,
      "Kinetic Coulomb friction mu_k of the terrain and obstacles (S2 §3.6: 0.2), applied at "
      "each contact as v_t *= max(0, 1 - mu_k |dv_n| / |v_t|) (SPEC §7.7)."),
    B("terrain.column_friction", column_friction,
      "Basal friction of the depth-averaged avalanche models (Savage-Hutter, Voellmy as in RAMMS "
      "and AvaFrame) spread over the flow column: every particle within its column's flow depth "
      "loses mu g_n dt (and the Voellmy drag) of its speed along the terrain. Off = S2's contact "
      "friction, which brakes only the particles touching the terrain (SPEC §7.7)."),
    D("terrain.turbulent_friction_mps2", turbulent_friction_mps2, "m/s2", 0, 0, 1e6, Z,
      "Voellmy turbulent friction xi (RAMMS, AvaFrame: 1000-4000 m/s2; needs "
      "terrain.column_friction): the basal stress rho g v^2 / xi on top of the Coulomb part, so "
      "that a flow of depth h on a slope theta tends to sqrt(xi h (sin theta - mu cos theta)); "
      "0 = none (S2)."),
    D("terrain.restitution", restitution, "1", 0, 0, 1, Z,
      "Restitution e of the normal velocity at a contact (SPEC §7.7: e ~ 0 for snow)."),
    D("numerics.speed_of_sound_mps", speed_of_sound_mps, "m/s", 0, 0, 1e5, Z,
      "Speed of sound c_s of the linear EOS p = c_s^2 (rho - rho0) (S2 eq. 3.38); 0 = 5 x the "
      "free-fall speed over the possible drop (Mach <= 0.2, density fluctuations ~ 4 %)."),
    E("numerics.kernel", kernel, "cubic|muller",
      "SPH kernels on the one support H: cubic spline for density and all gradients (energy-"
      "conserving pressure; the solver's default) or Mueller's poly6/spiky set (S2 eqs 3.15-3.21; "
      "S2 itself used the cubic spline for the non-Newtonian path, eq. 3.50)."),
    E("numerics.viscous", viscous, "morris|muller|tensor",
      "How the effective viscosity mu(|shear rate|) acts: Morris's pair form (dissipative pair by "
      "pair; default), Mueller's Laplacian (S2 eq. 3.39), or the stress tensor tau = 2 mu D "
      "(S2 eq. 3.57; lets zig-zag velocity modes grow, see sph.h)."),
    D("numerics.xsph_epsilon", xsph_epsilon, "1", 0.5, 1e-6, 1, 0,
      "XSPH velocity smoothing epsilon (S2 eq. 3.47: 0.5)."),
    D("numerics.artificial_viscosity", artificial_viscosity, "1", 0.1, 1e-6, 1, A,
      "Monaghan artificial viscosity alpha for approaching pairs (not in S2). Chosen: 0.1. "
      "Flowing snow compacts inelastically, weakly compressible SPH rebounds elastically; "
      "measured on the preset: without it particles reach 34 m/s (the flow 21 m/s mean), the "
      "deposit thins to 0.6 m and runs out 219 m (alpha 12.7 deg); with 0.1: 201 m, 13.6 deg, "
      "1.0 m; with 0.5: 205 m, 13.4 deg, 0.9 m."),
    B("numerics.no_artificial_viscosity", no_artificial_viscosity,
      "Switch the artificial viscosity off (alpha = 0)."),
    D("numerics.dt_max_s", dt_max_s, "s", 0, 0, 10, Z | A,
      "Cap on the solver's sub-step (the CFL, viscous and force limits apply anyway); 0 = none."),
    V3("domain.min_m", domain_min_m, "m", "0 0 0", -1e7, 1e7,
       "Lower corner of the simulation box; with domain.max_m all zero = the terrain's "
       "footprint from below its lowest point. Particles leaving the box are removed."),
    V3("domain.max_m", domain_max_m, "m", "0 0 0", -1e7, 1e7,
       "Upper corner of the simulation box; all zero (with domain.min_m) = auto, up to 10 H + "
       "20 m above the release top."),
    D("domain.layer_m", domain_layer_m, "m", 0, 0, 1e5, Z,
      "Height the neighbour grid keeps above the terrain (a terrain-following grid: real slopes "
      "with a drop of hundreds of metres need no box of cells); particles higher leave the "
      "domain. 0 = auto: follows the terrain with 10 H + 20 m above the thickest release column "
      "when domain.min_m/max_m are all zero or when that needs less than half the cells of the "
      "domain box, else the dense box."),
    D("deposit.cell_m", deposit_cell_m, "m", 0, 0, 1e4, Z,
      "Cell of the deposit depth map over the domain's footprint; 0 = 2 x spacing (coarser if "
      "the footprint would need more than 15 Mi cells)."),
    D("hazard.cell_m", hazard_cell_m, "m", 0, 0, 1e4, Z,
      "Cell of the hazard maps (peak flow depth, peak speed, peak pressure, deposit depth, "
      "travel angle) over the whole terrain, aligned with its samples; 0 = the terrain's "
      "spacing (a DEM's cell)."),
    D("metrics.moving_speed_mps", moving_speed_mps, "m/s", 0.5, 1e-6, 1e3, 0,
      "A particle faster than this counts as moving (moving_fraction). Chosen: 0.5 m/s."),
    D("metrics.front_percentile", front_percentile, "1", 0.99, 1e-6, 1, 0,
      "Quantile of the particles' fall-line coordinate taken as the front (robust against "
      "single splashed particles)."),
    D("metrics.airborne_m", airborne_m, "m", 2, 1e-6, 1e4, 0,
      "A particle this far above the terrain, measured along the terrain normal, counts as "
      "airborne (airborne_fraction); keep it above the slab thickness."),
    D("render.radius_factor", radius_factor, "1", 0.6, 0.01, 10, L,
      "Radius of the drawn snow spheres in particle spacings."),
    D("render.albedo", albedo, "1", 0.9, 0.01, 1, L,
      "Albedo of the snow spheres and the deposit (fresh/wet snow ~0.8-0.9)."),
    B("render.no_deposit_surface", no_deposit_surface,
      "Do not draw the deposit surface (terrain + depth, material snow; it covers the snow "
      "at rest, slower than metrics.moving_speed_mps) under the particles."),
    B("render.spheres", spheres,
      "Draw every particle as a lit sphere and the surface only where the snow rests (the "
      "look before the snow surface). Default: the snow surface is reconstructed over all the "
      "snow (its flow depth, smoothed) and only spray above it is drawn as spheres."),
    B("powder.enabled", powder,
      "Draw a powder cloud: fast particles shed suspended snow into a coarse grid that "
      "diffuses and settles (a visual model; S2 does not simulate the powder cloud)."),
    D("powder.speed_mps", powder_speed_mps, "m/s", 10, 1e-3, 1e3, 0,
      "Particles faster than this feed the powder cloud (shedding grows with the excess)."),
    D("powder.shed", powder_shed, "1/(m/s)/s", 2e-5, 1e-9, 1e-1, 0,
      "Suspended snow shed per second per m/s of speed above powder.speed_mps, as a fraction "
      "of a particle's mass: 2e-5 raises the light veil of a wet flow (extinction ~0.1 1/m), "
      "~5e-4 the opaque cloud of a dry mixed avalanche."),
    D("powder.cell_m", powder_cell_m, "m", 2, 0.01, 1e4, 0,
      "Cell of the powder grid (grown to keep at most 128 cells per axis)."),
    D("powder.box_m", powder_box_m, "m", 256, 1, 1e5, 0,
      "Side of the powder grid's cubic box. It starts around the release and follows the "
      "fast snow by whole cells (the powder it leaves behind is counted, not kept); cells "
      "below the terrain hold no powder."),
};

#undef SQ__PHEN_STATE_SAVE
#define SQ__PHEN_STATE_SAVE sq__avalanche_save_state
#undef SQ__PHEN_STATE_LOAD
#define SQ__PHEN_STATE_LOAD sq__avalanche_load_state
/* Live changes: the rendering keys (render.*) are read by every frame's drawables; the flow and
 * its deposit stay. */
static sq_result avalanche_apply_live(void *self, const void *desc)
{
    sq_avalanche *a = (sq_avalanche *)self;
    sq_params_copy_live(params, sizeof params / sizeof params[0], &a->plan.d, desc);
    a->version++;
    return SQ_OK;
}

#undef SQ__PHEN_APPLY_LIVE
#define SQ__PHEN_APPLY_LIVE avalanche_apply_live
SQ__PHEN_PLUGIN(avalanche,
    "dense snow avalanche: SPH slab release on the terrain, Cross rheology, Coulomb friction, "
    "run-out and deposit (S2 ch. 3)",
    1);

