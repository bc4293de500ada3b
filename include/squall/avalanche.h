/* squall/avalanche.h — a dense-flow snow avalanche (SPEC §7, source document S2 ch. 3): a slab
 * of snow released on the world's terrain flows down as a weakly compressible SPH fluid with a
 * non-Newtonian rheology (the SPH solver of include/squall/sph.h) and deposits on the run-out.
 *
 *   - terrain: the world heightfield (procedural `mountain`: a release slope descending toward
 *     +x into a flat run-out plain with a gully, or a 16-bit PNG heightmap) is the SPH solver's
 *     heightfield collider with restitution and kinetic Coulomb friction μ_k (S2: 0.2); the
 *     world's obstacles become box colliders (their axis-aligned bounding boxes);
 *   - release: a slab of slope-normal thickness `release.depth_m` over the horizontal rectangle
 *     centred at (release.x_m, release.y_m) of release.length_m (x) by release.width_m (y).
 *     Particles sit on vertical columns on the lattice of the particle spacing dx; a column
 *     where the terrain normal has vertical component n_z holds depth/(n_z dx) particles on
 *     average (ordered dithering of the fraction), its lowest particle dx/2 from the terrain
 *     along the normal. The particle count therefore follows from the release volume,
 *     N ≈ V / dx³ with V = Σ_columns dx² depth / n_z;
 *   - rheology: Cross (S2 eq. 3.29, the thesis's avalanche μ∞ = 1 Pa·s, μ₀ = 100 Pa·s, n = 2,
 *     K = 3000 s by default; see SPEC §7.9 ⚠ on its sensitivity), Newtonian, power law or
 *     Bingham (Papanastasiou): μ(|γ̇|) from the SPH velocity-gradient tensor, acting through
 *     Morris's pair form (default), Müller's Laplacian or S2's stress tensor τ = 2 μ D;
 *   - diagnostics: the front s_f is the `metrics.front_percentile` quantile (0.99) of the
 *     particles' horizontal coordinate along the fall line (the downhill direction of the
 *     terrain averaged over the release zone, +x on the mountain terrain); the run-out is s_f
 *     measured from the release zone's lower edge; the α angle is atan(H_drop / L) between the
 *     top of the release zone (the centre of its upslope edge, on the terrain) and the front
 *     particle (on the terrain below it); the deposit depth map is the snow volume per unit
 *     area, Σ m / (max(ρ_i, ρ₀) A), on a regular grid over the domain's footprint.
 *
 * Units: SI at this API (m, s, kg/m³, Pa·s). World axes x east, y north, z up. */
#ifndef SQ_AVALANCHE_H
#define SQ_AVALANCHE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sq_avalanche_rheology {
    SQ_AVALANCHE_RHEOLOGY_CROSS = 0,     /* default: μ∞ + (μ₀ − μ∞)/(1 + (K|γ̇|)^n) */
    SQ_AVALANCHE_RHEOLOGY_NEWTONIAN = 1, /* μ constant */
    SQ_AVALANCHE_RHEOLOGY_POWER_LAW = 2, /* K |γ̇|^(n−1) */
    SQ_AVALANCHE_RHEOLOGY_BINGHAM = 3    /* μ_p + τ_y (1 − e^(−m|γ̇|))/|γ̇| */
} sq_avalanche_rheology;

/* Zero fields take the defaults listed by `squall params avalanche` (the parameter table in
 * src/phen/avalanche/avalanche_plugin.c); fields marked "0 is physical" or "0 = auto" keep 0. */
typedef struct sq_avalanche_desc {
    /* particles */
    double spacing_m;          /* initial particle spacing dx; 0 -> 1 m */
    double support_radius_m;   /* kernel support H; 0 = auto (2 dx) */
    double density_kgm3;       /* rest density ρ₀ of the flowing snow; 0 -> 300 kg/m³ */
    double speed_of_sound_mps; /* c_s; 0 = auto (5 × sqrt(2 g ΔH), ΔH the possible drop) */
    bool cohesion;             /* keep negative pressure (default clamps p ≥ 0, SPEC §7.2 ⚠ 2) */
    /* release slab: the rectangle, or the polygons of a world area (release_area) */
    double release_x_m, release_y_m; /* centre of the release rectangle; 0 is physical */
    double release_length_m;   /* extent along x; 0 -> 40 m */
    double release_width_m;    /* extent along y; 0 -> 30 m */
    double release_depth_m;    /* slab thickness normal to the slope; 0 -> 2 m (an area's
                                  polygons override it with their attribute, when given) */
    char release_area[256];    /* name of a world area (world.areas) whose polygons are the
                                  release; "" = the rectangle */
    /* Slope-dependent thickness of the Swiss guidelines (Salm, Burkard & Gubler 1990, also in
     * RAMMS and AvaFrame): d(psi) = d0 * 0.291 / (sin psi - 0.202 cos psi), = d0 at psi = 28 deg
     * and thinner on steeper slopes (psi below 28 deg keeps d0), plus release_gradient_m per
     * 100 m of altitude above release_reference_altitude_m (d0 the thickness above). */
    bool release_slope_dependent;
    double release_gradient_m;          /* m per 100 m altitude; 0 is physical (none) */
    double release_reference_altitude_m; /* 0 -> 2000 m */
    /* rheology */
    int rheology;              /* sq_avalanche_rheology; 0 = Cross */
    double mu_pa_s;            /* NEWTONIAN: μ; 0 -> 1 Pa·s */
    double mu0_pa_s;           /* CROSS: zero-shear μ₀; 0 -> 100 Pa·s (S2) */
    double mu_inf_pa_s;        /* CROSS: infinite-shear μ∞; 0 -> 1 Pa·s (S2) */
    double cross_k_s;          /* CROSS: time constant K; 0 -> 3000 s (S2) */
    double cross_n;            /* CROSS: exponent n; 0 -> 2 (S2) */
    double power_k;            /* POWER_LAW: consistency K (Pa·sⁿ); 0 -> 1.5 (S2 Fig. 3.7) */
    double power_n;            /* POWER_LAW: exponent n; 0 -> 0.5 (S2 Fig. 3.7) */
    double bingham_mu_pa_s;    /* BINGHAM: plastic viscosity; 0 -> 1.5 Pa·s (S2 Fig. 3.8) */
    double yield_stress_pa;    /* BINGHAM: τ_y; 0 is physical */
    double mu_max_pa_s;        /* cap on the effective viscosity; 0 is physical (no cap) */
    /* numerics */
    int kernel;                /* 0 = cubic spline (solver default), 1 = Müller's set (S2) */
    int viscous;               /* 0 = Morris pair form (default), 1 = Müller Laplacian,
                                  2 = stress tensor τ = 2μD (S2 eq. 3.57) */
    double xsph_epsilon;       /* XSPH ε; 0 -> 0.5 (S2) */
    double artificial_viscosity; /* Monaghan α; 0 -> 0.1 (see no_artificial_viscosity) */
    bool no_artificial_viscosity; /* α = 0 */
    double dt_max_s;           /* cap on the sub-step; 0 is physical (none) */
    /* terrain contact (SPEC §7.7) */
    double friction;           /* kinetic Coulomb μ_k; 0 -> 0.2 (S2) */
    double restitution;        /* normal restitution e; 0 is physical (perfectly inelastic) */
    bool column_friction;      /* the basal friction of the depth-averaged models over the flow
                                  column (sq_sph_collider_desc.column_friction) instead of S2's
                                  contact friction */
    double turbulent_friction_mps2; /* Voellmy xi (m/s²) of the basal drag rho g v²/xi on top of
                                       the Coulomb part (needs column_friction); 0 is physical
                                       (none, S2) */
    /* domain box of the simulation; all zero = auto: the terrain's footprint, from below the
     * lowest terrain to 10 H + 20 m above the release top */
    float domain_min_m[3];
    float domain_max_m[3];
    /* > 0: the neighbour grid follows the terrain and holds this height above it (particles
     * higher leave through the open top; sq_sph_desc.terrain_layer_m); 0 = auto: follows the
     * terrain, with 10 H + 20 m above the release's thickest column, when domain_min_m/max_m
     * are all zero or when that needs less than half the cells of the box; else the dense box */
    double domain_layer_m;
    /* deposit map and metrics */
    double deposit_cell_m;     /* deposit grid cell; 0 = auto (2 dx) */
    /* hazard maps (peak flow depth, peak speed, peak pressure, deposit depth, travel angle):
     * a grid over the whole terrain, aligned with its samples; cell 0 = the terrain's spacing */
    double hazard_cell_m;
    double moving_speed_mps;   /* a particle "moves" above this speed; 0 -> 0.5 m/s */
    double front_percentile;   /* quantile of the fall-line coordinate that is the front; 0 -> 0.99 */
    double airborne_m;         /* a particle is airborne this far above the terrain; 0 -> 2 m */
    /* rendering */
    double radius_factor;      /* sphere radius / dx; 0 -> 0.6 */
    double albedo;             /* snow albedo of the particles; 0 -> 0.9 */
    bool no_deposit_surface;   /* do not publish the snow surface drawable */
    bool spheres;              /* every particle as a sphere, the surface only where the snow rests
                                  (default: the snow surface over all snow, spheres for spray) */
    bool powder;               /* publish a powder-cloud volume from fast particles at the front */
    double powder_speed_mps;   /* particles faster than this feed the powder cloud; 0 -> 10 m/s */
    double powder_cell_m;      /* powder grid cell; 0 -> 2 m */
    double powder_box_m;       /* side of the powder grid's cubic box, which moves with the flow
                                  by whole cells; 0 -> 256 m (at most 128 cells per axis: the
                                  cell grows to fit) */
    double powder_shed;        /* shed mass per s per (m/s of excess speed), as a fraction of a
                                  particle's mass; 0 -> 2e-5 (a wet flow's veil) */
} sq_avalanche_desc;

typedef struct sq_avalanche sq_avalanche;

/* Diagnostics of the current state (see the banner for the definitions). */
typedef struct sq_avalanche_state {
    double time_s;              /* simulated time since create */
    size_t particles;           /* alive */
    size_t released;            /* created at release */
    uint64_t removed;           /* left the domain through its faces */
    double release_volume_m3;   /* V = Σ_columns dx² depth / n_z */
    double mass_kg;             /* particles × particle mass */
    double fall_dir[2];         /* horizontal unit vector down the fall line */
    double front_m;             /* fall-line coordinate of the front (world, s = x·fall_dir) */
    double front_speed_mps;     /* d front_m / dt between the last two evaluations */
    double runout_m;            /* front_m − the release zone's lower edge */
    double alpha_deg;           /* atan(H_drop / L) from the release top to the front */
    double drop_m;              /* H_drop */
    double moving_fraction;     /* share of particles faster than moving_speed_mps */
    double max_speed_mps;
    double mean_speed_mps;
    double max_height_m;        /* highest particle above the terrain, along its normal (splash) */
    double airborne_fraction;   /* share of particles more than airborne_m above the terrain
                                   (along its normal) */
    double below_terrain_m;     /* deepest particle below the terrain surface (≥ 0) */
    double deposit_mean_m;      /* mean deposit depth over covered cells */
    double deposit_max_m;
    double deposit_volume_m3;   /* ∫ depth dA */
    double deposit_area_m2;     /* area of covered cells */
    int substeps;               /* solver sub-steps since the previous evaluation */
    double dt_s;                /* the last sub-step */
    /* along the thalweg (the path of the mass centre, sampled every 0.05 s): */
    double thalweg_runout_m;    /* horizontal length from the crown (the release's highest point)
                                   along the thalweg to the front */
    double thalweg_alpha_deg;   /* atan(drop / thalweg_runout_m), crown to the terrain under the
                                   front */
    double beta_deg;            /* Lied & Bakkehøi's beta: from the crown to the first point of
                                   the path (the thalweg, continued straight on beyond its end)
                                   below which the terrain's slope over 100 m is under 10 deg;
                                   0 if there is none */
    double alpha_lb_deg;        /* their statistical run-out angle 0.96 beta − 1.4 deg */
    double released_volume_m3;  /* sum of the released particles' rest volumes m/rho0 */
    double mass_balance;        /* (alive + removed − released) / released particles: 0 */
} sq_avalanche_state;

/* The desc with zero fields replaced by defaults (no validation). */
SQ_API sq_result sq_avalanche_desc_resolve(const sq_avalanche_desc *in, sq_avalanche_desc *out);
/* Checks the desc against physics and the world: spacing and support > 0, rheology ranges
 * (μ₀ ≥ μ∞, n > 0, ...), the release rectangle inside the terrain and the domain, and the
 * particle count against the context's memory limit (SQ_ERR_TOO_LARGE naming the count and
 * bytes; nothing is allocated). Messages name the key as layers.avalanche.<key>. */
SQ_API sq_result sq_avalanche_validate(sq_context *ctx, const sq_avalanche_desc *desc,
                                       const sq_world *world);
/* Particles the release produces on this world (0 if the desc or world are unusable). */
SQ_API size_t sq_avalanche_release_count(const sq_avalanche_desc *desc, const sq_world *world,
                                         double *volume_m3);
/* Bytes create will allocate (SPH solver plus deposit, drawables and metrics). */
SQ_API uint64_t sq_avalanche_memory_bytes(const sq_avalanche_desc *desc, const sq_world *world);
/* world: borrowed, must outlive the avalanche. */
SQ_API sq_result sq_avalanche_create(sq_context *ctx, const sq_avalanche_desc *desc,
                                     const sq_world *world, sq_avalanche **out);
SQ_API void sq_avalanche_destroy(sq_avalanche *a); /* accepts NULL */
/* Advances by dt_s (> 0), sub-stepping at the SPH solver's stable step (logged once).
 * SQ_ERR_UNSTABLE from the solver names the step, particle and field. */
SQ_API sq_result sq_avalanche_step(sq_avalanche *a, double dt_s);
/* The solver's stable step for the current state (s). */
SQ_API double sq_avalanche_max_stable_dt(const sq_avalanche *a);
/* Diagnostics (evaluated lazily after a step). */
SQ_API sq_result sq_avalanche_get_state(sq_avalanche *a, sq_avalanche_state *out);
/* The deposit depth map (m), nx*ny, x fastest, cell (i, j) centred at origin + (i + ½) cell;
 * valid until the next step or destroy. */
SQ_API const float *sq_avalanche_deposit(sq_avalanche *a, int *nx, int *ny, double origin_m[2],
                                         double *cell_m);
/* Particle positions (x, y, z interleaved, m) of the current state; valid until the next
 * step or destroy. */
SQ_API const float *sq_avalanche_positions(sq_avalanche *a, size_t *count);

#ifdef __cplusplus
}
#endif
#endif
