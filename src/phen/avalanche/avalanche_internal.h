/* avalanche_internal.h — state of the snow avalanche phenomenon (SPEC §7) and its kernels. */
#ifndef SQ_AVALANCHE_INTERNAL_H
#define SQ_AVALANCHE_INTERNAL_H

#include "core/core_internal.h"
#include "squall/avalanche.h"
#include "squall/noise.h"
#include "squall/sph.h"

#define SQ_AVAL_GRAVITY 9.81 /* m/s² */
#define SQ_AVAL_TRACK_S 0.05 /* s between samples of the hazard maps and the thalweg */

/* Everything create derives from the desc and the world before allocating: the SPH desc,
 * the fall line, the release geometry and the grids. */
typedef struct sq__aval_plan {
    sq_avalanche_desc d;          /* resolved */
    sq_sph_desc sph;              /* complete, with max_particles = the release count */
    double spacing, support;      /* dx, H (m) */
    double release_lo[2], release_hi[2]; /* the release rectangle (m) */
    double release_top_z;         /* highest particle of the slab (m) */
    double fall_dir[2];           /* horizontal unit vector downhill */
    double edge_s;                /* fall-line coordinate of the release's lower edge */
    double crown[3];              /* centre of the upslope edge, on the terrain */
    const sq_world_area *area;    /* the release polygons (NULL: the rectangle) */
    size_t count;                 /* particles of the release (capacity until create counts) */
    double count_estimate;        /* V / dx³ from the coarse pass */
    double columns;               /* columns of the release lattice */
    double volume_m3;             /* release volume */
    double release_area_m2;
    double max_column_m;          /* thickest vertical column of the release */
    double layer_m;               /* terrain-following grid layer (0: dense box) */
    int hz_nx, hz_ny;             /* hazard maps over the terrain */
    double hz_origin[2], hz_cell;
    int dep_nx, dep_ny;           /* deposit grid */
    double dep_origin[2], dep_cell;
    int pw_n[3];                  /* powder box (0 when off) */
    double pw_origin[3], pw_cell; /* its initial origin (around the release) and cell */
} sq__aval_plan;

struct sq_avalanche {
    sq_context *ctx;
    const sq_world *world;
    sq__aval_plan plan;
    sq_sph *sph;
    double particle_mass;
    double time_s;
    uint64_t memory_bytes;
    /* diagnostics, evaluated lazily */
    bool dirty;
    uint64_t version;
    uint64_t steps_at_eval;       /* solver sub-steps counted at the previous evaluation */
    double prev_front_m, prev_front_t;
    bool have_prev_front;
    sq_avalanche_state st;
    float *scratch;               /* count: fall-line coordinates for the front quantile */
    /* deposit map */
    double *dep_acc;              /* dep_nx*dep_ny: volume per cell (m³); scratch after evaluate */
    float *dep_depth;             /* depth (m) */
    float *dep_smooth;            /* display: smoothed depth */
    float *dep_terrain;           /* terrain height at the cell centres */
    float *dep_height;            /* terrain + smoothed depth (surface drawable) */
    float *dep_cover;             /* coverage of the surface drawable (snow at rest) */
    /* particles drawable */
    float *pos;                   /* 3*count */
    float *spray;                 /* 3*count: the particles above the snow surface */
    /* hazard maps over the terrain (hz_nx*hz_ny): peaks since release, sampled every
     * SQ_AVAL_TRACK_S of simulated time */
    double *hz_vol, *hz_mom;      /* this sample: volume (m³) and volume x speed per cell */
    float *hz_depth_peak;         /* peak flow depth: volume per map area (m) */
    float *hz_speed_peak;         /* peak of the cell's volume-weighted mean speed (m/s) */
    float *hz_pressure_peak;      /* rho0 v² at that (kPa) */
    float *hz_alpha;              /* smallest travel angle of the snow that reached the cell
                                     (deg; NaN = never reached) */
    float *hz_deposit;            /* depth of the current state (m), for the deposit map */
    double track_t;               /* time of the last sample (−1 before the first) */
    /* travel tracking per particle id: release height, horizontal path length, last x, y */
    float *tr_z0, *tr_path, *tr_px, *tr_py;
    /* the thalweg: the mass centre's path (x, y, terrain z), one point per SQ_AVAL_TRACK_S */
    double *thw;
    int thw_n, thw_cap;
    /* powder cloud */
    float *pw_density, *pw_tmp;   /* pw_n[0]*pw_n[1]*pw_n[2] */
    int *pw_ground;               /* pw_n[0]*pw_n[1]: ground cells at the bottom of each column */
    float *pw_vel;                /* 4 pw_n[0]*pw_n[1]: the carrier velocity per column (cells/s) */
    float *pw_work;               /* 2 pw_n[0]*pw_n[1]: smoothing scratch */
    float *pw_show;               /* pw_n[0]*pw_n[1]*pw_n[2]: the drawn density (billows) */
    sq_noise pw_noise;            /* the billows' noise (fixed seed) */
    float pw_max;
    double pw_time_s;             /* time up to which the powder has been advanced */
    double pw_origin[3];          /* the box's current origin (moves with the flow by whole cells) */
    /* the powder budget (kg): entrained = suspended + settled + left behind by the moving box */
    double pw_entrained, pw_settled, pw_left;
};

/* ---- kernels (avalanche_kernels.c): pure functions over arrays -------------------------- */

/* The k-th smallest of a[0..n) (0-based); a is reordered. n ≥ 1, k < n. */
float sq__aval_select(float *a, size_t n, size_t k);
/* Adds each particle's volume m / max(ρ_i, ρ₀) (m³) to the cell of the grid (x0, y0, cell,
 * nx, ny) that holds it (particles outside the grid are skipped). Serial, fixed order. */
void sq__aval_deposit_accumulate(const float *x, const float *y, const float *rho, size_t n,
                                 double mass, double rho0, double x0, double y0, double cell,
                                 int nx, int ny, double *acc);
/* The same for the particles at rest only (|v| <= v_rest): the settled part of the deposit. */
void sq__aval_deposit_accumulate_resting(const float *x, const float *y, const float *vx,
                                         const float *vy, const float *vz, const float *rho,
                                         size_t n, double v_rest, double mass, double rho0,
                                         double x0, double y0, double cell, int nx, int ny,
                                         double *acc);
/* 3x3 binomial smoothing (1 2 1)²/16 with clamped edges; dst and src must not overlap. */
void sq__aval_smooth3(const float *src, float *dst, int nx, int ny);
/* Ordered-dither threshold in [0, 1) of the 4x4 Bayer matrix at lattice column (i, j). */
double sq__aval_dither(int i, int j);
/* Powder cloud on its moving box (origin o, cell c, n[3] cells; ground[col] = the number of
 * cells at the bottom of column col = j*n[0]+i whose centre is below the terrain): adds
 * amount * (|v| - v_min) of each particle faster than v_min to the air cell holding it (a
 * particle in a ground cell feeds the first air cell above); serial. Returns the sum added. */
double sq__aval_powder_source(const float *x, const float *y, const float *z, const float *vx,
                              const float *vy, const float *vz, size_t n, float v_min, float amount,
                              const int nn[3], const double o[3], double c, const int *ground,
                              float *density);
/* One explicit diffusion step (7-point, k = D dt / c^2 <= 1/6) between air cells only (no flux
 * through the ground or the box's faces), then the decay factor (settling). dst and src must
 * not overlap; ground cells are set to 0. Returns the sum removed by the decay (settled). */
double sq__aval_powder_diffuse(const float *src, float *dst, const int nn[3], const int *ground,
                               float k, float decay);
/* The powder's carrier velocity per column (cells per second; vel[4 col + 0..2] = x, y, z, and
 * vel[4 col + 3] a work slot): the mean velocity of the particles in each column of the box,
 * smoothed twice with the 3x3 binomial filter (the cloud beside the flow is dragged too), plus
 * the rise of the cloud's top by entrainment, e_rise |u_h| (upward). Columns without particles
 * after smoothing are still. Serial, fixed order. */
void sq__aval_powder_velocity(const float *x, const float *y, const float *vx, const float *vy,
                              const float *vz, size_t n, const int nn[3], const double o[3],
                              double c, float e_rise, float *vel, float *work);
/* One conservative donor-cell advection step of dt seconds by the column velocities vel (cells
 * per second, sq__aval_powder_velocity): the flux through a face between two air cells is the
 * upwind cell's content times the face velocity (the mean of the two columns' for side faces)
 * times dt; no flux into or out of ground cells; what crosses the box's faces leaves.
 * Requires (|u| + |v| + |w|) dt <= 1 in every column. dst and src must not overlap. Returns the
 * sum that left through the box's faces. */
double sq__aval_powder_advect(const float *src, float *dst, const int nn[3], const int *ground,
                              const float *vel, float dt);
/* Moves the box by whole cells: dst[i] = src[i + shift] (0 where that is outside). Returns the
 * sum of the cells that fell out of the box (left behind). */
double sq__aval_powder_shift(const float *src, float *dst, const int nn[3], const int shift[3]);

/* ---- hazard maps and the thalweg (avalanche_hazard.c) ------------------------------------- */
sq_result sq__aval_hazard_alloc(sq_avalanche *a);
void sq__aval_hazard_free(sq_avalanche *a);
/* One sample: travel paths, the maps' peaks, the thalweg point (at a->time_s). */
void sq__aval_hazard_track(sq_avalanche *a);
/* The deposit map of the current state (hz_deposit). */
void sq__aval_hazard_deposit(sq_avalanche *a);
/* Thalweg run-out, alpha, beta and Lied & Bakkehøi's alpha into st (uses a->scratch). */
void sq__aval_hazard_summary(sq_avalanche *a, const sq_sph_view *v, sq_avalanche_state *st);
/* The maps as named fields on the hazard grid. */
int sq__aval_hazard_fields(sq_avalanche *a, sq_named_field *out, int max);

/* ---- used by the plug-in (avalanche_plugin.c) and tests ----------------------------------- */
/* The world's closed meshes inside the SPH domain as one voxelised collider (avalanche_meshes.c). */
sq_result sq__avalanche_add_meshes(sq_avalanche *a);
sq_result sq__avalanche_plan(sq_context *ctx, const sq_avalanche_desc *desc, const sq_world *w,
                             sq__aval_plan *out);

/* ---- the release (avalanche_release.c) ------------------------------------------------------ */
/* The Swiss slope factor 0.291 / (sin psi - 0.202 cos psi) (1 at and below 28 deg); nz = cos psi. */
double sq__aval_slope_factor(double nz);
/* Bounds (xmin, ymin, xmax, ymax) of the release region. */
void sq__aval_region_bounds(const sq__aval_plan *pl, double b[4]);
/* Slope-normal release thickness at (x, y) (m); −1 outside the region. *nz_out: the terrain
 * normal's vertical component there (capped below at 0.05). */
double sq__aval_thickness_at(const sq__aval_plan *pl, const sq_world *w, double x, double y,
                             double *nz_out);
/* The coarse pass: volume, count estimate, fall line, top, thickest column, crown (areas),
 * lattice columns; refuses a region without snow or over no-data. */
sq_result sq__aval_release_estimate(sq_context *ctx, sq__aval_plan *pl, const sq_world *w);
/* The exact release: counts (pos NULL) or places up to cap particles; polls ctx's interrupt. */
sq_result sq__aval_release_place(sq_context *ctx, const sq__aval_plan *pl, const sq_world *w,
                                 float *pos, size_t cap, size_t *count, double *volume,
                                 double *top_z);
/* The powder cloud (avalanche.c): advance to a->time_s (moving the box with the flow); the
 * terrain's ground cells of the box's columns; the suspended mass (kg). */
void sq__aval_update_powder(sq_avalanche *a);
void sq__aval_powder_ground(sq_avalanche *a);
double sq__aval_powder_suspended(const sq_avalanche *a);
int sq__avalanche_drawables(sq_avalanche *a, sq_drawable *out, int max);
int sq__avalanche_metrics(sq_avalanche *a, sq_metric *out, int max);
int sq__avalanche_fields(sq_avalanche *a, sq_named_field *out, int max);
sq_sph *sq__avalanche_sph(sq_avalanche *a);

/* checkpoint hooks (avalanche_state.c) */
sq_result sq__avalanche_save_state(const void *self, sq_state_writer *w);
sq_result sq__avalanche_load_state(void *self, sq_state_reader *r);

#endif
