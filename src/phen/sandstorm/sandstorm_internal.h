/* sandstorm_internal.h — state of the sandstorm phenomenon and its kernels. */
#ifndef SQ_SANDSTORM_INTERNAL_H
#define SQ_SANDSTORM_INTERNAL_H

#include "core/core_internal.h"
#include "squall/grid.h"
#include "squall/noise.h"
#include "squall/optics.h"
#include "squall/sandstorm.h"

#define SQ_SAND_AIR_DENSITY 1.2       /* kg/m³ (SPEC §1.2: "use 1.2") */
#define SQ_SAND_AIR_VISCOSITY 1.81e-5 /* Pa s, dynamic viscosity of air at 15-20 °C */
#define SQ_SAND_GRAVITY 9.81          /* m/s² */
#define SQ_SAND_DRY_LAPSE 0.0098      /* K/m, dry adiabatic lapse rate g / c_p (c_p = 1004) */
#define SQ_SAND_CP 1004.0             /* J/(kg K), specific heat of dry air at constant pressure */
#define SQ_SAND_FRONT_HISTORY 64      /* front samples kept for its speed */
/* the wall: where the dust's extinction reaches 3e-3 1/m (visibility <= 1 km at 5 % contrast) */
#define SQ_SAND_WALL_BETA 3.0e-3
#define SQ_SAND_KARMAN 0.4            /* von Kármán constant (S0) */
/* Height of a weather station's anemometer above the ground (WMO standard exposure, 10 m): the
 * station_wind metrics give the resolved wind there, from the first fluid cell by the log law. */
#define SQ_SAND_ANEMOMETER_M 10.0
#define SQ_SAND_NU_AIR 1.5e-5         /* m²/s kinematic viscosity of air (SPEC §1.5) */
/* Cap on the mixing length kappa d (m): kappa x 250 m. The mixing length grows with height only
 * through the surface layer; above it stays of the order of Blackadar's asymptotic length
 * (~10^2 m in strong winds). Uncapped, kappa d would reach kappa x the domain height (about
 * 1 km for a 2.5 km deep domain) and the upper-level eddy viscosity nu_t = l^2 |du/dz| would
 * smear the storm's vertical structure. */
#define SQ_SAND_MIXING_LENGTH_MAX 100.0
/* Turbulent Prandtl number Pr_t = nu_t / K of the dust's and heat's eddy diffusivity K: 0.74 in
 * the neutral surface layer (Businger, Wyngaard, Izumi, Bradley 1971, J. Atmos. Sci. 28, 181);
 * also the critical Richardson number of the stratified mixing length (Lilly 1962). */
#define SQ_SAND_PRANDTL_T 0.74
/* Rayleigh extinction of clean air at 550 nm, sea level (Bucholtz 1995: 1.16e-5 1/m): the
 * visibility of dust-free air is then ln(20)/beta ~ 258 km instead of infinite. */
#define SQ_SAND_BETA_AIR_550 1.16e-5
/* Asymmetry parameter of non-spherical mineral dust at 650, 550, 450 nm. Mie theory for
 * spheres overestimates g for irregular grains (their side scattering is stronger); these are
 * the AERONET spheroid-model retrievals of desert dust (Dubovik et al. 2002, J. Atmos. Sci. 59,
 * 590-608, Table 1: Bahrain, Solar Village, Cape Verde; g 0.68-0.73 at 440 nm, 0.66-0.71 at
 * 670 nm), the three sites averaged and interpolated linearly in wavelength; consistent with the
 * polar-nephelometer phase functions of Saharan dust, g > 0.65 (Horvath et al. 2018, Atmos.
 * Chem. Phys. 18, 17735-17744). */
#define SQ_SAND_G_DUST_650 0.68
#define SQ_SAND_G_DUST_550 0.69
#define SQ_SAND_G_DUST_450 0.70

/* Flow-following detail of the rendered dust (sandstorm_detail.c; display only). */
typedef struct sq__sand_detail {
    bool enabled;
    int nx, ny, nz;
    double h, amplitude_m, scale_cells, period_s;
    double age[2];    /* time since each phase's coordinates were re-seeded (s) */
    float *coord[2];  /* 3 per cell: advected noise-texture coordinates of each phase (cells) */
    float *tmp;       /* 3 per cell: scratch */
    float *vel;       /* 3 per cell: cell-centre wind (cells/s) */
    float *amp;       /* per cell: displacement amplitude (cells), from the vorticity */
    uint8_t *near[2]; /* per cell: dust within reach of the displacement (and scratch) */
    sq_noise noise;
} sq__sand_detail;

sq_result sq__sand_detail_init(sq__sand_detail *d, sq_context *ctx, int nx, int ny, int nz,
                               double h, double amplitude_m, double scale_m, double period_s,
                               uint64_t seed);
void sq__sand_detail_free(sq__sand_detail *d, sq_context *ctx);
void sq__sand_detail_reseed(sq__sand_detail *d, int phase);
/* advects both coordinate fields by the grid's wind over dt and re-seeds expired phases */
void sq__sand_detail_advect(sq__sand_detail *d, const sq_grid *g, double dt, int threads);
/* blend weight of a phase of this age: 1 - |1 - 2 age / period| */
double sq__sand_detail_weight(double age, double period);
/* out = in looked up at the detail-displaced points (nx*ny*nz, x fastest; out != in) */
void sq__sand_detail_apply(const sq__sand_detail *d, const float *in, float *out, int threads);

struct sq_sandstorm {
    sq_context *ctx;
    sq_sandstorm_desc d;
    const sq_world *world;
    uint64_t memory_bytes;
    /* grid (desert) */
    sq_grid *grid;    /* under mpirun: this rank's slab (the whole grid's columns lo .. lo+ln) */
    bool dist;        /* the grid is split over the ranks (every reduction is then global) */
    sq_grid *whole;   /* under mpirun, on rank 0 only: the whole grid, gathered at the frames
                         it draws or writes (sq__sandstorm_frame_sync; never stepped) */
    int lo[2], ln[2]; /* the slab's first column (x, y) and its columns; 0 and nx, ny if whole */
    int nb_lo, nb_hi; /* under mpirun: the ranks of the slabs before and after (-1: none) */
    int *blocks;      /* under mpirun: lo x, lo y, n x, n y of every rank's slab */
    int *slab_gk;     /* under mpirun: ground_k and ground_z1 of the slab's columns */
    float *slab_gz1;
    float *slab_vis;  /* under mpirun: the slab's visibility planes (vis_height_count of them) */
    float *vis_all;   /* under mpirun: every slab's planes, as gathered */
    double *tau;      /* under mpirun: ny * nz optical depths along x (the wall seen) */
    int64_t synced_step; /* under mpirun: the step of the last frame sync (-1: none) */
    double sync_suspended_kg, sync_max_wind, sync_beta_max; /* its global reductions */
    double sync_w10[2];      /* and the station's wind at the observer and its largest */
    double detail_pending_s; /* under mpirun: time the detail has not followed yet (rank 0) */
    int detail_pending_n;
    int nx, ny, nz;   /* the whole grid's cells */
    double h;
    double origin[3];
    sq_grid_sgs_desc sgs; /* the subgrid closure (solver.turbulence = smagorinsky or tke) */
    int temp_idx;     /* the scalar holding potential temperature theta (K) */
    float *theta_ref; /* nz: background potential temperature per level (K) */
    int *ground_k;    /* nx*ny: first fluid cell above the ground in each column (-1: none) */
    float *ground_z1; /* nx*ny: height of that cell's centre above the terrain (m) */
    float *accel_z;   /* nx*ny*nz scratch: dust-loading acceleration */
    float *keep;      /* nx*ny: per-column momentum factor of this step's emission */
    double *row_acc;  /* 4 * ny per-row partial sums (fixed-order reductions) */
    double *plane_mass; /* nz * SQ_SANDSTORM_MAX_BINS per-plane partial dust masses */
    float *mix_f;       /* 4 nz floats per slab row: the dust mixing's column (sandstorm_mixing.c) */
    double *mix_d;      /* 2 nz doubles per slab row: its tridiagonal solve */
    /* dust */
    int nbins;
    sq_size_bin bins[SQ_SANDSTORM_MAX_BINS];
    double w_settle[SQ_SANDSTORM_MAX_BINS];  /* terminal speed, m/s (down) */
    double k_ext[SQ_SANDSTORM_MAX_BINS][4];  /* mass extinction m²/kg, R G B 550 */
    double albedo_b[SQ_SANDSTORM_MAX_BINS][4];
    float sigma_rel[3], albedo[3], g[3];     /* drawable optics (per unit beta_550) */
    double k_ext_total_550;                  /* of the whole distribution (m²/kg) */
    double u_star_t;                         /* threshold friction velocity */
    /* drawable and metric buffers */
    float *density;                          /* nx*ny*nz, beta_ext at 550 nm (1/m) */
    float density_max;
    double return_mps;                       /* coldpool.return_flow: the west face's outflow
                                                aloft (m/s, subtracted above the cold pool) */
    double wall_height_m;                    /* highest dust with beta >= SQ_SAND_WALL_BETA */
    double wall_seen_m;                      /* the wall's top seen from ahead (sq__sand_wall_seen) */
    float *vis[SQ_SANDSTORM_MAX_VIS];        /* nx*ny visibility planes (m) */
    char vis_names[SQ_SANDSTORM_MAX_VIS][40];
    float *export_buf[6];                    /* fields for export (conc, u, v, w, T, beta) */
    bool derived_dirty;
    uint64_t version;
    /* urban */
    float urban_density[8];                  /* 2x2x2 constant grid */
    sq_vec3 urban_origin, urban_size;
    float urban_conc;
    /* time and accounting */
    double time_s;
    int64_t step;
    sq_sandstorm_budget budget;
    /* cold-pool front history (ring): times and positions, every step */
    double front_t[SQ_SAND_FRONT_HISTORY], front_x[SQ_SAND_FRONT_HISTORY];
    int32_t front_n, front_head;
    int32_t warned;                 /* bit 0: wind > 100 m/s, bit 1: dust > 1 kg/m3 (logged once) */
    sq_sandstorm_stats stats;
    /* flow-following detail of the drawable (display only) */
    sq__sand_detail detail;
    float *detail_out; /* nx*ny*nz: the drawable's extinction with the detail */
    float mirror_sides_m; /* detail.mirror_sides_m: the drawable beyond the y faces */
    /* near field */
    int np;
    float *p_pos, *p_radius, *p_rot, *p_spin, *p_tau, *p_fade, *p_age;
    bool have_camera;
    sq_vec3 cam_pos;
    uint64_t spawn_counter;
};

/* sum of a[i], i < n, in double with 8 interleaved partial sums (a fixed order that
 * vectorises; a plain double reduction does not) */
static inline double sq__sand_dsum(const float *a, int n)
{
    double p[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    int i = 0;
    for (; i + 8 <= n; i += 8)
        for (int l = 0; l < 8; l++) p[l] += (double)a[i + l];
    double t = 0.0;
    for (; i < n; i++) t += (double)a[i];
    return ((p[0] + p[4]) + (p[1] + p[5])) + ((p[2] + p[6]) + (p[3] + p[7])) + t;
}

/* kernels (sandstorm_kernels.c): pure functions over arrays */
double sq__sand_column_settle(float *c, ptrdiff_t cs, const uint8_t *solid, ptrdiff_t ss, int nz,
                              double frac);
void sq__sand_block_settle(float *c, ptrdiff_t cy, ptrdiff_t cs, const uint8_t *solid,
                           ptrdiff_t sy, ptrdiff_t ss, int nx, int nrows, int nz, float scale,
                           int substeps, double frac, double *dep);
/* The dust wall's top seen from ahead (median over rows of the highest level whose optical
 * depth along x reaches ln(1/contrast)); rows: ny doubles of scratch. */
double sq__sand_wall_seen(const float *beta, int nx, int ny, int nz, const int *ground_k,
                          const float *ground_z1, float h, double contrast, double *rows);
/* The median of rows[0 .. ny) (sorts them). */
double sq__sand_median_rows(double *rows, int ny);
void sq__sand_visibility_plane(const float *beta, int nx, int ny, int nz, const int *ground_k,
                               const float *ground_z1, float h, float height_m, double contrast,
                               float *out);

/* the dust's mixing by the ground's turbulence (sandstorm_mixing.c) */
void sq__sand_column_kmix(float *c, ptrdiff_t cs, int n, const float *kf, double h, double dt,
                          double *work);
double sq__sand_kprofile(float *kf, int n, double z1, double h, double ustar, double depth,
                         double schmidt);
double sq__sand_bulk_ri_depth(const float *theta, const float *u, const float *v, int n,
                              double z1, double dz, double ustar, double gravity);
void sq__sand_mix_dust(sq_sandstorm *s, double dt);

/* used by the plug-in (sandstorm_plugin.c) and tests */
int sq__sandstorm_drawables(sq_sandstorm *s, sq_drawable *out, int max);
int sq__sandstorm_metrics(sq_sandstorm *s, sq_metric *out, int max);
int sq__sandstorm_fields(sq_sandstorm *s, sq_named_field *out, int max);
void sq__sandstorm_observe(sq_sandstorm *s, const sq_camera *cam);
const float *sq__sandstorm_visibility_plane(sq_sandstorm *s, int v, int *nx, int *ny);

/* checkpoint hooks (sandstorm_state.c) */
sq_result sq__sandstorm_save_state(const void *self, sq_state_writer *w);
sq_result sq__sandstorm_load_state(void *self, sq_state_reader *r);

/* distributed runs: the frame's reductions, and the slabs gathered to rank 0 with gather */
sq_result sq__sandstorm_frame_sync(void *self, bool gather);

/* live changes (end of sandstorm.c): d differs from the running desc only in live keys */
sq_result sq__sandstorm_apply_live(sq_sandstorm *s, const sq_sandstorm_desc *d);

#endif
