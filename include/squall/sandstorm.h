/* squall/sandstorm.h — the parametric sandstorm of source document S0 (Gong 2012, ch. 2–3),
 * physically corrected as SPEC §1–2 recommends:
 *   - wind: Stam-split incompressible flow on a MAC grid (include/squall/grid.h), initialised
 *     from the pressure wave P'(x,y,z) = P0(z) sin(kx x + ky y − σ) by Bernoulli speed and the
 *     pressure-gradient direction (optionally rotated to geostrophic) over a hydrostatic
 *     background, then projected; mixing-length eddy viscosity (κ = 0.4); helicity-adaptive
 *     vorticity confinement with the dimensionless relative helicity;
 *   - temperature: T = T̄(z) + T0(z) sin(kx x + ky y − σ + σ0); the air carries its potential
 *     temperature θ = T + Γ_d z (conserved by dry adiabatic motion); the inflow face takes the
 *     same profile as the interior; the updraft is Boussinesq buoyancy g (θ − θ̄(z)) / θ̄(z)
 *     on the air with a gain (S0's thermophoresis is ~1e-8 m/s, §1.10);
 *   - dust: a log-normal size distribution (median radius, σ_g, grain density) split into size
 *     bins, each a mass concentration (kg/m³) carried by the air and settling at its terminal
 *     speed from the drag law C_D(Re) = 24/Re + 6/(1+√Re) + 0.4 (White); grains move with the
 *     air plus their settling speed, the equilibrium-Eulerian limit (SPEC §1.7 (a), §1.8),
 *     valid because the response time τ_p = w_s / g is ≤ 0.1 s for r ≤ 40 µm, far below a step
 *     and the flow's time scale h / |u|: no inertial slip, no stiff explicit drag; two-way momentum exchange: the drag of
 *     settling grains passes their weight to the air (dust-laden air is heavier) and emitted
 *     grains take their horizontal momentum from the air;
 *   - emission: u* = κ u(z1) / ln(z1/z0) at the first cell above the ground, threshold
 *     u*_t = u*_t0 · f_roughness · f_moisture · f_compactness, vertical mass flux
 *     F = C u*³ (1 − u*_t²/u*²) above it (Marticorena & Bergametti 1995 form of S0's F = C u*³);
 *   - optics and visibility: per-bin Mie mass extinction at R/G/B/550 nm (include/squall/optics.h),
 *     Koschmieder V = ln(1/ε)/β_ext(550 nm) on horizontal planes at chosen heights.
 * Scene type `urban` (S0 §3.5): no simulation, a homogeneous dust layer from the composition.
 * Units: SI everywhere (m, s, kg, Pa, K). */
#ifndef SQ_SANDSTORM_H
#define SQ_SANDSTORM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SQ_SANDSTORM_MAX_LEVELS 16
#define SQ_SANDSTORM_MAX_BINS 8
#define SQ_SANDSTORM_MAX_VIS 4
#define SQ_SANDSTORM_MAX_STAGES 8

typedef enum sq_sandstorm_mode {
    SQ_SANDSTORM_DESERT = 0, /* full simulation */
    SQ_SANDSTORM_URBAN = 1   /* homogeneous dust from the composition, no simulation */
} sq_sandstorm_mode;

/* Zero fields take the defaults named in `squall params sandstorm` (the parameter table in
 * src/phen/sandstorm/sandstorm_plugin.c is the reference); fields marked "0 is physical" keep 0. */
typedef struct sq_sandstorm_desc {
    int mode;                      /* sq_sandstorm_mode */
    uint64_t seed;                 /* 0 is a valid seed */
    /* domain */
    int cells[3];                  /* grid cells x, y, z; 0 -> 64 64 32 */
    double cell_size_m;             /* 0 -> 40 m */
    double center_m[2];             /* domain centre x, y; 0 is physical */
    /* pressure wave (S0 eq. 2.18) and Bernoulli wind (2.19–2.20) */
    float pressure_amp_pa[SQ_SANDSTORM_MAX_LEVELS]; /* P0 per level, bottom to top */
    int pressure_amp_count;
    double kx_per_m, ky_per_m;      /* horizontal wave numbers; 0 is physical */
    double phase_rad;               /* σ; 0 is physical */
    double wind_speed_mps;          /* wind speed U where P' = 0; the Bernoulli constant is
                                       C_B = rho U^2 / 2 over the surface pressure; 0 -> 18 m/s */
    bool geostrophic;              /* rotate the wind 90° to run along the isobars */
    double prevailing_dir_deg;      /* wind direction (toward, deg from east) where ∇P ≈ 0 */
    double ramp_s;                  /* wind rises from calm over this time; 0 is physical (none) */
    double roughness_m;             /* aerodynamic roughness length z0; 0 -> 5e-4 m */
    double log_layer_m;             /* log-law profile below this height; 0 -> 100 m */
    /* temperature wave (S0 eq. 2.35) and updraft (SPEC §1.10) */
    double surface_temperature_k;   /* 0 -> 305 K */
    double lapse_k_per_m;           /* 0 is physical (isothermal) */
    float temperature_amp_k[SQ_SANDSTORM_MAX_LEVELS];
    int temperature_amp_count;
    double temperature_lag_rad;     /* σ0, trough phase lag; 0 is physical */
    double buoyancy_gain;           /* 1 = physical Boussinesq; 0 is physical (off) */
    double surface_heat_flux_w_m2;  /* sensible heat flux into the lowest air (SPEC §1.10); 0 off */
    /* haboob (issue 12): the cold outflow of a convective downdraft entering through the west
     * face as a density current, and already out to coldpool_length_m at t = 0 */
    double coldpool_delta_t_k;      /* temperature deficit ΔT; 0 = no cold pool */
    double coldpool_depth_m;        /* depth H above the ground; 0 -> 1000 m */
    double coldpool_length_m;       /* extent from the west face at t = 0; 0 is physical */
    double coldpool_speed_mps;      /* inflow speed of the cold air; 0 -> √(g ΔT H / θ) */
    bool coldpool_return_flow;     /* above the cold pool the west face lets out as much air as
                                       the cold inflow brings in beyond the ambient wind's (the
                                       storm's inflow aloft): no net volume enters */
    double coldpool_spanwise;       /* relative amplitude (rms) of the deficit's variation along y
                                       at the west face (seeded Fourier modes); 0 = uniform */
    double observer_m[2];           /* fixed observer (x, y) of the visibility metric; 0 physical */
    int top_boundary;              /* 0 open (p = 0, air may leave or enter), 1 free-slip lid */
    int side_boundary;             /* north and south faces: 0 open, 1 periodic (a storm line
                                       much longer than the domain is wide) */
    /* numerics */
    int pressure_solver;           /* 0 mgpcg, 1 multigrid, 2 jacobi */
    int jacobi_iterations;         /* 0 -> 40 (S0) */
    double pressure_tolerance;      /* relative residual; 0 -> 1e-3 */
    int advection;                 /* 0 maccormack, 1 semi-lagrangian */
    int turbulence;                /* 0 mixing length (S0), 1 Smagorinsky-Lilly subgrid closure,
                                       2 Deardorff's TKE closure (one more scalar) */
    double smagorinsky_c;           /* C_s of the subgrid closure; 0 -> 0.18 (Lilly 1967) */
    bool log_law_ground;           /* mixing length: the ground's stress from the log law (the
                                       subgrid closure always uses it); false: no-slip (S0) */
    bool surface_layer_mixing;     /* the dust mixed up by the ground's turbulence: K = kappa u* z
                                       (1 - z/h) / Sc below a bulk-Richardson depth h */
    double confinement;             /* ε_h; 0 is physical (off) */
    bool plain_confinement;        /* false: helicity-adaptive (S0); true: Fedkiw's constant eps */
    double cfl;                     /* max |u| dt / h per sub-step; 0 -> 2 */
    /* dust */
    double median_radius_m;         /* number median radius; 0 -> 5e-6 m */
    double sigma_g;                 /* geometric standard deviation; 0 -> 2.0 */
    double grain_density_kg_m3;     /* 0 -> 2650 */
    int bins;                      /* size bins; 0 -> 4 */
    double n_real, n_imag;          /* refractive index; n_real 0 -> dust default per wavelength */
    double inflow_dust_kg_m3;       /* dust entering with the inflow at the ground; 0 is physical */
    double inflow_dust_height_m;    /* e-folding height of the inflow dust; 0 -> 300 m */
    double inflow_dust_width_m;     /* Gaussian half-width across the inflow (storm cell); 0 = uniform */
    bool no_mass_fix;              /* false: rescale after advection so the budget closes */
    /* surface (S0 eq. 2.32–2.34) */
    double u_star_t0_mps;           /* single-grain threshold friction velocity; 0 -> 0.25 */
    double roughness_factor;        /* R >= 1; 0 -> 1 */
    double moisture_factor;         /* H >= 1; 0 -> 1 */
    double compactness_factor;      /* M >= 1; 0 -> 1 */
    double emission_coeff;          /* C in F = C u*^3 (kg s² m⁻⁵); 0 is physical (no emission) */
    /* visibility (S0 eq. 3.23) */
    float vis_heights_m[SQ_SANDSTORM_MAX_VIS];
    int vis_height_count;          /* 0 -> 2 m and 10 m */
    double contrast;                /* Koschmieder threshold; 0 -> 0.05 */
    /* urban scene (S0 §3.5) */
    float urban_conc_kg_m3[SQ_SANDSTORM_MAX_STAGES]; /* one or more severities */
    int urban_conc_count;
    double urban_stage_s;           /* time at each severity; 0 -> 4 s */
    double urban_height_m;          /* depth of the dust layer; 0 -> 400 m */
    /* flow-following detail of the rendered dust (display only; docs/phen/sandstorm.md) */
    double detail_amplitude_m;      /* largest displacement; 0 = off */
    double detail_scale_m;          /* noise feature size; 0 -> 4 cells */
    double detail_period_s;         /* re-seeding period of the advected coordinates; 0 -> 20 s */
    double detail_mirror_sides_m;   /* dust drawn beyond the y faces, mirrored; 0 = none */
    /* near-field soft particles (S3) */
    bool near_field;
    int near_particles;            /* 0 -> 4000 */
    double near_radius_m;           /* region radius around the camera; 0 -> 80 m */
    double near_particle_radius_m;  /* 0 -> 4 m */
    double near_fraction;           /* share of the local extinction drawn as particles; 0 -> 0.3 */
} sq_sandstorm_desc;

typedef struct sq_sandstorm sq_sandstorm;

/* Dust budget since creation (kg). emitted − deposited − outflow + inflow = suspended − initial. */
typedef struct sq_sandstorm_budget {
    double suspended_kg, initial_kg, emitted_kg, deposited_kg, outflow_kg, inflow_kg;
    double advection_correction_kg; /* mass added/removed by the mass fix (0 when off) */
} sq_sandstorm_budget;

typedef struct sq_sandstorm_stats {
    int64_t steps;
    double ms_advect, ms_forces, ms_diffuse, ms_project, ms_emission, ms_dust;
    double ms_detail;               /* flow-following detail: advection and lookup (display) */
    double pressure_residual;
    int pressure_iterations;
    double max_wind_mps, max_u_star_mps, emitting_fraction;
    double front_m;                 /* cold-pool front: distance from the west face (m) */
    double front_speed_mps;         /* its speed over the last ~30 s of simulated time */
    uint64_t memory_bytes;
    int64_t slab_cells;             /* cells this rank steps (under mpirun its slab, else all) */
    uint64_t bytes_exchanged;       /* under mpirun: bytes this rank sent to the others since
                                       create (halos, sums, the gather of the whole grid) */
} sq_sandstorm_stats;

/* Copies in to out with zero fields replaced by their defaults (the table of `squall params
 * sandstorm`); never validates. */
SQ_API sq_result sq_sandstorm_desc_resolve(const sq_sandstorm_desc *in, sq_sandstorm_desc *out);
/* Every rule of desc (and against world: the domain over the terrain) before anything is
 * allocated: SQ_ERR_INVALID_ARG naming sq_sandstorm_desc.<key>, the value and the rule. */
SQ_API sq_result sq_sandstorm_validate(sq_context *ctx, const sq_sandstorm_desc *desc,
                                       const sq_world *world);
/* Bytes sq_sandstorm_create will allocate for a resolved desc (checked against the
 * context's limit before allocating). */
SQ_API uint64_t sq_sandstorm_memory_bytes(const sq_sandstorm_desc *desc);
/* world: terrain and obstacles become solid cells; borrowed, must outlive the sandstorm. */
SQ_API sq_result sq_sandstorm_create(sq_context *ctx, const sq_sandstorm_desc *desc,
                                     const sq_world *world, sq_sandstorm **out);
SQ_API void sq_sandstorm_destroy(sq_sandstorm *s);
SQ_API sq_result sq_sandstorm_step(sq_sandstorm *s, double dt_s);
SQ_API double sq_sandstorm_max_stable_dt(const sq_sandstorm *s);
SQ_API void sq_sandstorm_get_budget(const sq_sandstorm *s, sq_sandstorm_budget *out);
SQ_API void sq_sandstorm_get_stats(const sq_sandstorm *s, sq_sandstorm_stats *out);

/* Terminal settling speed (m/s, positive down) of a sphere of radius r and density rho_p in air
 * (rho_air, mu_air), solving |w| = sqrt(8 r g (rho_p − rho_air) / (3 rho_air C_D(Re))) with
 * White's C_D(Re) (SPEC §1.8 eq. 2.29). At low Re it tends to Stokes 2 r² g Δρ / (9 μ). */
SQ_API double sq_dust_terminal_speed(double radius_m, double rho_p, double rho_air,
                                     double mu_air);
/* White's drag coefficient for a sphere, 0 < Re < 2e5. */
SQ_API double sq_drag_coefficient(double reynolds);
/* Dust vertical mass flux (kg m⁻² s⁻¹): C u*³ (1 − u*_t²/u*²) for u* > u*_t, else 0. */
SQ_API double sq_dust_emission_flux(double u_star, double u_star_t, double coeff);
/* Friction velocity from the log law: kappa u(z) / ln(z/z0). */
SQ_API double sq_friction_velocity(double u_mps, double z_m, double z0_m);

#ifdef __cplusplus
}
#endif
#endif
