/* lbm_internal.h — the D3Q15 lattice (SPEC §5.2 index order and opp() table), the solver
 * struct, lattice-unit conversion and kernel prototypes.
 *
 * Storage: SoA float populations on a lattice padded by one ghost layer on every side:
 * population i of padded cell c is f[i*stride + c], c = (x+1) + (y+1)*sy + (z+1)*sz. The stored
 * value is shifted, h_i = f_i − w_i (0 at rest), for float precision.
 *
 * Streaming uses the AA pattern (Bailey et al. 2009) in place:
 *   even step: cell x reads f_i from its own slot i, collides, writes f*_i to its own slot opp(i);
 *   odd step:  cell x reads f_i from slot opp(i) of x−c_i, collides, writes f*_i to slot i of
 *              x+c_i.
 * Each cell touches only its own 15 locations, so both steps are race-free in place and move
 * 2 × 15 × 4 = 120 B per cell update. After an odd step (next step even, "natural" layout)
 * slot i of x holds the pre-collision f_i(x); after an even step ("swapped" layout) slot opp(i)
 * of x holds the post-collision f*_i(x).
 * A solid cell is a cell whose collision is f*_i = f_opp(i): in the AA pattern that is a no-op,
 * i.e. full-way bounce-back (the wall lies half-way between fluid and solid cell centres). */
#ifndef SQ_LBM_INTERNAL_H
#define SQ_LBM_INTERNAL_H

#include <stdint.h>

#include "core/core_internal.h"
#include "squall/lbm.h"
#include "squall/par.h"

#define SQ_LBM_Q 15

/* D3Q15 velocities, SPEC §5.2 order. */
static const int sq__lbm_c[SQ_LBM_Q][3] = {
    {0, 0, 0},   {1, 0, 0},   {-1, 0, 0},  {0, 1, 0},  {0, -1, 0},
    {0, 0, 1},   {0, 0, -1},  {1, 1, 1},   {-1, -1, -1}, {1, 1, -1},
    {-1, -1, 1}, {1, -1, 1},  {-1, 1, -1}, {-1, 1, 1}, {1, -1, -1}};
/* opp(i) = i+1 for odd i, i−1 for even i ≥ 2, opp(0) = 0. */
static const int sq__lbm_opp[SQ_LBM_Q] = {0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9, 12, 11, 14, 13};
/* Weights (S1 eq 7): 2/9, 1/9, 1/72. */
static const double sq__lbm_w[SQ_LBM_Q] = {2.0 / 9,  1.0 / 9,  1.0 / 9,  1.0 / 9,  1.0 / 9,
                                           1.0 / 9,  1.0 / 9,  1.0 / 72, 1.0 / 72, 1.0 / 72,
                                           1.0 / 72, 1.0 / 72, 1.0 / 72, 1.0 / 72, 1.0 / 72};

/* Cell classes of one x-row, so the fused kernel runs branch-free on fluid rows. */
enum { SQ_LBM_ROW_FLUID = 0, SQ_LBM_ROW_MIXED = 1, SQ_LBM_ROW_SOLID = 2 };

/* Boundary link kinds (see lbm_boundary.c). */
enum { SQ_LBM_LINK_WALL = 0, SQ_LBM_LINK_COPY = 1, SQ_LBM_LINK_INFLOW = 2 };

/* One population entering an edge cell from outside a non-periodic face. */
typedef struct sq__lbm_link {
    int32_t x;     /* padded index of the receiving (interior) cell */
    int32_t src;   /* COPY: padded index of the interior cell whose population r is copied;
                    * INFLOW: index of the receiving cell in the inflow-cell list */
    uint8_t i;     /* direction entering x */
    uint8_t r;     /* COPY: direction of the copied population */
    uint8_t kind;  /* SQ_LBM_LINK_* */
    uint8_t face;  /* WALL/INFLOW: the face that decided the kind */
    float extra;   /* WALL: 6 w_i (c_i·u_wall) in l.u. */
} sq__lbm_link;

/* SI <-> lattice units, the one place where they meet. */
typedef struct sq__lbm_units {
    double dx, dt;  /* m, s */
    double rho;     /* kg/m³ per lattice density */
    double u;       /* m/s per lattice velocity (dx/dt) */
    double nu;      /* m²/s per lattice viscosity (dx²/dt) */
    double a;       /* m/s² per lattice acceleration (dx/dt²) */
} sq__lbm_units;

/* Parameters of one fused collide-and-stream sweep (lattice units, float). */
typedef struct sq__lbm_kparams {
    float omega_p, omega_m; /* symmetric / antisymmetric rates (BGK: equal) */
    float src;              /* Guo source factor 1 − ω-/2 */
    float g[3];             /* body acceleration for this step */
    float d0;               /* τ0 − ½ (Smagorinsky) */
    float tau0;             /* τ0 */
    float smag_k;           /* 18 C_s² */
    float magic;            /* Λ */
    int smagorinsky;
} sq__lbm_kparams;

struct sq_lbm {
    sq_context *ctx;
    sq_lbm_desc desc;          /* resolved */
    sq__lbm_units units;
    int nx, ny, nz;
    int64_t sy, sz;            /* padded strides */
    int64_t ncell;             /* padded cell count */
    int64_t stride;            /* population stride (ncell rounded up to 16) */
    int64_t off[SQ_LBM_Q];     /* padded index offset of c_i */
    float *f;                  /* 15 * stride populations */
    uint8_t *solid;            /* ncell flags */
    uint8_t *row_class;        /* ny*nz */
    int32_t *row_solids;       /* ny*nz solid counts */
    float *macro;              /* 4 * nx*ny*nz: density, ux, uy, uz (SI) */
    float *ustar;              /* nx*ny*nz */
    sq__lbm_link *links;
    int64_t nlinks;
    int32_t *inflow_cells;     /* padded indices of the cells on INFLOW faces */
    float *inflow_shape;       /* their log-law shape factors */
    int64_t ninflow;
    bool periodic[3];
    bool bc_valid;             /* boundary populations filled for the current layout */
    bool macro_valid, ustar_valid;
    bool lmacro_valid;         /* this slab's views (lmacro; macro itself when not split) */
    bool inflow_dirty;         /* inflow shape factors need recomputing */
    int64_t step;
    double tau, nu_lu;
    sq_lbm_collision collision;
    sq_lbm_drive drive;
    /* wind state (lattice units unless noted) */
    double wind_speed_mps, wind_heading_deg, beaufort;
    double setpoint[2];        /* ramped wind vector at ref height */
    double inflow_u[3];        /* current inflow reference velocity */
    double g_step[3];          /* body acceleration used by the last step */
    double pending[3];         /* one-shot injection pending for the next step */
    double max_wind_lu;
    int k_ref;                 /* plane where BODY_FORCE measures the wind (global) */
    uint64_t seed;
    /* distributed (desc.decompose, more than one rank; lbm_dist.c): this rank holds the
     * planes [kz0, kz0 + nz) of the nzg planes of the lattice; nx, ny, nz, the padded arrays
     * and the links are this slab's. */
    bool zdist;
    int kz0, nzg;
    int znb[2];                /* ranks below / above (-1: the ground / the sky) */
    int nranks;
    int *plane_rank;           /* nzg: the rank holding each plane */
    int64_t *rank_cells;       /* nranks: cells of each rank's slab (the gathers' counts) */
    uint8_t *gsolid;           /* nx*ny*nzg solid flags of the whole lattice (every rank) */
    float *lmacro;             /* 4 * this slab's cells: its views before the gather */
    double *nbr;               /* 2 planes x nx*ny x 4: density and velocity (l.u.) of the
                                * planes beyond the slab's lower and upper faces */
    bool nbr_valid;
    float *zbuf;               /* exchange buffers: 4 x 5 populations x one padded plane */
    sq_par_exchange zx;        /* transfers in flight (sq__lbm_z_exchange_begin) */
    int zx_mode;
};

/* ---- desc / units (lbm_desc.c) ---- */
sq_result sq__lbm_validate(sq_context *ctx, const sq_lbm_desc *d);
/* Largest wind speed (m/s) the desc implies: max_wind_mps or the wind with gusts at the top of
 * its log-law profile. */
double sq__lbm_max_wind_mps(const sq_lbm_desc *d);
/* Derives units from a validated desc (dt chosen if 0) and checks τ and Mach. */
sq_result sq__lbm_units_make(sq_context *ctx, const sq_lbm_desc *d, sq__lbm_units *u,
                             double *tau);
/* Mach check of a wind of speed_lu lattice units: warn above 0.1 l.u., refuse above Ma 0.3. */
sq_result sq__lbm_check_mach(sq_context *ctx, const sq__lbm_units *u, double speed_mps,
                             const char *what);
/* Log-law shape ln((h+z0)/z0)/ln((zr+z0)/z0) for height h (m) above the ground. */
double sq__lbm_log_shape(double h_m, double z0_m, double zref_m);

/* ---- kernels (lbm_kernels.c) ---- */
/* One fused collide-and-stream sweep over all interior rows (parity 0 = even, 1 = odd). */
void sq__lbm_sweep(sq_lbm *l, int parity, const sq__lbm_kparams *p);
/* The same over the rows of planes [z0, z1) only. */
void sq__lbm_sweep_planes(sq_lbm *l, int parity, const sq__lbm_kparams *p, int z0, int z1);
/* Periodic ghost exchange for the given layout parity (0 natural, 1 swapped). */
void sq__lbm_fold_periodic(sq_lbm *l, int parity);
/* Reads the 15 populations of padded cell c as f_i(c) (pre-collision for parity 0,
 * post-collision for parity 1), unshifted (f = h + w). */
void sq__lbm_gather(const sq_lbm *l, int64_t c, int parity, double f[SQ_LBM_Q]);
/* Writes f_i as the populations of padded cell c in the layout of parity (stored shifted). */
void sq__lbm_scatter(sq_lbm *l, int64_t c, int parity, const double f[SQ_LBM_Q]);
/* Density and velocity of all interior cells, scaled (0 in solid cells); see lbm_kernels.c. */
void sq__lbm_macro(const sq_lbm *l, int parity, const float gh[3], float rho_scale,
                   float u_scale, float *rho_out, float *ux_out, float *uy_out, float *uz_out);
/* Sum of the horizontal velocity (l.u., shifted by gh like sq__lbm_macro) over the fluid
 * cells of plane z, and their number. */
void sq__lbm_plane_velocity(const sq_lbm *l, int parity, const float gh[3], int z,
                            double u_sum[2], int64_t *fluid);
/* D3Q15 equilibrium (SPEC §5.2 corrected). */
void sq__lbm_feq(double rho, const double u[3], double feq[SQ_LBM_Q]);

/* ---- boundaries (lbm_boundary.c) ---- */
sq_result sq__lbm_links_build(sq_lbm *l);
void sq__lbm_inflow_shapes(sq_lbm *l);
/* Makes the ghost layer consistent with populations set directly in the natural layout. */
void sq__lbm_prime_ghosts(sq_lbm *l);
/* Fills the populations entering through the faces for the current layout. */
void sq__lbm_boundaries(sq_lbm *l);

/* ---- distributed slabs (lbm_dist.c) ---- */
/* Splits the lattice (desc.decompose and more than one rank): slab, neighbours, buffers. */
sq_result sq__lbm_dist_setup(sq_lbm *l, const sq_lbm_desc *d);
void sq__lbm_dist_free(sq_lbm *l);
/* Populations crossing the slab faces: SQ_LBM_Z_FILL before an odd step (this slab's edge
 * planes into the neighbours' ghost planes, as the periodic fill); SQ_LBM_Z_FOLD right after
 * it (what left into the ghost planes onto the neighbours' edge planes). */
enum { SQ_LBM_Z_FILL = 0, SQ_LBM_Z_FOLD = 1 };
void sq__lbm_z_exchange(sq_lbm *l, int mode);
/* The same in two halves: begin packs and posts the transfers, end waits and unpacks; the
 * planes 1..nz-2 may be updated in between (the transfers touch the ghost and edge planes). */
void sq__lbm_z_exchange_begin(sq_lbm *l, int mode);
void sq__lbm_z_exchange_end(sq_lbm *l);
/* One step's sweep on a slab: for an odd step the edge planes first, then the fold of what
 * they sent across the slab faces overlapped with the interior planes' update. */
void sq__lbm_dist_sweep(sq_lbm *l, int parity, const sq__lbm_kparams *p);
/* Density and velocity of the planes beyond the slab faces (for cells turning fluid). */
void sq__lbm_dist_neighbour_planes(sq_lbm *l);
/* Gathers this slab's views (lmacro) into the global views (macro) on every rank. */
void sq__lbm_dist_gather_macro(sq_lbm *l);
/* Whether face s (0 below, 1 above) of the z axis continues into another slab. */
static inline bool sq__lbm_z_joined(const sq_lbm *l, int s) { return l->zdist && l->znb[s] >= 0; }
/* Whether a population crossing face s of axis a stays in the lattice (periodic axis, or a
 * slab face with a neighbour): no boundary link there. */
static inline bool sq__lbm_face_joined(const sq_lbm *l, int a, int s)
{
    if (a == 2 && l->zdist) return l->znb[s] >= 0;
    return l->periodic[a];
}
/* Solid flag of global cell (x, y, z) (inside the lattice). */
static inline uint8_t sq__lbm_gsolid(const sq_lbm *l, int x, int y, int z);

static inline int64_t sq__lbm_cell(const sq_lbm *l, int x, int y, int z)
{
    return (int64_t)(x + 1) + (int64_t)(y + 1) * l->sy + (int64_t)(z + 1) * l->sz;
}

static inline uint8_t sq__lbm_gsolid(const sq_lbm *l, int x, int y, int z)
{
    if (l->zdist) return l->gsolid[x + (int64_t)l->nx * (y + (int64_t)l->ny * z)];
    return l->solid[sq__lbm_cell(l, x, y, z)];
}

#endif
