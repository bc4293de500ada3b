/* squall/grid.h — incompressible fluid solver on a 3D staggered (MAC) grid: advection
 * (semi-Lagrangian or MacCormack with Selle's limiter), forces, buoyancy, vorticity confinement
 * (plain and helicity-adaptive), mixing-length eddy viscosity, pressure projection (MG-
 * preconditioned CG, plain multigrid V-cycles, or the thesis's Jacobi) and stability checks.
 * Implements SPEC §1.4 (Stam splitting, MacCormack + limiter, projection, confinement), §1.5
 * (mixing-length eddy viscosity) and §1.12 (boundary conditions). It knows nothing of dust.
 *
 * Geometry. Cells (i,j,k), 0 <= i < nx (x east), j < ny (y north), k < nz (z up), cubic with
 * edge h = cell_size_m. Cell (i,j,k) spans [origin + (i,j,k) h, origin + (i+1,j+1,k+1) h].
 *   - cell-centred scalars: nx*ny*nz samples at the cell centres;
 *   - u (x velocity) on x-faces: (nx+1)*ny*nz samples at (i h, (j+.5) h, (k+.5) h);
 *   - v on y-faces: nx*(ny+1)*nz; w on z-faces: nx*ny*(nz+1).
 * Every field is an sq_field3 (x fastest) with ONE ghost layer; the ghosts are filled from the
 * boundary conditions by each stage (and by sq_grid_apply_boundary after direct edits).
 *
 * Units. SI at this API: metres, seconds, m/s, m/s^2. The pressure the projection solves for
 * is phi = p dt / rho (m^2/s, Stam's convention, SPEC §1.4); the stored and viewed pressure is
 * the kinematic pressure p/rho = phi/dt in m^2/s^2 (multiply by the air density for Pa). It is
 * kept between steps and warm-starts the next projection.
 *
 * Boundaries (SPEC §1.12). Per domain face:
 *   FREE_SLIP (default)  wall: u.n = 0, tangential velocity mirrored (no drag), dp/dn = 0
 *   NO_SLIP              wall: u = 0 at the wall, dp/dn = 0
 *   INFLOW               prescribed velocity (sq_grid_set_inflow*), dp/dn = 0; scalars take
 *                        the value from sq_grid_set_scalar_inflow (default 0), or per sample
 *                        from sq_grid_scalar_inflow_data
 *   OUTFLOW              zero-gradient velocity and scalars, p = 0 on the face; inflow through
 *                        the face (backflow) is clipped to 0 before each projection
 *   OPEN                 as OUTFLOW but backflow is allowed
 *   PERIODIC             must be set on both faces of an axis
 * Solid cells (terrain, obstacles; sq_grid_set_solid*) are no-slip, no-penetration: every face
 * touching a solid cell has zero velocity, dp/dn = 0 there. Scalars in solid cells belong to
 * the caller: advection leaves them unchanged and interpolation near walls reads them (set,
 * e.g., dust 0 and the ground temperature there).
 *
 * Memory (bytes per interior cell; the ghost layers add (n+2)^3/n^3 - 1, 10 % at 64^3):
 *   velocity 12, scalars 4 each, pressure 4, flags / links / ground distance / solid 6,
 *   shared scratch 52 (advection displacements and outputs; reused by the projection's CG
 *   vectors, confinement and diffusion), multigrid coarse levels ~4.6
 *   =>  about 79 + 4 * scalar_count bytes per cell.
 * sq_grid_memory_bytes() returns the exact figure for a desc (what create allocates).
 *
 * Views and fields. Advection writes into a spare buffer and swaps it in: sq_field_view data
 * pointers are valid until the next stage; the sq_field3 pointers returned by
 * sq_grid_velocity_field / sq_grid_scalar_field stay valid for the grid's life (re-read their
 * origin after a stage).
 *
 * Cost. The RK2 traces are computed once per velocity field at the cell centres and cached:
 * all scalars advected with one velocity share them, and so does the next velocity advection
 * if nothing changed the velocity in between. A step that advects its scalars last (with the
 * projected velocity) and the wind first in the next step therefore traces once per step.
 * sq_grid_advect_scalars advects the scalars in batches that share the trace locations (use it
 * rather than a loop over sq_grid_advect_scalar). The kernels are branch-free row loops that
 * GCC vectorises (with -march=native: AVX2/AVX-512); nothing is allocated per step.
 *
 * Threads: kernels run on sq_context_threads() threads (OpenMP over z). Reductions sum per
 * z-plane and then in plane order, so results do not depend on the thread count. */
#ifndef SQ_GRID_H
#define SQ_GRID_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/field.h"
#include "squall/sqmath.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SQ_GRID_MAX_SCALARS 64

typedef enum sq_grid_face {
    SQ_FACE_XMIN = 0,
    SQ_FACE_XMAX = 1,
    SQ_FACE_YMIN = 2,
    SQ_FACE_YMAX = 3,
    SQ_FACE_ZMIN = 4, /* the ground */
    SQ_FACE_ZMAX = 5, /* the top */
    SQ_FACE_COUNT = 6
} sq_grid_face;

typedef enum sq_boundary {
    SQ_BOUNDARY_DEFAULT = 0, /* = SQ_BOUNDARY_FREE_SLIP */
    SQ_BOUNDARY_FREE_SLIP = 1,
    SQ_BOUNDARY_NO_SLIP = 2,
    SQ_BOUNDARY_INFLOW = 3,
    SQ_BOUNDARY_OUTFLOW = 4,
    SQ_BOUNDARY_OPEN = 5,
    SQ_BOUNDARY_PERIODIC = 6
} sq_boundary;

typedef enum sq_pressure_solver {
    SQ_PRESSURE_DEFAULT = 0,   /* = SQ_PRESSURE_MGPCG */
    SQ_PRESSURE_MGPCG = 1,     /* conjugate gradients preconditioned by one multigrid V-cycle */
    SQ_PRESSURE_MULTIGRID = 2, /* plain multigrid V-cycles */
    SQ_PRESSURE_JACOBI = 3     /* fixed number of Jacobi sweeps (S0, for comparison) */
} sq_pressure_solver;

typedef enum sq_advect_scheme {
    SQ_ADVECT_DEFAULT = 0, /* = SQ_ADVECT_MACCORMACK */
    SQ_ADVECT_MACCORMACK = 1, /* Selle et al. 2008, with the limiter below */
    SQ_ADVECT_SEMI_LAGRANGIAN = 2
} sq_advect_scheme;

typedef enum sq_advect_limiter {
    SQ_LIMITER_DEFAULT = 0, /* = SQ_LIMITER_REVERT */
    SQ_LIMITER_REVERT = 1,  /* outside the range of the 8 source values: use the SL value */
    SQ_LIMITER_CLAMP = 2    /* outside that range: clamp to it */
} sq_advect_limiter;

typedef struct sq_grid_desc {
    sq_dims cells;               /* required; every axis >= 4 */
    double cell_size_m;          /* h, required, > 0 */
    double origin_m[3];          /* world position of the domain's min corner; 0 is physical */
    sq_boundary boundary[6];     /* indexed by sq_grid_face; 0 = free-slip wall */
    sq_pressure_solver pressure; /* 0 = MG-preconditioned CG */
    int jacobi_iterations;       /* SQ_PRESSURE_JACOBI sweeps; 0 = 40 (S0) */
    double tolerance;            /* relative residual |b - A phi|_2 / |b|_2; 0 = 1e-3 */
    int max_iterations;          /* cap on CG iterations / V-cycles; 0 = 50 */
    int smoothing_sweeps;        /* red-black Gauss-Seidel sweeps before and after the coarse
                                    correction on every level; 0 = 1. Multigrid coarsens by 2
                                    per axis (ceil(n/2): any size >= 4 works; sizes divisible
                                    by 8 coarsen best) down to <= 2 cells per axis */
    bool cold_start;             /* false (default): start from the previous pressure */
    sq_advect_scheme advection;  /* 0 = MacCormack */
    sq_advect_limiter limiter;   /* 0 = revert */
    int scalar_count;            /* cell-centred scalars advected by the flow; 0 is valid */
    uint64_t scalar_nonnegative; /* bit s set: scalar s is clamped to >= 0 after advection;
                                    0 = no clamping */
    double confinement_max_cells; /* the confinement force may move a parcel at most this
                                     many cells in one step: |f| dt^2 <= c h; 0 = 0.25 */
    double mixing_length_max_m;  /* cap on the mixing length kappa d; 0 = no cap */
    double wall_roughness_m;     /* > 0: the mixing-length closure's stress on the ground (a
                                    solid or no-slip bottom below) is the log law's, u*^2 =
                                    (kappa |u_h| / ln(h / 2 z0))^2 with this z0 (as
                                    sq_grid_diffuse_sgs); 0 = the wind 0 half a cell below */
    int diffusion_iterations;    /* Gauss-Seidel sweeps of the implicit molecular diffusion
                                    (used only when nu_mol dt / h^2 > 1/6); 0 = 3 */
    bool decompose;              /* under mpirun (squall/par.h, more than one rank): this rank's
                                    grid is its slab of `cells` along the longer horizontal axis
                                    (slabs >= 4 cells; sq_grid_get_block says which), create is
                                    collective. Every stage is then collective (call them in the
                                    same order on every rank): advection (bit-identical to one
                                    rank split along a non-periodic axis), forces, confinement,
                                    diffusion and closures (one ghost plane from each neighbour),
                                    the projection (to its tolerance), the checks, and
                                    sq_grid_max_speed / cfl_dt / divergence_max (global). Fields,
                                    views, solid masks and cell indices are the slab's (local).
                                    false, or one rank: the whole grid (docs/mpi.md) */
} sq_grid_desc;

typedef struct sq_grid sq_grid;

/* Statistics of one projection. */
typedef struct sq_grid_project_stats {
    int iterations;          /* CG iterations, V-cycles or Jacobi sweeps done */
    int fine_sweeps;         /* smoothing sweeps on the finest grid (one sweep = every cell
                                updated once; a red-black sweep counts as one) */
    double work_units;       /* fine_sweeps plus coarse-level sweeps weighted by their size */
    double initial_residual; /* relative residual of the warm start */
    double residual;         /* relative residual reached, |b - A phi|_2 / |b|_2 */
    bool converged;          /* residual <= tolerance */
    double ms;
} sq_grid_project_stats;

/* Accumulated since create or the last sq_grid_stats_reset. */
typedef struct sq_grid_stats {
    double ms_advect, ms_forces, ms_confine, ms_diffuse, ms_project;
    int64_t advect_calls, project_calls;
    double last_cfl;              /* max |u| dt / h of the last velocity or scalar advection */
    double last_diffusion_number; /* max (nu_mol + nu_t) dt / h^2 of the last diffusion */
    bool last_diffusion_implicit; /* the last diffusion solved implicitly (always when nu_t > 0) */
    sq_grid_project_stats last_project;
    int mg_levels;                /* levels of the multigrid hierarchy */
} sq_grid_stats;

typedef struct sq_grid_info {
    sq_dims cells;
    double cell_size_m;
    double origin_m[3];
    int scalar_count;
    uint64_t memory_bytes;
    int mg_levels;
} sq_grid_info;

/* Fills zero fields with defaults (see each field). */
SQ_API sq_grid_desc sq_grid_desc_resolve(const sq_grid_desc *desc);
/* Bytes sq_grid_create would allocate for this desc (0 if the dims are not positive). */
SQ_API uint64_t sq_grid_memory_bytes(const sq_grid_desc *desc);

/* Creates the grid (fields zeroed, no solids) after checking desc and its memory against the
 * context's limit (SQ_ERR_INVALID_ARG naming sq_grid_desc.<field>, SQ_ERR_TOO_LARGE). */
SQ_API sq_result sq_grid_create(sq_context *ctx, const sq_grid_desc *desc, sq_grid **out);
SQ_API void sq_grid_destroy(sq_grid *g); /* accepts NULL */
/* The place of this rank's slab in a decomposed grid (desc.decompose): lo = global index of
 * its first cell per axis, global = the whole grid's cells (lo = 0 and the grid's own cells
 * when not decomposed). */
SQ_API sq_result sq_grid_get_block(const sq_grid *g, int lo[3], sq_dims *global);
/* Collective: the velocity and scalars of every rank's slab into `whole`, a grid of the
 * whole grid's cells and scalars that is not decomposed (on every rank: outputs, views). Its
 * ghosts are not filled (sq_grid_apply_boundary does). With g not decomposed: a copy. */
SQ_API sq_result sq_grid_gather(const sq_grid *g, sq_grid *whole);
/* Collective: the same into `whole` on rank 0 only (NULL on the other ranks, which only send
 * their slab): a rank-0 output without the whole grid's copy on every rank. */
SQ_API sq_result sq_grid_gather_root(const sq_grid *g, sq_grid *whole);
/* Bytes this rank sent to its neighbouring slabs since create (0 when not decomposed). */
SQ_API uint64_t sq_grid_bytes_exchanged(const sq_grid *g);
/* Sizes, spacing and the pressure solver's set-up of the grid. */
SQ_API sq_grid_info sq_grid_get_info(const sq_grid *g);
SQ_API sq_grid_desc sq_grid_get_desc(const sq_grid *g); /* the resolved desc */

/* ---- fields -------------------------------------------------------------------------------- */
/* Face velocity component axis (0 = u on x-faces, 1 = v, 2 = w), interior samples only. */
SQ_API sq_field_view sq_grid_velocity_view(const sq_grid *g, int axis);
/* Mutable field with its ghost layer, for initialisation and coupling. After writing call
 * sq_grid_apply_boundary (or any stage, which applies it first). NULL for a bad axis. */
SQ_API sq_field3 *sq_grid_velocity_field(sq_grid *g, int axis);
SQ_API sq_field_view sq_grid_scalar_view(const sq_grid *g, int idx);
SQ_API sq_field3 *sq_grid_scalar_field(sq_grid *g, int idx); /* NULL for a bad index */
/* Kinematic pressure p/rho in m^2/s^2 from the last projection. */
SQ_API sq_field_view sq_grid_pressure_view(const sq_grid *g);
/* Solid flags, nx*ny*nz bytes, x fastest, 1 = solid. */
SQ_API const uint8_t *sq_grid_solid(const sq_grid *g);

/* Marks cell (i, j, k) solid or fluid (SQ_ERR_INVALID_ARG outside the grid). */
SQ_API sq_result sq_grid_set_solid(sq_grid *g, int i, int j, int k, bool solid);
/* mask: nx*ny*nz bytes, x fastest, non-zero = solid; NULL clears all solids. */
SQ_API sq_result sq_grid_set_solid_mask(sq_grid *g, const uint8_t *mask);
SQ_API bool sq_grid_is_solid(const sq_grid *g, int i, int j, int k); /* outside: false */

/* Inflow velocity on a face whose boundary is SQ_BOUNDARY_INFLOW. The callback is evaluated
 * once, now, at the centre of every boundary cell face (world coordinates, metres). */
typedef void (*sq_grid_inflow_fn)(void *user, double x_m, double y_m, double z_m,
                                  float vel_mps[3]);
/* Sets the inflow of face from fn (see above); SQ_ERR_INVALID_ARG if that face is not an
 * inflow boundary. */
SQ_API sq_result sq_grid_set_inflow(sq_grid *g, sq_grid_face face, sq_grid_inflow_fn fn,
                                    void *user);
/* The same with one velocity (m/s) for the whole face. */
SQ_API sq_result sq_grid_set_inflow_uniform(sq_grid *g, sq_grid_face face, double vx_mps,
                                            double vy_mps, double vz_mps);
/* Mutable inflow array of a face: na*nb entries of 3 floats (vx, vy, vz), a fastest, where
 * (a, b) are the face's two tangential axes in x, y, z order (x-faces: a = y, b = z; y-faces:
 * a = x, b = z; z-faces: a = x, b = y). NULL if the face is not an inflow face. */
SQ_API float *sq_grid_inflow_data(sq_grid *g, sq_grid_face face, int *na, int *nb);
/* Value a scalar takes where air enters through an inflow face (default 0). It also resets
 * any per-sample values (below) to this value. */
SQ_API sq_result sq_grid_set_scalar_inflow(sq_grid *g, int idx, double value);
/* Mutable per-sample inflow values of scalar idx on an inflow face (e.g. a temperature that
 * follows the atmosphere's background profile with height): na*nb floats, a fastest, on the
 * same tangential axes as sq_grid_inflow_data, allocated on the first call (filled with the
 * constant value; not part of sq_grid_memory_bytes: na*nb*4 bytes) and used from then on.
 * NULL if the face is not an inflow face, idx is out of range or out of memory. */
SQ_API float *sq_grid_scalar_inflow_data(sq_grid *g, sq_grid_face face, int idx, int *na,
                                         int *nb);

/* Sets the velocity on solid and wall faces, the inflow faces, clips outflow backflow and fills
 * every ghost layer. Stages call it themselves; call it after editing fields directly. */
SQ_API void sq_grid_apply_boundary(sq_grid *g);

/* ---- stages (SPEC §1.11: advect -> forces -> diffuse -> confine -> project) --------------- */
SQ_API sq_result sq_grid_advect_velocity(sq_grid *g, double dt_s);
/* Advects scalar idx with the current (normally projected) velocity. */
SQ_API sq_result sq_grid_advect_scalar(sq_grid *g, int idx, double dt_s);
/* As sq_grid_advect_scalar with drift_w_mps added to the vertical velocity (e.g. minus a
 * settling speed). The flow's own velocity is not changed. */
SQ_API sq_result sq_grid_advect_scalar_drift(sq_grid *g, int idx, double dt_s,
                                             double drift_w_mps);
SQ_API sq_result sq_grid_advect_scalars(sq_grid *g, double dt_s); /* all scalars */

/* u += a dt on every free face. */
SQ_API sq_result sq_grid_add_acceleration(sq_grid *g, double ax_mps2, double ay_mps2,
                                          double az_mps2, double dt_s);
/* Cell-centred acceleration fields (m/s^2, nx*ny*nz views; NULL components are zero),
 * averaged to the faces. */
SQ_API sq_result sq_grid_add_acceleration_field(sq_grid *g, const sq_field_view *ax,
                                                const sq_field_view *ay,
                                                const sq_field_view *az, double dt_s);
/* Boussinesq buoyancy on w: a_z = beta g (T - Tref(z)) / Tref(z) with T the scalar
 * temperature_idx (kelvin). tref_k: nz values (one per level) or NULL for the horizontal mean
 * of T over the fluid cells of each level. beta is the (artistic) gain, 1 = physical. */
SQ_API sq_result sq_grid_add_buoyancy(sq_grid *g, int temperature_idx, const float *tref_k,
                                      double beta, double gravity_mps2, double dt_s);
/* Vorticity confinement f = eps h (N x omega) (Fedkiw, Stam, Jensen 2001), or with
 * helicity_adaptive f = eps h (|u.omega| / (|u||omega| + eps0)) (N x omega) (SPEC §1.4, the
 * dimensionless relative helicity), with |f| dt^2 <= confinement_max_cells * h. */
SQ_API sq_result sq_grid_confine_vorticity(sq_grid *g, double eps, bool helicity_adaptive,
                                           double dt_s);
/* Mixing-length Reynolds stress (S0 2.17, SPEC §1.5): du_h/dt = d/dz ((nu_mol + nu_t) du_h/dz)
 * for the horizontal wind, nu_t = (kappa d)^2 |d u_h / dz| with d the height above the nearest
 * solid cell or no-slip/free-slip ground below (none below: nu_t = 0), capped by
 * mixing_length_max_m. Solved exactly by backward Euler per column (tridiagonal): stable and
 * monotone for any dt. No-slip ground and solids act as u = 0 half a cell below. The isotropic
 * molecular term nu_mol lap(u) on all components is added only where it matters (nu_mol dt/h^2
 * > 1e-3): explicit up to 1/6, else backward Euler by red-black Gauss-Seidel sweeps (logged). */
SQ_API sq_result sq_grid_diffuse_eddy(sq_grid *g, double nu_mol_m2ps, double kappa,
                                      double dt_s);
/* Turbulent transport of the scalars and stratification of the mixing length, used by every
 * later sq_grid_diffuse_eddy (off after create):
 *  - every scalar c gets the vertical eddy flux of the same mixing-length closure,
 *    dc/dt = d/dz (K dc/dz), K = nu_t / prandtl_t (gradient diffusion; no flux through the
 *    ground, solids or the domain's ends: sources and sinks belong to the caller), solved by
 *    backward Euler per column (conservative, monotone, stable for any dt);
 *  - with theta_idx >= 0 (a potential-temperature scalar, K) the eddy viscosity feels the
 *    stratification (Lilly 1962): nu_t = l^2 sqrt(max(0, S^2 - N^2 / Pr_t)), S = |du_h/dz|,
 *    N^2 = (g / theta) d theta / dz, i.e. l^2 S sqrt(1 - Ri / Pr_t): no mixing above the
 *    critical Richardson number Ri = Pr_t, and free convection (mixing without shear) where the
 *    air is statically unstable (N^2 < 0). theta_idx = -1: neutral (nu_t = l^2 S).
 * prandtl_t in [0.1, 10] (neutral surface layer 0.74, Businger et al. 1971); gravity > 0. */
SQ_API sq_result sq_grid_set_eddy_scalars(sq_grid *g, double prandtl_t, int theta_idx,
                                          double gravity_mps2);
/* Smagorinsky-Lilly subgrid closure (grid_sgs.c, SPEC §1.5), an alternative to the mixing
 * length above for large-eddy resolutions (cells much smaller than the flow's big eddies):
 *   nu_t = l^2 sqrt(max(0, |S|^2 - N^2 / Pr_t)), |S| = sqrt(2 S_ij S_ij) (all nine gradients),
 *   1 / l^2 = 1 / (C_s h)^2 + 1 / (kappa (z + z0))^2 (Mason & Thomson 1992; z above the ground),
 *   du_i/dt = div (nu_t grad u_i) for u, v, w; dc/dt = div (K grad c), K = nu_t / Pr_t for every
 *   scalar (no flux through solids, the ground or the domain's faces), and with roughness_m > 0
 *   the log-law stress u*^2, u* = kappa |u_h| / ln(h / 2 z0), on the horizontal wind of the
 *   first fluid cells above a solid or a no-slip ground. Explicit, sub-stepped to a diffusion
 *   number <= 1/6 (conservative, no new extrema). */
/* closure = SQ_SGS_TKE instead: Deardorff's (1980) 1.5-order closure with a prognostic subgrid
 * kinetic energy e (m^2/s^2), held by the caller's scalar tke_idx and carried by the scalar
 * advection like any other scalar (grid_tke.c; as Moeng 1984 and WRF's km_opt = 2):
 *   length           l = min(h, 0.76 sqrt(e) / N) where N^2 > 0, else h (at least 1e-3 h)
 *   coefficients     K_m = C_k l sqrt(e), K_h = (1 + 2 l / h) K_m
 *   e's budget       de/dt = K_m |S|^2 - K_h N^2 - C_eps e^(3/2) / l + div (2 K_m grad e),
 *                    C_eps = 0.19 + 0.51 l / h
 * the wind diffused with K_m, every other scalar with K_h; e is floored at tke_min_m2ps2 (a
 * seed: K_m = 0 at e = 0 would never produce any). */
typedef enum sq_grid_sgs_closure {
    SQ_SGS_SMAGORINSKY = 0, /* default */
    SQ_SGS_TKE = 1
} sq_grid_sgs_closure;
typedef struct sq_grid_sgs_desc {
    sq_grid_sgs_closure closure;
    double smagorinsky_c; /* C_s; 0 = 0.18 (Lilly 1967) */
    double prandtl_t;     /* Pr_t = nu_t / K, also the critical Richardson number; 0 = 0.74 */
    double kappa;         /* von Karman constant of the wall length and stress; 0 = 0.4 */
    double roughness_m;   /* z0 of the wall stress; 0 = no wall stress (no flux) */
    bool stratified;      /* theta_idx is a potential temperature (K): N^2 enters nu_t */
    int theta_idx;
    double gravity_mps2;  /* g of N^2 = (g / theta) d theta / dz, with stratified */
    int tke_idx;          /* SQ_SGS_TKE: the scalar holding e (m^2/s^2) */
    double tke_ck;        /* SQ_SGS_TKE: C_k; 0 = 0.10 (Deardorff 1980; Moeng 1984) */
    double tke_min_m2ps2; /* SQ_SGS_TKE: floor of e; 0 = 1e-6 m^2/s^2 */
} sq_grid_sgs_desc;
/* desc with its zero fields replaced by the defaults above (desc NULL: all defaults). */
SQ_API sq_grid_sgs_desc sq_grid_sgs_desc_resolve(const sq_grid_sgs_desc *desc);
/* One step dt_s of the closure's diffusion of the wind and every scalar (and the wall stress
 * with roughness_m > 0). SQ_ERR_UNSTABLE, naming the diffusion number, when it would need more
 * than 1000 sub-steps. */
SQ_API sq_result sq_grid_diffuse_sgs(sq_grid *g, const sq_grid_sgs_desc *desc, double dt_s);
/* The closure's nu_t (m^2/s; K_m of SQ_SGS_TKE, from the current e) per cell of the current
 * wind, nx*ny*nz floats (x fastest; solids 0), e.g. for tests and diagnostics. */
SQ_API sq_result sq_grid_sgs_viscosity(sq_grid *g, const sq_grid_sgs_desc *desc, float *nu_out);
/* Makes the velocity divergence-free: solves A phi = -h^2 div u* for phi = p dt / rho to the
 * relative residual tolerance (warm-started from the previous pressure), then u -= grad phi.
 * The residual reported equals h^2 |div u|_2 / h^2 |div u*|_2 after the correction. Fluid
 * regions enclosed without an outflow/open face get one pinned cell (exact for a compatible
 * right-hand side). stats may be NULL. */
SQ_API sq_result sq_grid_project(sq_grid *g, double dt_s, sq_grid_project_stats *stats);

/* ---- diagnostics ----------------------------------------------------------------------------- */
/* SQ_ERR_UNSTABLE naming the step, the first bad cell/face (i,j,k) and the field when a
 * velocity, scalar or the pressure is non-finite, or a speed exceeds 1e8 m/s. A decomposed
 * grid: collective; every rank gets the lowest failing slab's result and message (global
 * (i,j,k)). */
SQ_API sq_result sq_grid_check_finite(sq_grid *g, int64_t step);
SQ_API double sq_grid_max_speed(const sq_grid *g); /* max |face component|, m/s */
/* dt such that max |u| dt / h = cfl (1e30 for a fluid at rest). */
SQ_API double sq_grid_cfl_dt(const sq_grid *g, double cfl);
/* max over fluid cells of |div u| in 1/s. */
SQ_API double sq_grid_divergence_max(const sq_grid *g);
/* Trilinear velocity (each component from its own faces) at a world point; clamped to the
 * domain. */
SQ_API sq_vec3 sq_grid_sample_velocity(const sq_grid *g, sq_vec3 p_m);
SQ_API float sq_grid_sample_scalar(const sq_grid *g, int idx, sq_vec3 p_m);
/* Velocity at the centre of cell (i,j,k): the mean of its two faces per component. */
SQ_API sq_vec3 sq_grid_cell_velocity(const sq_grid *g, int i, int j, int k);

/* Counters and timings of the stages since creation or the last sq_grid_stats_reset. */
SQ_API void sq_grid_get_stats(const sq_grid *g, sq_grid_stats *out);
SQ_API void sq_grid_stats_reset(sq_grid *g);

/* Checkpoints (squall/core.h records): velocity, scalars, pressure, inflow and solids, to restore
 * into a grid created from the same desc, which then steps bit-identically. */
SQ_API sq_result sq_grid_save_state(const sq_grid *g, sq_state_writer *w);
SQ_API sq_result sq_grid_load_state(sq_grid *g, sq_state_reader *r);

#ifdef __cplusplus
}
#endif
#endif
