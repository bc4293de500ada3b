/* snowdrift_internal.h — snow transport on the wind lattice (SPEC §5.6, S1 §2.2 eqs 8–13):
 * integer flake counts per cell carried stochastically by the wind, deposition with
 * stable/roll-off rules, cells that fill up turning solid (bounce-back for the wind), erosion
 * where the friction velocity exceeds its threshold, snowfall from a rate in mm/h.
 *
 * The snow lives on the same nx × ny × nz lattice as the wind (same cell index: x fastest,
 * then y, then z). Per cell it holds
 *   air[c]  flakes carried by the air (S1's S_i summed over i: the direction is redrawn every
 *           step from the local wind, so the 15 per-direction counts are not needed),
 *   dep[c]  flakes deposited in the cell (resting on the surface below, or the content of a
 *           cell that filled up and became snow-solid),
 *   kind[c] 0 air, 1 static solid (terrain, buildings, fences), 2 snow-solid.
 *
 * Flake mass: one flake is 1/threshold of a cell of deposited snow, m = ρ_snow Δx³ / threshold
 * (10 flakes and ρ_snow = 150 kg/m³ on 1 m cells: 15 kg, i.e. 15 mm water equivalent per m²).
 * Snowfall R (mm/h water equivalent = kg m⁻² h⁻¹) then gives λ = s R Δt Δx² / (3600 m) flakes
 * per top cell per step, s being an optional time-lapse factor for accumulation.
 *
 * Budget (integers, exact every step): fallen = airborne + deposited + left the domain. */
#ifndef SQ_SNOWDRIFT_INTERNAL_H
#define SQ_SNOWDRIFT_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "core/core_internal.h"
#include "squall/drawable.h"
#include "squall/field.h"
#include "squall/lbm.h"
#include "squall/snowdrift.h"
#include "squall/world.h"

enum { SQ_SNOW_AIR = 0, SQ_SNOW_STATIC = 1, SQ_SNOW_SOLID = 2 };

/* RNG streams (Philox counter = purpose, step, cell, block): one per stochastic rule. */
enum {
    SQ_SNOW_RNG_INJECT = 1,
    SQ_SNOW_RNG_TRANSPORT = 2,
    SQ_SNOW_RNG_ROLL = 3,
    SQ_SNOW_RNG_ERODE = 4
};

/* Snow parameters (SI). Zero fields are replaced by the defaults noted. */
typedef struct sq__snow_params {
    double dx_m;                /* cell size (must equal the wind lattice's) */
    double dt_s;                /* snow step; max |u − u_fall| dt/dx must stay <= 1 (clamped) */
    double fall_speed_mps;      /* settling speed u_g of flakes; default 1.0 (SPEC: 0.5–1.5) */
    int threshold;              /* a cell holding more flakes turns solid; default 10 (S1) */
    double snow_density_kgm3;   /* deposited snow, fixes the flake mass; default 150 */
    double snowfall_mmh;        /* water-equivalent rate; 0 is physical (no snowfall) */
    double speedup;             /* accumulation time-lapse factor; default 1 */
    /* erosion (S1 eqs 12–13 on the friction velocity): θ = θ_c (C_sat − C_salt),
     * C_sat = eff (1 − u*_t²/u*²) for u* > u*_t, C_salt = airborne snow mass concentration in
     * the cell above the surface / saltation_kgm3; flakes eroded per surface cell per step
     * = speedup (Δt / t_sat)(C_sat − C_salt) n_sat with n_sat = saltation_kgm3 Δx³ / m_flake
     * (the time-lapse factor applies to erosion as to snowfall, keeping their ratio) */
    double ustar_threshold_mps; /* u*_t; default 0.25 (dry fresh snow 0.15–0.35, Li & Pomeroy
                                 * 1997); S1 quotes a wind speed of "4" instead */
    double erosion_efficiency;  /* eff; default 1 */
    double saturation_time_s;   /* t_sat; default 1 */
    double saltation_kgm3;      /* airborne snow in a surface cell at C = 1; default 0.05 kg/m³
                                 * (saltation layers carry ~0.1–1 kg/m³ in their lowest 10 cm) */
    bool periodic[2];           /* flakes leaving through x / y faces wrap around */
    uint64_t seed;
} sq__snow_params;

/* Parameters of one snow step in lattice units, for the kernels. The arrays may be a z-slab
 * of a larger lattice (a distributed snow, snowdrift_split.c): local plane k is global plane
 * kz0 + k of the gnz planes, and the kernels update the local planes k0 .. k1-1 only (the
 * planes outside are the neighbouring slabs' edge planes: read, and written only where a
 * flake crosses into them). A whole lattice has k0 = kz0 = 0, k1 = gnz = nz. The random
 * streams are drawn per global cell, so the flakes do not depend on the slabs. */
typedef struct sq__snow_kparams {
    int nx, ny, nz;
    float dt_over_dx;           /* converts m/s to cells per step */
    float fall_cells;           /* u_fall dt/dx (cells per step, downward) */
    bool periodic[2];
    uint64_t seed, step;
    int threads;
    int k0, k1, kz0, gnz;
    int64_t wind0;              /* local index of the wind arrays' first sample (a slab's
                                 * wind holds its own planes only: k0 nx ny); 0 when whole */
} sq__snow_kparams;

typedef struct sq__snow_budget {
    uint64_t fallen;    /* flakes injected by snowfall since create */
    uint64_t airborne;  /* flakes in the air now */
    uint64_t deposited; /* flakes deposited now (resting + inside snow-solid cells) */
    uint64_t left;      /* flakes that left through open faces or the top */
    uint64_t eroded;    /* flakes lifted by erosion since create (moved deposited -> airborne) */
    int64_t solid_cells; /* snow-solid cells now */
} sq__snow_budget;

typedef struct sq__snow {
    sq_context *ctx;
    sq__snow_params p;
    int nx, ny, nz;
    int64_t n;
    uint32_t *air, *air_next, *land, *dep;
    uint8_t *kind;
    uint8_t *changed;    /* per cell: 1 turned snow-solid, 2 turned fluid in this step */
    uint64_t step;
    uint64_t fallen, left, eroded;
    double flake_mass_kg;
    /* wall-clock ms spent per stage since create (sq_snowdrift_get_stats) */
    double ms_transport, ms_deposit, ms_erode, ms_couple;
} sq__snow;
/* The kernel parameters of the snow's next step over its whole lattice (k0 = kz0 = 0,
 * k1 = gnz = nz); a slab sets its own planes after. */
void sq__snow_kparams_of(const sq__snow *s, sq__snow_kparams *kp);

/* ---- kernels (snowdrift_kernels.c): pure functions over arrays ---------------------------- */

/* Adds floor(λ) + Bernoulli(frac λ) flakes to every air cell of the top layer (mean exactly λ
 * per cell). Returns the number added. */
uint64_t sq__snow_inject(const sq__snow_kparams *kp, double lambda, const uint8_t *kind,
                         uint32_t *air);

/* Moves the flakes of air into air_next (which must be zeroed): per axis a flake steps one cell
 * toward sign(d) with probability |d|, d = (u − u_fall ẑ) dt/dx (clamped to [−1, 1]), so the
 * mean displacement is exactly d. Counts are split by binomial draws (exact for small counts,
 * see sq__snow_binomial). Flakes whose step would enter a solid cell or the ground below the
 * lattice stay and are counted in land (for sq__snow_settle); flakes leaving through the top or
 * a non-periodic side are counted in *left. u* are SI views on the same lattice. */
void sq__snow_transport(const sq__snow_kparams *kp, const float *ux, const float *uy,
                        const float *uz, const uint8_t *kind, const uint32_t *air,
                        uint32_t *air_next, uint32_t *land, uint64_t *left);

/* Deposition (SPEC §5.6 (2)): landed flakes rest where the cell below is solid (the 4 stable
 * configurations); otherwise they roll to a random free cell of the 8 lower diagonal neighbours
 * (the roll-off configurations), or drop into the hole below when all 8 are solid. Cells whose
 * deposit exceeds threshold turn snow-solid (changed = 1) and engulf their airborne flakes.
 * land is cleared. */
void sq__snow_settle(const sq__snow_kparams *kp, int threshold, uint8_t *kind, uint32_t *land,
                     uint32_t *dep, uint32_t *air_next, uint8_t *changed);
/* sq__snow_settle in its two halves (a slab hands the flakes rolled into the plane below
 * over in between): the landed flakes rest, roll or drop; then cells over the threshold turn
 * snow-solid. */
void sq__snow_settle_land(const sq__snow_kparams *kp, uint8_t *kind, uint32_t *land,
                          uint32_t *dep, uint32_t *air_next);
void sq__snow_settle_solidify(const sq__snow_kparams *kp, int threshold, uint8_t *kind,
                              uint32_t *dep, uint32_t *air_next, uint8_t *changed);

/* Erosion (S1 eqs 12–13, see sq__snow_params): lifts flakes from the resting deposit of surface
 * cells, then from the snow-solid cell below (which turns fluid when emptied, changed = 2), into
 * the air of the surface cell. Resting flakes that lost their support are released into the air.
 * ustar: friction velocity (m/s) per cell. Returns the number of flakes lifted. */
uint64_t sq__snow_erode(const sq__snow_kparams *kp, const sq__snow_params *sp,
                        const float *ustar, uint8_t *kind, uint32_t *dep, uint32_t *air_next,
                        uint8_t *changed);

/* Counter-based generator of uniforms for one (purpose, step, cell): a deterministic sequence
 * independent of thread scheduling. */
typedef struct sq__snow_rng {
    uint64_t seed, stream, index;
    uint32_t buf[4];
    int avail;
    bool has_next;    /* next holds the block of `index`, drawn ahead (batched kernels) */
    uint32_t next[4];
} sq__snow_rng;
void sq__snow_rng_init(sq__snow_rng *r, uint64_t seed, int purpose, uint64_t step, int64_t cell);
float sq__snow_rng_uniform(sq__snow_rng *r);   /* [0, 1), 24 bits */
double sq__snow_rng_uniform_d(sq__snow_rng *r); /* [0, 1), 53 bits */
/* Binomial(n, p): per-flake Bernoulli draws for n <= 32; otherwise inversion when the smaller
 * of np, n(1−p) is below 25 (exact), else the normal approximation with stochastic rounding
 * (mean exact up to a clamping bias below 1e-6 flakes). */
uint32_t sq__snow_binomial(sq__snow_rng *r, uint32_t n, double p);

/* ---- the snow model (snowdrift_snow.c) --------------------------------------------------- */
sq__snow_params sq__snow_params_resolve(const sq__snow_params *in);
sq_result sq__snow_create(sq_context *ctx, sq_dims cells, const sq__snow_params *p,
                          sq__snow **out);
void sq__snow_destroy(sq__snow *s);
/* Marks cell (i,j,k) as static solid (terrain, building) or air; not for snow cells. */
void sq__snow_set_static(sq__snow *s, int i, int j, int k, bool solid);
/* One snow step (S1 §3.2 steps 6–8): snowfall, transport by the wind u (SI views on the same
 * lattice), deposition and solidification, erosion by the friction velocity ustar (may be NULL:
 * no erosion). Cells turning snow-solid or fluid are passed to lbm (may be NULL). */
sq_result sq__snow_step(sq__snow *s, const sq_field_view u[3], const sq_field_view *ustar,
                        sq_lbm *lbm);
void sq__snow_get_budget(const sq__snow *s, sq__snow_budget *out);
/* Flakes per top cell per step for the current parameters (see the header comment). */
double sq__snow_flakes_per_top_cell(const sq__snow_params *p);

/* ---- the snow split in z slabs over the ranks (snowdrift_split.c) -------------------------- */
typedef struct sq__snow_slab sq__snow_slab;
/* Collective: this rank's slab of a global lattice (the wind lattice's z slabs). Its snow
 * (sq__snow_slab_snow) holds the own planes from local plane local0 (sq__snow_slab_range)
 * and, below and above them, the neighbouring slabs' edge planes; set the static solids of
 * every local plane (sq__snow_set_static, local indices). */
sq_result sq__snow_slab_create(sq_context *ctx, sq_dims global, const sq__snow_params *p,
                               sq__snow_slab **out);
void sq__snow_slab_destroy(sq__snow_slab *sl);
/* Global first own plane, own planes, local index of the first own plane. */
void sq__snow_slab_range(const sq__snow_slab *sl, int *lo, int *own, int *local0);
sq__snow *sq__snow_slab_snow(sq__snow_slab *sl);
/* Collective: one snow step of the slab (sq__snow_step's recipe without the wind coupling)
 * from the wind ux, uy, uz of the own planes only (the wind lattice's slab views, x fastest)
 * and the friction velocity ustar (may be NULL) on the local lattice (its own planes are
 * read); flakes crossing a slab face are handed over. changed marks the own cells that
 * turned snow-solid (1) or fluid (2). */
sq_result sq__snow_slab_step(sq__snow_slab *sl, const float *ux, const float *uy, const float *uz,
                             const float *ustar);
/* Collective: the whole lattice's budget (sums over the slabs). */
void sq__snow_slab_budget(const sq__snow_slab *sl, sq__snow_budget *out);
/* Flakes this rank handed to its neighbours since create. */
uint64_t sq__snow_slab_handed(const sq__snow_slab *sl);

/* ---- the phenomenon (snowdrift.c) ------------------------------------------------------- */
struct sq_snowdrift {
    sq_context *ctx;
    sq_snowdrift_desc d;         /* resolved */
    const sq_world *world;
    sq_lbm *lbm;
    sq__snow *snow;
    int nx, ny, nz;
    double h;
    double origin[3];            /* lower corner of the lattice (m) */
    double lbm_dt;               /* wind step (s) */
    int sub;                     /* wind steps per snow step */
    double t_acc;                /* time not yet stepped (s) */
    double time_s;
    int64_t snow_steps;
    /* visual flakes */
    int nflakes;
    float *fpos, *frot, *fspin;
    /* friction velocity on the snow surface only: the cells of the surface list (air above
     * a solid cell) hold u*, every other cell 0 */
    float *ustar;                  /* nx*ny*nz */
    int64_t *surf;                 /* surface cells (lattice index) */
    float *surf_us;                /* their u* */
    int64_t nsurf, surf_cap;
    /* derived drawables and fields; the drawn snow cover extends `margin` columns beyond the
     * lattice on every side (ex = nx + 2 margin, ey = ny + 2 margin), where the deposited depth
     * (continued periodically across recycled faces) fades into the world's ground */
    int margin, ex, ey;
    float *depth;                  /* nx*ny: deposited depth of the lattice columns */
    float *ground_z;               /* ex*ey: the world's surface height at column centres */
    float *surf_h, *cover;         /* ex*ey: the drawn snow cover */
    float *fade_w;                 /* ex*ey: weight of the lattice depth (1 inside) */
    int64_t *src_col;              /* ex*ey: lattice column whose depth a drawn column shows */
    /* flakes drawn with a minimum angular size (observe): radius and alpha per flake */
    float *fradius, *ffade;
    bool have_camera;
    sq_vec3 cam_pos;
    float cam_tan_half_fov;
    float *air_kgm3;               /* nx*ny*nz, kg m-3 at the real snowfall rate (speedup
                                      divided out), built only for fields() */
    double *tally_part;            /* ny*5 per-row partial sums of the budget tally */
    bool derived_dirty, air_dirty;
    uint64_t version;
    /* under mpirun (more than one rank) the snow is split in the wind lattice's z slabs
     * (snowdrift_split.c); snow is then the slab's snow: this rank's planes and the
     * neighbours' edge planes (local indices), and ustar its size */
    sq__snow_slab *slab;           /* NULL: the whole snow on this process */
    int slab_lo, slab_own, slab_l0;/* global first own plane, own planes, its local index */
    int64_t *tot;                  /* nx*ny + 6, reduced after each stepped call: the flakes
                                    * of every column (depth: snow-solid cells count the
                                    * threshold, air cells their resting flakes), airborne,
                                    * deposited, snow-solid cells, fallen, left, eroded */
    int64_t *rank_cells;           /* cells of each rank's own planes (the gathers) */
    int64_t *chg, chg_cap;         /* the cells that changed kind this snow step (2c + solid):
                                    * this rank's, then every rank's */
    int64_t *chg_all, chg_all_cap;
    int64_t *chg_count;            /* per rank */
    uint32_t *gair;                /* rank 0: airborne flakes of the whole lattice (gathered) */
    uint8_t *gkind;                /* nx*ny*nz: cell kinds of the whole lattice (rank 0:
                                    * gathered with gair; zero on the others) */
    sq_lbm_views gviews;           /* the wind as last gathered (the fields) */
    /* timings (ms since create) */
    int64_t steps, lbm_steps;
    double ms_lbm, ms_ustar, ms_flakes, ms_derived, ms_budget;
};

/* The wind solver's desc for a resolved snowdrift desc. */
void sq__snowdrift_lbm_desc(const sq_snowdrift_desc *d, sq_lbm_desc *out);
/* The camera of the coming frame (flake sizes). */
void sq__snowdrift_observe(sq_snowdrift *s, const sq_camera *camera);
int sq__snowdrift_drawables(sq_snowdrift *s, sq_drawable *out, int max);
int sq__snowdrift_metrics(sq_snowdrift *s, sq_metric *out, int max);
int sq__snowdrift_fields(sq_snowdrift *s, sq_named_field *out, int max);
/* Under mpirun, collective, once per frame (sq_phen_plugin.frame_sync): with gather, the wind,
 * the airborne snow and the cell kinds of the whole lattice to rank 0 (its fields). */
sq_result sq__snowdrift_frame_sync(void *self, bool gather);

/* checkpoint hooks (snowdrift_state.c) */
sq_result sq__snowdrift_save_state(const void *self, sq_state_writer *w);
sq_result sq__snowdrift_load_state(void *self, sq_state_reader *r);

/* live changes (end of snowdrift.c): d differs from the running desc only in live keys */
sq_result sq__snowdrift_apply_live(sq_snowdrift *s, const sq_snowdrift_desc *d);

#endif
