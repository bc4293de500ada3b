/* squall/sph.h — weakly compressible SPH with Newtonian and non-Newtonian rheology, wall and
 * periodic boundaries, a heightfield terrain collider and box obstacles. Implements SPEC §7.2
 * (summation density including the self term), §7.3 (Müller poly6 / spiky / viscosity kernels
 * and the cubic spline, all on ONE support radius), §7.4 (velocity-gradient tensor, strain rate,
 * |γ̇| = sqrt(2 D:D), τ = 2 μ(|γ̇|) D, Monaghan's symmetric pressure term, XSPH), §7.5
 * (kick-drift-kick leap-frog, CFL/viscous/force time-step limits), §7.6 (uniform cell grid with
 * a counting sort) and §7.7 (heightfield collision with restitution and Coulomb friction).
 * It knows nothing of snow or avalanches.
 *
 * Units. SI at this API: metres, seconds, kg/m³, Pa, dynamic viscosity μ in Pa·s (the kinematic
 * viscosity is ν = μ/ρ₀ in m²/s). World axes x east, y north, z up. Positions are stored as
 * float in world coordinates: keep the domain within ~10⁴ particle spacings of the origin.
 *
 * Kernels. H = support_radius_m is the radius of every kernel (and the cell size of the
 * neighbour grid). Müller's poly6/spiky/viscosity kernels use H directly; the cubic spline's
 * smoothing length is rescaled to ℓ = H/2 so that its support 2ℓ equals H (SPEC §7.3 ⚠).
 * The time-step limits use ℓ = H/2 (the Monaghan/Morris smoothing length they were derived
 * for):  dt ≤ 0.4 ℓ/(c_s + |v|max),  dt ≤ 0.125 ℓ² ρ₀/μmax,  dt ≤ 0.25 sqrt(ℓ/|a|max).
 * Particle mass m = ρ₀ / Σ_lattice W: a cubic lattice of the given spacing has density ρ₀
 * exactly (m ≈ ρ₀ dx³; the lattice sum differs from 1/dx³ by about 1 %).
 *
 * Equation of state. LINEAR: p = k (ρ − ρ₀) with k = c_s² (SPEC eq. 3.38);
 * TAIT: p = (ρ₀ c_s²/γ) ((ρ/ρ₀)^γ − 1), γ = 7. The speed of sound c_s defaults to 10 × the
 * expected maximum flow speed (density fluctuations ≈ Ma² ≈ 1 %); the expected speed defaults
 * to sqrt(2 |g| L) with L the domain extent along gravity (free-fall speed over the domain).
 * Negative pressures are clamped to 0 unless tensile_pressure is set (SPEC §7.2 ⚠ 2).
 *
 * Gradient correction. By default the velocity gradient uses the renormalised kernel gradient
 * ∇̃W = L_i ∇W with L_i = (Σ_j V_j (x_j − x_i) ⊗ ∇W_ij)⁻¹ (Bonet & Lok 1999), so that linear
 * velocity fields have exact gradients on any particle arrangement, free surfaces included (a
 * plain spiky gradient under-estimates them by ~4.5 % on a lattice with H = 2 dx, the cubic
 * spline over-estimates them by 2 %); particles with too few neighbours for a meaningful
 * inverse (det B < 0.05 or tr L > 12) keep L = I. The pair forces (pressure, artificial and
 * Morris viscosity) use the kernel gradient times ONE constant, 1/(the lattice value of
 * Σ_j V_j (z_j − z_i) ∂W/∂z_i) computed at create: a constant keeps the pressure force the
 * gradient of an energy and the viscous force dissipative under the stable time step, whereas
 * a per-particle L pumps energy into free surfaces and stiffens the viscous term at edges
 * beyond the viscous time-step limit. Only the TENSOR viscous form uses ½(L_i + L_j) ∇W_ij.
 *
 * Boundaries. Each face of the domain box is a no-slip wall (default), a free-slip wall, open
 * (particles that leave are removed and counted) or periodic (both faces of the axis). Walls
 * are handled by mirror images: a particle within H of a wall sees the mirror image of every
 * neighbour across it (velocity negated for no-slip, normal component negated for free-slip;
 * pressure extrapolated hydrostatically, p' = p + ρ g·(x' − x), as in Adami et al. 2012).
 * Images complete the kernel support at the wall, so density, pressure and shear are right
 * up to the wall without boundary particles; hydrostatic columns rest. A safety clamp keeps
 * particles a quarter of the collision radius inside the walls. The terrain heightfield and
 * box obstacles are colliders (SPEC §7.7): penetrating particles are projected to the surface
 * plus the collision radius, the normal velocity into the surface is reversed and scaled by
 * the restitution e, and the tangential velocity is reduced by Coulomb friction
 * v_t ← v_t max(0, 1 − μ_k |Δv_n| / |v_t|).
 *
 * Time integration: kick-drift-kick leap-frog. The velocity-dependent forces (viscosity, XSPH)
 * are evaluated with the predicted end-of-step velocity; positions advance with the XSPH-
 * smoothed half-step velocity v_½ + ε Σ_j 2 m/(ρ_i + ρ_j) (v_j − v_i) W_ij (SPEC §7.4, 7.5).
 * sq_sph_step(dt_frame) sub-steps at the stable dt and logs once when it has to.
 *
 * Memory per particle (bytes, see sq_sph_memory_bytes): state 168 (positions, velocities,
 * half-step velocities, accelerations, XSPH terms, density, pressure, volume, p/ρ², the
 * correction L, the velocity gradient, the stress, |γ̇|, μ), id/cell/permutation 12, reorder
 * targets 44, list counts 4 and the neighbour list 4 × capacity (capacity ≈ 1.6 × the lattice
 * neighbour count + 8, i.e. 64 for H = 2 dx; it grows if a particle has more neighbours)
 * => 484 bytes for H = 2 dx. The cell grid adds 8 bytes per cell (cells = domain / H³); each
 * sub-step only touches the cells between the lowest and highest occupied one.
 *
 * Performance (measured on a shared 2-core Xeon, single thread, H = 2 dx, ~29 neighbours):
 * about 0.55 M particle-steps/s per core with the default C flags; compiling
 * src/solvers/sph/sph_passes.c with -fno-math-errno -fno-trapping-math (which lets GCC
 * vectorise the neighbour loops) about 1.0 M per core.
 *
 * Threads: every pass is a parallel loop over particles that writes only its own particle,
 * so results are bit-identical for any thread count. */
#ifndef SQ_SPH_H
#define SQ_SPH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sq_sph sq_sph;

typedef enum sq_sph_kernel {
    SQ_SPH_KERNEL_DEFAULT = 0, /* = SQ_SPH_KERNEL_CUBIC (see below) */
    /* Müller 2003: poly6 for density and XSPH, spiky gradient for pressure, velocity gradient
     * and viscous terms, viscosity-kernel Laplacian for the MULLER viscous form (SPEC §7.3).
     * The spiky gradient is not the gradient of the poly6 density kernel, so the pressure
     * force does not conserve energy: a resting water column under gravity develops
     * ~0.1 m/s of particle noise within a second. Faithful to the thesis, not the default. */
    SQ_SPH_KERNEL_MULLER = 1,
    /* Cubic spline (ℓ = H/2) for density, gradients and XSPH (the MULLER viscous form keeps
     * the viscosity-kernel Laplacian). Density and pressure use the same kernel, so pressure
     * forces conserve energy. */
    SQ_SPH_KERNEL_CUBIC = 2
} sq_sph_kernel;

typedef enum sq_sph_gradient {
    SQ_SPH_GRADIENT_DEFAULT = 0,   /* = SQ_SPH_GRADIENT_CORRECTED */
    SQ_SPH_GRADIENT_CORRECTED = 1, /* renormalised kernel gradient (see banner) */
    SQ_SPH_GRADIENT_PLAIN = 2      /* the kernel gradient as in the thesis */
} sq_sph_gradient;

/* How the viscous acceleration is formed. The effective viscosity μ_i = μ(|γ̇|_i) always comes
 * from the SPH velocity-gradient tensor (SPEC §7.4); the forms differ in how μ acts:
 *   MORRIS  Σ_j m (μ_i + μ_j)/(ρ_i ρ_j) (x_ij·∇̃W_ij)/(r² + 0.01 ℓ²) (v_i − v_j) (Morris et al.
 *           1997 with per-particle μ): exactly dissipative pair by pair, damps every velocity
 *           mode, exact for Newtonian flow and for plane shear flows of any rheology.
 *   MULLER  Σ_j ½(μ_i + μ_j) m/(ρ_i ρ_j) ∇²W_visc (v_j − v_i) (Müller 2003, eq. 3.39,
 *           symmetrised): the thesis's Newtonian term; about 1–5 % too weak on a lattice.
 *   TENSOR  Σ_j m (τ_i + τ_j)/(ρ_i ρ_j) · ∇̃W_ij, τ = 2 μ D (SPEC eq. 3.57): the thesis's
 *           non-Newtonian term. The product of two SPH first derivatives cannot see zig-zag
 *           velocity modes, which then grow unchecked: in the power-law Poiseuille test it
 *           approaches the analytic profile (≈ 3 %) and then degrades to > 20 % error after about
 *           one viscous time. Kept for comparison with the thesis; not recommended. */
typedef enum sq_sph_viscous {
    SQ_SPH_VISCOUS_DEFAULT = 0, /* = SQ_SPH_VISCOUS_MORRIS */
    SQ_SPH_VISCOUS_MORRIS = 1,
    SQ_SPH_VISCOUS_MULLER = 2,
    SQ_SPH_VISCOUS_TENSOR = 3
} sq_sph_viscous;

typedef enum sq_sph_eos {
    SQ_SPH_EOS_DEFAULT = 0, /* = SQ_SPH_EOS_LINEAR */
    SQ_SPH_EOS_LINEAR = 1,  /* p = c_s² (ρ − ρ₀) */
    SQ_SPH_EOS_TAIT = 2     /* p = ρ₀ c_s²/γ ((ρ/ρ₀)^γ − 1) */
} sq_sph_eos;

typedef enum sq_sph_rheology_kind {
    SQ_SPH_RHEOLOGY_DEFAULT = 0, /* = SQ_SPH_RHEOLOGY_NEWTONIAN */
    SQ_SPH_RHEOLOGY_NEWTONIAN = 1,
    SQ_SPH_RHEOLOGY_POWER_LAW = 2, /* Ostwald–de Waele μ = K |γ̇|^(n−1) (SPEC eq. 3.26) */
    SQ_SPH_RHEOLOGY_CROSS = 3,     /* μ = μ∞ + (μ₀ − μ∞)/(1 + (K|γ̇|)^n) (SPEC eq. 3.29) */
    SQ_SPH_RHEOLOGY_BINGHAM = 4    /* Papanastasiou: μ = K + τ_y (1 − e^(−m|γ̇|))/|γ̇| */
} sq_sph_rheology_kind;

/* Effective viscosity model. Non-Newtonian models go through the velocity-gradient tensor:
 * D = ½(∇v + ∇vᵀ), |γ̇| = sqrt(2 D:D) (simple shear u = γ̇ y gives |γ̇| = γ̇), τ = 2 μ(|γ̇|) D. */
typedef struct sq_sph_rheology {
    sq_sph_rheology_kind kind;
    double mu_pa_s;     /* NEWTONIAN: dynamic viscosity μ (Pa·s); 0 is physical (inviscid) */
    /* POWER_LAW: consistency K (Pa·sⁿ); CROSS: time constant K (s);
     * BINGHAM: plastic viscosity K (Pa·s). Must be > 0 (BINGHAM: ≥ 0). */
    double k;
    double n;           /* POWER_LAW, CROSS: exponent n > 0 (no default) */
    double mu0_pa_s;    /* CROSS: zero-shear viscosity μ₀ ≥ μ∞ */
    double mu_inf_pa_s; /* CROSS: infinite-shear viscosity μ∞ ≥ 0; 0 is physical */
    double yield_stress_pa; /* BINGHAM: τ_y ≥ 0; 0 is physical (Newtonian with μ = K) */
    double bingham_m_s;     /* BINGHAM: Papanastasiou regularisation m (s); 0 -> 100 s */
    /* POWER_LAW: |γ̇| is floored at this value before μ = K|γ̇|^(n−1) (keeps μ finite for
     * n < 1 and non-zero for n > 1); 0 -> 1e-3 1/s */
    double shear_rate_min_per_s;
    /* Cap on the effective viscosity of every model (Pa·s); 0 = no cap. For POWER_LAW with
     * n < 1 the floor above already bounds μ by K γ̇_min^(n−1); a lower cap shortens the
     * viscous time-step limit, which scales with 1/μmax. */
    double mu_max_pa_s;
} sq_sph_rheology;

/* Named rheology presets (SPEC §7.9):
 *   "s2-avalanche"   Cross, μ∞ = 1 Pa·s, μ₀ = 100 Pa·s, n = 2, K = 3000 s (the thesis's final
 *                    avalanche, Fig. 3.20; its units are unstated, read here as SI)
 *   "s2-cross-curve" Cross, μ∞ = 1, μ₀ = 200, n = 1, K = 300 (Fig. 3.9)
 *   "water"          Newtonian, μ = 1.0e-3 Pa·s (20 °C)
 * SQ_ERR_NOT_FOUND for another name (the message lists the names). */
SQ_API sq_result sq_sph_rheology_preset(const char *name, sq_sph_rheology *out);
/* Effective dynamic viscosity μ(|γ̇|) in Pa·s of a rheology (zero fields take their defaults;
 * no validation). */
SQ_API double sq_sph_rheology_viscosity(const sq_sph_rheology *r, double shear_rate_per_s);

typedef enum sq_sph_face {
    SQ_SPH_FACE_XMIN = 0,
    SQ_SPH_FACE_XMAX = 1,
    SQ_SPH_FACE_YMIN = 2,
    SQ_SPH_FACE_YMAX = 3,
    SQ_SPH_FACE_ZMIN = 4,
    SQ_SPH_FACE_ZMAX = 5
} sq_sph_face;

typedef enum sq_sph_boundary {
    SQ_SPH_BOUNDARY_DEFAULT = 0,   /* = SQ_SPH_BOUNDARY_NO_SLIP */
    SQ_SPH_BOUNDARY_NO_SLIP = 1,   /* wall, mirror image with negated velocity */
    SQ_SPH_BOUNDARY_FREE_SLIP = 2, /* wall, mirror image with negated normal velocity */
    SQ_SPH_BOUNDARY_OPEN = 3,      /* particles crossing the face are removed */
    SQ_SPH_BOUNDARY_PERIODIC = 4   /* both faces of the axis; the axis needs ≥ 3 H */
} sq_sph_boundary;

typedef struct sq_sph_desc {
    double spacing_m;          /* initial particle spacing dx (> 0, required) */
    double support_radius_m;   /* kernel support H; 0 -> 2 dx (≈ 33 neighbours) */
    double rest_density_kgm3;  /* ρ₀; 0 -> 1000 */
    sq_sph_eos eos;
    double speed_of_sound_mps; /* c_s; 0 -> 10 × max_speed_mps */
    double max_speed_mps;      /* expected flow speed; 0 -> sqrt(2|g| L) (see banner), or
                                  1 m/s without gravity */
    bool tensile_pressure;     /* keep negative pressure (cohesion); default clamps p ≥ 0 */
    /* Added to the EOS pressure (Pa); 0 is physical (off). For confined flows without a free
     * surface (channels, periodic boxes) a background pressure of ~0.05–1 ρ₀ c_s² keeps the
     * particle arrangement regular (Morris et al. 1997); never use it with a free surface. */
    double background_pressure_pa;
    sq_sph_kernel kernel;
    sq_sph_gradient gradient;
    sq_sph_viscous viscous;
    sq_sph_rheology rheology;
    /* Monaghan (1992) artificial viscosity α in [0, 1] for approaching pairs,
     * Π_ij = −α c_s ℓ (v_ij·x_ij)/((r² + 0.01 ℓ²) ρ̄_ij); 0 is physical (off). It damps the
     * acoustic noise of weakly compressible SPH in low-viscosity flows (0.01–0.1 typical);
     * its effective kinematic viscosity is about α ℓ c_s / 10. */
    double artificial_viscosity;
    double xsph_epsilon;       /* XSPH ε in [0, 1]; 0 -> 0.5 (S2); see xsph_off */
    bool xsph_off;             /* disable XSPH (ε = 0) */
    double gravity_mps2[3];    /* body acceleration (m/s²); 0 is physical. Earth: {0,0,-9.81} */
    double domain_min_m[3];    /* the domain box (required, max > min on every axis) */
    double domain_max_m[3];
    /* 0 (default): the neighbour grid is a dense box of cells over the whole domain. > 0: a
     * terrain-following grid for flows that stay near a terrain with a large drop (a real
     * avalanche path): each column of cells starts just below the lowest terrain under it (the
     * heightfield of sq_sph_set_terrain, set before particles are added) and holds this much
     * height (m) above it; a particle higher than that leaves the domain through its open top.
     * Needs every face OPEN. Memory: cells_x × cells_y × (layer / H + 3) instead of the box. */
    double terrain_layer_m;
    sq_sph_boundary boundary[6]; /* per face, indexed by sq_sph_face */
    double collision_radius_m; /* clearance kept from colliders; 0 -> dx/2 */
    size_t max_particles;      /* capacity allocated at create (≥ 1, required) */
    int neighbour_capacity;    /* list entries per particle; 0 -> auto (grows if exceeded) */
    int max_substeps;          /* per sq_sph_step call before SQ_ERR_UNSTABLE; 0 -> 100000 */
    double dt_max_s;           /* optional cap on the sub-step; 0 = none */
} sq_sph_desc;

/* The desc with zero fields replaced by their defaults (no validation; speed of sound and the
 * expected speed are derived as documented). */
SQ_API sq_sph_desc sq_sph_desc_resolve(const sq_sph_desc *desc);
/* Checks a desc; messages name the field, its value and the rule. */
SQ_API sq_result sq_sph_desc_validate(const sq_sph_desc *desc);
/* Bytes sq_sph_create allocates for this desc with room for `particles` particles (the desc's
 * max_particles is ignored here). 0 if the desc's domain or spacing are unusable. */
SQ_API uint64_t sq_sph_memory_bytes(const sq_sph_desc *desc, size_t particles);

/* Validates the desc and refuses (SQ_ERR_TOO_LARGE, naming the particle count and bytes) a
 * request above the context's memory limit before allocating anything. */
SQ_API sq_result sq_sph_create(sq_context *ctx, const sq_sph_desc *desc, sq_sph **out);
SQ_API void sq_sph_destroy(sq_sph *sph); /* accepts NULL */

/* Adds count particles: positions_m holds x,y,z per particle (inside the domain box),
 * velocities_mps likewise (NULL = at rest). Both arrays are borrowed for the call. Particle
 * ids continue from the number added before. SQ_ERR_TOO_LARGE beyond max_particles. */
SQ_API sq_result sq_sph_add_particles(sq_sph *sph, size_t count, const float *positions_m,
                                      const float *velocities_mps);
/* Fills the box [min, max) with particles on the cubic lattice of the desc's spacing, at
 * min + (i + ½) dx, with the given velocity (NULL = rest). *added (may be NULL) gets the count. */
SQ_API sq_result sq_sph_add_block(sq_sph *sph, const double min_m[3], const double max_m[3],
                                  const double velocity_mps[3], size_t *added);

typedef struct sq_sph_collider_desc {
    double restitution;    /* e in [0, 1] for the normal velocity; 0 is physical (default) */
    double friction;       /* kinetic Coulomb μ_k ≥ 0; 0 -> 0.2 (S2), see frictionless */
    bool frictionless;     /* μ_k = 0 */
    /* Terrain only. false (default): S2's contact friction above (SPEC §7.7), which acts on the
     * particles touching the terrain; an almost inviscid flow then slides over its own braked
     * base. true: the basal friction of the depth-averaged avalanche models (Savage & Hutter;
     * Voellmy in RAMMS and AvaFrame), spread over the flow column as in those models: every
     * particle within the flow depth h of its column (particle volumes per area on the neighbour
     * grid's columns, 3x3 smoothed, at least dx) loses μ_k g_n dt of its speed along the terrain
     * (g_n the gravity normal to it; a particle at rest stays where tan θ < μ_k) and the Voellmy
     * drag g |v_t| v_t / (ξ h) (implicit); the contact itself is then frictionless. A layer of
     * depth h tends to sqrt(ξ h (sin θ − μ_k cos θ)) and decelerates at g (μ_k cos θ − sin θ)
     * where the slope is below the friction angle. */
    bool column_friction;
    /* Voellmy's turbulent friction ξ (m/s²) of avalanche practice (Salm 1993): the basal stress
     * ρ g |v|²/ξ on top of the Coulomb part; needs column_friction. 0 is physical (none). */
    double turbulent_friction_mps2;
} sq_sph_collider_desc;

/* Heightfield terrain: heights_m[j*nx + i] is the elevation at (origin_x + i dx, origin_y +
 * j dy) (the same layout as sq_world). Bilinear height and normal; outside the grid the edge
 * sample is extended. The heights are COPIED (the caller's array is borrowed for the call);
 * calling again replaces the terrain. */
typedef struct sq_sph_terrain_desc {
    double origin_m[2];   /* x, y of sample (0, 0); 0 is physical */
    double spacing_m[2];  /* dx, dy > 0 */
    int nx, ny;           /* samples ≥ 2 each */
    const float *heights_m;
    sq_sph_collider_desc contact;
} sq_sph_terrain_desc;
/* Sets (or replaces) the terrain; heights_m is borrowed for the call. SQ_ERR_INVALID_ARG (the
 * message names the field) for a bad size or spacing, non-finite values or contact law. */
SQ_API sq_result sq_sph_set_terrain(sq_sph *sph, const sq_sph_terrain_desc *terrain);
/* Terrain height (m) and unit normal at (x, y). SQ_ERR_NOT_FOUND without a terrain. */
SQ_API sq_result sq_sph_terrain_sample(const sq_sph *sph, double x_m, double y_m,
                                       double *height_m, double normal[3]);

/* Axis-aligned box obstacle (a building): solid for particles. */
typedef struct sq_sph_box_desc {
    double min_m[3], max_m[3];
    sq_sph_collider_desc contact;
} sq_sph_box_desc;
/* Adds a box obstacle (index = the number added before). SQ_ERR_INVALID_ARG for min > max or a
 * bad contact law. */
SQ_API sq_result sq_sph_add_box_obstacle(sq_sph *sph, const sq_sph_box_desc *box);
/* Moves box obstacle `index` (0-based, in the order added) to [min_m, max_m] between steps: a
 * gate that is lifted, a moving wall (its contact law is kept; the box has no velocity of its
 * own, so particles are only pushed out of where it now is). */
SQ_API sq_result sq_sph_move_box_obstacle(sq_sph *sph, int index, const double min_m[3],
                                          const double max_m[3]);

/* A voxelised solid (e.g. meshes voxelised with sq_world_voxelise): solid[i + n[0] (j + n[1] k)]
 * != 0 for the cell centred at origin_m + (i + 1/2, j + 1/2, k + 1/2) cell_m. The solver keeps
 * its signed distance at the cell centres (exact Euclidean distance transform; the surface lies
 * halfway between a solid and an empty centre; negative inside) and collides particles with its
 * 0-level: the distance is trilinear, the normal is its gradient. Outside the box nothing is
 * solid. The mask is COPIED (borrowed for the call); each call adds one collider. */
typedef struct sq_sph_solid_grid_desc {
    double origin_m[3];
    double cell_m;        /* > 0 */
    int n[3];             /* cells >= 2 each */
    const uint8_t *solid;
    sq_sph_collider_desc contact;
} sq_sph_solid_grid_desc;
/* Adds a voxel solid (solid is borrowed for the call; its signed distance field is built now).
 * SQ_ERR_INVALID_ARG (naming the field) for a bad size or cell; SQ_ERR_TOO_LARGE for memory. */
SQ_API sq_result sq_sph_add_solid_grid(sq_sph *sph, const sq_sph_solid_grid_desc *grid);
/* Signed distance (m) to the solid grids' surface at p (the smallest over the grids; +INFINITY
 * outside every grid) and its unit normal (may be NULL). */
SQ_API double sq_sph_solid_distance(const sq_sph *sph, const double p_m[3], double normal[3]);

/* Replaces the body acceleration (m/s², e.g. to ramp gravity up smoothly when settling a
 * column, or to tilt a slope). */
SQ_API sq_result sq_sph_set_gravity(sq_sph *sph, const double gravity_mps2[3]);

/* Advances by dt_frame_s (> 0), in sub-steps no longer than the stable dt. Errors:
 * SQ_ERR_UNSTABLE (a non-finite or runaway velocity — faster than 3 c_s — or more than
 * max_substeps sub-steps) naming the step, particle index and id, field and a hint. */
SQ_API sq_result sq_sph_step(sq_sph *sph, double dt_frame_s);
/* The stable sub-step (s) for the current state (forces are evaluated if stale). */
SQ_API double sq_sph_max_stable_dt(sq_sph *sph);

/* Read-only views, valid until the next step, add or destroy. Particles are reordered by cell
 * every sub-step; id[] follows each particle (its creation index). */
typedef struct sq_sph_view {
    size_t count;
    const float *x, *y, *z;       /* m */
    const float *vx, *vy, *vz;    /* m/s */
    const float *density;         /* kg/m³ */
    const float *pressure;        /* Pa */
    const float *shear_rate;      /* |γ̇| (1/s) */
    const float *viscosity;       /* effective μ (Pa·s) */
    const uint32_t *id;
} sq_sph_view;
/* Borrowed arrays of the current particles, valid until the next step, add or remove. */
SQ_API sq_sph_view sq_sph_particles(const sq_sph *sph);

typedef struct sq_sph_info {
    double particle_mass_kg;
    double support_radius_m;
    double speed_of_sound_mps;
    double max_speed_mps;
    double stiffness;             /* LINEAR: k = c_s² (m²/s²); TAIT: B = ρ₀ c_s²/γ (Pa) */
    int cells[3];                 /* neighbour grid */
    int neighbour_capacity;
    size_t max_particles;
    uint64_t bytes;               /* allocated */
} sq_sph_info;
/* Constants and sizes of the solver. */
SQ_API sq_sph_info sq_sph_get_info(const sq_sph *sph);

typedef struct sq_sph_stats {
    double time_s;                 /* simulated time since create */
    uint64_t steps;                /* sub-steps since create */
    int substeps;                  /* in the last sq_sph_step call */
    double dt_s;                   /* the last sub-step */
    const char *dt_limit;          /* what limited it: "cfl", "viscous", "force", "dt_max",
                                      "frame" */
    double max_speed_mps;
    double max_accel_mps2;
    double max_viscosity_pa_s;
    double neighbours_per_particle; /* mean list length, images included */
    int max_neighbours;
    size_t particles;
    uint64_t removed;              /* left through open faces since create */
    /* wall-clock ms spent in each stage during the last sq_sph_step call */
    double ms_sort, ms_density, ms_strain, ms_forces, ms_integrate;
} sq_sph_stats;
/* Counters and timings, the last sq_sph_step call's where so marked. */
SQ_API sq_sph_stats sq_sph_get_stats(const sq_sph *sph);

/* Checkpoints (squall/core.h records): the complete particle state, to restore into a solver
 * created from the same desc and colliders, which then steps bit-identically. */
SQ_API sq_result sq_sph_save_state(const sq_sph *s, sq_state_writer *w);
SQ_API sq_result sq_sph_load_state(sq_sph *s, sq_state_reader *r);

#ifdef __cplusplus
}
#endif
#endif
