/* sandstorm_plugin.c — the sandstorm's parameter table (scene keys, units, defaults, ranges,
 * docs) and its plug-in vtable. Defaults not given by S0 are chosen and justified here and in
 * docs/phen/sandstorm.md. */
#include <stddef.h>
#include <stdlib.h>

#include "sandstorm_internal.h"
#include "squall/plugin.h"

#define S sq_sandstorm_desc
#include "phen/plugin_glue.h"

static const sq_param params[] = {
    E("mode", mode, "desert|urban",
      "desert: full two-phase simulation (S0 ch. 2); urban: homogeneous dust from the composition "
      "parameters, no simulation (S0 §3.5)."),
    {"seed", SQ_PARAM_U64, "", offsetof(S, seed), 0, 0, 0, NULL, NULL, 0, 0, Z,
     "Seed of the near-field particles."},
    I("domain.nx", cells[0], "1", 64, 4, 1024, "Grid cells along x (east). S0 used 64^3 or 128^3."),
    I("domain.ny", cells[1], "1", 64, 4, 1024, "Grid cells along y (north)."),
    I("domain.nz", cells[2], "1", 32, 4, 1024, "Grid cells along z (up)."),
    D("domain.cell_size_m", cell_size_m, "m", 40, 0.01, 1e4, 0,
      "Cubic cell edge. Chosen: 40 m resolves a haboob's km-scale dust wall on 64 cells."),
    D("domain.center_x_m", center_m[0], "m", 0, -1e7, 1e7, Z, "Domain centre, x."),
    D("domain.center_y_m", center_m[1], "m", 0, -1e7, 1e7, Z, "Domain centre, y."),
    FL("wave.pressure_amp_pa", pressure_amp_pa, pressure_amp_count, "Pa", "400 300 150", 16,
       -1e4, 1e4,
       "P0 per vertical level, bottom to top (S0 eq. 2.18); a perturbation over the hydrostatic "
       "background. Chosen: a few hundred Pa, a synoptic trough's scale."),
    D("wave.kx_per_m", kx_per_m, "1/m", 0, -1, 1, Z,
      "Horizontal wave number k_x (S0 eq. 2.18); must resolve on the grid (|k| h <= pi/2)."),
    D("wave.ky_per_m", ky_per_m, "1/m", 0, -1, 1, Z, "Horizontal wave number k_y."),
    D("wave.phase_rad", phase_rad, "rad", 0, -100, 100, Z, "Time phase sigma of the wave."),
    D("wind.speed_mps", wind_speed_mps, "m/s", 18, 0.01, 100, L,
      "Wind speed U where the pressure wave P' = 0. The Bernoulli constant is derived from it, "
      "C_B = rho U^2 / 2 over the surface pressure, and |v| = sqrt(U^2 - 2 P' / rho) elsewhere "
      "(S0 eq. 2.19 over a hydrostatic background). Chosen: 18 m/s, a strong dust-raising wind."),
    B("wind.geostrophic", geostrophic,
      "Rotate the wind 90 deg to run along the isobars (SPEC §1.6 ⚠4); false: down-gradient (S0)."),
    D("wind.prevailing_dir_deg", prevailing_dir_deg, "deg", 0, -360, 360, Z | L,
      "Direction the wind blows toward (deg from east) where the pressure gradient vanishes."),
    D("wind.ramp_s", ramp_s, "s", 0, 0, 1e5, Z,
      "The inflow wind rises smoothly from calm over this time (the trough arriving); 0 = none."),
    D("wind.roughness_m", roughness_m, "m", 5e-4, 1e-6, 10, 0,
      "Aerodynamic roughness length z0 (desert 1e-4..1e-3 m, SPEC §1.9)."),
    D("wind.log_layer_m", log_layer_m, "m", 100, 1, 1e4, 0,
      "Height below which the initial wind follows the log law u ~ ln(z/z0)."),
    D("temperature.surface_k", surface_temperature_k, "K", 305, 150, 400, 0,
      "Mean air temperature at the ground."),
    D("temperature.lapse_k_per_m", lapse_k_per_m, "K/m", 0, -0.1, 0.1, Z,
      "Mean temperature decrease with height (0.0065 standard, 0.0098 dry adiabatic, the "
      "largest allowed: more is statically unstable)."),
    FL("temperature.amp_k", temperature_amp_k, temperature_amp_count, "K", "", 16, -100, 100,
       "Temperature wave amplitude T0 per level (S0 eq. 2.35)."),
    D("temperature.lag_rad", temperature_lag_rad, "rad", 0, -100, 100, Z,
      "Phase lag sigma0 between the pressure and temperature troughs (S0 eq. 2.35)."),
    D("temperature.buoyancy_gain", buoyancy_gain, "1", 0, 0, 100, Z,
      "Boussinesq buoyancy on the air, 1 = physical (replaces S0's negligible thermophoresis, "
      "SPEC §1.10); 0 = off."),
    D("coldpool.delta_t_k", coldpool_delta_t_k, "K", 0, 0, 20, Z,
      "Haboob: temperature deficit of the thunderstorm's cold outflow, which enters through the "
      "west face as a density current (issue 12); 0 = none. Refused above 20 K."),
    D("coldpool.depth_m", coldpool_depth_m, "m", 1000, 1, 1e4, 0,
      "Depth H of the cold outflow above the ground (observed 0.5-2 km); inside the domain: "
      "2 cells to 0.8 of its height."),
    D("coldpool.length_m", coldpool_length_m, "m", 0, 0, 1e6, Z,
      "How far the outflow has already come in from the west face at t = 0."),
    D("coldpool.speed_mps", coldpool_speed_mps, "m/s", 0, 0, 100, Z,
      "Inflow speed of the cold air; 0 = the density current's scale sqrt(g dT H / T_s)."),
    B("coldpool.return_flow", coldpool_return_flow,
      "Above the cold pool the west face lets out as much air as the cold inflow brings in "
      "beyond the ambient wind (the thunderstorm's inflow aloft that feeds its downdraft), so "
      "that no net volume enters the domain: the air ahead of the front keeps the ambient "
      "wind. Off: the cold inflow's volume must leave through the other faces (with periodic "
      "sides, the east face: the air ahead of the front is pushed)."),
    D("coldpool.spanwise_variation", coldpool_spanwise, "1", 0, 0, 0.5, Z,
      "Relative rms variation of the cold pool's deficit dT along y (across the outflow) where it "
      "enters, and in its initial part: dT (1 + a xi(y)), xi a sum of Fourier modes periodic over "
      "the domain's width with wavelengths from the width down to 8 cells, equal amplitudes, "
      "phases drawn from seed (reproducible), rms 1. A thunderstorm's outflow is fed by "
      "downdraft cells and is not uniform across; the head's lobe-and-cleft instability grows "
      "from such variations (Simpson 1972; Hartel et al. 2000). 0 = uniform."),
    D("surface.heat_flux_w_m2", surface_heat_flux_w_m2, "W/m2", 0, -200, 1000, Z,
      "Sensible heat flux from the sunlit ground into the lowest air (SPEC §1.10): "
      "d theta/dt = H_s / (rho c_p h); with temperature.buoyancy_gain the warm air rises."),
    D("observer.x_m", observer_m[0], "m", 0, -1e7, 1e7, Z,
      "Fixed observer of the visibility_observer_m metric (on the first visibility plane), x."),
    D("observer.y_m", observer_m[1], "m", 0, -1e7, 1e7, Z, "Fixed observer, y."),
    E("domain.top", top_boundary, "open|free-slip",
      "Top face: open (pressure 0; air leaves or enters freely) or free-slip (a rigid lid, "
      "w = 0). Under an open top a cold pool that slumps draws air down through the top, and "
      "the downdraft can run away in runs longer than ~5 min (the haboob reached 226 m/s "
      "at 400 s); a lid at least twice the cold pool's depth keeps the flow bounded."),
    E("domain.sides", side_boundary, "open|periodic",
      "North and south faces: open (pressure 0; air leaves or enters freely) or periodic (what "
      "leaves through one face enters through the other: a squall line's outflow many times "
      "longer than the domain is wide, quasi two-dimensional along the line)."),
    E("solver.pressure", pressure_solver, "mgpcg|multigrid|jacobi",
      "Pressure solver: multigrid-preconditioned CG (default), multigrid V-cycles, or S0's "
      "fixed-count Jacobi."),
    I("solver.jacobi_iterations", jacobi_iterations, "1", 40, 1, 100000,
      "Jacobi sweeps when solver.pressure = jacobi (S0: 40)."),
    D("solver.tolerance", pressure_tolerance, "1", 1e-3, 1e-12, 0.5, 0,
      "Relative residual the pressure solve converges to."),
    E("solver.advection", advection, "maccormack|semi-lagrangian",
      "Advection: MacCormack with Selle's limiter (S0 + SPEC §1.4) or semi-Lagrangian."),
    E("solver.turbulence", turbulence, "mixing-length|smagorinsky|tke",
      "Turbulence closure. mixing-length: S0's nu_t = (kappa d)^2 |du_h/dz| on the horizontal "
      "wind and the vertical flux of the scalars (a boundary-layer closure for coarse cells); "
      "smagorinsky: the Smagorinsky-Lilly subgrid closure of a large-eddy simulation, "
      "nu_t = (C_s h)^2 |S| sqrt(1 - Ri/Pr_t) from the full strain rate, on all three wind "
      "components, the heat and the dust in all directions, with the log-law stress at the "
      "ground (for cells much smaller than the storm's big eddies: a haboob's head). Use it with "
      "solver.confinement 0: its small viscosity lets the confinement force run away (the "
      "haboob preset reached 151 m/s with 0.15). tke: Deardorff's (1980) 1.5-order closure, "
      "a prognostic subgrid kinetic energy e carried by the flow (produced by shear and "
      "buoyancy, dissipated as e^1.5/l), K_m = 0.1 l sqrt(e), K_h = (1 + 2l/h) K_m, "
      "l = min(h, 0.76 sqrt(e)/N), on the same terms as smagorinsky (the turbulence made in a "
      "haboob's head is carried into its body); one more scalar per cell (4 bytes)."),
    B("solver.log_law_ground", log_law_ground,
      "Mixing-length closure: the ground's stress on the wind is the log law's, u*^2 = "
      "(kappa |u_h| / ln(z1/z0))^2 at the first cell centre z1 = h/2 (the wall law of the "
      "emission's u*), instead of S0's wind 0 half a cell below, whose stress (kappa u)^2 is "
      "ln(z1/z0)^2 ~ 100x larger over desert roughness and brakes the near-ground wind. "
      "The smagorinsky closure always uses the log law."),
    B("solver.surface_layer_mixing", surface_layer_mixing,
      "The dust is mixed up through each column by the ground's own turbulence, which the "
      "resolved closure misses on coarse cells: eddy diffusivity K = kappa u* z (1 - z/h) / Sc "
      "(the parabolic profile of a log-law flow, Rouse 1937; u* the column's friction velocity, "
      "Sc = 0.74) below the depth h where the bulk Richardson number reaches 0.25 (Vogelezang "
      "& Holtslag 1996; in a cold pool its depth). The dust only; the heat and the wind keep "
      "solver.turbulence. Off: the dust a strong wind raises can stay in the lowest cells."),
    D("solver.smagorinsky_c", smagorinsky_c, "1", 0.18, 0.05, 0.5, 0,
      "Smagorinsky constant C_s of solver.turbulence = smagorinsky (Lilly 1967: 0.17-0.18 for "
      "an inertial range; 0.1-0.23 in use)."),
    D("solver.confinement", confinement, "1", 0, 0, 2, Z,
      "Vorticity-confinement strength eps_h (S0 eq. 2.15); 0 = off. A numerical force that "
      "puts back vorticity the grid diffuses, not physics; the helicity-adaptive form is zero "
      "in a two-dimensional flow (no variation and no wind across it). The haboob preset uses "
      "0 (0.15 fed its winds by ~8 m/s and stops a 3-D lock-exchange current: "
      "docs/phen/sandstorm.md)."),
    B("solver.plain_confinement", plain_confinement,
      "Use Fedkiw's constant-eps confinement instead of S0's helicity-adaptive one."),
    D("solver.cfl", cfl, "1", 2, 0.1, 20, 0,
      "Largest |u| dt / h per step; longer frame steps are sub-stepped."),
    D("dust.median_radius_m", median_radius_m, "m", 5e-6, 1e-8, 1e-3, 0,
      "Number median radius of the log-normal (S0 'dust main radius'). Chosen: 5 um, emitted "
      "desert dust."),
    D("dust.sigma_g", sigma_g, "1", 2.0, 1.0001, 5, 0,
      "Geometric standard deviation (> 1). S0's eta = ln(sigma_g) (0.5 and 0.8)."),
    D("dust.density_kg_m3", grain_density_kg_m3, "kg/m3", 2650, 100, 20000, 0,
      "Grain density (quartz / Met Office UM: 2650)."),
    I("dust.bins", bins, "1", 4, 1, 8, "Size bins of the distribution (each settles at its own speed)."),
    D("dust.n_real", n_real, "1", 0, 0, 5, Z,
      "Real refractive index; 0 = mineral-dust default per wavelength (1.53, SPEC §2.3)."),
    D("dust.n_imag", n_imag, "1", 0, 0, 10, Z,
      "Imaginary refractive index (absorption, >= 0); used when dust.n_real is set."),
    D("dust.inflow_kg_m3", inflow_dust_kg_m3, "kg/m3", 0, 0, 1, Z | L,
      "Prescribed dust inflow, an option (off: 0): dust concentration entering through the west "
      "face at the ground, a storm that formed outside the domain. Off in the haboob and "
      "frontal presets, whose dust comes only from emission."),
    D("dust.inflow_height_m", inflow_dust_height_m, "m", 300, 1, 1e5, L,
      "E-folding height of the inflow dust profile."),
    D("dust.inflow_width_m", inflow_dust_width_m, "m", 0, 0, 1e6, Z | L,
      "Standard deviation across the inflow face of the inflow dust (a storm cell of finite "
      "width, centred on the domain); 0 = uniform across the face."),
    B("dust.no_mass_fix", no_mass_fix,
      "Skip the global rescaling that makes the dust budget close after advection."),
    D("surface.u_star_t0_mps", u_star_t0_mps, "m/s", 0.25, 0.01, 5, L,
      "Single-grain threshold friction velocity u*_t0 (fine sand 0.2-0.3, Bagnold; SPEC §1.9)."),
    D("surface.roughness_factor", roughness_factor, "1", 1, 1, 100, L,
      "R >= 1 in u*_t = R H M u*_t0 (S0 eq. 2.32): non-erodible roughness raises the threshold."),
    D("surface.moisture_factor", moisture_factor, "1", 1, 1, 100, L, "H >= 1: soil moisture."),
    D("surface.compactness_factor", compactness_factor, "1", 1, 1, 100, L,
      "M >= 1: crusting / compactness."),
    D("surface.emission_coeff", emission_coeff, "kg s2/m5", 0, 0, 1, Z | L,
      "C in F = C u*^3 (1 - u*_t^2/u*^2) (S0 eq. 2.33, smooth form); 0 = non-erodible surface."),
    FL("visibility.heights_m", vis_heights_m, vis_height_count, "m", "2 10", 4, 0, 1e4,
       "Heights above the ground of the visibility planes (metrics and fields)."),
    D("visibility.contrast", contrast, "1", 0.05, 1e-4, 0.5, L,
      "Koschmieder contrast threshold: 0.05 (S0, WMO MOR) or 0.02 (UM/UPP)."),
    {"urban.concentration_kg_m3", SQ_PARAM_FLOATS, "kg/m3", offsetof(S, urban_conc_kg_m3), 0, 0, 1,
     "0.005", NULL, 8, offsetof(S, urban_conc_count), L,
     "Urban mode: dust mass concentration; several values are shown one after another."},
    D("urban.stage_s", urban_stage_s, "s", 4, 0.01, 1e6, L, "Urban mode: time per severity."),
    D("urban.height_m", urban_height_m, "m", 400, 1, 1e5, L, "Urban mode: depth of the dust layer."),
    D("detail.amplitude_m", detail_amplitude_m, "m", 0, 0, 1e4, Z,
      "Flow-following detail of the rendered dust (display only; metrics and fields keep the "
      "simulated dust): the largest displacement of the point where the extinction is looked "
      "up, reached where the resolved flow turns (vorticity >> 0.1 1/s); the noise's texture "
      "coordinates are advected by the simulated wind. 0 = off."),
    D("detail.scale_m", detail_scale_m, "m", 0, 0, 1e5, Z,
      "Feature size of the detail noise; 0 = 4 cells."),
    D("detail.period_s", detail_period_s, "s", 20, 0.01, 1e5, 0,
      "Re-seeding period of the advected noise coordinates (two phases half a period apart, "
      "blended, so the flow's shear never stretches the pattern for longer than this)."),
    D("detail.mirror_sides_m", detail_mirror_sides_m, "m", 0, 0, 1e5, Z,
      "Display only: the dust is drawn this far beyond the domain's south and north faces, "
      "mirrored at them, so a wall wider than the simulated strip does not end inside the "
      "view (metrics and fields keep the domain). 0 = the domain only."),
    B("near.enabled", near_field, "Soft-particle near field around the camera (S3)."),
    I("near.particles", near_particles, "1", 4000, 1, 1000000, "Near-field particle count."),
    D("near.radius_m", near_radius_m, "m", 80, 1, 1e4, 0, "Radius of the region around the camera."),
    D("near.particle_radius_m", near_particle_radius_m, "m", 4, 0.01, 1e3, 0,
      "Mean radius of a near-field puff."),
    D("near.fraction", near_fraction, "1", 0.3, 0.001, 1, 0,
      "Share of the local extinction drawn by the near-field particles."),
};

/* Live changes: the live entries of desc onto the running desc (sandstorm.c re-derives). */
static sq_result sandstorm_apply_live(void *self, const void *desc)
{
    sq_sandstorm *s = (sq_sandstorm *)self;
    sq_sandstorm_desc d = s->d;
    sq_params_copy_live(params, sizeof params / sizeof params[0], &d, desc);
    return sq__sandstorm_apply_live(s, &d);
}

#undef SQ__PHEN_APPLY_LIVE
#define SQ__PHEN_APPLY_LIVE sandstorm_apply_live
#undef SQ__PHEN_FRAME_SYNC
#define SQ__PHEN_FRAME_SYNC sq__sandstorm_frame_sync
#undef SQ__PHEN_STATE_SAVE
#define SQ__PHEN_STATE_SAVE sq__sandstorm_save_state
#undef SQ__PHEN_STATE_LOAD
#define SQ__PHEN_STATE_LOAD sq__sandstorm_load_state
SQ__PHEN_PLUGIN_OBSERVING(sandstorm,
    "two-phase Eulerian sandstorm: pressure-wave wind, dust emission/settling, Mie optics, "
    "visibility (S0)",
    0, sq__sandstorm_observe);

