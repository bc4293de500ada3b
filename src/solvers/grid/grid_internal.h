/* grid_internal.h — the sq_grid struct, lattice helpers and the kernels shared by the files of
 * the MAC-grid fluid solver (grid.c lifecycle/boundaries, grid_advect.c, grid_project.c,
 * grid_forces.c, grid_diffuse.c). SPEC §1.4, §1.5, §1.12. */
#ifndef SQ_GRID_INTERNAL_H
#define SQ_GRID_INTERNAL_H

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/core_internal.h"
#include "squall/grid.h"

/* Sample lattices: cell centres and the three face sets. */
enum { SQ__L_CELL = 0, SQ__L_U = 1, SQ__L_V = 2, SQ__L_W = 3 };

/* Cell flags on the padded cell lattice (one ghost layer, strides of the pressure field). */
#define SQ__CF_SOLID 1u     /* interior solid cell, or the periodic copy of one */
#define SQ__CF_WALL 2u      /* ghost of a wall or inflow face: faces against it are fixed */
#define SQ__CF_DIRICHLET 4u /* ghost of an outflow/open face: p = 0 on the face */
#define SQ__CF_FIXED (SQ__CF_SOLID | SQ__CF_WALL)

/* Scratch arrays: each holds scratch_count floats (the largest padded lattice). Arrays 0..3
 * are one contiguous block (the advection's 4-float cell velocity lives there) and are never
 * swapped; 4..9 hold the cached cell displacements; 10..12 receive advection results, which
 * are swapped into the fields. Projection, confinement, diffusion and the topology rebuild
 * use 0..3 only (and invalidate nothing else: they change the velocity anyway). */
enum {
    SQ__S_BLOCK = 0, /* 0..3: uc4 (AoS cell velocity), then hats / limiter highs */
    SQ__S_DISP = 4,  /* 4..6: backward displacement x,y,z; 7..9: forward (cell units) */
    SQ__S_OUT = 10,  /* 10..12: advection outputs */
    SQ__SCRATCH = 13
};

/* One multigrid level (levels >= 1; level 0 uses the byte link masks of sq_grid). Arrays are
 * padded with one ghost layer; c[a][idx] is the coefficient of the link between cell idx and
 * idx + e_a (idx may be a low ghost: the link across the low boundary). */
typedef struct sq__mg_level {
    int n[3];
    int b[3]; /* block size (1 or 2) per axis used to coarsen the finer level into this one */
    ptrdiff_t sy, sz;
    size_t count;
    float *x, *rhs, *res;
    float *c[3];
    float *inv_diag; /* 0 marks a solid (inactive) cell */
    float *ext_w;    /* solid cells: 1 / (number of fluid face neighbours), else 0 */
} sq__mg_level;

#define SQ__MG_MAX_LEVELS 16

typedef struct sq__grid_halo sq__grid_halo; /* grid_dist.c: this rank's slab, NULL if whole */

struct sq_grid {
    sq_context *ctx;
    sq_grid_desc d; /* resolved */
    int n[3];
    float h;
    bool periodic[3];
    sq_field3 vel[3];
    sq_field3 *scalar;
    float scalar_inflow[SQ_GRID_MAX_SCALARS];
    float *scalar_inflow_data[6][SQ_GRID_MAX_SCALARS]; /* per-sample values (NULL: constant) */
    sq_field3 p; /* kinematic pressure p/rho, m^2/s^2 */
    /* padded cell lattice (same layout as p) */
    ptrdiff_t sy, sz;
    size_t cell_count; /* padded */
    uint8_t *flags;
    uint8_t *links;     /* level 0: bit 2a (low) / 2a+1 (high) = unit link open along axis a */
    uint8_t *diag;      /* level 0: diagonal (sum of link coefficients + pin) */
    uint16_t *below;    /* cells from the nearest solid/ground below (1 = resting on it);
                           0 = none below */
    uint8_t *solid;     /* nx*ny*nz public solid flags */
    uint8_t *plane_solid; /* per padded z plane (nz + 2): plane contains solid cells */
    float *scratch[SQ__SCRATCH];
    float *scratch_block; /* allocation behind scratch[0..3] */
    size_t scratch_count;
    float *inflow[6];
    int inflow_n[6][2];
    double *plane_sum; /* per z plane partial sums (nz + 2) x 4 */
    sq__mg_level mg[SQ__MG_MAX_LEVELS];
    int mg_levels; /* including level 0 */
    int pins;
    bool topology_dirty;
    bool has_dirichlet;
    double last_project_dt;
    /* cached RK2 cell displacements (scratch 4..9), shared by the scalars and the next
     * velocity advection while the velocity does not change */
    uint64_t vel_version;
    bool trace_valid;
    bool trace_fwd;
    uint64_t trace_version;
    double trace_dt, trace_drift;
    float trace_cfl;
    /* turbulent scalar transport and stratified mixing length (sq_grid_set_eddy_scalars) */
    bool eddy_scalars;   /* sq_grid_diffuse_eddy also diffuses every scalar with K = nu_t/Pr_t */
    int eddy_theta;      /* potential-temperature scalar for N^2, -1: neutral */
    float eddy_g;        /* gravity of N^2 = (g / theta) d theta / dz */
    float eddy_prandtl;  /* turbulent Prandtl number Pr_t */
    sq_grid_stats stats;
    sq__grid_halo *halo; /* decomposed (grid_dist.c); NULL: the whole grid */
    /* the frame the advection kernels place samples in: local sample i lies at global index
     * i + lat_shift[a] of a lattice of lat_n[a] cells (n and 0, except on the widened copy of
     * a decomposed grid's slab, grid_dist.c) */
    int lat_n[3];
    int lat_shift[3];
    /* the widened copy of a slab (own_only): the advection's results are used at the slab's
     * own cells [own_lo, own_hi) along own_ax only, and its first (semi-Lagrangian) pass within
     * trace_margin cells of them (the second pass reads it that far), so the kernels skip the
     * rest of the copy (grid_advect.c); false: every sample */
    bool own_only;
    int own_ax, own_lo, own_hi, trace_margin;
};

static inline ptrdiff_t sq__cidx(const sq_grid *g, int i, int j, int k)
{
    return (ptrdiff_t)(i + 1) + (ptrdiff_t)(j + 1) * g->sy + (ptrdiff_t)(k + 1) * g->sz;
}

/* Lattice offsets in cell units: sample (i,j,k) of lattice L lies at (i+ox, j+oy, k+oz) h. */
static inline float sq__lattice_off(int L, int axis)
{
    return (L == SQ__L_CELL || L - 1 != axis) ? 0.5f : 0.0f;
}

/* c ? a : b through bit masks. Kernels use it for selects in their inner loops: with the
 * default -ftrapping-math GCC does not if-convert a floating-point ?: whose operands are
 * conditional loads or arithmetic, and the loop is then not vectorised. Evaluate both sides
 * and combine conditions with | and &, not || and &&. */
static inline float sq__fsel(bool c, float a, float b)
{
    int32_t ia, ib;
    memcpy(&ia, &a, sizeof ia);
    memcpy(&ib, &b, sizeof ib);
    const int32_t m = -(int32_t)c;
    const int32_t r = (ia & m) | (ib & ~m);
    float f;
    memcpy(&f, &r, sizeof f);
    return f;
}

/* m ? a : b for an int32 mask m of all ones or zero. Masks built as -(int32_t)(comparison)
 * and combined with & | ~ stay integer vectors; GCC narrows 0/1 ints combined with & back to
 * _Bool, which it does not vectorise. */
static inline float sq__fselm(int32_t m, float a, float b)
{
    int32_t ia, ib;
    memcpy(&ia, &a, sizeof ia);
    memcpy(&ib, &b, sizeof ib);
    const int32_t r = (ia & m) | (ib & ~m);
    float f;
    memcpy(&f, &r, sizeof f);
    return f;
}

/* sum a[i] b[i], i < n, in float with 8 interleaved partial sums (a fixed order that
 * vectorises; GCC does not vectorise a plain float reduction without -fassociative-math). */
static inline float sq__dotf(const float *a, const float *b, int n)
{
    float p[8] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
    int i = 0;
    for (; i + 8 <= n; i += 8)
        for (int l = 0; l < 8; l++) p[l] += a[i + l] * b[i + l];
    float t = 0.0f;
    for (; i < n; i++) t += a[i] * b[i];
    return ((p[0] + p[4]) + (p[1] + p[5])) + ((p[2] + p[6]) + (p[3] + p[7])) + t;
}

/* v[i] = sqrt(v[i]) for i < n. sqrtf itself does not vectorise (errno handling keeps a call
 * in the loop); _mm_sqrt_ps is the same correctly rounded IEEE square root. */
static inline void sq__sqrt_row(float *v, int n)
{
    int i = 0;
#if defined(__SSE2__)
    for (; i + 4 <= n; i += 4) _mm_storeu_ps(v + i, _mm_sqrt_ps(_mm_loadu_ps(v + i)));
#endif
    for (; i < n; i++) v[i] = sqrtf(v[i]);
}

/* Coefficient of the Poisson link between two adjacent cells of the padded lattice: 1 between
 * fluid cells, 2 from a fluid cell to an outflow/open ghost (p = 0 on the face, half a cell
 * away), 0 against solids and walls (dp/dn = 0). */
static inline int sq__link_coef(uint8_t fa, uint8_t fb)
{
    if ((fa | fb) & SQ__CF_FIXED) return 0;
    if ((fa & SQ__CF_DIRICHLET) && (fb & SQ__CF_DIRICHLET)) return 0;
    if ((fa | fb) & SQ__CF_DIRICHLET) return 2;
    return 1;
}

/* ---- grid.c ------------------------------------------------------------------------------ */
/* Fills the ghost layer of a field on lattice L from the boundary conditions; scalar: index of
 * the scalar for inflow values, or -1 for a generic zero-gradient cell field. */
void sq__grid_fill_ghosts(sq_grid *g, float *origin, ptrdiff_t sy, ptrdiff_t sz, int L,
                          int scalar);
/* The same without the exchange toward neighbouring slabs (their ghost planes keep what they
 * held): for a field whose neighbours' planes arrive another way (the advection's widened
 * copy). */
void sq__grid_fill_ghosts_local(sq_grid *g, float *origin, ptrdiff_t sy, ptrdiff_t sz, int L,
                                int scalar);
/* Rebuilds flags-derived data (links, pins, multigrid, ground distance) when solids or
 * boundaries changed. */
sq_result sq__grid_update_topology(sq_grid *g);
/* Sets fixed faces (solids, walls, inflow), syncs periodic faces and fills the velocity
 * ghosts; clip_backflow also sets inflow through OUTFLOW faces to 0 (before projections). */
void sq__grid_enforce_velocity_ex(sq_grid *g, bool clip_backflow);
static inline void sq__grid_enforce_velocity(sq_grid *g) { sq__grid_enforce_velocity_ex(g, false); }
/* Sums the per-z-plane partials plane_sum[4 k + slot], k < nz, in plane order. */
double sq__grid_sum_planes(const sq_grid *g, int slot);

/* ---- grid_advect.c ------------------------------------------------------------------------ */
sq_result sq__grid_advect_velocity(sq_grid *g, float dt);
/* Advects scalars s0 .. s0+count-1 sharing one trace (velocity + drift_w on w). */
sq_result sq__grid_advect_scalars(sq_grid *g, int s0, int count, float dt, float drift);
/* Trilinear sample of a lattice-L field at a point in cell units (x/h), wrapped on periodic
 * axes and clamped into the ghost layer elsewhere. */
float sq__grid_interp(const sq_grid *g, const float *origin, ptrdiff_t sy, ptrdiff_t sz, int L,
                      float X, float Y, float Z);

/* ---- grid_sgs.c --------------------------------------------------------------------------- */
/* Log-law stress of the ground on the horizontal wind of the first fluid layer above a solid or
 * a no-slip bottom: u_h /= 1 + dt C_d |u_h| / h, C_d = (kappa / ln(h / 2 z0))^2 (implicit). */
void sq__grid_wall_stress(sq_grid *g, double kappa, double z0, float dt);

/* ---- grid_tke.c (SQ_SGS_TKE; arrays in the padded cell layout, e = scalar d->tke_idx) ------ */
/* The length l and K_m, K_h from max(e, tke_min) (solids 0); returns max(K_h, 2 K_m).
 * n2: N^2 per cell (1/s^2). */
float sq__grid_tke_coefficients(sq_grid *g, const sq_grid_sgs_desc *d, const float *n2, float *l,
                                float *km, float *kh);
/* Floors e, then advances it by the shear production K_m |S|^2 (s2 = |S|^2), the buoyancy term -K_h N^2 and
 * the dissipation -C_eps e^(3/2) / l over dt; refills e's ghosts. */
void sq__grid_tke_sources(sq_grid *g, const sq_grid_sgs_desc *d, const float *s2, const float *n2,
                          const float *l, const float *km, const float *kh, float dt);

/* ---- grid_project.c ----------------------------------------------------------------------- */
sq_result sq__grid_build_multigrid(sq_grid *g);
void sq__grid_free_multigrid(sq_grid *g);
uint64_t sq__grid_multigrid_bytes(const int n[3]);
sq_result sq__grid_project(sq_grid *g, float dt, sq_grid_project_stats *st);

/* ---- grid_dist.c (a decomposed grid; every call is a no-op / identity when g->halo is NULL) */
/* d: the resolved, validated global desc; with decompose under several ranks it becomes this
 * rank's slab (cells, origin, inner faces OPEN) and *out the halo (else NULL). */
sq_result sq__grid_dist_setup(sq_context *ctx, sq_grid_desc *d, sq__grid_halo **out);
void sq__grid_dist_free(sq_context *ctx, sq__grid_halo *h);
/* Collective: the ghost planes of inner faces of a padded cell-lattice array (level-0 layout,
 * elements of elem bytes, base = its allocation) become the neighbours' edge planes. */
void sq__grid_halo_cells(sq_grid *g, void *base, size_t elem);
/* The whole grid's cells n0 and the slab's first cell lo (g->n and 0 when not decomposed). */
void sq__grid_dist_frame(const sq_grid *g, int n0[3], int lo[3]);
/* Swaps the whole grid's boundaries and periodicity with the slab's (call twice: the coarse
 * multigrid levels are the whole grid's). */
void sq__grid_dist_global_bc(sq_grid *g);
/* Collective: float array v[0..n) summed over the ranks (counted in the bytes exchanged). */
void sq__grid_dist_sum_f32(sq_grid *g, float *v, size_t n);
/* Collective: the normal velocity on every inner face (held by both slabs) becomes the upper
 * slab's (its face 0; across a split periodic axis the first slab's, as one rank's periodic
 * face n copies face 0). Inside a batch (sq__grid_dist_batch_begin) the faces travel with the
 * batch's ghost planes and are set, tangential ghosts included, after them. */
void sq__grid_dist_sync_faces(sq_grid *g);
/* Collective: the ghost planes toward neighbouring slabs of a padded lattice-L array (origin
 * o, strides sy, sz) become the neighbours' samples next to them (no-op when whole). */
void sq__grid_dist_halo_lattice(sq_grid *g, float *o, ptrdiff_t sy, ptrdiff_t sz, int L);
/* Batches the ghost exchanges of several arrays: between begin and end (nestable),
 * sq__grid_dist_halo_lattice only records its array, and end (the outermost) sends every
 * recorded array's planes in one message per neighbour. The recorded arrays must not be
 * written, nor their ghost planes read, until the batch ends. No-op on an undivided grid. */
void sq__grid_dist_batch_begin(sq_grid *g);
void sq__grid_dist_batch_end(sq_grid *g);
/* Collective: link coefficients a (origin, strides) of face lattice L normal to the split
 * axis: the links across the slab faces (a[-1], a[n]) become the neighbours' (their a[n-1]
 * and a[0]), which they compute from their own cells. */
void sq__grid_dist_face_links(sq_grid *g, float *a, ptrdiff_t sy, ptrdiff_t sz, int L);
/* Collective: v[0..n) summed over the ranks. */
void sq__grid_dist_sum(const sq_grid *g, double *v, int n);
/* Collective: v[0..n) the largest over the ranks. */
void sq__grid_dist_max(const sq_grid *g, double *v, int n);
/* Collective: whether v is true on any rank. */
bool sq__grid_dist_any(const sq_grid *g, bool v);
/* Advection on a decomposed grid (grid_advect.c runs its kernels on a widened copy of the
 * slab: the slab plus `width` planes of each neighbouring slab along the split axis, width =
 * 2 ceil(D) + 3 for a step that moves samples at most D cells along it).
 * Collective: chooses the width for dt from the largest speed along the split axis (global),
 * (re)allocates the copy and fills its velocity and cell flags; *out = the copy. */
sq_result sq__grid_dist_widen(sq_grid *g, float dt, sq_grid **out);
/* The widened copy (g itself when not decomposed). */
sq_grid *sq__grid_dist_wide(sq_grid *g);
/* Collective, one exchange: the copy's scalar arrays 0..count-1 become scalars s0.. of the
 * slab, widened (count at most sq__grid_dist_wide_scalars). */
void sq__grid_dist_widen_scalars(sq_grid *g, int s0, int count);
/* The widened copy's scalar arrays (0 when not decomposed). */
int sq__grid_dist_wide_scalars(const sq_grid *g);
/* The slab's samples (interior of lattice L, every face it holds) from an array in the copy's
 * layout of lattice L (origin: its sample 0) into an array in the slab's layout. */
void sq__grid_dist_narrow(const sq_grid *g, const float *wide, int L, float *slab);
/* Global red-black colour offset of local cell (0,0,0); whether face is an inner face. */
int sq__grid_dist_parity(const sq_grid *g);
bool sq__grid_dist_inner(const sq_grid *g, int face);

#endif
