/* clouds_internal.h — the clouds phenomenon's private types and kernels (SPEC §8, S4; issue 10):
 * the structured-particle clustering (clouds_cluster.c), the cloud field with its time series,
 * optics and sub-grid structure (clouds_field.c), cloud segmentation (clouds_segment.c), the
 * particle system (clouds_particles.c) and the phenomenon object (clouds.c). */
#ifndef SQ_CLOUDS_INTERNAL_H
#define SQ_CLOUDS_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "core/core_internal.h"
#include "squall/clouds.h"
#include "squall/drawable.h"
#include "squall/noise.h"
#include "squall/optics.h"
#include "squall/plugin.h"
#include "world/world_struct.h"

/* ==== structured particles: similarity and leader clustering (clouds_cluster.c) ============= */

#define SQ__MAX_SYMBOLS 4   /* values of the symbolic attribute (hydrometeor phase) */
#define SQ__MAX_CLASSES 64  /* classes d of measure (3) (clouds; larger ids share the last) */

/* Probabilities for measure (3): p_joint[v * classes + k] = P(a = v and d = k), p_class[k] =
 * P(d = k), estimated from the particles. */
typedef struct sq__symbolic_table {
    int classes;
    float p_joint[SQ__MAX_SYMBOLS * SQ__MAX_CLASSES];
    float p_class[SQ__MAX_CLASSES];
} sq__symbolic_table;

/* Measure (1): continuous attribute with range [amin, amax]; 1 when amax == amin. */
float sq__sim_continuous(float vi, float vj, float amin, float amax);
/* Measure (2): ordinal attribute, ranks ri, rj of t sorted values; 1 when t <= 1. */
float sq__sim_ordinal(int ri, int rj, int t);
/* Measure (3) as S4 prints it, empty classes skipped, clamped to [0, 1]. */
float sq__sim_symbolic(const sq__symbolic_table *s, int vi, int vj);
/* The normalised value-difference metric 1 - 1/2 sum_k |P(d=k|v_i) - P(d=k|v_j)| (SPEC 8.3). */
float sq__sim_symbolic_vdm(const sq__symbolic_table *s, int vi, int vj);
/* Fills p_joint, p_class from n (value, class) pairs; s->classes must be set (<= 64). */
void sq__symbolic_table_build(sq__symbolic_table *s, const uint8_t *value, const int32_t *cls,
                              int n);

/* The attributes of n particles (all borrowed). */
typedef struct sq__cluster_input {
    int n;
    const float *pos;       /* 3n: x, y, z (continuous) */
    const float *density;   /* n: local extinction relative to the maximum (continuous) */
    const uint8_t *stage;   /* n: life stage rank 0..stages-1 (ordinal) */
    const uint8_t *phase;   /* n: hydrometeor phase 0..SQ__MAX_SYMBOLS-1 (symbolic) */
    const int32_t *cls;     /* n: class label d of measure (3): the particle's cloud */
    int stages;
    const sq__symbolic_table *symbols;
} sq__cluster_input;

/* Thresholds sigma(a) in [0, 1] per attribute and the seed of the leader order. */
typedef struct sq__cluster_params {
    float sigma_pos[3];
    float sigma_density;
    float sigma_stage;
    float sigma_phase;
    bool symbolic_vdm; /* measure (3) as the value-difference metric instead of S4's form */
    uint64_t seed;
} sq__cluster_params;

/* max(a), min(a) of the continuous attributes: x, y, z, density. */
typedef struct sq__cluster_ranges {
    float lo[4], hi[4];
} sq__cluster_ranges;

void sq__cluster_ranges_compute(const sq__cluster_input *in, sq__cluster_ranges *rg);
/* Global similarity: every attribute's measure >= its threshold. */
bool sq__particles_similar(const sq__cluster_input *in, const sq__cluster_params *p,
                           const sq__cluster_ranges *rg, int i, int j);

/* Workspace and result of a clustering: label[i] in [0, clusters). */
typedef struct sq__clustering {
    int n, cap, clusters;
    int32_t *label, *order, *sorted, *bucket_of, *bucket_start;
    int bucket_cap;
    int dims[3];
    float bsize[3];
    sq__cluster_ranges ranges;
    uint64_t comparisons; /* similarity tests made (for the benchmark) */
    int order_n;          /* the seed order in `order` is for order_n particles and order_seed */
    uint64_t order_seed;  /* (it depends on nothing else, so it is made once) */
} sq__clustering;

sq_result sq__cluster_reserve(sq_context *ctx, sq__clustering *c, int n);
void sq__cluster_free(sq_context *ctx, sq__clustering *c);
/* Leader clustering (S4 §2.2 step 3) with a deterministic seed order; use_grid selects the
 * bucketed scan (same result as the naive O(N x clusters) scan). */
sq_result sq__cluster_leader(sq_context *ctx, sq__clustering *c, const sq__cluster_input *in,
                             const sq__cluster_params *p, bool use_grid);

/* One structured particle per cluster (arrays of c->clusters entries, caller-owned). */
typedef struct sq__structured {
    float *pos;     /* 3m: optical-cross-section-weighted centroid */
    float *radius;  /* m: sqrt of the weighted second moment of the members' discs */
    float *tau;     /* m: centre optical depth keeping sum tau r² */
    float *density; /* m: weighted mean */
    float *weight;  /* m: sum tau r² */
    int32_t *members;
    int32_t *cloud; /* cloud of the first member */
} sq__structured;

void sq__cluster_aggregate(const sq__clustering *c, const sq__cluster_input *in,
                           const float *radius, const float *tau, sq__structured *out);

/* ==== the cloud field (clouds_source.c, clouds_field.c) ======================================= */

/* The world's vertical exaggeration (world.terrain.vertical_exaggeration, its one home): the
 * clouds stretch with the terrain. 1 without a world. */
static inline float sq__clouds_exaggeration(const sq_world *w)
{
    return w && w->vertical_exaggeration > 0.0f ? w->vertical_exaggeration : 1.0f;
}

/* Fields of the model at one time on its mass grid (borrowed from the source until its next
 * read). 3D arrays nx*ny*nz, index (k*ny + j)*nx + i, x fastest, row 0 south, level 0 lowest. */
typedef struct sq__cloud_frame {
    const float *z_m;                      /* height of the mass points, m above sea level */
    const float *z_w_m;                    /* nx*ny*(nz+1) cell interfaces; NULL: midpoints */
    const float *conc[SQ_HYDRO_COUNT];     /* g/m³; NULL where the source lacks the species */
    const float *number_ice, *number_rain; /* 1/m³ or NULL */
    const float *cldfra;                   /* cloud fraction [0, 1] or NULL */
    const float *u, *v, *w;                /* m/s along world x, y, z */
    const float *terrain_m;                /* nx*ny, m above sea level */
} sq__cloud_frame;

typedef struct sq__cloud_source sq__cloud_source;

typedef struct sq__cloud_grid {
    int nx, ny, nz;
    float dx, dy;       /* m */
    float x0, y0;       /* world x, y of mass point (0, 0) */
    double duration_s;  /* last stored time - first (0: a single time or analytic) */
    bool analytic;
    char description[640];
} sq__cloud_grid;

/* Opens the desc's source (the WRF file, or an analytic field placed over the world's terrain);
 * errors name the file and variable. */
sq_result sq__cloud_source_open(sq_context *ctx, const sq_clouds_desc *d, const sq_world *world,
                                sq__cloud_source **out);
void sq__cloud_source_close(sq__cloud_source *s);
void sq__cloud_source_grid(const sq__cloud_source *s, sq__cloud_grid *out);
/* Fields at time_s after the first stored time (clamped to the series). */
sq_result sq__cloud_source_read(sq__cloud_source *s, double time_s, sq__cloud_frame *out);

/* Noise quantiles for the sub-grid pattern: threshold and mean mask per cloud fraction. */
#define SQ__SUBGRID_TABLE 65
typedef struct sq__subgrid {
    float theta[SQ__SUBGRID_TABLE]; /* noise threshold leaving fraction f = i / 64 covered */
    float mean[SQ__SUBGRID_TABLE];  /* mean of the soft mask at that threshold */
    float width;                    /* soft edge half-width in noise units */
    float scale_m, scale_z_m;       /* horizontal and vertical pattern sizes (physical m) */
    float offset[2];                /* drift with the mean wind (m) */
    bool on;
    sq_noise noise;
} sq__subgrid;

/* The current state of the cloud field on the model grid (owned copies). */
typedef struct sq__cloud_field {
    sq__cloud_grid grid;
    float exaggeration;          /* world z = e * z */
    size_t cells;
    float *z, *zw;               /* mass points and interfaces (m above sea level) */
    float *conc[SQ_HYDRO_COUNT]; /* g/m³ (zero-filled for absent species) */
    bool has[SQ_HYDRO_COUNT];
    float *beta;                 /* extinction (1/m, physical) */
    float *g;                    /* extinction-weighted HG asymmetry */
    float *pack;                 /* 8 per cell for sampling: beta, beta g, cond, ice + snow,
                                    frac, u, v, w */
    float *cond;                 /* cloud condensate: cloud water + ice + snow (g/m³) */
    float *frac;                 /* cloud fraction of the cell */
    float frac_default;          /* the desc's cloud.fraction: without CLDFRA, or where it is 0 */
    bool frac_from_source;       /* frac holds the source's CLDFRA of the last update */
    float *u, *v, *w;
    float *terrain;              /* nx*ny */
    int32_t *label;              /* cloud id of the cell or -1 */
    float beta_max;
    sq__subgrid sub;
    sq_cloud_optics optics;
    bool reff_from_number, rayleigh;
    double time_s;
} sq__cloud_field;

sq_result sq__cloud_field_init(sq_context *ctx, sq__cloud_field *f, const sq__cloud_grid *grid,
                               const sq_clouds_desc *d, float exaggeration);
void sq__cloud_field_free(sq_context *ctx, sq__cloud_field *f);
/* Copies a frame, derives extinction and asymmetry per cell, drifts the sub-grid pattern. */
void sq__cloud_field_update(sq__cloud_field *f, const sq__cloud_frame *fr, double time_s,
                            double dt_s);
/* Interpolated values at a world point (x, y, world z): physical extinction (1/m), asymmetry
 * and wind (m/s, world frame with w scaled by the exaggeration). Outside the cloud grid: 0. */
typedef struct sq__cloud_sample {
    float beta, g, cond, ice_fraction, frac;
    float wind[3];
} sq__cloud_sample;
void sq__cloud_field_sample(const sq__cloud_field *f, float x, float y, float zw,
                            sq__cloud_sample *out);
/* Sub-grid weight m(p) / E[m] (mean 1 over a cell of cloud fraction frac); 1 when off. */
float sq__cloud_subgrid_weight(const sq__cloud_field *f, float x, float y, float z_phys,
                               float frac);
/* The soft mask m(p) in [0, 1] alone (for rejection sampling). */
float sq__cloud_subgrid_mask(const sq__cloud_field *f, float x, float y, float z_phys,
                             float frac);
/* Cell index helpers. */
static inline size_t sq__cell(const sq__cloud_grid *g, int i, int j, int k)
{
    return ((size_t)k * (size_t)g->ny + (size_t)j) * (size_t)g->nx + (size_t)i;
}
/* Bottom and top interface of cell (i, j, k), physical m. */
void sq__cloud_cell_bounds(const sq__cloud_field *f, int i, int j, int k, float *zlo, float *zhi);

/* ==== clouds: connected cloudy cells (clouds_segment.c) ======================================= */
#define SQ__MAX_CLOUDS 4096
typedef struct sq__segmentation {
    int clouds;
    sq_cloud_info *info;   /* clouds entries (capacity SQ__MAX_CLOUDS) */
    int32_t *stack;        /* cells: flood-fill work list */
    uint8_t *column;       /* nx*ny: 1 where a column holds a cloudy cell */
    int32_t *colmark;      /* nx*ny: fill that last counted the column */
    int32_t *foot;         /* per cloud: columns of its footprint */
    double cover_fraction, cloud_top_m, lwp_g_m2, iwp_g_m2;
    int largest_dropped;   /* clouds beyond the capacity merged into the last (counted) */
} sq__segmentation;

sq_result sq__segment_init(sq_context *ctx, sq__segmentation *s, const sq__cloud_grid *g);
void sq__segment_free(sq_context *ctx, sq__segmentation *s);
/* Labels 6-connected cells whose condensate >= threshold and fills per-cloud and domain
 * statistics (world coordinates use the field's exaggeration). */
void sq__segment_clouds(sq__segmentation *s, sq__cloud_field *f, float threshold_g_m3);

/* Cell containing a world point (nearest column, the level whose interfaces bracket z), or -1
 * outside the grid. */
int64_t sq__cloud_field_cell_at(const sq__cloud_field *f, float x, float y, float zw);
/* Zeroes the sampled extinction of cells outside every cloud (label < 0): only clouds are drawn,
 * and particles, volume and metrics see the same field. */
void sq__cloud_field_mask_to_clouds(sq__cloud_field *f);

/* ==== the particle system (clouds_particles.c) ================================================= */
#define SQ__STAGES 4 /* S4 §2.1: birth, motion, growth, death */
enum { SQ__PHASE_LIQUID = 0, SQ__PHASE_MIXED = 1, SQ__PHASE_ICE = 2 };

typedef struct sq__particles {
    int n;
    float *pos;       /* 3n world m */
    float *radius;    /* n world m */
    float *tau;       /* n: drawn optical depth (with the life fade) */
    float *coef;      /* n: tau = coef * beta(p) (see clouds_particles.c) */
    float *age, *life;
    float *density;   /* n: beta(p) / beta_max (continuous attribute) */
    float *g;         /* n: HG asymmetry at the particle */
    uint8_t *stage;   /* n: life stage (ordinal attribute) */
    uint8_t *phase;   /* n: liquid, mixed, ice (symbolic attribute) */
    int32_t *cloud;   /* n: cloud id of the particle's cell (class d of measure (3)) */
    uint32_t *gen;    /* n: (re)spawn count, the RNG counter */
    /* spawn distribution over cloudy cells: cumulative beta V */
    double *cdf;
    int32_t *cdf_cell;
    int cdf_n;
    double cross_section; /* X = sum beta V over cloudy cells (m², physical) */
    double cloud_volume;  /* sum V f over cloudy cells (m³, world) */
    float radius_auto;    /* current billboard radius (world m) */
    uint64_t respawns;
} sq__particles;

typedef struct sq__particle_params {
    int count;
    float radius_m;     /* 0: auto */
    float lifetime_s;
    uint64_t seed;
    int threads;        /* for the particle loops (results do not depend on it) */
} sq__particle_params;

sq_result sq__particles_init(sq_context *ctx, sq__particles *p, int count, size_t cells);
void sq__particles_free(sq_context *ctx, sq__particles *p);
/* Spawn distribution from the field's cloudy cells. */
void sq__particles_prepare(sq__particles *p, const sq__cloud_field *f,
                           const sq__particle_params *pp);
/* First fill: every particle spawned with a random age. */
void sq__particles_seed(sq__particles *p, const sq__cloud_field *f, const sq__particle_params *pp);
/* Moves the particles with the wind, ages them, re-initialises those at the end of their life
 * (S4 §2.2 step 4) or in clear air, and updates tau and the attributes from the field. */
void sq__particles_advance(sq__particles *p, const sq__cloud_field *f,
                           const sq__particle_params *pp, double dt_s);

/* Bytes per particle of the phenomenon (particles, clustering, drawable copies). */
#define SQ__CLOUDS_BYTES_PER_PARTICLE 200u

/* Plug-in accessors (clouds.c). */
int sq__clouds_drawables(sq_clouds *c, sq_drawable *out, int max);
int sq__clouds_metrics(sq_clouds *c, sq_metric *out, int max);
int sq__clouds_fields(sq_clouds *c, sq_named_field *out, int max);
/* Live changes (end of clouds.c): the live entries of table taken from desc. */
sq_result sq__clouds_apply_live(sq_clouds *c, const sq_param *table, size_t n,
                                const sq_clouds_desc *desc);

/* ---- the phenomenon ------------------------------------------------------------------------ */
struct sq_clouds {
    sq_context *ctx;
    sq_clouds_desc d;
    const sq_world *world;
    sq__cloud_source *src;
    sq__cloud_field field;
    sq__segmentation seg;
    sq__particles parts;
    sq__particle_params pp;
    double time_s;
    uint64_t version;
    /* structured particles */
    sq__clustering clus;
    sq__symbolic_table sym;
    sq__structured st;
    float *st_g;
    /* drawn elements, sorted by cloud */
    int draw_n;
    float *d_pos, *d_radius, *d_tau, *d_g;
    int32_t *d_key, *d_cursor;
    sq_cloud_group *groups;
    int group_count;
    /* volume of the extinction field (world units) */
    float *vox;
    int vn[3];
    sq_vec3 vox_origin, vox_size;
    float vox_max, vox_g;
    uint64_t vox_version;
    float *vox_phys; /* physical extinction for export (1/m) */
    float *vox_cond; /* condensate for export (g/m³) */
    /* 2D maps on the model grid */
    float *map_lwp, *map_iwp, *map_tau, *map_top, *map_cover;
    sq_clouds_stats stats;
};

/* After a checkpoint load (clouds_state.c): rebuilds the field, segmentation, maps, clusters and
 * drawn elements at the restored clock from the restored particles; nothing advances. */
sq_result sq__clouds_refresh(sq_clouds *c);
sq_result sq__clouds_save_state(const void *self, sq_state_writer *w);
sq_result sq__clouds_load_state(void *self, sq_state_reader *r);

#endif
