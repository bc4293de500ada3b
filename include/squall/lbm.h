/* squall/lbm.h — D3Q15 lattice-Boltzmann wind solver (SPEC §5.2–5.5, with its corrections:
 * the equilibrium carries the ½ on the quadratic term, τ must exceed ½, wind injection is the
 * mass-conserving ΔF_i = 3 w_i ρ (c_i·V) and gusts vary around the mean).
 *
 * The solver knows nothing of snow: it moves air on an nx × ny × nz lattice of cubic cells
 * (x east, y north, z up; cell (i,j,k) has its centre at ((i+½)Δx, (j+½)Δx, (k+½)Δx) from the
 * domain's lower corner). Cells are fluid or solid; the caller may turn cells solid or fluid
 * between steps (terrain, buildings, fences, snow cells that filled up).
 *
 * Memory: 15 float populations per cell, updated in place with the AA pattern (60 B), 1 B solid
 * flag, 16 B for the density/velocity views, 4 B for the friction-velocity view, all on a
 * lattice padded by one ghost layer: about 81 B per cell (sq_lbm_memory_bytes gives the exact
 * figure). One cell update reads and writes its 15 populations once: 120 B of memory traffic.
 *
 * Units: SI at this API. Lattice units (Δx = Δt = 1) are used inside; the conversion lives in
 * one place (lbm_desc.c) and is reported by sq_lbm_get_info. */
#ifndef SQ_LBM_H
#define SQ_LBM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/field.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sq_lbm sq_lbm;

/* Collision operator. */
typedef enum sq_lbm_collision {
    SQ_LBM_COLLISION_DEFAULT = 0, /* = SQ_LBM_COLLISION_SMAGORINSKY */
    SQ_LBM_COLLISION_BGK = 1,     /* single relaxation time ω = 1/τ (SPEC eq 2) */
    SQ_LBM_COLLISION_TRT = 2,     /* two relaxation times: ω+ = 1/τ, ω- from the magic number Λ */
    /* TRT whose symmetric rate follows a Smagorinsky eddy viscosity computed from the local
     * non-equilibrium stress (SPEC §5.3 recommendation for high-Reynolds atmospheric flow) */
    SQ_LBM_COLLISION_SMAGORINSKY = 3
} sq_lbm_collision;

/* Boundary condition of one face of the box. */
typedef enum sq_lbm_bc {
    SQ_LBM_BC_DEFAULT = 0,   /* = SQ_LBM_BC_PERIODIC */
    SQ_LBM_BC_PERIODIC = 1,  /* wraps to the opposite face (both faces of the axis) */
    SQ_LBM_BC_WALL = 2,      /* no-slip, half-way bounce-back; may move (wall_velocity_mps) */
    SQ_LBM_BC_FREE_SLIP = 3, /* specular reflection: zero normal velocity, free tangential (sky) */
    SQ_LBM_BC_INFLOW = 4,    /* equilibrium inlet with the wind's log-law profile */
    SQ_LBM_BC_OUTFLOW = 5,   /* zero-gradient extrapolation of the leaving populations */
    /* S1's recirculation: what leaves through one face re-enters through the opposite one (as
     * PERIODIC, both faces of the axis); the wind drive then defaults to BODY_FORCE */
    SQ_LBM_BC_RECYCLE = 6
} sq_lbm_bc;

enum {
    SQ_LBM_FACE_XMIN = 0,
    SQ_LBM_FACE_XMAX = 1,
    SQ_LBM_FACE_YMIN = 2,
    SQ_LBM_FACE_YMAX = 3,
    SQ_LBM_FACE_ZMIN = 4,
    SQ_LBM_FACE_ZMAX = 5
};

/* How the wind is kept up. */
typedef enum sq_lbm_drive {
    /* INFLOW if a face is INFLOW, else BODY_FORCE if a face is RECYCLE, else NONE */
    SQ_LBM_DRIVE_DEFAULT = 0,
    SQ_LBM_DRIVE_NONE = 1,       /* only sq_lbm_inject and body_accel_mps2 move the air */
    SQ_LBM_DRIVE_INFLOW = 2,     /* INFLOW faces impose the log-law profile of the wind */
    /* a uniform body acceleration, controlled every step so that the mean horizontal wind of the
     * fluid cells at ref_height_m follows the wind (with gusts): the paper's re-injection for
     * recycled (periodic) domains */
    SQ_LBM_DRIVE_BODY_FORCE = 3
} sq_lbm_drive;

/* The wind (SPEC §5.5). Speed and heading may be changed during a run (sq_lbm_set_wind). */
typedef struct sq_lbm_wind_desc {
    double speed_mps;     /* mean wind at ref_height_m; 0 is physical (calm) */
    double heading_deg;   /* direction the wind blows TOWARD, counter-clockwise from +x (east):
                           * 0 = toward east, 90 = toward north; 0 is physical */
    double ref_height_m;  /* height of the quoted speed above the ground; default 10 */
    double roughness_m;   /* aerodynamic roughness z0 of the log law u ∝ ln((h+z0)/z0), also
                           * used for the friction velocity; default 0.01 */
    double beaufort;      /* gust level n_B: gust amplitude μ_g = n_B/20 (S1 eq 14); 0 is physical
                           * (no gusts) */
    double gust_period_s; /* the gust phase α is redrawn this often (smoothly blended); default 3 */
    /* progressive set-up: the wind speed changes at most this fast; 0 is physical and means an
     * instantaneous set-up (one-shot mass-conserving injection) */
    double ramp_mps2;
    sq_lbm_drive drive;
} sq_lbm_wind_desc;

typedef struct sq_lbm_desc {
    sq_dims cells;           /* lattice size; every axis at least 1 (no default) */
    double cell_size_m;      /* Δx; default 1 */
    /* Δt; default 0 = chosen so that the fastest expected wind (max_wind_mps, else the wind with
     * gusts at the top of its profile, else 10 m/s) is 0.08 lattice units */
    double dt_s;
    /* kinematic viscosity ν (molecular, or an effective value); default 1.5e-5 (air at 15 °C).
     * Gives τ = ½ + 3 ν Δt/Δx². Ignored when tau is set. */
    double viscosity_m2s;
    double tau;              /* relaxation time in lattice units; 0 = from viscosity_m2s */
    double air_density_kgm3; /* density of lattice density 1; default 1.225 */
    double max_wind_mps;     /* fastest wind the run will see (Mach check, dt); 0 = from wind */
    sq_lbm_collision collision;
    double smagorinsky_c;    /* Smagorinsky constant C_s; default 0.16 */
    /* TRT magic number Λ = (τ+ − ½)(τ- − ½); default 3/16 (bounce-back walls exactly half-way) */
    double trt_magic;
    sq_lbm_bc bc[6];         /* per face (SQ_LBM_FACE_*); default PERIODIC */
    double wall_velocity_mps[6][3]; /* tangential velocity of WALL faces; 0 is physical */
    double body_accel_mps2[3];      /* constant body acceleration; 0 is physical */
    sq_lbm_wind_desc wind;
    int check_interval;      /* steps between finiteness checks of the whole lattice; default 64 */
    /* true: in a distributed run (squall/par.h, more than one rank) the lattice is split into
     * slabs along z, one per rank (each at least 2 planes), and every call below is collective
     * (all ranks make the same calls with the same arguments; cells are named by their global
     * index). The views, friction velocity, totals and solid flags stay global: the
     * density/velocity views are gathered on every rank, so results are those of one rank,
     * bit for bit. false is physical (each rank holds the whole lattice). */
    bool decompose;
} sq_lbm_desc;

/* Facts about a created solver (lattice ↔ SI conversion included). */
typedef struct sq_lbm_info {
    sq_dims cells;
    double cell_size_m, dt_s;
    double tau;               /* relaxation time (lattice units) */
    double viscosity_lu;      /* ν in lattice units = (τ − ½)/3 */
    double velocity_scale;    /* m/s per lattice velocity unit = Δx/Δt */
    double max_wind_lu;       /* the Mach check's wind in lattice units */
    double mach;              /* max_wind_lu / c_s, c_s = 1/√3 */
    double bytes_per_cell_update; /* memory traffic of one cell update (120) */
    uint64_t memory_bytes;
    int64_t step;             /* steps taken */
    double time_s;
    double wind_speed_mps;    /* current wind target including the gust */
    double wind_heading_deg;
    sq_lbm_collision collision; /* resolved */
    sq_lbm_drive drive;         /* resolved */
} sq_lbm_info;

/* Read-only views of the macroscopic state (SI), valid until the next step, edit or destroy. */
typedef struct sq_lbm_views {
    sq_field_view density; /* kg/m³ (solid cells: 0) */
    sq_field_view u[3];    /* m/s (solid cells: 0) */
} sq_lbm_views;

/* Sums over fluid cells and the populations in flight into solid cells (double). */
typedef struct sq_lbm_totals {
    double mass_kg;
    double momentum_kgmps[3];
    int64_t fluid_cells;
} sq_lbm_totals;

/* Returns desc with zero fields replaced by defaults (zero-is-physical fields stay). dt_s is
 * left 0 (it is chosen at create from the wind; see sq_lbm_get_info). */
SQ_API sq_lbm_desc sq_lbm_desc_resolve(const sq_lbm_desc *desc);
/* Fastest wind (m/s) the desc implies for the Mach check: max_wind_mps, else the wind with
 * gusts at the top of its log-law profile (and moving walls). */
SQ_API double sq_lbm_max_wind_mps(const sq_lbm_desc *desc);
/* The time step sq_lbm_create uses: dt_s, else 0.08 Δx / sq_lbm_max_wind_mps (10 m/s if calm). */
SQ_API double sq_lbm_time_step_s(const sq_lbm_desc *desc);
/* Mach number above which sq_lbm_create refuses a wind (0.3). */
SQ_API double sq_lbm_mach_limit(void);
/* The checks sq_lbm_create makes, without allocating: the fields' rules, the relaxation time
 * (τ > ½) and the Mach number of the fastest wind. The one home of these rules: a phenomenon
 * built on the lattice calls this and translates the message (which starts with the lbm field,
 * e.g. "tau = 0.5; must be > 0.5 ..." or "dt_s = 0.05 s: the wind ... Mach ...") into its own
 * keys. ctx may be NULL (no log lines). */
SQ_API sq_result sq_lbm_desc_validate(sq_context *ctx, const sq_lbm_desc *desc);
/* Bytes sq_lbm_create will allocate for desc (0 if cells is invalid). */
SQ_API uint64_t sq_lbm_memory_bytes(const sq_lbm_desc *desc);

/* Creates the solver with air at rest (density 1 l.u.) everywhere. Refuses bad descs (messages
 * name the field, value and rule), τ ≤ ½, a wind above Mach 0.3 (naming the knob to turn:
 * cell_size_m, dt_s or the wind) and lattices above the context's memory limit (before
 * allocating, with the bytes needed). Warns when the wind exceeds 0.1 lattice units. */
SQ_API sq_result sq_lbm_create(sq_context *ctx, const sq_lbm_desc *desc, sq_lbm **out);
SQ_API void sq_lbm_destroy(sq_lbm *lbm);

/* Advances `steps` time steps of dt_s: wind update (gusts, ramp, drive), boundaries, fused
 * collide-and-stream. Every check_interval steps the lattice is checked: a non-finite or
 * non-positive density or a supersonic velocity returns SQ_ERR_UNSTABLE naming step and cell. */
SQ_API sq_result sq_lbm_step(sq_lbm *lbm, int steps);

/* Sizes, resolved relaxation time, lattice units and memory of the lattice. */
SQ_API sq_lbm_info sq_lbm_get_info(const sq_lbm *lbm);

/* Changes the mean wind (Mach-checked). With wind.ramp_mps2 = 0 the change is injected at once
 * into every fluid cell; otherwise the drive ramps to it. */
SQ_API sq_result sq_lbm_set_wind(sq_lbm *lbm, double speed_mps, double heading_deg);
/* Changes the gust level (Beaufort number, 0 = no gusts). */
SQ_API sq_result sq_lbm_set_gusts(sq_lbm *lbm, double beaufort);

/* One-shot wind injection into every fluid cell (SPEC §5.5 corrected):
 * ΔF_i = 3 w_i ρ (c_i·V), which changes no density and adds exactly ρV of momentum. Where a
 * population would turn negative, V is scaled down in that cell; *limited_cells (may be NULL)
 * counts those cells. */
SQ_API sq_result sq_lbm_inject(sq_lbm *lbm, const double v_mps[3], int64_t *limited_cells);

/* Sets every fluid cell to equilibrium with the given density (kg/m³, NULL = air_density) and
 * velocity (m/s, NULL = at rest); arrays have nx*ny*nz entries, x fastest. */
SQ_API sq_result sq_lbm_init_fields(sq_lbm *lbm, const float *density_kgm3, const float *ux_mps,
                                    const float *uy_mps, const float *uz_mps);

/* Solid cells: bounce-back obstacles. A cell that turns fluid is re-initialised at equilibrium
 * with the mean density and velocity of its fluid neighbours. */
SQ_API sq_result sq_lbm_set_solid(sq_lbm *lbm, int i, int j, int k, bool solid);
/* Sets all flags from mask (nx*ny*nz bytes, x fastest, non-zero = solid). */
SQ_API sq_result sq_lbm_set_solid_mask(sq_lbm *lbm, const uint8_t *mask);
/* Whether cell (i,j,k) is solid (cells outside the lattice: false). */
SQ_API bool sq_lbm_is_solid(const sq_lbm *lbm, int i, int j, int k);

/* Density and velocity views (computed on demand after a step). */
SQ_API sq_result sq_lbm_get_views(sq_lbm *lbm, sq_lbm_views *out);
/* Friction velocity u* (m/s) of fluid cells next to a solid surface, from the log law
 * u* = κ |u_t| / ln((Δx/2 + z0)/z0) with κ = 0.41 and u_t the velocity tangential to the
 * surface (the solid below is preferred); 0 elsewhere. */
SQ_API sq_result sq_lbm_get_friction_velocity(sq_lbm *lbm, sq_field_view *out);
/* The same u* for `count` cells only (cells[q] = x + nx (y + ny z)), into out[q]: for callers
 * that need it on a surface list rather than the whole lattice. */
SQ_API sq_result sq_lbm_get_friction_velocity_at(sq_lbm *lbm, int64_t count,
                                                 const int64_t *cells, float *out);
SQ_API sq_result sq_lbm_get_totals(sq_lbm *lbm, sq_lbm_totals *out);
/* A split lattice (desc.decompose, several ranks): the density and velocity of this rank's
 * slab only, gathered from no other rank (collective: the slab's boundaries are exchanged).
 * The views hold the slab's planes, x fastest; *z0 is the global index of its first plane.
 * Not split: the whole lattice's views and *z0 = 0. Valid until the next step; cells that
 * sq_lbm_set_solid changes are updated in them as in sq_lbm_get_views. */
SQ_API sq_result sq_lbm_get_slab_views(sq_lbm *lbm, sq_lbm_views *out, int *z0);
/* sq_lbm_get_friction_velocity_at from the slab's views, for cells (global indices) of this
 * rank's slab only (collective as sq_lbm_get_slab_views). */
SQ_API sq_result sq_lbm_get_slab_friction_velocity_at(sq_lbm *lbm, int64_t count,
                                                      const int64_t *cells, float *out);

/* Names of the enumerators as the parameter tables spell them ("bgk", "zou-he"); static. */
SQ_API const char *sq_lbm_collision_name(sq_lbm_collision c);
SQ_API const char *sq_lbm_bc_name(sq_lbm_bc bc);

/* Checkpoints (squall/core.h records): populations, solid flags, step and wind state, to restore
 * into a lattice created from the same desc, which then steps bit-identically. */
SQ_API sq_result sq_lbm_save_state(const sq_lbm *lbm, sq_state_writer *w);
SQ_API sq_result sq_lbm_load_state(sq_lbm *lbm, sq_state_reader *r);

#ifdef __cplusplus
}
#endif
#endif
